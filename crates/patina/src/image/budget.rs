//! The memory budget every input and every run is checked against before
//! anything large is allocated.
//!
//! The budget is the memory the system reports available (Linux
//! `MemAvailable`), or 4 GiB where the system does not say: the size the
//! project promises a 4096 x 4096 texture or a 500-frame sequence fits in.
//! `PATINA_MEMORY_MB` overrides it (for tests, and for users sharing a
//! machine). Estimates count the run's real buffers: the decoded file, its
//! f32 copy, and the engine's working set at that size.

use crate::error::{Error, Result};

/// The budget where the system does not report available memory.
pub const DEFAULT_BYTES: u64 = 4 << 30;

/// Bytes patina may use: `PATINA_MEMORY_MB`, else the system's available
/// memory, else [`DEFAULT_BYTES`].
pub fn available() -> u64 {
    if let Some(mb) = std::env::var("PATINA_MEMORY_MB").ok().and_then(|v| v.trim().parse::<u64>().ok()) {
        return mb.saturating_mul(1 << 20);
    }
    system_available().unwrap_or(DEFAULT_BYTES)
}

/// Linux `MemAvailable`, when the system says.
fn system_available() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Fail with [`Error::TooLarge`] when `bytes` exceed the budget.
pub fn check(what: impl FnOnce() -> String, bytes: u128) -> Result<()> {
    let avail = available();
    if bytes > u128::from(avail) {
        return Err(Error::TooLarge { what: what(), need_mib: u64::try_from(bytes >> 20).unwrap_or(u64::MAX), available_mib: avail >> 20 });
    }
    Ok(())
}

/// Bytes the synthesis engine keeps for a `w` x `h` image of `channels`
/// channels: about eight f32 copies, two nearest-neighbour fields (12 bytes
/// a pixel each), and a third more for the pyramid.
pub fn working_set(w: usize, h: usize, channels: usize) -> u128 {
    let px = (w as u128) * (h as u128);
    px * (8 * 4 * channels as u128 + 2 * 12) * 4 / 3
}

/// [`check`] for the engine's [`working_set`] at `w` x `h`.
pub fn check_working_set(what: &str, w: usize, h: usize, channels: usize) -> Result<()> {
    check(|| format!("{what} at {w}x{h} with {channels} channels"), working_set(w, h, channels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_working_set_grows_with_pixels_and_channels_and_huge_sizes_are_refused() {
        assert!(working_set(64, 64, 3) < working_set(128, 64, 3));
        assert!(working_set(64, 64, 3) < working_set(64, 64, 4));
        // 100k x 100k RGB needs far more than any machine's memory.
        assert!(matches!(check_working_set("test", 100_000, 100_000, 3), Err(Error::TooLarge { .. })));
        assert!(check_working_set("test", 16, 16, 3).is_ok());
    }
}
