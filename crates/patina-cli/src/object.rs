//! `--mask FILE|auto|none` and `--point X,Y`: which object of a photo a
//! command works on (decay, weather).

use patina::image::{grabcut, Image, Mask};
use patina::{Error, Result};
use std::path::PathBuf;

/// Parse `X,Y` (non-negative integers).
pub fn parse_point(s: &str) -> std::result::Result<(usize, usize), String> {
    let bad = || format!("'{s}' is not X,Y with X and Y pixel positions >= 0 (e.g. 320,240)");
    let (x, y) = s.split_once(',').ok_or_else(bad)?;
    Ok((x.trim().parse().map_err(|_| bad())?, y.trim().parse().map_err(|_| bad())?))
}

/// The mask file `--mask` names, if it names one; errors when `--point`
/// is given without `--mask auto`, which it is for.
pub fn mask_file(mask: &str, point: Option<(usize, usize)>) -> Result<Option<PathBuf>> {
    if point.is_some() && mask != "auto" {
        return Err(Error::InvalidInput("--point picks the object for --mask auto; add --mask auto".into()));
    }
    Ok(match mask {
        "auto" | "none" => None,
        path => Some(PathBuf::from(path)),
    })
}

/// The mask `--mask` asks for on `photo`: none, the file (white = the
/// object) or the object GrabCut finds ([`grabcut::salient_object`]: the
/// one under `point`, else the main one).
pub fn resolve(mask: &str, point: Option<(usize, usize)>, photo: &Image) -> Result<Option<Mask>> {
    match mask {
        "none" => Ok(None),
        "auto" => {
            if let Some((x, y)) = point {
                if x >= photo.width() || y >= photo.height() {
                    return Err(Error::InvalidInput(format!("--point {x},{y} is outside the {}x{} photo", photo.width(), photo.height())));
                }
            }
            Ok(Some(grabcut::salient_object(photo, point)))
        }
        path => Ok(Some(Mask::from_image(&patina::image::color::luminance(&crate::input::load(path)?)))),
    }
}
