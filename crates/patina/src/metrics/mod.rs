//! Quality measures shared by the tests, the benchmarks and the CLI.
//!
//! Distances are RMS differences per value between two patches (square root
//! of the mean over texels and channels of the squared difference), so they
//! read in image units whatever the patch size or channel count. Nearest
//! patches are found with the engine's PatchMatch (many sweeps; approximate
//! but very close to exhaustive search at these settings).

mod defects;
mod stationarity;

pub use defects::{grid_peak, material_drift, nonstationarity, rare_feature_use, repeated_share};
pub use stationarity::{stationarity, Stationarity};

use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use crate::synth::{Nnf, PatchMatch, PatchMetric};

/// PatchMatch sweeps used by the metrics.
const SWEEPS: usize = 8;

/// Nearest-patch distances from every interior patch of `from` to `to`.
pub(super) fn nearest(from: &Image, to: &Image, patch: usize, exclude_self: Option<usize>, seed: u64) -> Result<(Nnf, Mask)> {
    if patch.is_multiple_of(2) || patch < 3 {
        return Err(Error::invalid(format!("metric patch size must be odd and >= 3, got {patch}")));
    }
    if from.channels() != to.channels() {
        return Err(Error::invalid(format!("cannot compare images with {} and {} channels", from.channels(), to.channels())));
    }
    let metric = PatchMetric::mean_ssd(from.channels());
    let pm = PatchMatch { radius: patch / 2, iterations: SWEEPS, metric: &metric, uniformity: 0.0, max_search_radius: None, exclude_self };
    pm.nearest(from, to, seed, seed ^ 0x5eed)
}

fn rms_map(nnf: &Nnf, inside: &Mask, patch: usize) -> Image {
    let texels = (patch * patch) as f32;
    Image::from_fn(nnf.width(), nnf.height(), 1, |x, y, p| {
        p[0] = if inside.get(x, y) { (nnf.get(x, y).cost / texels).max(0.0).sqrt() } else { f32::NAN };
    })
}

fn mean_where(map: &Image, mask: impl Fn(usize, usize) -> bool) -> f32 {
    let (mut sum, mut n) = (0f64, 0usize);
    for y in 0..map.height() {
        for x in 0..map.width() {
            let v = map.at(x, y, 0);
            if v.is_finite() && mask(x, y) {
                sum += v as f64;
                n += 1;
            }
        }
    }
    if n == 0 {
        f32::NAN
    } else {
        (sum / n as f64) as f32
    }
}

/// Bidirectional similarity (Simakov, Caspi, Shechtman, Irani 2008).
#[derive(Clone, Debug)]
pub struct Bidirectional {
    /// Mean distance from each output patch to its nearest exemplar patch:
    /// low when the output holds nothing the exemplar lacks.
    pub coherence: f32,
    /// Mean distance from each exemplar patch to its nearest output patch:
    /// low when everything in the exemplar appears in the output.
    pub completeness: f32,
    /// Per output pixel, its patch's coherence distance (NaN at borders).
    pub coherence_map: Image,
    /// Per exemplar pixel, its patch's completeness distance (NaN at borders).
    pub completeness_map: Image,
}

/// Coherence and completeness of `output` with respect to `exemplar`.
pub fn bidirectional(output: &Image, exemplar: &Image, patch: usize, seed: u64) -> Result<Bidirectional> {
    let (n1, m1) = nearest(output, exemplar, patch, None, seed)?;
    let (n2, m2) = nearest(exemplar, output, patch, None, seed ^ 1)?;
    let coherence_map = rms_map(&n1, &m1, patch);
    let completeness_map = rms_map(&n2, &m2, patch);
    Ok(Bidirectional {
        coherence: mean_where(&coherence_map, |_, _| true),
        completeness: mean_where(&completeness_map, |_, _| true),
        coherence_map,
        completeness_map,
    })
}

/// The exemplar's own self-similarity: mean distance from each patch to the
/// nearest patch that does not overlap it. A synthesis whose coherence is
/// near this copies no worse than the exemplar resembles itself.
pub fn self_similarity(exemplar: &Image, patch: usize, seed: u64) -> Result<f32> {
    let (nnf, inside) = nearest(exemplar, exemplar, patch, Some(patch - 1), seed)?;
    Ok(mean_where(&rms_map(&nnf, &inside, patch), |_, _| true))
}

/// Seam visibility: the mean coherence distance over the pixels of `seams`
/// (e.g. [`crate::synth::QuiltPlan::overlap_mask`]). Where blocks meet
/// invisibly the patches there exist in the exemplar (distance near 0 for
/// a good cut, like block interiors); a visible seam or blended ghosting
/// makes patches the exemplar never had.
pub fn seam_visibility(output: &Image, exemplar: &Image, seams: &Mask, patch: usize, seed: u64) -> Result<f32> {
    if seams.size() != output.size() {
        return Err(Error::invalid("seam mask and output sizes differ"));
    }
    let (nnf, inside) = nearest(output, exemplar, patch, None, seed)?;
    Ok(mean_where(&rms_map(&nnf, &inside, patch), |x, y| seams.get(x, y)))
}

/// Area under the ROC curve of `scores` as a detector of `labels`: the
/// probability that a random positive scores above a random negative (ties
/// count half). 0.5 is chance, 1 is perfect separation. NaN when either
/// class is empty.
pub fn roc_auc(scores: &[f32], labels: &[bool]) -> f32 {
    assert_eq!(scores.len(), labels.len());
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]));
    // Mann-Whitney U with average ranks over ties.
    let (mut rank_sum, mut i) = (0f64, 0);
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && scores[order[j + 1]] == scores[order[i]] {
            j += 1;
        }
        let avg = (i + j) as f64 / 2.0 + 1.0;
        rank_sum += (i..=j).filter(|&k| labels[order[k]]).count() as f64 * avg;
        i = j + 1;
    }
    let pos = labels.iter().filter(|&&l| l).count() as f64;
    let neg = labels.len() as f64 - pos;
    ((rank_sum - pos * (pos + 1.0) / 2.0) / (pos * neg)) as f32
}

/// Mean absolute change between consecutive frames of a sequence, over
/// every pixel and channel: its temporal coherence (0 = still; flicker
/// raises it). 0 for fewer than two frames.
pub fn flicker(frames: &[Image]) -> f64 {
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for w in frames.windows(2) {
        for (a, b) in w[0].data().iter().zip(w[1].data()) {
            sum += f64::from((a - b).abs());
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

/// Radially averaged power spectrum of channel 0 (mean removed): entry k is
/// the mean |FFT|^2 / (w h) over frequencies whose radius, in cycles per
/// pixel, lies in [k, k + 1) / min(w, h); k = 1 .. min(w, h) / 2 (entry 0
/// is unused and 0).
pub fn radial_power_spectrum(img: &Image) -> Vec<f64> {
    use crate::image::fourier::{fft2, Complex, FftDirection};
    let (w, h) = img.size();
    let mean = (0..w * h).map(|i| img.at(i % w, i / w, 0) as f64).sum::<f64>() / (w * h) as f64;
    let mut data: Vec<Complex<f64>> = (0..w * h).map(|i| Complex::new(img.at(i % w, i / w, 0) as f64 - mean, 0.0)).collect();
    fft2(&mut data, w, h, FftDirection::Forward);
    let bins = w.min(h) / 2;
    let (mut sum, mut count) = (vec![0f64; bins + 1], vec![0usize; bins + 1]);
    let side = w.min(h) as f64;
    for y in 0..h {
        let fy = (if y <= h / 2 { y as f64 } else { y as f64 - h as f64 }) / h as f64;
        for x in 0..w {
            let fx = (if x <= w / 2 { x as f64 } else { x as f64 - w as f64 }) / w as f64;
            let k = ((fx * fx + fy * fy).sqrt() * side) as usize;
            if (1..=bins).contains(&k) {
                sum[k] += data[y * w + x].norm_sqr() / (w * h) as f64;
                count[k] += 1;
            }
        }
    }
    sum.iter().zip(&count).map(|(s, &n)| if n > 0 { s / n as f64 } else { 0.0 }).collect()
}

/// The least-squares slope of log power against log frequency over the
/// bins `lo..=hi` of a [`radial_power_spectrum`] (-2 for a 1/f^2 spectrum).
pub fn spectral_slope(spectrum: &[f64], lo: usize, hi: usize) -> f64 {
    let pts: Vec<(f64, f64)> =
        (lo..=hi.min(spectrum.len() - 1)).filter(|&k| spectrum[k] > 0.0).map(|k| ((k as f64).ln(), spectrum[k].ln())).collect();
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}

/// Two-sample Kolmogorov-Smirnov distance: the largest gap between the
/// empirical distribution functions of `a` and `b`.
pub fn ks_distance(a: &[f32], b: &[f32]) -> f32 {
    let (mut a, mut b) = (a.to_vec(), b.to_vec());
    a.sort_unstable_by(f32::total_cmp);
    b.sort_unstable_by(f32::total_cmp);
    ks_distance_sorted(&a, &b)
}

/// [`ks_distance`] of two samples already sorted in ascending order.
pub fn ks_distance_sorted(a: &[f32], b: &[f32]) -> f32 {
    let (mut i, mut j, mut worst) = (0, 0, 0f32);
    while i < a.len() && j < b.len() {
        let v = a[i].min(b[j]);
        while i < a.len() && a[i] <= v {
            i += 1;
        }
        while j < b.len() && b[j] <= v {
            j += 1;
        }
        worst = worst.max((i as f32 / a.len() as f32 - j as f32 / b.len() as f32).abs());
    }
    worst
}

/// How much of an injected weathering a de-weathered image keeps (0 = none,
/// 1 = all of it): over the weathered pixels `mask`, the excess of the
/// distance from each pixel's patch to its nearest patch of the `clean`
/// texture over that distance elsewhere, relative to the same excess for
/// the `weathered` input itself. Nearest patches rather than pixel
/// differences, so a stochastic texture rebuilt with new (but clean)
/// material does not count as residue.
pub fn weathering_residue(result: &Image, clean: &Image, weathered: &Image, mask: &Mask, patch: usize, seed: u64) -> Result<f32> {
    if result.size() != mask.size() || weathered.size() != mask.size() {
        return Err(Error::invalid("the result, the weathered input and the mask must have one size"));
    }
    let excess = |img: &Image| -> Result<f64> {
        let (nnf, inside) = nearest(img, clean, patch, None, seed)?;
        let (mut on, mut n_on, mut off, mut n_off) = (0f64, 0usize, 0f64, 0usize);
        for y in 0..img.height() {
            for x in 0..img.width() {
                if !inside.get(x, y) {
                    continue;
                }
                let d = (nnf.get(x, y).cost.max(0.0) as f64).sqrt();
                if mask.get(x, y) {
                    (on, n_on) = (on + d, n_on + 1);
                } else {
                    (off, n_off) = (off + d, n_off + 1);
                }
            }
        }
        if n_on == 0 || n_off == 0 {
            return Err(Error::invalid("the weathering mask must hold some but not all pixels"));
        }
        Ok(on / n_on as f64 - off / n_off as f64)
    };
    let base = excess(weathered)?;
    if base <= 0.0 {
        return Err(Error::invalid("the weathered input does not differ from the clean texture where the mask says"));
    }
    Ok((excess(result)? / base).max(0.0) as f32)
}

/// Pacing of a sequence from its first frame to its last: the largest
/// share of the whole change (mean absolute difference from the first
/// frame to the last) that one step between consecutive frames brings.
/// 1 / steps is perfectly even; 1 means everything happens in one step.
pub fn pacing(frames: &[&Image]) -> Result<f32> {
    if frames.len() < 2 {
        return Err(Error::invalid("pacing needs at least two frames"));
    }
    let step = |a: &Image, b: &Image| -> Result<f64> {
        if a.size() != b.size() || a.channels() != b.channels() {
            return Err(Error::invalid("frames differ in size or channel count"));
        }
        Ok(a.data().iter().zip(b.data()).map(|(x, y)| (x - y).abs() as f64).sum::<f64>())
    };
    let steps: Vec<f64> = frames.windows(2).map(|w| step(w[0], w[1])).collect::<Result<_>>()?;
    let total: f64 = steps.iter().sum();
    Ok(if total > 0.0 { (steps.iter().copied().fold(0.0, f64::max) / total) as f32 } else { 0.0 })
}

/// Blocks per side over which [`reveal_spread`] compares the change.
pub const SPREAD_BLOCKS: usize = 4;

/// How unevenly over the picture a frame between `first` and `last` has
/// made their change: per block of a [`SPREAD_BLOCKS`]^2 grid, the share
/// of the block's change (colour distance, first to last, summed) that
/// `frame` holds, and the standard deviation of those shares weighted by
/// each block's change (blocks holding under 0.1% of it are left out).
/// 0: every region at the same stage; 0.5: half the picture done, half
/// not begun.
pub fn reveal_spread(first: &Image, frame: &Image, last: &Image) -> Result<f32> {
    if first.size() != frame.size()
        || first.size() != last.size()
        || first.channels() != frame.channels()
        || first.channels() != last.channels()
    {
        return Err(Error::invalid("the frames differ in size or channel count"));
    }
    let (w, h) = first.size();
    let n = first.channels();
    let dist = |a: &Image, i: usize| -> f64 {
        a.data()[i * n..(i + 1) * n]
            .iter()
            .zip(&first.data()[i * n..(i + 1) * n])
            .map(|(x, y)| ((x - y) as f64).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let b = SPREAD_BLOCKS;
    let (mut total, mut made) = (vec![0f64; b * b], vec![0f64; b * b]);
    for i in 0..w * h {
        let k = ((i / w) * b / h) * b + (i % w) * b / w;
        total[k] += dist(last, i);
        made[k] += dist(frame, i);
    }
    let all: f64 = total.iter().sum();
    let blocks: Vec<(f64, f64)> = (0..b * b).filter(|&k| total[k] > 1e-3 * all).map(|k| (made[k] / total[k], total[k])).collect();
    let weight: f64 = blocks.iter().map(|&(_, t)| t).sum();
    if weight <= 0.0 {
        return Ok(0.0);
    }
    let mean = blocks.iter().map(|&(s, t)| s * t).sum::<f64>() / weight;
    Ok((blocks.iter().map(|&(s, t)| t * (s - mean).powi(2)).sum::<f64>() / weight).sqrt() as f32)
}

#[cfg(test)]
mod tests {
    /// Half the picture done and half not begun spreads 0.5; the same
    /// change made halfway everywhere spreads 0.
    #[test]
    fn reveal_spread_tells_a_sweep_from_an_even_fade() {
        use crate::image::Image;
        let (first, last) = (Image::new(64, 64, 3), Image::from_fn(64, 64, 3, |_, _, p| p.fill(1.0)));
        let sweep = Image::from_fn(64, 64, 3, |x, _, p| p.fill(if x < 32 { 1.0 } else { 0.0 }));
        let fade = Image::from_fn(64, 64, 3, |_, _, p| p.fill(0.5));
        assert!((super::reveal_spread(&first, &sweep, &last).unwrap() - 0.5).abs() < 1e-6);
        assert!(super::reveal_spread(&first, &fade, &last).unwrap() < 1e-6);
    }

    #[test]
    fn auc_is_one_for_separated_scores_and_half_for_ties() {
        assert_eq!(roc_auc(&[0.1, 0.2, 0.8, 0.9], &[false, false, true, true]), 1.0);
        assert_eq!(roc_auc(&[0.1, 0.2, 0.8, 0.9], &[true, true, false, false]), 0.0);
        assert_eq!(roc_auc(&[0.5; 4], &[true, false, true, false]), 0.5);
    }

    use super::*;

    #[test]
    fn a_crop_is_coherent_and_a_foreign_image_is_not() {
        let ex = crate::samples::cobbles(64, 64, 3);
        let crop = ex.crop(8, 8, 40, 40).unwrap();
        let b = bidirectional(&crop, &ex, 5, 1).unwrap();
        assert!(b.coherence < 1e-3, "a crop's patches all exist in the exemplar: {}", b.coherence);
        assert!(b.completeness > 0.02, "the crop misses most of the exemplar: {}", b.completeness);
        let other = crate::samples::bricks(40, 40, 3);
        assert!(bidirectional(&other, &ex, 5, 1).unwrap().coherence > 0.05);
        let own = self_similarity(&ex, 5, 1).unwrap();
        assert!(own > 0.0 && own < 0.2, "{own}");
    }
}
