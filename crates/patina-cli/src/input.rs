//! Reading input images the CLI's way: strictly (see
//! `patina::image::io::decode_with`), or with `--allow-nonfinite`, which sets
//! NaN and infinite EXR samples to 0 and says so on stderr.

use patina::image::io::{load_with, LoadOptions};
use patina::image::Image;
use patina::Result;
use std::path::Path;
use std::sync::OnceLock;

static OPTIONS: OnceLock<LoadOptions> = OnceLock::new();

/// Set how inputs are read, once, before any is.
pub fn configure(options: LoadOptions) {
    let _ = OPTIONS.set(options);
}

/// Load an image input.
pub fn load(path: impl AsRef<Path>) -> Result<Image> {
    let path = path.as_ref();
    let loaded = load_with(path, OPTIONS.get().copied().unwrap_or_default())?;
    if loaded.nonfinite > 0 {
        eprintln!("patina: warning: {}: {} NaN or infinite samples set to 0 (--allow-nonfinite)", path.display(), loaded.nonfinite);
    }
    Ok(loaded.image)
}
