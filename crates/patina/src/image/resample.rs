//! Resampling (nearest, linear, cubic; antialiased when shrinking) and
//! Gaussian pyramids.

use super::Image;
use crate::error::{Error, Result};
use rayon::prelude::*;

/// Reconstruction filter for [`resize`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Nearest,
    /// Triangle (bilinear).
    Linear,
    /// Catmull-Rom cubic.
    Cubic,
}

impl Filter {
    fn support(self) -> f32 {
        match self {
            Filter::Nearest => 0.5,
            Filter::Linear => 1.0,
            Filter::Cubic => 2.0,
        }
    }
    /// The filter's kernel at distance `x` (in samples).
    pub fn weight(self, x: f32) -> f32 {
        let x = x.abs();
        match self {
            Filter::Nearest => (x < 0.5) as u8 as f32,
            Filter::Linear => (1.0 - x).max(0.0),
            Filter::Cubic => {
                if x < 1.0 {
                    1.5 * x * x * x - 2.5 * x * x + 1.0
                } else if x < 2.0 {
                    -0.5 * x * x * x + 2.5 * x * x - 4.0 * x + 2.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// Taps (first source index, weights) for each output position along one axis.
fn axis_taps(src: usize, dst: usize, filter: Filter) -> Vec<(usize, Vec<f32>)> {
    let scale = src as f32 / dst as f32;
    let widen = if filter == Filter::Nearest { 1.0 } else { scale.max(1.0) };
    let support = filter.support() * widen;
    (0..dst)
        .map(|i| {
            let centre = (i as f32 + 0.5) * scale - 0.5;
            if filter == Filter::Nearest {
                return ((centre.round().max(0.0) as usize).min(src - 1), vec![1.0]);
            }
            let lo = (centre - support).floor().max(0.0) as usize;
            let hi = ((centre + support).ceil() as usize).min(src - 1);
            let mut w: Vec<f32> = (lo..=hi).map(|s| filter.weight((s as f32 - centre) / widen)).collect();
            let sum: f32 = w.iter().sum();
            if sum.abs() > 1e-8 {
                w.iter_mut().for_each(|v| *v /= sum);
            }
            (lo, w)
        })
        .collect()
}

fn resize_axis(img: &Image, dst: usize, horizontal: bool, filter: Filter) -> Image {
    let (w, h, n) = (img.width(), img.height(), img.channels());
    let (ow, oh) = if horizontal { (dst, h) } else { (w, dst) };
    let taps = axis_taps(if horizontal { w } else { h }, dst, filter);
    let src = img.data();
    let mut out = Image::new(ow, oh, n);
    out.set_groups(img.groups().to_vec()).expect("same channels");
    out.data_mut().par_chunks_mut(ow * n).enumerate().for_each(|(y, row)| {
        for x in 0..ow {
            let px = &mut row[x * n..(x + 1) * n];
            let (lo, ws) = &taps[if horizontal { x } else { y }];
            for (k, &wt) in ws.iter().enumerate() {
                let (sx, sy) = if horizontal { (lo + k, y) } else { (x, lo + k) };
                let s = &src[(sy * w + sx) * n..(sy * w + sx + 1) * n];
                for (v, &sv) in px.iter_mut().zip(s) {
                    *v += wt * sv;
                }
            }
        }
    });
    out
}

/// Resize to `width` x `height`. Shrinking widens the filter (antialiasing).
pub fn resize(img: &Image, width: usize, height: usize, filter: Filter) -> Result<Image> {
    if width == 0 || height == 0 || width > super::MAX_SIDE || height > super::MAX_SIDE {
        return Err(Error::invalid(format!("cannot resize to {width}x{height}")));
    }
    let tmp = if width == img.width() { img.clone() } else { resize_axis(img, width, true, filter) };
    Ok(if height == img.height() { tmp } else { resize_axis(&tmp, height, false, filter) })
}

/// One pyramid step: binomial [1 4 6 4 1]/16 blur, then every other pixel.
/// Output size is ceil(w/2) x ceil(h/2).
pub fn pyr_down(img: &Image) -> Image {
    let taps = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];
    let blurred = super::filter::convolve_1d(&super::filter::convolve_1d(img, &taps, true), &taps, false);
    let (w, h) = (img.width().div_ceil(2), img.height().div_ceil(2));
    let mut out = Image::new(w, h, img.channels());
    out.set_groups(img.groups().to_vec()).expect("same channels");
    for y in 0..h {
        for x in 0..w {
            out.pixel_mut(x, y).copy_from_slice(blurred.pixel(2 * x, 2 * y));
        }
    }
    out
}

/// A pyramid of anything, finest first: `first`, then `levels - 1` more,
/// each `down` of the previous (images, masks, ...).
pub fn pyramid<T>(first: T, levels: usize, down: impl Fn(&T) -> T) -> Vec<T> {
    let mut out = vec![first];
    while out.len() < levels {
        let next = down(out.last().expect("non-empty"));
        out.push(next);
    }
    out
}

/// Gaussian pyramid, finest first: `levels` images, each half the previous.
pub fn gaussian_pyramid(img: &Image, levels: usize) -> Vec<Image> {
    pyramid(img.clone(), levels, pyr_down)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resize_preserves_constants_and_linear_ramps() {
        let c = Image::from_fn(10, 7, 2, |_, _, p| p.copy_from_slice(&[0.25, 0.75]));
        for f in [Filter::Nearest, Filter::Linear, Filter::Cubic] {
            for (w, h) in [(23, 5), (4, 14), (10, 7)] {
                let r = resize(&c, w, h, f).unwrap();
                assert!(r.data().iter().enumerate().all(|(i, v)| (v - [0.25, 0.75][i % 2]).abs() < 1e-5));
            }
        }
        let ramp = Image::from_fn(16, 4, 1, |x, _, p| p[0] = x as f32);
        let up = resize(&ramp, 32, 4, Filter::Linear).unwrap();
        // Pixel centres: output x maps to source (x + 0.5)/2 - 0.5.
        assert!((up.at(9, 1, 0) - 4.25).abs() < 1e-5);
        assert!(resize(&ramp, 0, 4, Filter::Linear).is_err());
    }

    #[test]
    fn pyramid_halves_sizes() {
        let img = Image::new(37, 20, 3);
        let p = gaussian_pyramid(&img, 4);
        let sizes: Vec<_> = p.iter().map(|i| i.size()).collect();
        assert_eq!(sizes, vec![(37, 20), (19, 10), (10, 5), (5, 3)]);
    }
}
