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
