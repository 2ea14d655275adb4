//! Degree maps D in [0, 1]: where and how far the surface has decayed
//! (Hao et al. 2023, sections III-C2 and III-C4).

use super::noise::Layer;
use crate::image::resample::{resize, Filter};
use crate::image::{Image, Mask};
use crate::rng::{self, Rng};
use crate::{Error, Result};
use rayon::prelude::*;

/// Degree below which self-growth does not act (eq. 6: D += Z where D > 0.25).
pub const GROWTH_THRESHOLD: f32 = 0.25;

/// How many times Algorithm 1 re-draws the pattern before falling back to
/// an exact quantile threshold.
const MAX_DRAWS: u64 = 64;

/// Algorithm 1: the initial degree map of a `mask`.
///
/// A uniform random pattern on a coarse grid (one cell per `continuity` x
/// the longer side, so a larger continuity gives larger, more continuous
/// blobs) is upsampled with cubic interpolation and thresholded at
/// 1 - `area`; the pattern is re-drawn until the covered fraction of the
/// mask is within +/-25% of `area` (after 64 draws the threshold becomes
/// the exact quantile). Covered pixels are filled with Perlin fBm mapped to
/// [0.1, 1]; everything else, and everything outside the mask, is 0.
/// Returns the map and the number of draws it took.
pub fn initial(mask: &Mask, area: f32, continuity: f32, seed: u64) -> Result<(Image, u64)> {
    if !(0.0..=1.0).contains(&area) || !area.is_finite() {
        return Err(Error::invalid(format!("--area must be in [0, 1], got {area}")));
    }
    if !(continuity > 0.0 && continuity <= 1.0) {
        return Err(Error::invalid(format!("--continuity must be in (0, 1], got {continuity}")));
    }
    let (w, h) = mask.size();
    let inside = mask.count();
    if inside == 0 {
        return Err(Error::invalid("the mask is empty: nothing can decay"));
    }
    let cell = (continuity * w.max(h) as f32).max(1.0);
    let (gw, gh) = ((w as f32 / cell).ceil() as usize + 1, (h as f32 / cell).ceil() as usize + 1);
    let mut draws = 0;
    let pattern = loop {
        draws += 1;
        let mut g = rng::generator(seed, &[0xa1, draws]);
        let coarse = Image::from_fn(gw, gh, 1, |_, _, p| p[0] = g.gen::<f32>());
        let fine = resize(&coarse, w, h, Filter::Cubic)?;
        let covered = fine.data().iter().zip(mask.bits()).filter(|(&v, &m)| m && v > 1.0 - area).count();
        let fraction = covered as f32 / inside as f32;
        if (fraction - area).abs() <= 0.25 * area || area == 0.0 {
            break (fine, 1.0 - area);
        }
        if draws == MAX_DRAWS {
            let mut values: Vec<f32> = fine.data().iter().zip(mask.bits()).filter(|(_, &m)| m).map(|(&v, _)| v).collect();
            values.sort_by(f32::total_cmp);
            let k = ((1.0 - area) * values.len() as f32) as usize;
            break (fine, values[k.min(values.len() - 1)]);
        }
    };
    let (fine, threshold) = pattern;
    let fill = Layer::new(seed, 0xf1);
    let scale = cell.max(8.0);
    let degree = Image::from_fn(w, h, 1, |x, y, p| {
        p[0] = if mask.get(x, y) && fine.at(x, y, 0) > threshold {
            (0.55 + 0.6 * fill.fbm(x as f32, y as f32, scale, 5, 0.5)).clamp(0.1, 1.0)
        } else {
            0.0
        };
    });
    Ok((degree, draws))
}

/// A user's degree map (a brush painting): the mean of its colour
/// channels (its grey for a grey painting), 0 outside the mask.
pub fn from_painting(painting: &Image, mask: &Mask) -> Result<Image> {
    if painting.size() != mask.size() {
        let ((a, b), (c, d)) = (painting.size(), mask.size());
        return Err(Error::invalid(format!("the degree map is {a}x{b} but the photo is {c}x{d}")));
    }
    let grey = channel_mean(painting);
    Ok(Image::from_fn(mask.width(), mask.height(), 1, |x, y, p| {
        p[0] = if mask.get(x, y) { grey.at(x, y, 0).clamp(0.0, 1.0) } else { 0.0 };
    }))
}

/// The mean of the first (up to) three channels of a painted map: its
/// grey value, whatever its channel layout.
pub fn channel_mean(painting: &Image) -> Image {
    let n = painting.channels().min(3);
    Image::from_fn(painting.width(), painting.height(), 1, |x, y, p| p[0] = painting.pixel(x, y)[..n].iter().sum::<f32>() / n as f32)
}

/// Parameters of decay diffusion (section III-C4).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Diffusion {
    /// Diffusion length per frame, as a fraction of the longer image side:
    /// the heat equation runs for time sigma^2 / (2 alpha) per frame.
    pub spread: f32,
    /// Upper bound of the self-growth Z ~ U(0, growth) added per frame
    /// where D > 0.25 (eq. 6).
    pub growth: f32,
}

impl Default for Diffusion {
    fn default() -> Self {
        Diffusion { spread: 0.015, growth: 0.15 }
    }
}

/// Coefficient alpha of dD/dt = alpha Lap D (eq. 4), in px^2 per unit time.
const ALPHA: f32 = 1.0;
/// Explicit time step: stable for the 5-point Laplacian when alpha dt <= 1/4.
const DT: f32 = 0.24;

/// One frame of decay diffusion (eqs. 4-7), in place: explicit finite
/// differences of dD/dt = alpha r(x) Lap D for the frame's time (Neumann
/// borders at the mask's edge, so decay neither leaks out nor drains), then
/// self-growth D += r(x) Z with Z ~ U(0, growth) where D > 0.25, then
/// D = max(D_new, D_old) so decay never retreats. `rate` (the user's
/// regularisation map, 1 = normal speed, up to 2) scales both terms.
/// Returns the number of finite-difference steps taken.
pub fn step(degree: &mut Image, mask: &Mask, rate: Option<&Image>, params: &Diffusion, seed: u64, frame: u64) -> usize {
    let (w, h) = mask.size();
    let sigma = params.spread * w.max(h) as f32;
    let steps = ((sigma * sigma / (2.0 * ALPHA * DT)).ceil() as usize).max(1);
    let old = degree.clone();
    let mut next = degree.clone();
    let bits = mask.bits();
    let rate_at = |i: usize| rate.map_or(1.0, |r| r.data()[i]);
    for _ in 0..steps {
        let cur = degree.data();
        next.data_mut().par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, out) in row.iter_mut().enumerate() {
                let i = y * w + x;
                if !bits[i] {
                    continue;
                }
                let c = cur[i];
                let nb = |ok: bool, j: usize| if ok && bits[j] { cur[j] } else { c };
                let lap =
                    nb(x > 0, i.wrapping_sub(1)) + nb(x + 1 < w, i + 1) + nb(y > 0, i.wrapping_sub(w)) + nb(y + 1 < h, i + w) - 4.0 * c;
                *out = c + ALPHA * DT * rate_at(i) * lap;
            }
        });
        std::mem::swap(degree, &mut next);
    }
    degree.data_mut().par_chunks_mut(w).zip(old.data().par_chunks(w)).enumerate().for_each(|(y, (row, before))| {
        let mut g = rng::generator(seed, &[0x96, frame, y as u64]);
        for (x, (d, &b)) in row.iter_mut().zip(before).enumerate() {
            let z: f32 = g.gen::<f32>() * params.growth;
            if !bits[y * w + x] {
                continue;
            }
            if *d > GROWTH_THRESHOLD {
                *d += rate_at(y * w + x) * z;
            }
            *d = d.clamp(0.0, 1.0).max(b);
        }
    });
    steps
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(w: usize, h: usize) -> Mask {
        Mask::from_fn(w, h, |x, y| (x as f32 - 40.0).powi(2) + (y as f32 - 30.0).powi(2) < 900.0)
    }

    #[test]
    fn initial_map_covers_about_the_area_asked_inside_the_mask_only() {
        let mask = disc(80, 60);
        for seed in 0..5 {
            let (d, _) = initial(&mask, 0.25, 0.1, seed).unwrap();
            let covered = d.data().iter().filter(|&&v| v > 0.0).count() as f32 / mask.count() as f32;
            assert!((covered - 0.25).abs() <= 0.25 * 0.25 + 1e-6, "seed {seed}: covered {covered}");
            for (v, m) in d.data().iter().zip(mask.bits()) {
                assert!((0.0..=1.0).contains(v));
                assert!(*m || *v == 0.0);
            }
        }
    }

    #[test]
    fn diffusion_spreads_decay_without_leaving_the_mask_or_retreating() {
        let mask = disc(80, 60);
        let (mut d, _) = initial(&mask, 0.2, 0.15, 3).unwrap();
        let before = d.clone();
        step(&mut d, &mask, None, &Diffusion::default(), 3, 0);
        let count = |img: &Image| img.data().iter().filter(|&&v| v > 0.0).count();
        assert!(count(&d) > count(&before));
        for ((a, b), m) in d.data().iter().zip(before.data()).zip(mask.bits()) {
            assert!(a >= b);
            assert!(*m || *a == 0.0);
        }
    }
}
