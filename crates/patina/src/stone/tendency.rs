//! Weathering tendency (Xue et al. 2011, section 2.1): how strongly each
//! pixel's neighbourhood varies, i.e. how much carved detail or sharp
//! structure there is to wear away.

use crate::image::summed::SummedArea;
use crate::image::{Image, Mask};
use rayon::prelude::*;

/// The window radius r = sqrt(N(I)) / m (at least 1), N(I) = object pixels.
pub fn window_radius(object_pixels: usize, m: f32) -> usize {
    ((object_pixels as f32).sqrt() / m.max(1e-3)).round().max(1.0) as usize
}

/// d(x) = (v(x) / v*)^eta, v(x) = sum over RGB of the intensity variance
/// in the square window of side 2r + 1 centred on x (the paper's "size 2r",
/// made odd so it is centred), v* = the object's 98th percentile of v
/// ([`reference_variance`]; the paper's is the largest).
///
/// Windows only count object pixels, so the background does not make the
/// silhouette look busy. Variances come from summed-area tables of I and
/// I^2 and an object count: O(1) per pixel whatever r is. 0 outside `mask`.
pub fn tendency(linear: &Image, mask: &Mask, eta: f32, m: f32) -> Image {
    let (w, h) = linear.size();
    let r = window_radius(mask.count(), m);
    let inside = |x: usize, y: usize| if mask.get(x, y) { 1.0 } else { 0.0 };
    let count = SummedArea::new(w, h, inside);
    let channels = linear.channels().min(3);
    let tables: Vec<(SummedArea, SummedArea)> = (0..channels)
        .into_par_iter()
        .map(|c| {
            let s = SummedArea::new(w, h, |x, y| inside(x, y) * linear.at(x, y, c) as f64);
            let s2 = SummedArea::new(w, h, |x, y| inside(x, y) * (linear.at(x, y, c) as f64).powi(2));
            (s, s2)
        })
        .collect();
    let mut v = vec![0f32; w * h];
    v.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        for (x, out) in row.iter_mut().enumerate() {
            if !mask.get(x, y) {
                continue;
            }
            let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
            let n = count.sum(x0, y0, x1 - x0, y1 - y0);
            let mut var = 0.0;
            for (s, s2) in &tables {
                let mean = s.sum(x0, y0, x1 - x0, y1 - y0) / n;
                var += (s2.sum(x0, y0, x1 - x0, y1 - y0) / n - mean * mean).max(0.0);
            }
            *out = var as f32;
        }
    });
    // v* has a floor (a standard deviation of 0.001) so a flat object
    // stays at d = 0 instead of amplifying rounding noise to 1.
    let vmax = reference_variance(&v, mask).max(1e-6);
    let mut d = Image::new(w, h, 1);
    for (o, &vi) in d.data_mut().iter_mut().zip(&v) {
        *o = (vi / vmax).min(1.0).powf(eta);
    }
    d
}

/// `d` (measured on `object`) carried over the pixels of `grown` outside
/// `object`, ring by ring: each takes the largest value among its known
/// 4-neighbours, so the rim weathers as the stone next to it.
pub fn extend(d: &Image, object: &Mask, grown: &Mask) -> Image {
    let (w, h) = object.size();
    let mut out = d.clone();
    let mut known = object.clone();
    loop {
        let mut next = Vec::new();
        for y in 0..h {
            for x in 0..w {
                if known.get(x, y) || !grown.get(x, y) {
                    continue;
                }
                let mut best: Option<f32> = None;
                for (nx, ny) in super::neighbours(x, y, w, h) {
                    if known.get(nx, ny) {
                        best = Some(best.map_or(out.at(nx, ny, 0), |b: f32| b.max(out.at(nx, ny, 0))));
                    }
                }
                if let Some(v) = best {
                    next.push((x, y, v));
                }
            }
        }
        if next.is_empty() {
            return out;
        }
        for (x, y, v) in next {
            out.pixel_mut(x, y)[0] = v;
            known.set(x, y, true);
        }
    }
}

/// Share of the object's pixels whose variance is at or above v*.
pub const REFERENCE_SHARE: f32 = 0.02;

/// v*: the variance that [`REFERENCE_SHARE`] of the object reaches.
///
/// Departure: the paper takes the largest v. On photos that is a few
/// outliers (a lichen spot, a marker, a specular glint), which pushed the
/// carving itself to d = 0.1-0.3 and left a gravestone unchanged at the
/// paper's "heavily weathered" t = 100. The 98th percentile is the busiest
/// carving; the few pixels above it are clamped to d = 1.
fn reference_variance(v: &[f32], mask: &Mask) -> f32 {
    let mut inside: Vec<f32> = super::set_pixels(mask).map(|i| v[i]).collect();
    if inside.is_empty() {
        return 0.0;
    }
    let k = ((inside.len() as f32 * (1.0 - REFERENCE_SHARE)) as usize).min(inside.len() - 1);
    *inside.select_nth_unstable_by(k, f32::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn busy_regions_tend_to_weather_and_flat_ones_do_not() {
        // Left half flat grey, right half a fine checkerboard.
        let img = Image::from_fn(120, 60, 3, |x, y, p| p.fill(if x >= 60 && (x + y) % 2 == 0 { 0.8 } else { 0.3 }));
        let d = tendency(&img, &Mask::filled(120, 60, true), 0.6, 60.0);
        assert_eq!(d.at(10, 30, 0), 0.0);
        assert!(d.at(100, 30, 0) > 0.95);
        // Windows only see object pixels: a flat object next to a bright background stays calm.
        let mask = Mask::from_fn(120, 60, |x, _| x < 60);
        let d = tendency(&img, &mask, 0.6, 60.0);
        assert!(d.data().iter().all(|&v| v < 1e-3), "max {}", d.value_range().1);
    }
}
