//! The per-pixel features every weathering step compares patches with
//! (Bellini et al. 2016, eq. 1): appearance (luminance, or CIE Lab) and the
//! direction of the strongest gradient.

use crate::error::{Error, Result};
use crate::image::filter::{gaussian_blur, gradients};
use crate::image::{color, Image};

/// Gradient magnitude (value units per pixel) at which a direction counts
/// half: flat areas have no meaningful direction, so their direction
/// vectors fade to 0 instead of adding noise to the distance.
const DIRECTION_SOFTNESS: f32 = 0.02;

/// Appearance and structure features of an image.
#[derive(Clone, Debug)]
pub struct Features {
    /// L/100 (luminance only) or L/100, a/100, b/100 (with colour).
    pub appearance: Image,
    /// (cos theta, sin theta) of the strongest gradient direction, scaled
    /// by m / (m + [`DIRECTION_SOFTNESS`]) with m its magnitude. The squared
    /// difference of two unit vectors is 2 - 2 cos(delta theta): the
    /// direction difference G of eq. (1) in a form correlation can sum.
    pub direction: Image,
}

/// The first three channels as sRGB colour (grey images repeat channel 0).
pub fn rgb(img: &Image) -> Result<Image> {
    match img.channels() {
        0 => Err(Error::invalid("the image has no channels")),
        1 | 2 => Ok(Image::from_fn(img.width(), img.height(), 3, |x, y, p| p.fill(img.at(x, y, 0)))),
        _ => Ok(img.select_channels(0..3)),
    }
}

/// The appearance channels of [`Features`] alone (see [`Features::new`]).
pub fn appearance(img: &Image, colour: bool) -> Result<Image> {
    Ok(appearance_of(&rgb(img)?, colour))
}

fn appearance_of(rgb: &Image, colour: bool) -> Image {
    let lab = color::to_lab(rgb);
    if colour {
        lab.map(|v| v / 100.0)
    } else {
        lab.select_channels(0..1).map(|v| v / 100.0)
    }
}

impl Features {
    /// Features of `img` (sRGB values in [0, 1]; extra channels such as
    /// alpha are ignored). `colour` adds Lab's a and b to the luminance the
    /// paper compares: rust on a grey plate can match its luminance.
    pub fn new(img: &Image, colour: bool) -> Result<Self> {
        let rgb = rgb(img)?;
        let appearance = appearance_of(&rgb, colour);
        let g = gradients(&gaussian_blur(&rgb, 0.8));
        let direction = Image::from_fn(img.width(), img.height(), 2, |x, y, p| {
            let m = g.magnitude.at(x, y, 0);
            let s = m / (m + DIRECTION_SOFTNESS);
            let d = g.direction.at(x, y, 0);
            p[0] = s * d.cos();
            p[1] = s * d.sin();
        });
        Ok(Features { appearance, direction })
    }

    /// Appearance then direction, as one image (for the patch engine).
    pub fn stacked(&self) -> Image {
        Image::concat_channels(&[&self.appearance, &self.direction]).expect("features share one size")
    }

    /// Per-channel weights of [`Self::stacked`] for D = I / i_scale + G / g_scale.
    pub fn weights(&self, i_scale: f32, g_scale: f32) -> Vec<f32> {
        let a = self.appearance.channels();
        (0..a + 2).map(|c| if c < a { 1.0 / i_scale } else { 1.0 / g_scale }).collect()
    }
}
