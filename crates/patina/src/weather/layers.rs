//! Colour layers (Bellini et al. 2016, section 4, "layers"): a texture
//! made of several materials (paint over wood, glaze and grout) is split
//! by colour, each layer is aged on its own terms, and the results merged.
//!
//! Segmentation is k-means in CIE Lab (k-means++ seeding from the seed,
//! Lloyd iterations on a regular subsample, then every pixel assigned), or
//! a user label image (one grey level per layer).
//!
//! Simplification: the age map is computed once on the whole image and
//! then normalised to [0, 1] within each layer, and the intact texture's
//! discarded sources are the most-aged fraction of each layer. So a layer
//! that is weathered throughout its own area is judged against itself, not
//! against the other layers' material. The paper computes the whole
//! age-map pipeline per layer; the grid cells then mix layers at their
//! boundaries, which this avoids.

use crate::error::{Error, Result};
use crate::image::{color, Image, Mask};
use crate::rng::{self, Rng};

/// Lloyd iterations of k-means.
const ITERATIONS: usize = 12;
/// Pixels sampled for k-means (all pixels are then assigned).
const SAMPLES: usize = 20_000;

/// Per-pixel layer labels in 0..k.
#[derive(Clone, Debug, PartialEq)]
pub struct Layers {
    pub width: usize,
    pub height: usize,
    pub count: usize,
    pub labels: Vec<u8>,
}

impl Layers {
    /// Segment `img` (sRGB) into `k` colour layers by k-means in Lab.
    pub fn kmeans(img: &Image, k: usize, seed: u64) -> Result<Layers> {
        if !(1..=16).contains(&k) {
            return Err(Error::invalid(format!("layers must be between 1 and 16, got {k}")));
        }
        let lab = color::to_lab(img);
        let px: Vec<[f32; 3]> = lab.data().chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
        let stride = (px.len() / SAMPLES).max(1);
        let sample: Vec<[f32; 3]> = px.iter().step_by(stride).copied().collect();
        let d2 = |a: &[f32; 3], b: &[f32; 3]| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f32>();
        // k-means++ seeding.
        let mut g = rng::generator(seed, &[0x1a]);
        let mut centres = vec![sample[g.gen_range(0..sample.len())]];
        while centres.len() < k {
            let dist: Vec<f32> = sample.iter().map(|p| centres.iter().map(|c| d2(p, c)).fold(f32::MAX, f32::min)).collect();
            let total: f64 = dist.iter().map(|&d| d as f64).sum();
            if total <= 0.0 {
                break; // fewer distinct colours than layers
            }
            let mut pick = g.gen_range(0.0..total);
            let mut chosen = sample.len() - 1;
            for (i, &d) in dist.iter().enumerate() {
                pick -= d as f64;
                if pick <= 0.0 {
                    chosen = i;
                    break;
                }
            }
            centres.push(sample[chosen]);
        }
        let nearest = |p: &[f32; 3], centres: &[[f32; 3]]| {
            (0..centres.len()).min_by(|&a, &b| d2(p, &centres[a]).total_cmp(&d2(p, &centres[b]))).expect("at least one centre")
        };
        for _ in 0..ITERATIONS {
            let mut sums = vec![([0f64; 3], 0usize); centres.len()];
            for p in &sample {
                let c = nearest(p, &centres);
                (0..3).for_each(|i| sums[c].0[i] += p[i] as f64);
                sums[c].1 += 1;
            }
            for (centre, (sum, count)) in centres.iter_mut().zip(&sums) {
                if *count > 0 {
                    *centre = [0, 1, 2].map(|i| (sum[i] / *count as f64) as f32);
                }
            }
        }
        let labels = px.iter().map(|p| nearest(p, &centres) as u8).collect();
        Ok(Layers { width: img.width(), height: img.height(), count: centres.len(), labels })
    }

    /// Layers from a label image: each distinct grey level (8-bit) is a layer.
    pub fn from_label_image(labels: &Image) -> Result<Layers> {
        let grey = color::luminance(labels);
        let mut levels: Vec<u8> = grey.data().iter().map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8).collect();
        let mut distinct = levels.clone();
        distinct.sort_unstable();
        distinct.dedup();
        if distinct.len() > 16 {
            return Err(Error::invalid(format!("the label image has {} grey levels; at most 16 layers are supported", distinct.len())));
        }
        levels.iter_mut().for_each(|v| *v = distinct.binary_search(v).expect("level is listed") as u8);
        Ok(Layers { width: labels.width(), height: labels.height(), count: distinct.len(), labels: levels })
    }

    /// The pixels of layer `l`.
    pub fn mask(&self, l: usize) -> Mask {
        Mask::from_fn(self.width, self.height, |x, y| self.labels[y * self.width + x] as usize == l)
    }

    /// The age map normalised to [0, 1] within each layer.
    pub fn normalise_age(&self, age: &Image) -> Image {
        let mut out = age.clone();
        for l in 0..self.count {
            let (mut lo, mut hi) = (f32::MAX, f32::MIN);
            for (v, &lab) in age.data().iter().zip(&self.labels) {
                if lab as usize == l {
                    lo = lo.min(*v);
                    hi = hi.max(*v);
                }
            }
            for (o, &lab) in out.data_mut().iter_mut().zip(&self.labels) {
                if lab as usize == l {
                    *o = if hi > lo { (*o - lo) / (hi - lo) } else { 0.0 };
                }
            }
        }
        out
    }

    /// The labels of the area (left, top, width, height), which lies
    /// inside the layers' image.
    pub fn crop(&self, (x0, y0, w, h): (usize, usize, usize, usize)) -> Layers {
        let labels = (y0..y0 + h).flat_map(|y| (x0..x0 + w).map(move |x| (x, y))).map(|(x, y)| self.labels[y * self.width + x]).collect();
        Layers { width: w, height: h, count: self.count, labels }
    }

    /// As an image: layer l has grey level l / (count - 1).
    pub fn to_image(&self) -> Image {
        let scale = 1.0 / (self.count.max(2) - 1) as f32;
        Image::from_fn(self.width, self.height, 1, |x, y, p| p[0] = self.labels[y * self.width + x] as f32 * scale)
    }
}
