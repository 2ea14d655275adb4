//! Filters: separable Gaussian blur and image gradients.

use super::resample::{resize, Filter};
use super::{Image, Mask};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Normalised 1-D Gaussian taps for `sigma`, radius ceil(3 sigma).
pub fn gaussian_kernel(sigma: f32) -> Vec<f32> {
    let r = (3.0 * sigma).ceil().max(1.0) as isize;
    let k: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp()).collect();
    let s: f32 = k.iter().sum();
    k.into_iter().map(|v| v / s).collect()
}

/// Convolve rows (horizontal) or columns (vertical) with symmetric taps,
/// clamping coordinates at the border.
pub fn convolve_1d(img: &Image, taps: &[f32], horizontal: bool) -> Image {
    let (w, h, n) = (img.width(), img.height(), img.channels());
    let r = (taps.len() / 2) as isize;
    let src = img.data();
    let mut out = img.clone();
    out.data_mut().par_chunks_mut(w * n).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            let px = &mut row[x * n..(x + 1) * n];
            px.iter_mut().for_each(|v| *v = 0.0);
            for (i, &t) in taps.iter().enumerate() {
                let o = i as isize - r;
                let (sx, sy) = if horizontal {
                    ((x as isize + o).clamp(0, w as isize - 1) as usize, y)
                } else {
                    (x, (y as isize + o).clamp(0, h as isize - 1) as usize)
                };
                let s = &src[(sy * w + sx) * n..(sy * w + sx + 1) * n];
                for (v, &sv) in px.iter_mut().zip(s) {
                    *v += t * sv;
                }
            }
        }
    });
    out
}

/// Sigma (pixels) above which [`gaussian_blur`] works on a shrunken copy.
const PYRAMID_SIGMA: f32 = 12.0;

/// Gaussian blur of every channel with standard deviation `sigma` pixels.
///
/// Up to [`PYRAMID_SIGMA`] the separable kernel runs directly. Wider blurs
/// (lighting fields, a sigma of 128 px at 1024 px) shrink the image by f =
/// floor(sigma / 6) (antialiased: a triangle prefilter of variance f^2/6),
/// blur it with the remaining sigma, sqrt(sigma^2 - f^2/3) / f, and stretch
/// it back bilinearly (another f^2/6): the same Gaussian to within 1% of
/// the value range, at a cost that no longer grows with sigma. (Within
/// sigma of the border it extends the image by the mean of its last few
/// rows and columns, where the direct blur repeats the very last one.)
pub fn gaussian_blur(img: &Image, sigma: f32) -> Image {
    if sigma <= 0.0 {
        return img.clone();
    }
    if sigma > PYRAMID_SIGMA {
        if let Some(out) = shrunk_blur(img, sigma, (sigma / 6.0).floor()) {
            return out;
        }
    }
    direct_blur(img, sigma)
}

/// The two halves of a normalised convolution: `values` (any number of
/// channels) weighted per pixel by `weight` (one channel) and blurred by
/// a Gaussian of `sigma`, and `weight` blurred alike. Their ratio is the
/// weighted local mean; each caller divides where the weight is enough.
pub fn weighted_blur(values: &Image, weight: &Image, sigma: f32) -> (Image, Image) {
    let mut held = values.clone();
    let n = values.channels();
    held.data_mut().chunks_exact_mut(n).zip(weight.data()).for_each(|(px, &m)| px.iter_mut().for_each(|v| *v *= m));
    (gaussian_blur(&held, sigma), gaussian_blur(weight, sigma))
}

/// The Gaussian blur by `sigma` done on a copy shrunk by `f` (see
/// [`gaussian_blur`]: a triangle prefilter, the remaining sigma
/// sqrt(sigma^2 - f^2/3) / f, a bilinear stretch back). `None` when the
/// copy would be under 2 x 2 pixels or `f` is 0.
pub fn shrunk_blur(img: &Image, sigma: f32, f: f32) -> Option<Image> {
    let (w, h) = img.size();
    if f < 1.0 {
        return None;
    }
    let (sw, sh) = ((w as f32 / f).ceil() as usize, (h as f32 / f).ceil() as usize);
    let inner = (sigma * sigma - f * f / 3.0).sqrt() / f;
    if sw < 2 || sh < 2 {
        return None;
    }
    let small = resize(img, sw, sh, Filter::Linear).ok()?;
    resize(&direct_blur(&small, inner), w, h, Filter::Linear).ok()
}

/// The separable Gaussian, tap by tap.
fn direct_blur(img: &Image, sigma: f32) -> Image {
    let k = gaussian_kernel(sigma);
    convolve_1d(&convolve_1d(img, &k, true), &k, false)
}

/// Per-pixel gradient of an image.
pub struct Gradients {
    /// |grad I| (1 channel).
    pub magnitude: Image,
    /// Direction atan2(dy, dx) in radians, in (-pi, pi] (1 channel).
    pub direction: Image,
}

/// Sobel gradients. For several channels, each pixel takes the gradient of
/// the channel where it is strongest (so a colour edge invisible in
/// luminance still has a direction).
pub fn gradients(img: &Image) -> Gradients {
    let (w, h, n) = (img.width(), img.height(), img.channels());
    let at = |x: isize, y: isize, c: usize| img.at(x.clamp(0, w as isize - 1) as usize, y.clamp(0, h as isize - 1) as usize, c);
    let mut mag = vec![0f32; w * h];
    let mut dir = vec![0f32; w * h];
    mag.par_chunks_mut(w).zip(dir.par_chunks_mut(w)).enumerate().for_each(|(y, (mrow, drow))| {
        let y = y as isize;
        for x in 0..w {
            let xi = x as isize;
            let mut best = (-1.0f32, 0.0f32, 0.0f32);
            for c in 0..n {
                let gx = (at(xi + 1, y - 1, c) + 2.0 * at(xi + 1, y, c) + at(xi + 1, y + 1, c))
                    - (at(xi - 1, y - 1, c) + 2.0 * at(xi - 1, y, c) + at(xi - 1, y + 1, c));
                let gy = (at(xi - 1, y + 1, c) + 2.0 * at(xi, y + 1, c) + at(xi + 1, y + 1, c))
                    - (at(xi - 1, y - 1, c) + 2.0 * at(xi, y - 1, c) + at(xi + 1, y - 1, c));
                let m = (gx * gx + gy * gy).sqrt() / 8.0;
                if m > best.0 {
                    best = (m, gx, gy);
                }
            }
            mrow[x] = best.0;
            let d = best.2.atan2(best.1);
            drow[x] = if d <= -PI { PI } else { d };
        }
    });
    Gradients {
        magnitude: Image::from_data(w, h, 1, mag).expect("sizes match"),
        direction: Image::from_data(w, h, 1, dir).expect("sizes match"),
    }
}

/// Dominant local orientation from the structure tensor (the outer product
/// of the Sobel gradient, averaged by a Gaussian of `sigma`).
pub struct Orientation {
    /// Direction of the dominant gradient (across the structure: across
    /// wood grain, across a crack), in radians (1 channel).
    pub across: Image,
    /// Coherence (l1 - l2) / (l1 + l2) in [0, 1]: 0 isotropic, 1 one
    /// direction (1 channel).
    pub coherence: Image,
}

/// The structure tensor's dominant orientation and coherence at every pixel,
/// from the pixels of `only` when given (a normalised convolution: so the
/// edges of a region left out, such as damage, do not take over the
/// orientation of the material around it).
pub fn orientation(img: &Image, sigma: f32, only: Option<&Mask>) -> Orientation {
    let g = gradients(img);
    let (w, h) = img.size();
    let tensor = Image::from_fn(w, h, 3, |x, y, p| {
        if only.is_some_and(|m| !m.get(x, y)) {
            return;
        }
        let (m, d) = (g.magnitude.at(x, y, 0), g.direction.at(x, y, 0));
        let (gx, gy) = (m * d.cos(), m * d.sin());
        p.copy_from_slice(&[gx * gx, gx * gy, gy * gy]);
    });
    // Coherence is a ratio, so the normaliser of the convolution cancels.
    let t = gaussian_blur(&tensor, sigma);
    let mut across = Image::new(w, h, 1);
    let mut coherence = Image::new(w, h, 1);
    for (i, j) in t.data().chunks_exact(3).enumerate() {
        let (xx, xy, yy) = (j[0], j[1], j[2]);
        across.data_mut()[i] = 0.5 * (2.0 * xy).atan2(xx - yy);
        let trace = xx + yy;
        coherence.data_mut()[i] = if trace > 1e-12 { ((xx - yy).powi(2) + 4.0 * xy * xy).sqrt() / trace } else { 0.0 };
    }
    Orientation { across, coherence }
}

/// Ranks of a one-channel image's values mapped to [0, 1] (ties share the
/// lowest rank): its histogram-equalised version.
pub fn equalize(img: &Image) -> Image {
    let v = img.data();
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]).then(a.cmp(&b)));
    let mut out = vec![0.0f32; v.len()];
    let scale = 1.0 / (v.len().max(2) - 1) as f32;
    let mut rank = 0;
    for (i, &idx) in order.iter().enumerate() {
        if i > 0 && v[idx] != v[order[i - 1]] {
            rank = i;
        }
        out[idx] = rank as f32 * scale;
    }
    Image::from_data(img.width(), img.height(), 1, out).expect("same size")
}

/// The grey-level closing of a one-channel image: the maximum over a
/// (2r+1)^2 square, then the minimum over the same square (both
/// separable, clamped at the image's edges). It fills dark features
/// narrower than the square and keeps everything else.
pub fn closing(img: &Image, r: usize) -> Image {
    let pass = |src: &Image, horizontal: bool, max: bool| -> Image {
        let (w, h) = src.size();
        let mut out = vec![0f32; w * h];
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let (pos, len) = if horizontal { (x, w) } else { (y, h) };
                let range = pos.saturating_sub(r)..(pos + r + 1).min(len);
                let values = range.map(|q| if horizontal { src.at(q, y, 0) } else { src.at(x, q, 0) });
                *o = if max { values.fold(f32::MIN, f32::max) } else { values.fold(f32::MAX, f32::min) };
            }
        });
        Image::from_data(w, h, 1, out).expect("same size")
    };
    let dilated = pass(&pass(img, true, true), false, true);
    pass(&pass(&dilated, true, false), false, false)
}

/// Otsu's threshold of `values` (64 bins over their range).
pub fn otsu(values: &[f32]) -> f32 {
    let (lo, hi) = values.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    if hi <= lo {
        return lo;
    }
    let bins = 64;
    let mut hist = vec![0f64; bins];
    values.iter().for_each(|&v| hist[(((v - lo) / (hi - lo) * bins as f32) as usize).min(bins - 1)] += 1.0);
    let total: f64 = hist.iter().sum();
    let sum_all: f64 = hist.iter().enumerate().map(|(i, &c)| i as f64 * c).sum();
    let (mut best, mut best_t, mut w0, mut s0) = (-1.0, 0usize, 0.0, 0.0);
    for (t, &c) in hist.iter().enumerate() {
        w0 += c;
        s0 += t as f64 * c;
        let w1 = total - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let between = w0 * w1 * (s0 / w0 - (sum_all - s0) / w1).powi(2);
        if between > best {
            best = between;
            best_t = t;
        }
    }
    lo + (best_t + 1) as f32 / bins as f32 * (hi - lo)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closing_fills_narrow_dark_features_and_keeps_wide_ones() {
        // A 3 px dark dot and a 12 px dark square on 1.0.
        let img = Image::from_fn(40, 20, 1, |x, y, p| {
            p[0] = if (4..7).contains(&x) && (8..11).contains(&y) || (20..32).contains(&x) && (4..16).contains(&y) { 0.2 } else { 1.0 }
        });
        let closed = closing(&img, 2);
        assert_eq!(closed.at(5, 9, 0), 1.0, "the dot is filled");
        assert_eq!(closed.at(26, 10, 0), 0.2, "the square's inside stays");
        assert_eq!(closed.at(15, 10, 0), 1.0, "the surface stays");
    }

    #[test]
    fn horizontal_stripes_point_across_in_y_and_are_coherent() {
        let img = Image::from_fn(64, 64, 1, |_, y, p| p[0] = (y as f32 * 0.7).sin());
        let o = orientation(&img, 3.0, None);
        let (a, c) = (o.across.at(32, 32, 0), o.coherence.at(32, 32, 0));
        assert!((a.abs() - std::f32::consts::FRAC_PI_2).abs() < 0.05, "across {a}");
        assert!(c > 0.95, "coherence {c}");
        let noise = Image::from_fn(64, 64, 1, |x, y, p| p[0] = ((x * 7919 + y * 104729) % 97) as f32 / 97.0);
        assert!(orientation(&noise, 6.0, None).coherence.at(32, 32, 0) < 0.5);
    }

    #[test]
    fn a_wide_blur_on_a_shrunken_copy_matches_the_direct_one() {
        // A vignette times a texture, and a hard step: lighting-like
        // content and the worst case for resampling.
        let (w, h) = (560, 420);
        let tex = crate::samples::cobbles(w, h, 2);
        let img = Image::from_fn(w, h, 3, |x, y, p| {
            let v = 1.0 - 0.6 * ((x as f32 - 280.0).powi(2) + (y as f32 - 210.0).powi(2)) / 123_000.0;
            let step = if x < 250 { 0.0 } else { 0.3 };
            p.iter_mut().zip(tex.pixel(x, y)).for_each(|(o, t)| *o = t * v + step);
        });
        for sigma in [13.0f32, 17.0, 30.0, 55.0] {
            let fast = gaussian_blur(&img, sigma);
            let slow = direct_blur(&img, sigma);
            // Near the border the two extend the image differently: the
            // direct blur repeats the last row, the shrunken copy the mean
            // of the last few.
            let m = 2 * sigma as usize;
            let mut err = 0.0f32;
            for y in m..h - m {
                for x in m..w - m {
                    for c in 0..3 {
                        err = err.max((fast.at(x, y, c) - slow.at(x, y, c)).abs());
                    }
                }
            }
            assert!(err < 0.01, "sigma {sigma}: max difference {err}");
        }
    }

    #[test]
    fn blur_keeps_mean_and_lowers_variance() {
        let img = Image::from_fn(32, 32, 1, |x, y, p| p[0] = ((x * 7 + y * 13) % 5) as f32);
        let b = gaussian_blur(&img, 2.0);
        let mean = |i: &Image| i.data().iter().sum::<f32>() / i.data().len() as f32;
        let var = |i: &Image| {
            let m = mean(i);
            i.data().iter().map(|v| (v - m).powi(2)).sum::<f32>()
        };
        assert!((mean(&img) - mean(&b)).abs() < 0.05);
        assert!(var(&b) < 0.1 * var(&img));
    }

    #[test]
    fn gradient_of_a_ramp_points_along_it() {
        let img = Image::from_fn(16, 16, 3, |x, y, p| p[1] = 0.01 * x as f32 + 0.02 * y as f32);
        let g = gradients(&img);
        let d = g.direction.at(8, 8, 0);
        assert!((d - (2.0f32).atan2(1.0)).abs() < 1e-4, "direction {d}");
        assert!((g.magnitude.at(8, 8, 0) - (0.01f32.hypot(0.02))).abs() < 1e-5);
    }

    #[test]
    fn equalization_spreads_values_evenly() {
        let img = Image::from_fn(4, 1, 1, |x, _, p| p[0] = [0.1, 0.9, 0.5, 0.11][x]);
        assert_eq!(equalize(&img).data(), &[0.0, 1.0, 2.0 / 3.0, 1.0 / 3.0]);
    }
}
