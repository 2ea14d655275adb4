//! Stationarity of a texture (Hao et al. 2023, eq. 10): the mean distance
//! between the Gram matrices of filter responses of random,
//! non-overlapping crop pairs. Low = the same statistics everywhere.
//!
//! The paper takes its responses from VGG16, whose weights patina cannot
//! ship. In their place is a fixed bank of 12 responses per pixel, all
//! computed on CIE Lab scaled to about [0, 1] (L / 100, a / 100, b / 100):
//! - the three Lab channels themselves (colour);
//! - at Gaussian scales sigma = 1, 2, 4 px of L: the x and y derivatives
//!   (central differences of the blurred L, times 4 sigma so every scale
//!   has a similar range) and the difference of Gaussians
//!   blur(L, sigma) - blur(L, 2 sigma), times 4 (edges, orientation, blobs).
//!
//! Each crop's Gram matrix is G = (1/N) sum over its pixels of f f^T
//! (uncentred, as in Gatys et al.), the distance of a pair is
//! ||G1 - G2||_F / ((||G1||_F + ||G2||_F) / 2), and crops are a quarter of
//! the image's width and height unless a crop size is given. Quarter-size
//! crops make the value fall as the image grows even for a perfectly
//! stationary texture (bigger crops estimate their Gram matrix with less
//! noise), so comparisons across sizes use one fixed crop size.

use crate::error::{Error, Result};
use crate::image::color::to_lab;
use crate::image::filter::gaussian_blur;
use crate::image::Image;
use crate::rng::{self, Rng};
use rayon::prelude::*;

/// Responses per pixel.
const FEATURES: usize = 12;
/// Gaussian scales of the bank, in pixels.
const SCALES: [f32; 3] = [1.0, 2.0, 4.0];

/// The result of [`stationarity`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct Stationarity {
    /// Mean relative Gram distance over the pairs (eq. 10): lower is more stationary.
    pub mean: f64,
    /// Standard deviation over the pairs.
    pub std: f64,
    /// Number of crop pairs.
    pub pairs: usize,
    /// Crop size (width, height).
    pub crop: (usize, usize),
}

/// Eq. 10 with the fixed filter bank over `pairs` random pairs of
/// non-overlapping crops of `img` (sRGB), drawn from `seed`. Crops are
/// `crop` (width, height), or a quarter of the image's sides if `None`.
pub fn stationarity(img: &Image, crop: Option<(usize, usize)>, pairs: usize, seed: u64) -> Result<Stationarity> {
    let (w, h) = img.size();
    let (cw, ch) = crop.unwrap_or((w / 4, h / 4));
    if cw < 16 || ch < 16 {
        return Err(Error::invalid(format!("stationarity needs crops of at least 16x16, got {cw}x{ch}")));
    }
    if 2 * cw > w && 2 * ch > h {
        return Err(Error::invalid(format!("two {cw}x{ch} crops cannot fit apart in a {w}x{h} image")));
    }
    if pairs == 0 {
        return Err(Error::invalid("stationarity needs at least one crop pair"));
    }
    let features = responses(img);
    let crops: Vec<[(usize, usize); 2]> = (0..pairs as u64)
        .map(|i| {
            let mut g = rng::generator(seed, &[0x57a7, i]);
            let mut draw = || (g.gen_range(0..=w - cw), g.gen_range(0..=h - ch));
            let a = draw();
            loop {
                let b = draw();
                if a.0.abs_diff(b.0) >= cw || a.1.abs_diff(b.1) >= ch {
                    return [a, b];
                }
            }
        })
        .collect();
    let distances: Vec<f64> = crops
        .par_iter()
        .map(|[a, b]| {
            let (ga, gb) = (gram(&features, w, *a, (cw, ch)), gram(&features, w, *b, (cw, ch)));
            let norm = |g: &[f64]| g.iter().map(|v| v * v).sum::<f64>().sqrt();
            let diff = ga.iter().zip(&gb).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt();
            diff / (0.5 * (norm(&ga) + norm(&gb))).max(1e-12)
        })
        .collect();
    let mean = distances.iter().sum::<f64>() / pairs as f64;
    let std = (distances.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / pairs as f64).sqrt();
    Ok(Stationarity { mean, std, pairs, crop: (cw, ch) })
}

/// The filter bank's responses, FEATURES per pixel, interleaved.
fn responses(img: &Image) -> Vec<f32> {
    let (w, h) = img.size();
    let lab = to_lab(img);
    let l = Image::from_fn(w, h, 1, |x, y, p| p[0] = lab.at(x, y, 0) / 100.0);
    let blurred: Vec<Image> = SCALES.iter().chain(std::iter::once(&8.0)).map(|&s| gaussian_blur(&l, s)).collect();
    let mut out = vec![0f32; w * h * FEATURES];
    out.par_chunks_mut(w * FEATURES).enumerate().for_each(|(y, row)| {
        for (x, f) in row.chunks_exact_mut(FEATURES).enumerate() {
            let px = lab.pixel(x, y);
            f[0] = px[0] / 100.0;
            f[1] = px[1] / 100.0;
            f[2] = px[2] / 100.0;
            for (k, &sigma) in SCALES.iter().enumerate() {
                let b = &blurred[k];
                let (xl, xr, yu, yd) = (x.saturating_sub(1), (x + 1).min(w - 1), y.saturating_sub(1), (y + 1).min(h - 1));
                f[3 + 3 * k] = 2.0 * sigma * (b.at(xr, y, 0) - b.at(xl, y, 0));
                f[4 + 3 * k] = 2.0 * sigma * (b.at(x, yd, 0) - b.at(x, yu, 0));
                f[5 + 3 * k] = 4.0 * (b.at(x, y, 0) - blurred[k + 1].at(x, y, 0));
            }
        }
    });
    out
}

/// Uncentred Gram matrix (upper triangle, row-major) of the crop at `at`.
fn gram(features: &[f32], width: usize, at: (usize, usize), (cw, ch): (usize, usize)) -> Vec<f64> {
    let mut g = vec![0f64; FEATURES * (FEATURES + 1) / 2];
    for y in at.1..at.1 + ch {
        let mut row = [0f32; FEATURES * (FEATURES + 1) / 2];
        for f in features[(y * width + at.0) * FEATURES..(y * width + at.0 + cw) * FEATURES].chunks_exact(FEATURES) {
            let mut k = 0;
            for i in 0..FEATURES {
                for j in i..FEATURES {
                    row[k] += f[i] * f[j];
                    k += 1;
                }
            }
        }
        for (a, r) in g.iter_mut().zip(row) {
            *a += r as f64;
        }
    }
    let n = (cw * ch) as f64;
    g.iter_mut().for_each(|v| *v /= n);
    g
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples::value_noise;

    /// A stationary noise scores lower than the same noise with a drift
    /// (brightening and coarsening from left to right).
    #[test]
    fn drift_is_less_stationary_than_noise() {
        let (w, h) = (256, 256);
        let plain = Image::from_fn(w, h, 3, |x, y, p| p.fill(0.3 + 0.4 * value_noise(1, x as f32 / 4.0, y as f32 / 4.0)));
        let drift = Image::from_fn(w, h, 3, |x, y, p| {
            let s = 2.0 + 10.0 * x as f32 / w as f32;
            p.fill(0.1 + 0.5 * x as f32 / w as f32 + 0.3 * value_noise(1, x as f32 / s, y as f32 / s))
        });
        let (a, b) = (stationarity(&plain, None, 24, 0).unwrap(), stationarity(&drift, None, 24, 0).unwrap());
        assert!(b.mean > 3.0 * a.mean, "plain {a:?} drift {b:?}");
    }
}
