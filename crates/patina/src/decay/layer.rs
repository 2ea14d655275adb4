//! The decay layer's own relief: the step at the edge of a paint flake,
//! the walls of a crack, the bulk of a moss cushion or a rust crust, lit
//! by the photo's light.
//!
//! Hao et al. (2023) composite a flat texture (eq. 3), so a hole in the
//! paint reads as a stain and a crack as an ink line. Here the visible
//! decay weight w is read as a height field h = height x w (negative for
//! material lost: a flake's hole, a crack's groove; positive for material
//! added: moss, rust scale), softened by a Gaussian of the layer's
//! thickness, and lit as a Lambertian height field under the photo's
//! light direction l (in the image plane, towards the light):
//!
//!   F = (1 - strength x grad(h) . l) x (1 - shadow),
//!
//! where the shadow is cast along -l: how far the height towards the light
//! rises above the pixel (max over d of h(x + d l) - h(x) - d tan(elevation)).
//! So the wall of a hole facing away from the light is dark and throws a
//! thin shadow onto the exposed substrate, the wall facing the light shows
//! as a lit lip of the paint's thickness, a crack gets one dark and one lit
//! wall, and a moss cushion shades its own far side. F multiplies the
//! composite's linear colour, photo and texture alike (the paint around a
//! hole is part of the step).

use crate::image::filter::gaussian_blur;
use crate::image::{Image, Mask};
use rayon::prelude::*;
use serde::Serialize;

/// How a class's decay stands out of (or sinks into) the surface.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Relief {
    /// Height of fully visible decay, in pixels: negative for material lost
    /// (a flake's depth), positive for material added (a cushion).
    pub height: f32,
    /// Gaussian softness of the step, in pixels (the layer's thickness).
    pub softness: f32,
    /// How strongly a slope facing the light brightens (and one facing away darkens).
    pub strength: f32,
    /// Darkness of a full cast shadow, in [0, 1].
    pub shadow: f32,
}

impl Relief {
    /// A flat layer (the paper's eq. 3 alone).
    pub const FLAT: Relief = Relief { height: 0.0, softness: 0.0, strength: 0.0, shadow: 0.0 };
}

/// Rise of the light over the image plane, as run per unit rise of a cast
/// shadow: a step of height h throws a shadow h / `SHADOW_SLOPE` pixels long.
const SHADOW_SLOPE: f32 = 0.6;

/// Lighting factors further than this from 1 change no 8-bit level.
const NO_CHANGE: f32 = 1e-3;

/// The direction of the photo's light in the image plane (a unit vector
/// towards the light, y down), from the object's shading `form`: the mean
/// gradient of log shading over the mask points to where the object is
/// lit. When the shading has no clear direction (a flat plate, light from
/// the front), light from above and to the left, the common studio and
/// sun position, is assumed.
pub fn light_direction(form: &Image, mask: &Mask) -> [f32; 2] {
    let (w, h) = mask.size();
    let (mut gx, mut gy, mut len, mut n) = (0f64, 0f64, 0f64, 0usize);
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let inside = mask.get(x, y) && mask.get(x - 1, y) && mask.get(x + 1, y) && mask.get(x, y - 1) && mask.get(x, y + 1);
            if !inside {
                continue;
            }
            let l = |x: usize, y: usize| (form.at(x, y, 0).max(1e-6) as f64).ln();
            let (dx, dy) = (0.5 * (l(x + 1, y) - l(x - 1, y)), 0.5 * (l(x, y + 1) - l(x, y - 1)));
            gx += dx;
            gy += dy;
            len += (dx * dx + dy * dy).sqrt();
            n += 1;
        }
    }
    let default = [-0.45f32, -0.89];
    let norm = (gx * gx + gy * gy).sqrt();
    // The mean gradient must be a clear part of the typical one.
    if n == 0 || norm <= 1e-9 || norm < 0.15 * len {
        return default;
    }
    [(gx / norm) as f32, (gy / norm) as f32]
}

/// The lighting factor F of the decay layer with visible weight `weight`
/// (per pixel, in [0, 1]) and the given `relief`, under light `light`
/// ([`light_direction`]). 1 wherever `degree` is 0, so those pixels keep
/// the photo's bytes. `None` for a flat relief.
pub fn factor(weight: &Image, degree: &Image, relief: &Relief, light: [f32; 2]) -> Option<Vec<f32>> {
    if relief.height == 0.0 || (relief.strength <= 0.0 && relief.shadow <= 0.0) {
        return None;
    }
    let (w, h) = weight.size();
    let mut height = weight.map(|v| v * relief.height);
    if relief.softness > 0.0 {
        height = gaussian_blur(&height, relief.softness);
    }
    let hd = height.data();
    let at = |x: isize, y: isize| hd[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize];
    let reach = (relief.height.abs() / SHADOW_SLOPE).ceil() as usize;
    let [lx, ly] = light;
    let degree = degree.data();
    let mut out = vec![1f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let y = y as isize;
        for (x, f) in row.iter_mut().enumerate() {
            if degree[y as usize * w + x] <= 0.0 {
                continue;
            }
            let x = x as isize;
            let here = at(x, y);
            let (gx, gy) = (0.5 * (at(x + 1, y) - at(x - 1, y)), 0.5 * (at(x, y + 1) - at(x, y - 1)));
            let lit = (1.0 - relief.strength * (gx * lx + gy * ly)).clamp(0.3, 1.7);
            let mut rise = 0f32;
            for d in 1..=reach {
                let d = d as f32;
                let towards = at(x + (d * lx).round() as isize, y + (d * ly).round() as isize);
                rise = rise.max(towards - here - d * SHADOW_SLOPE);
            }
            let shade = 1.0 - relief.shadow * (rise / relief.height.abs()).clamp(0.0, 1.0);
            let v = lit * shade;
            if (v - 1.0).abs() > NO_CHANGE {
                *f = v;
            }
        }
    });
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square hole in a layer lit from the left: its left wall (facing
    /// away from the light) is dark and shadows the floor beside it, its
    /// right wall is a lit lip; pixels at degree 0 keep a factor of 1.
    #[test]
    fn a_hole_has_a_dark_wall_towards_the_light_and_a_lit_one_away_from_it() {
        let (w, h) = (40, 40);
        let hole = Image::from_fn(w, h, 1, |x, y, p| p[0] = ((12..28).contains(&x) && (12..28).contains(&y)) as u8 as f32);
        let degree = Image::from_fn(w, h, 1, |x, _, p| p[0] = if x < 4 { 0.0 } else { 0.5 });
        let relief = Relief { height: -1.5, softness: 0.8, strength: 0.8, shadow: 0.6 };
        let f = factor(&hole, &degree, &relief, [-1.0, 0.0]).unwrap();
        let at = |x: usize| f[20 * w + x];
        // Inside the hole just right of its left edge: wall and cast shadow.
        assert!(at(12) < 0.75 && at(13) < 0.85, "left wall {} {}", at(12), at(13));
        // The right edge faces the light.
        assert!(at(27).max(at(28)) > 1.15, "right lip {} {}", at(27), at(28));
        // Flat floor and flat paint are unchanged.
        assert!((at(20) - 1.0).abs() < 1e-3 && (at(36) - 1.0).abs() < 1e-3);
        assert!((0..4).all(|x| f[20 * w + x] == 1.0));
    }

    #[test]
    fn the_light_comes_from_the_lit_side_of_the_object() {
        let (w, h) = (64, 48);
        let form = Image::from_fn(w, h, 1, |x, y, p| p[0] = (1.5 - x as f32 / 64.0 - 0.3 * y as f32 / 48.0).max(0.1));
        let l = light_direction(&form, &Mask::filled(w, h, true));
        assert!(l[0] < -0.9 && l[1] < 0.0, "{l:?}");
        let flat = Image::from_fn(w, h, 1, |_, _, p| p[0] = 1.0);
        assert_eq!(light_direction(&flat, &Mask::filled(w, h, true)), [-0.45, -0.89]);
    }
}
