//! Helpers shared by the benchmark examples.

/// This process's peak resident memory (VmHWM) in MiB; NaN where unknown.
pub fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

/// The benchmark's photo: `PHOTO MASK` from the command line resized to
/// `w` x `h`, else `fallback` (a procedural photo and mask, and its name).
#[allow(dead_code)] // each example compiles this module; not all take a photo
pub fn photo_and_mask(
    w: usize,
    h: usize,
    fallback: impl FnOnce() -> (patina::Image, patina::Mask, String),
) -> (patina::Image, patina::Mask, String) {
    use patina::image::resample::{resize, Filter};
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.as_slice() {
        [photo, mask] => {
            let p = resize(&patina::image::io::load(photo).expect("photo"), w, h, Filter::Cubic).expect("resize");
            let m = resize(&patina::image::io::load(mask).expect("mask"), w, h, Filter::Linear).expect("resize");
            (p, patina::Mask::from_image(&m), photo.clone())
        }
        _ => fallback(),
    }
}
