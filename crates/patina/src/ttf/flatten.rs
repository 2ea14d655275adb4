//! Low-frequency normalisation (Enrique et al., section 5.3): a time-lapse
//! lit unevenly (a flash, a window) carries its lighting gradient into every
//! block, and quilting would scatter bright and dark blocks over the output.
//! Low-pass a representative frame, divide every frame by it before
//! synthesis, and optionally multiply the gradient back afterwards.
//!
//! The representative frame is the temporal mean (robust to any one frame
//! being odd); the low-pass is a Gaussian with sigma = `sigma` x the larger
//! side, normalised to mean 1 per channel so the division keeps the overall
//! brightness.

use crate::error::Result;
use crate::image::filter::gaussian_blur;
use crate::image::resample::{resize, Filter};
use crate::image::Image;
use rayon::prelude::*;

/// Smallest low-pass value divided by (relative to its mean): guards black
/// corners against blowing up.
const FLOOR: f32 = 0.05;

/// The lighting field of a sequence.
#[derive(Clone, Debug)]
pub struct Lighting(Image);

impl Lighting {
    /// Estimate the lighting of `frames` (Gaussian of sigma = `sigma` x the
    /// larger side over the temporal mean).
    pub fn estimate(frames: &[Image], sigma: f32) -> Self {
        let first = &frames[0];
        let mut mean = Image::new(first.width(), first.height(), first.channels());
        let inv = 1.0 / frames.len() as f32;
        mean.data_mut().par_chunks_mut(4096).enumerate().for_each(|(b, chunk)| {
            for f in frames {
                let src = &f.data()[b * 4096..b * 4096 + chunk.len()];
                chunk.iter_mut().zip(src).for_each(|(m, v)| *m += v * inv);
            }
        });
        let low = gaussian_blur(&mean, sigma * first.width().max(first.height()) as f32);
        let c = low.channels();
        let mut avg = vec![0.0f64; c];
        for p in low.data().chunks_exact(c) {
            avg.iter_mut().zip(p).for_each(|(a, v)| *a += f64::from(*v));
        }
        let n = (low.width() * low.height()) as f64;
        let avg: Vec<f32> = avg.iter().map(|a| (a / n) as f32).collect();
        let mut field = low;
        for p in field.data_mut().chunks_exact_mut(c) {
            p.iter_mut().zip(&avg).for_each(|(v, a)| *v = if *a > 0.0 { (*v / a).max(FLOOR) } else { 1.0 });
        }
        Lighting(field)
    }

    /// The field (mean 1 per channel), the source's size.
    pub fn field(&self) -> &Image {
        &self.0
    }

    /// Every frame divided by the field.
    pub fn divide(&self, frames: &[Image]) -> Vec<Image> {
        frames
            .par_iter()
            .map(|f| {
                let mut out = f.clone();
                out.data_mut().iter_mut().zip(self.0.data()).for_each(|(v, l)| *v /= l);
                out
            })
            .collect()
    }

    /// `frame` multiplied by the field stretched to its size (the
    /// gradient's shape carried over the larger output).
    pub fn restore(&self, frames: &mut [Image]) -> Result<()> {
        let Some(first) = frames.first() else { return Ok(()) };
        let field = resize(&self.0, first.width(), first.height(), Filter::Linear)?;
        frames.par_iter_mut().for_each(|f| f.data_mut().iter_mut().zip(field.data()).for_each(|(v, l)| *v *= l));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lighting_ramp_is_divided_out_and_can_be_put_back() {
        let tex = crate::samples::blotches(64, 48, 3);
        let ramp = |x: usize| 0.4 + 0.6 * x as f32 / 63.0;
        let lit: Vec<Image> = (0..4)
            .map(|_| Image::from_fn(64, 48, 3, |x, y, p| tex.pixel(x, y).iter().zip(p.iter_mut()).for_each(|(t, o)| *o = t * ramp(x))))
            .collect();
        let light = Lighting::estimate(&lit, 0.125);
        let flat = light.divide(&lit);
        let half_mean = |img: &Image, left: bool| {
            let xs = if left { 4..28 } else { 36..60 };
            let mut s = 0.0;
            for y in 0..48 {
                for x in xs.clone() {
                    s += img.pixel(x, y)[0];
                }
            }
            s / (24.0 * 48.0)
        };
        // The right half's brightness relative to the left, lit and
        // flattened, against the same texture unlit and flattened.
        let ratio = |img: &Image| half_mean(img, false) / half_mean(img, true);
        let plain = vec![tex.clone()];
        let plain_flat = Lighting::estimate(&plain, 0.125).divide(&plain);
        let (before, after, want) = (ratio(&lit[0]), ratio(&flat[0]), ratio(&plain_flat[0]));
        assert!(before > 1.2 * want, "lit {before} vs {want}");
        assert!((after / want - 1.0).abs() < 0.1, "flattened {after} vs {want}");
        let mut back = flat.clone();
        light.restore(&mut back).unwrap();
        let err = back[0].data().iter().zip(lit[0].data()).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(err < 1e-4, "{err}");
    }
}
