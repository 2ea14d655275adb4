//! The age map (Bellini et al. 2016, section 4): patches that recur across
//! the texture are the original material, patches that do not are
//! weathering.
//!
//! 1. Split the image into an N x N grid of non-overlapping source patches.
//! 2. For each, the distance eq. (1), D = I / max I + G / max G, to every
//!    overlapping target patch of the same size, by FFT correlation
//!    ([`crate::synth::correlate`]): one transform per feature channel and
//!    one inverse per source patch, whatever the patch size.
//! 3. Per source patch, the minimum of D inside each grid cell (so the
//!    neighbours come from different regions), then the mean of the K
//!    smallest, leaving out its own cell: the patch's age.
//! 4. Interpolate the grid of ages to pixels, smooth with a Gaussian,
//!    normalise to [0, 1] (0 intact, 1 most weathered).
//!
//! Departures from the paper, each a parameter that restores it:
//! - max I and max G are the maxima over a regular subset of at most
//!   [`SCALE_SAMPLES`] source patches, not over all of them: computing every
//!   distance twice (once to find the maxima, once to combine them) would
//!   double the cost for a normalisation that only balances the two terms.
//! - `k_fraction`: K as a fraction of the cells. With the paper's K = 10 of
//!   400 cells a weathering that covers more than 10 cells (smooth rust
//!   over gravel) finds its K neighbours among its own kind and looks
//!   intact; the mean over the bulk of the image keeps meaning "rare".
//! - `detail`: the grid age is as coarse as the grid (20 px cells on a 400
//!   px image), which cannot single out a 2 px crack. A per-pixel term adds
//!   the distance from each pixel's small patch to its nearest patch among
//!   the clearly intact half of the image (PatchMatch), so thin weathering
//!   inside an intact cell is found too.

use super::features::Features;
use crate::error::{Error, Result};
use crate::image::filter::gaussian_blur;
use crate::image::{Image, Mask};
use crate::synth::correlate::SpectralSource;
use crate::synth::nnf::{random_nnf, SourceDomain};
use crate::synth::{PatchMatch, PatchMetric};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Quantile of the intact pixels' rarity below which the detail term is 0.
pub const DETAIL_QUANTILE: f32 = 0.95;

/// Source patches sampled to find max I and max G.
pub const SCALE_SAMPLES: usize = 49;

/// Parameters of the age map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AgeParams {
    /// N: source patches per side. Paper: 20. Lowered for small images so
    /// that patches keep at least `min_patch` pixels.
    pub grid: usize,
    /// Smallest source patch side in pixels.
    pub min_patch: usize,
    /// K: cells averaged per patch. Paper: 10. Ignored when `k_fraction` is set.
    pub k: usize,
    /// K as a fraction of the other cells (see the module docs); `None`
    /// uses `k`.
    pub k_fraction: Option<f32>,
    /// Compare colour (Lab) instead of the paper's luminance alone.
    pub colour: bool,
    /// Gaussian smoothing of the interpolated grid, in patch sides.
    pub smoothing: f32,
    /// Weight of the per-pixel detail term, which can only raise the grid
    /// age (0 = the paper's grid age only).
    pub detail: f32,
    /// Patch side of the detail term (odd).
    pub detail_patch: usize,
}

impl Default for AgeParams {
    fn default() -> Self {
        AgeParams { grid: 20, min_patch: 8, k: 10, k_fraction: Some(0.4), colour: true, smoothing: 0.5, detail: 1.0, detail_patch: 5 }
    }
}

/// An age map and how it was made.
#[derive(Clone, Debug)]
pub struct AgeMap {
    /// One channel in [0, 1]: 0 = intact, 1 = most weathered.
    pub map: Image,
    /// N actually used (the grid shrinks on small images).
    pub grid: usize,
    /// Source patch size (width, height).
    pub patch: (usize, usize),
    /// K actually used.
    pub k: usize,
    /// The raw age of each grid cell, row-major N x N.
    pub cell_ages: Vec<f32>,
}

impl AgeParams {
    /// N and the patch size for a `w` x `h` image.
    pub fn resolve(&self, w: usize, h: usize) -> Result<(usize, (usize, usize))> {
        if self.grid < 3 {
            return Err(Error::invalid(format!("the age map grid must be at least 3x3 patches, got {}", self.grid)));
        }
        let min_patch = self.min_patch.max(3);
        let n = self.grid.min(w / min_patch).min(h / min_patch);
        if n < 3 {
            return Err(Error::invalid(format!(
                "the image ({w}x{h}) is too small for an age map: it needs at least 3x3 patches of {min_patch} px"
            )));
        }
        if self.k == 0 && self.k_fraction.is_none() {
            return Err(Error::invalid("age map K must be at least 1"));
        }
        if self.k_fraction.is_some_and(|f| !(f > 0.0 && f <= 1.0)) {
            return Err(Error::invalid("age map k_fraction must be in (0, 1]"));
        }
        if !(self.detail >= 0.0 && self.detail <= 1.0) || self.detail_patch < 3 || self.detail_patch.is_multiple_of(2) {
            return Err(Error::invalid("age map detail weight must be in [0, 1] and its patch odd and >= 3"));
        }
        Ok((n, (w / n, h / n)))
    }

    fn k_for(&self, cells: usize) -> usize {
        let others = cells - 1;
        match self.k_fraction {
            Some(f) => ((f * others as f32).round() as usize).clamp(1, others),
            None => self.k.clamp(1, others),
        }
    }
}

/// The age map of `img` (sRGB colour or grey, values in [0, 1]).
pub fn age_map(img: &Image, params: &AgeParams) -> Result<AgeMap> {
    let (w, h) = img.size();
    let (n, (pw, ph)) = params.resolve(w, h)?;
    let features = Features::new(img, params.colour)?;
    let k = params.k_for(n * n);
    let (i_max, g_max) = distance_scales(&features, n, (pw, ph));
    let cell_ages = grid_ages(&features, n, (pw, ph), k, (i_max, g_max));
    let mut map = interpolate(&cell_ages, n, (pw, ph), w, h);
    map = gaussian_blur(&map, (params.smoothing * pw.max(ph) as f32).max(0.5));
    normalise(&mut map);
    if params.detail > 0.0 {
        let detail = detail_term(&features, &map, params.detail_patch)?;
        for (a, d) in map.data_mut().iter_mut().zip(detail.data()) {
            *a = a.max(params.detail * d);
        }
    }
    Ok(AgeMap { map, grid: n, patch: (pw, ph), k, cell_ages })
}

/// The source patch of cell (i, j) as a template of `channels` values per pixel.
fn cell_template(img: &Image, i: usize, j: usize, (pw, ph): (usize, usize)) -> Vec<f32> {
    img.crop(i * pw, j * ph, pw, ph).expect("cells lie inside the image").into_data()
}

/// max I and max G over a regular subset of the source patches.
fn distance_scales(f: &Features, n: usize, patch: (usize, usize)) -> (f32, f32) {
    let stride = n.div_ceil((SCALE_SAMPLES as f64).sqrt() as usize).max(1);
    let cells: Vec<(usize, usize)> = (0..n).step_by(stride).flat_map(|j| (0..n).step_by(stride).map(move |i| (i, j))).collect();
    let max_of = |img: &Image| -> f32 {
        let spectral = SpectralSource::new(img, &vec![1.0; img.channels()]);
        let maxima: Vec<f32> = cells
            .par_iter()
            .map(|&(i, j)| {
                let mut q = spectral.query(patch.0, patch.1);
                spectral.add_box_term(&mut q, &cell_template(img, i, j, patch), 1.0);
                spectral.finish(q).into_iter().fold(0.0, f32::max)
            })
            .collect();
        maxima.into_iter().fold(0.0, f32::max).max(1e-12)
    };
    (max_of(&f.appearance), max_of(&f.direction))
}

/// The raw age of every grid cell: mean of the K smallest per-cell minima
/// of D, leaving out the cell itself.
fn grid_ages(f: &Features, n: usize, (pw, ph): (usize, usize), k: usize, (i_max, g_max): (f32, f32)) -> Vec<f32> {
    let stacked = f.stacked();
    let spectral = SpectralSource::new(&stacked, &f.weights(i_max, g_max));
    let (vw, vh) = (stacked.width() - pw + 1, stacked.height() - ph + 1);
    // The grid cell of each placement, by the placement's centre.
    let cell_x: Vec<usize> = (0..vw).map(|x| ((x + pw / 2) / pw).min(n - 1)).collect();
    let cell_y: Vec<usize> = (0..vh).map(|y| ((y + ph / 2) / ph).min(n - 1)).collect();
    (0..n * n)
        .into_par_iter()
        .map(|c| {
            let (i, j) = (c % n, c / n);
            let mut q = spectral.query(pw, ph);
            spectral.add_box_term(&mut q, &cell_template(&stacked, i, j, (pw, ph)), 1.0);
            let d = spectral.finish(q);
            let mut best = vec![f32::INFINITY; n * n];
            for (y, row) in d.chunks_exact(vw).enumerate() {
                let base = cell_y[y] * n;
                for (x, &v) in row.iter().enumerate() {
                    let b = &mut best[base + cell_x[x]];
                    if v < *b {
                        *b = v;
                    }
                }
            }
            best.swap_remove(c);
            best.sort_by(f32::total_cmp);
            best[..k].iter().sum::<f32>() / k as f32
        })
        .collect()
}

/// Bilinear interpolation of the grid (values at cell centres) to pixels.
fn interpolate(cells: &[f32], n: usize, (pw, ph): (usize, usize), w: usize, h: usize) -> Image {
    let coord = |p: usize, size: usize| -> (usize, usize, f32) {
        let t = ((p as f32 + 0.5) / size as f32 - 0.5).clamp(0.0, (n - 1) as f32);
        let i = (t.floor() as usize).min(n - 1);
        (i, (i + 1).min(n - 1), t - i as f32)
    };
    Image::from_fn(w, h, 1, |x, y, p| {
        let (x0, x1, fx) = coord(x, pw);
        let (y0, y1, fy) = coord(y, ph);
        let at = |i: usize, j: usize| cells[j * n + i];
        let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
        let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
        p[0] = top * (1.0 - fy) + bottom * fy;
    })
}

/// Rescale a one-channel image to [0, 1] (a constant image becomes 0).
pub(crate) fn normalise(img: &mut Image) {
    let (lo, hi) = img.value_range();
    let span = hi - lo;
    img.data_mut().iter_mut().for_each(|v| *v = if span > 1e-12 { (*v - lo) / span } else { 0.0 });
}

/// Per pixel, how much rarer its patch is than intact patches: the distance
/// d from its patch to the nearest patch (not overlapping it) among the
/// pixels whose grid age is below the median, mapped to [0, 1] from the
/// [`DETAIL_QUANTILE`] of d over those intact pixels (0: as common as
/// intact material gets) to the largest d (1). On stochastic textures
/// (gravel) every patch is a little unique, and only what stands out of
/// that spread counts.
fn detail_term(f: &Features, coarse: &Image, patch: usize) -> Result<Image> {
    let appearance = &f.appearance;
    let (w, h) = appearance.size();
    let r = patch / 2;
    let mut ages: Vec<f32> = coarse.data().to_vec();
    ages.sort_by(f32::total_cmp);
    let median = ages[ages.len() / 2];
    let pool = Mask::from_fn(w, h, |x, y| coarse.at(x, y, 0) <= median);
    let domain = SourceDomain::new(w, h, r, Some(&pool)).or_else(|_| SourceDomain::new(w, h, r, None))?;
    let metric = PatchMetric::mean_ssd(appearance.channels());
    let mut nnf = random_nnf(w, h, &domain, 0xa9e);
    let pm = PatchMatch { radius: r, iterations: 6, metric: &metric, uniformity: 0.0, max_search_radius: None, exclude_self: Some(patch) };
    pm.improve(appearance, appearance, &domain, &mut nnf, None, 0xa9e5);
    let cost = Image::from_fn(w, h, 1, |x, y, p| p[0] = nnf.get(x, y).cost.max(0.0).sqrt());
    // Spread each patch's distance over the pixels it covers.
    let spread = gaussian_blur(&cost, r as f32 * 0.5 + 0.5);
    if !spread.data().iter().all(|v| v.is_finite()) {
        return Err(Error::Internal("the age map's detail term is not finite".into()));
    }
    let mut intact: Vec<f32> = spread.data().iter().zip(pool.bits()).filter(|(_, &p)| p).map(|(v, _)| *v).collect();
    intact.sort_by(f32::total_cmp);
    let floor = intact[((intact.len() - 1) as f32 * DETAIL_QUANTILE) as usize];
    let top = spread.value_range().1;
    Ok(spread.map(|v| if top > floor { ((v - floor) / (top - floor)).clamp(0.0, 1.0) } else { 0.0 }))
}
