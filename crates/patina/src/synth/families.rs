//! The material families of an exemplar and their shares, so synthesis can
//! keep the output's mix of materials to the exemplar's.
//!
//! A family is a k-means cluster ([`crate::image::cluster`]) of the
//! exemplar's colours (its first three channels, weighted as the synthesis
//! weighs them) after a Gaussian blur, so a family is a material at the
//! scale of a feature (teal paint, red rust, an orange bloom), not a pixel
//! colour. Every exemplar pixel belongs to its nearest centre; a family's
//! share is its part of the exemplar's area.
//!
//! Not in the quilting paper. Quilting continues whatever its neighbours
//! hold, so a material that joins the rest along only a short edge of the
//! exemplar (rust blooms' teal corner, 10% of it) spreads once started: the
//! output came out about half teal, and every teal block brought one of the
//! corner's two orange blooms (18-20 of them in a 2x enlargement). The
//! per-region reuse bound cannot see it, since the two blooms are each
//! other's near twin.

use crate::error::{Error, Result};
use crate::image::cluster::{kmeans, nearest};
use crate::image::filter::gaussian_blur;
use crate::image::Image;
use crate::rng;
use nalgebra::Vector3;

/// Families per exemplar.
pub const FAMILIES: usize = 6;
/// At most this many pixels (an even stride) seed the k-means.
const SAMPLES: usize = 4000;

/// An exemplar's material families: centres, each pixel's family and
/// each family's share of the area.
#[derive(Clone, Debug)]
pub struct Families {
    centres: Vec<Vector3<f64>>,
    weights: Vec<f32>,
    sigma: f32,
    size: (usize, usize),
    labels: Vec<u8>,
    shares: Vec<f64>,
}

impl Families {
    /// The families of `exemplar`, whose channels are weighed by `weights`
    /// (as the synthesis's SSD weighs them), blurred at `sigma` pixels.
    pub fn of(exemplar: &Image, weights: &[f32], sigma: f32, seed: u64) -> Result<Self> {
        if weights.len() != exemplar.channels() {
            return Err(Error::invalid(format!("{} channel weights for a {}-channel exemplar", weights.len(), exemplar.channels())));
        }
        let points = features(exemplar, weights, sigma);
        let stride = points.len().div_ceil(SAMPLES).max(1);
        let sample: Vec<Vector3<f64>> = points.iter().step_by(stride).copied().collect();
        let centres = kmeans(&sample, FAMILIES.min(sample.len()), &mut rng::generator(seed, &[0xfa]));
        let labels: Vec<u8> = points.iter().map(|p| nearest(p, &centres) as u8).collect();
        let mut shares = vec![0.0f64; centres.len()];
        labels.iter().for_each(|&l| shares[l as usize] += 1.0);
        shares.iter_mut().for_each(|s| *s /= labels.len() as f64);
        Ok(Families { centres, weights: weights.to_vec(), sigma, size: exemplar.size(), labels, shares })
    }

    /// How many families there are.
    pub fn count(&self) -> usize {
        self.centres.len()
    }

    /// The family of exemplar pixel (x, y).
    pub fn label(&self, x: usize, y: usize) -> usize {
        self.labels[y * self.size.0 + x] as usize
    }

    /// Each family's share of the exemplar.
    pub fn shares(&self) -> &[f64] {
        &self.shares
    }

    /// Each family's share of `img` (the exemplar's channels, any size):
    /// every pixel, blurred as the exemplar was, joins its nearest centre.
    pub fn shares_in(&self, img: &Image) -> Result<Vec<f64>> {
        if img.channels() != self.weights.len() {
            return Err(Error::invalid(format!(
                "a {}-channel image has no share of {}-channel families",
                img.channels(),
                self.weights.len()
            )));
        }
        let points = features(img, &self.weights, self.sigma);
        let mut shares = vec![0.0f64; self.count()];
        points.iter().for_each(|p| shares[nearest(p, &self.centres)] += 1.0);
        shares.iter_mut().for_each(|s| *s /= points.len().max(1) as f64);
        Ok(shares)
    }
}

/// Per pixel, the first three channels of `img` blurred at `sigma`, each
/// times the square root of its weight (missing ones 0), so squared
/// distances between features are the synthesis's weighted SSD.
fn features(img: &Image, weights: &[f32], sigma: f32) -> Vec<Vector3<f64>> {
    let blurred = gaussian_blur(img, sigma);
    let c = img.channels();
    let scale: Vec<f64> = (0..3).map(|k| weights.get(k).map_or(0.0, |&w| f64::from(w.max(0.0)).sqrt())).collect();
    blurred.data().chunks_exact(c).map(|p| Vector3::from_fn(|k, _| p.get(k).map_or(0.0, |&v| f64::from(v) * scale[k]))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corner_of_another_material_is_its_own_family_with_its_share() {
        // Red with a teal corner of 48 x 48 of 128 x 128 (14%).
        let ex = Image::from_fn(128, 128, 3, |x, y, p| {
            let n = ((x * 7 + y * 13) % 5) as f32 * 0.02;
            p.copy_from_slice(&if x >= 80 && y >= 80 { [0.2 + n, 0.6, 0.55] } else { [0.6 + n, 0.15, 0.1] });
        });
        let f = Families::of(&ex, &[1.0 / 3.0; 3], 2.0, 1).unwrap();
        let teal = f.label(110, 110);
        assert_ne!(teal, f.label(10, 10));
        let share = f.shares()[teal];
        assert!((0.1..0.18).contains(&share), "teal share {share}");
        // An image that is half teal shows that family at about one half.
        let half =
            Image::from_fn(128, 128, 3, |x, y, p| p.copy_from_slice(ex.pixel(if x < 64 { x } else { 100 }, if x < 64 { y } else { 100 })));
        let got = f.shares_in(&half).unwrap()[teal];
        assert!((0.45..0.55).contains(&got), "teal share of the half-teal image {got}");
    }
}
