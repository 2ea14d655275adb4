//! Compositing a decay texture into the photo (Hao et al. 2023, section
//! III-C3, eq. 3), in CIE Lab:
//!
//! O_L = w T_L s + (1 - w) I_L,  O_ab = w T_ab s + (1 - w) I_ab,
//!
//! with s = S^(1/3) (S is a ratio of linear luminance; Lab goes as its
//! cube root).
//!
//! The paper writes O_L = (D T_L + (1 - D) I_L) S; since I already carries
//! its shading, that form darkens the photo twice and D = 0 would not give
//! the input back. Writing I_L = R_L S and applying S once, to the blend of
//! T_L and the reflectance R_L, gives the line above: the texture takes the
//! object's shading and D = 0 returns the input unchanged. The paper
//! leaves ab unshaded, which turns shadows into saturated colour (rust on
//! a dark flank read as candy red): a surface R under shading S has
//! a = 500 ((X_R S)^(1/3) - (Y_R S)^(1/3)) = s a_R, so ab is shaded by s
//! like L.
//!
//! The blend weight w is where patina adds to the paper: instead of the
//! degree D itself, w = smoothstep(onset - 0.04, onset + 0.04, D) with the
//! texture's per-texel onset (see [`super::texture`]). A half-decayed
//! region then shows half of the texels fully decayed (cracks before the
//! crazed paint between them, rust at its pits first) rather than the whole
//! texture at half opacity, which reads as a ghost of the texture. w is
//! monotone in D, 0 at D = 0 and 1 at D = 1.

use super::noise::smoothstep;
use crate::image::color::lab_pixel_to_srgb;
use crate::image::{Image, Mask};
use rayon::prelude::*;

/// Half-width of the onset transition in degree units.
const ONSET_SOFTNESS: f32 = 0.04;

/// Share of the texture's own luminance contrast kept by the colour
/// transfer even when the photo is flatter (so cracks stay cracks on
/// uniform paint).
const MIN_CONTRAST: f32 = 0.7;

/// The blend weight of a texel with onset `onset` at degree `degree`
/// (0 for texels that never appear).
#[inline]
pub fn weight(degree: f32, onset: f32) -> f32 {
    if degree <= 0.0 || onset >= super::texture::NEVER {
        return 0.0;
    }
    smoothstep((onset - ONSET_SOFTNESS).max(0.0), onset + ONSET_SOFTNESS, degree)
}

/// Colour transfer (Reinhard, Ashikhmin, Gooch, Shirley 2001), in Lab (the
/// paper works in l-alpha-beta; Lab is as decorrelated for this purpose):
/// per channel, move the texture's mean and standard deviation to those
/// of the photo inside the mask. The luminance contrast is scaled by at
/// least 0.7, so a flat-painted object still shows its cracks. `strength`
/// blends between the texture's own colours (0) and the full transfer (1).
pub fn transfer_colour(texture_lab: &mut Image, photo_lab: &Image, mask: &Mask, strength: f32) {
    let stats = |img: &Image, keep: &dyn Fn(usize) -> bool| {
        let mut acc = [[0f64; 2]; 3];
        let mut n = 0f64;
        for (i, px) in img.data().chunks_exact(3).enumerate() {
            if keep(i) {
                n += 1.0;
                for c in 0..3 {
                    acc[c][0] += px[c] as f64;
                    acc[c][1] += (px[c] as f64).powi(2);
                }
            }
        }
        acc.map(|[s, s2]| {
            let mean = s / n.max(1.0);
            (mean as f32, ((s2 / n.max(1.0) - mean * mean).max(0.0).sqrt()) as f32)
        })
    };
    let from = stats(texture_lab, &|_| true);
    let to = stats(photo_lab, &|i| mask.bits()[i]);
    let scale: Vec<f32> = (0..3)
        .map(|c| {
            let s = to[c].1 / from[c].1.max(1e-3);
            if c == 0 {
                s.max(MIN_CONTRAST)
            } else {
                s
            }
        })
        .collect();
    texture_lab.data_mut().par_chunks_mut(3).for_each(|px| {
        for c in 0..3 {
            let moved = (px[c] - from[c].0) * scale[c] + to[c].0;
            px[c] += strength * (moved - px[c]);
        }
        px[0] = px[0].clamp(0.0, 100.0);
    });
}

/// Eq. 3: the photo `photo` (sRGB, its bytes kept wherever w = 0) decayed
/// to `degree` with the texture (`texture_lab`, `onset`) under `shading`.
/// Pixels with degree 0 (and so everything outside the mask) are copied
/// from the photo untouched.
pub fn composite(photo: &Image, photo_lab: &Image, texture_lab: &Image, onset: &Image, shading: &Image, degree: &Image) -> Image {
    let (w, channels) = (photo.width(), photo.channels());
    let mut out = photo.clone();
    out.data_mut().par_chunks_mut(w * channels).enumerate().for_each(|(y, row)| {
        for (x, px) in row.chunks_exact_mut(channels).enumerate() {
            let i = y * w + x;
            let wt = weight(degree.data()[i], onset.data()[i]);
            if wt <= 0.0 || channels < 3 {
                continue;
            }
            let (p, t) = (&photo_lab.data()[i * 3..i * 3 + 3], &texture_lab.data()[i * 3..i * 3 + 3]);
            // S is a ratio of linear luminance; L* goes as Y^(1/3).
            let s = shading.data()[i].cbrt();
            let lab = [wt * t[0] * s + (1.0 - wt) * p[0], wt * t[1] * s + (1.0 - wt) * p[1], wt * t[2] * s + (1.0 - wt) * p[2]];
            let rgb = lab_pixel_to_srgb(lab);
            for c in 0..3 {
                px[c] = rgb[c].clamp(0.0, 1.0);
            }
        }
    });
    out
}
