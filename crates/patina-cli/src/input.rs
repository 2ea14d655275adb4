//! Reading input images the CLI's way: strictly (see
//! `patina::image::io::decode_with`), or with `--allow-nonfinite`, which sets
//! NaN and infinite EXR samples to 0 and says so on stderr.

use patina::image::io::{load_with, LoadOptions};
use patina::image::Image;
use patina::Result;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

static ALLOW_NONFINITE: AtomicBool = AtomicBool::new(false);

/// Set how inputs are read, before a run reads any.
pub fn configure(options: LoadOptions) {
    ALLOW_NONFINITE.store(options.allow_nonfinite, Ordering::Relaxed);
}

/// Load an image input.
pub fn load(path: impl AsRef<Path>) -> Result<Image> {
    let path = path.as_ref();
    let loaded = load_with(path, LoadOptions { allow_nonfinite: ALLOW_NONFINITE.load(Ordering::Relaxed) })?;
    if loaded.nonfinite > 0 {
        eprintln!("patina: warning: {}: {} NaN or infinite samples set to 0 (--allow-nonfinite)", path.display(), loaded.nonfinite);
    }
    Ok(loaded.image)
}

/// A time-lapse's frames registered on its first (a camera that shakes;
/// `patina::image::register`) on the mean of `channels`, with the
/// registration when any frame moved; `off` (`--no-register`) keeps them.
pub fn registered(
    frames: Vec<Image>,
    channels: std::ops::Range<usize>,
    off: bool,
) -> Result<(Vec<Image>, Option<patina::image::register::Registration>)> {
    if off {
        return Ok((frames, None));
    }
    let registration = patina::image::register::Registration::of(&frames, channels)?;
    if registration.is_steady() {
        return Ok((frames, None));
    }
    Ok((registration.apply(&frames), Some(registration)))
}

/// Says how far the camera moved, once the run has succeeded (a failing
/// run's error stays its one line).
pub fn registration_note(registration: &Option<patina::image::register::Registration>) {
    if let Some(r) = registration {
        let [mx, my] = r.largest_motion();
        let [_, _, w, h] = r.window;
        crate::output::summary(format!(
            "note: the camera moves by up to {mx} x {my} px over the time steps; they were registered and cropped to the {w}x{h} window all of them show (--no-register takes them as they are)"
        ));
    }
}
