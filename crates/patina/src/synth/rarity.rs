//! How distinctive each part of an exemplar is, so synthesis can copy its
//! rare features (a plank knot, a lichen rosette, a chip) less often than
//! its common material.
//!
//! A pixel's rarity is the distance from its neighbourhood to the most
//! similar neighbourhood elsewhere in the exemplar (at least one patch
//! away), over the median of that distance: common material has a near
//! twin somewhere (about 1), a one-off feature does not (well above 1).
//! This is the exemplar's own nearest-neighbour self-similarity, the same
//! quantity [`crate::metrics::self_similarity`] averages, kept per pixel.
//!
//! Not in the quilting paper. Block-level reuse bounds (ours, and the
//! uniformity term of Kaspar et al. 2015) treat every source region alike,
//! so an enlargement shows a distinctive feature as often as plain grain:
//! 4-7 copies of the same knot in a 2x enlargement, which reads as a stamp.

use super::distance::PatchMetric;
use super::patchmatch::PatchMatch;
use crate::error::Result;
use crate::image::resample::{resize, Filter};
use crate::image::Image;
use crate::rng;

/// Rarity above which a neighbourhood counts as a distinctive feature. On
/// the real exemplars of examples/engine_quality the median is 1.1 and the
/// 99th percentile 1.7-2.0, except where there are one-off features (plank
/// knots 3-6); stochastic test textures reach 2-3.5 at their 99th
/// percentile on small neighbourhoods.
pub const DISTINCT_FROM: f32 = 2.0;

/// Narrowest neighbourhood judged, in pixels: on 7 px patches at full
/// resolution, stochastic textures already lack near twins (a 96 px
/// cobble exemplar's 99th percentile is 2.7), so noise would count as
/// features.
pub const SMALLEST: usize = 14;

/// Patch side at the working scale.
const PATCH: usize = 7;
/// PatchMatch sweeps of the self-match.
const SWEEPS: usize = 5;

/// Feature widths looked at: `feature`, twice it and four times it.
const SCALES: usize = 3;

/// Rarity of every exemplar pixel (one channel): the largest over
/// neighbourhoods `feature`, 2 `feature` and 4 `feature` pixels wide of
/// [`rarity_at`], so a small chip and a large peeled patch both count as
/// rare. Scales whose shrunken exemplar would be under 4 patches wide are
/// skipped. `weights` weigh the channels as the synthesis does.
pub fn rarity(exemplar: &Image, weights: &[f32], feature: usize, seed: u64) -> Result<Image> {
    let (w, h) = exemplar.size();
    let mut out = rarity_at(exemplar, weights, feature, seed)?;
    for k in 1..SCALES {
        let f = feature << k;
        if w.min(h) / (f / PATCH).max(1) < 4 * PATCH {
            break;
        }
        let coarse = rarity_at(exemplar, weights, f, rng::derive(seed, &[k as u64]))?;
        out.data_mut().iter_mut().zip(coarse.data()).for_each(|(a, &b)| *a = a.max(b));
    }
    Ok(out)
}

/// Per exemplar pixel, the squared distance from its 7 px neighbourhood to
/// its nearest twin elsewhere in the exemplar, over the median of that
/// squared distance: how large a seam error a natural match there has.
/// Busy material (a peel's torn lip) has no close twin and a large error;
/// plain paint has a small one.
pub fn twin_error(exemplar: &Image, weights: &[f32], seed: u64) -> Result<Image> {
    let mut e = rarity_at(exemplar, weights, PATCH, seed)?;
    e.data_mut().iter_mut().for_each(|v| *v *= *v);
    Ok(e)
}

/// Rarity on neighbourhoods about `feature` pixels wide (median 1): the
/// exemplar is shrunk so that a [`PATCH`]-pixel patch spans that width,
/// matched against itself with PatchMatch (matches within one patch of the
/// pixel excluded), and the distances over their median stretched back.
fn rarity_at(exemplar: &Image, weights: &[f32], feature: usize, seed: u64) -> Result<Image> {
    let (w, h) = exemplar.size();
    let shrink = (feature / PATCH).min(w.min(h) / (4 * PATCH)).max(1);
    let small = if shrink > 1 { resize(exemplar, w / shrink, h / shrink, Filter::Cubic)? } else { exemplar.clone() };
    let (sw, sh) = small.size();
    let r = PATCH / 2;
    let metric = PatchMetric::ssd(weights.to_vec());
    let pm =
        PatchMatch { radius: r, iterations: SWEEPS, metric: &metric, uniformity: 0.0, max_search_radius: None, exclude_self: Some(PATCH) };
    let (nnf, _) = pm.nearest(&small, &small, seed, seed ^ 0x7a7e)?;
    // Distances at interior pixels; border pixels take the nearest interior one.
    let dist = |x: usize, y: usize| {
        let (cx, cy) = (x.clamp(r, sw - 1 - r), y.clamp(r, sh - 1 - r));
        nnf.get(cx, cy).cost.max(0.0).sqrt()
    };
    let mut sorted: Vec<f32> = (r..sh - r).flat_map(|y| (r..sw - r).map(move |x| (x, y))).map(|(x, y)| dist(x, y)).collect();
    sorted.sort_by(f32::total_cmp);
    let median = sorted[sorted.len() / 2].max(1e-6);
    let map = Image::from_fn(sw, sh, 1, |x, y, p| p[0] = dist(x, y) / median);
    if shrink > 1 {
        resize(&map, w, h, Filter::Linear)
    } else {
        Ok(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples;

    #[test]
    fn a_one_off_stamp_is_rarer_than_the_material_around_it() {
        let mut img = samples::stucco(128, 128, 4);
        // One red disc of radius 8 at (40, 70): nothing like it elsewhere.
        for y in 0..128 {
            for x in 0..128 {
                let d = ((x as f32 - 40.0).powi(2) + (y as f32 - 70.0).powi(2)).sqrt();
                if d < 8.0 {
                    img.pixel_mut(x, y).copy_from_slice(&[0.8, 0.1, 0.1]);
                }
            }
        }
        let rare = rarity(&img, &[1.0 / 3.0; 3], 8, 1).unwrap();
        let at = rare.at(40, 70, 0).max(rare.at(34, 70, 0));
        let far = rare.at(100, 20, 0);
        assert!(at > 3.0 && far < 2.0, "disc {at}, plaster {far}");
    }

    #[test]
    fn busy_material_has_a_larger_twin_error_than_plain() {
        // Left half gravel (busy), right half blotches at low contrast (plain).
        let (gravel, plain) = (samples::gravel(96, 96, 2), samples::blotches(96, 96, 3));
        let img = Image::from_fn(96, 96, 3, |x, y, p| {
            let v = if x < 48 { gravel.pixel(x, y).to_vec() } else { plain.pixel(x, y).iter().map(|c| 0.4 + 0.2 * c).collect() };
            p.copy_from_slice(&v);
        });
        let e = twin_error(&img, &[1.0 / 3.0; 3], 1).unwrap();
        let median = |x0: usize| {
            let mut v: Vec<f32> = (8..88).flat_map(|y| (x0..x0 + 32).map(move |x| (x, y))).map(|(x, y)| e.at(x, y, 0)).collect();
            v.sort_by(f32::total_cmp);
            v[v.len() / 2]
        };
        let (busy, calm) = (median(8), median(56));
        assert!(busy > 4.0 * calm, "twin error: gravel {busy}, plain {calm}");
    }
}
