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
//! - `regions`: not in the paper. A wide weathering with a plain interior
//!   is rare only at its rim; [`super::material`] raises the interior by
//!   the weathered material's colour.

use super::features::Features;
use super::tiles::{self, Periodicity};
use crate::error::{Error, Result};
use crate::image::filter::gaussian_blur;
use crate::image::order::{median, quantile};
use crate::image::resample::{resize, Filter};
use crate::image::summed::SummedArea;
use crate::image::{Image, Mask};
use crate::rng::Rng;
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
    /// How a cell's distances to the other cells become its age.
    pub prevalence: Prevalence,
    /// Look for a period (tiles, boards, grooves) and, when there is one,
    /// age by departure from the median repeat instead of by rarity, so
    /// that regular structure never ages.
    pub regular: bool,
    /// Raise the age of whole regions whose colour belongs to the weathered
    /// material ([`super::material`]; not in the paper): plain interiors of
    /// wide damage are not rare patches.
    pub regions: bool,
}

/// How a grid cell's minimum distances to the other cells become its age.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Prevalence {
    /// The share of the other cells holding no match (see [`coverage_ages`]).
    Coverage,
    /// The paper's mean of the K smallest distances.
    KNearest,
}

impl Default for AgeParams {
    fn default() -> Self {
        AgeParams {
            grid: 20,
            min_patch: 8,
            k: 10,
            k_fraction: Some(0.4),
            colour: true,
            smoothing: 0.5,
            detail: 1.0,
            detail_patch: 5,
            prevalence: Prevalence::Coverage,
            regular: true,
            regions: true,
        }
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
    /// How the texture repeats, when it does (and `regular` was on).
    pub periodicity: Option<Periodicity>,
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
    age_map_within(img, params, None)
}

/// Share of the image a mask must cover for the image to be searched for
/// a period (tiles, boards): an object on a background is not.
pub const PERIODIC_COVER: f32 = 0.9;

/// The age map of the surface `within` marks in `img` (the whole image
/// when `None`): every statistic (the cells compared, the regions counted,
/// the detail term's samples, reference and scale, the colour regions) is
/// taken over those pixels only, so a background neither serves as a match
/// nor counts as a region the surface's material is missing from. Pixels
/// outside are 0. `img`'s pixels just outside `within` should continue its
/// material (see [`super::object`]): patches at the outline reach there.
/// A surface covering less than [`PERIODIC_COVER`] of the image is not
/// searched for a period.
pub fn age_map_within(img: &Image, params: &AgeParams, within: Option<&Mask>) -> Result<AgeMap> {
    let (w, h) = img.size();
    let (n, (pw, ph)) = params.resolve(w, h)?;
    if within.is_some_and(|m| m.size() != (w, h)) {
        return Err(Error::invalid("the age map's mask must be the image's size"));
    }
    let inside = cells_inside(within, n, (pw, ph));
    let inside_count = inside.iter().filter(|&&b| b).count();
    if inside_count < 9 {
        return Err(Error::invalid(format!(
            "the mask covers too little of the image for an age map: it needs at least 9 cells of {pw}x{ph} px, it covers {inside_count}"
        )));
    }
    let features = Features::new(img, params.colour)?;
    let k = params.k_for(inside_count);
    let covers = within.is_none_or(|m| m.count() as f32 >= PERIODIC_COVER * (w * h) as f32);
    let periodicity = if params.regular && covers { tiles::periods(img) } else { None };
    let (i_max, g_max) = distance_scales(&features, n, (pw, ph), &inside);
    let minima = cell_minima(&features, n, (pw, ph), (i_max, g_max), &inside);
    let cell_ages = match params.prevalence {
        Prevalence::Coverage => coverage_ages(&minima, n, pw.min(ph), &inside),
        Prevalence::KNearest => k_nearest_ages(&minima, k, &inside),
    };
    let mut map = match &periodicity {
        // A tiled texture: what departs from its own median tile is
        // weathered; the grout and inserts that repeat are not.
        Some(p @ Periodicity::Grid(_)) => periodic_deviation(&features, p, params.detail_patch),
        _ => {
            let mut m = interpolate(&nearest_inside(&cell_ages, n, &inside), n, (pw, ph), w, h);
            m = gaussian_blur(&m, (params.smoothing * pw.max(ph) as f32).max(0.5));
            // Coverage is an absolute share (0: a match in every region),
            // so a clean texture stays low; the paper's K-mean is a
            // distance and is normalised.
            match params.prevalence {
                Prevalence::Coverage => m.data_mut().iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0)),
                Prevalence::KNearest => normalise(&mut m),
            }
            m
        }
    };
    // A tiled texture's deviation map is already per pixel; the detail
    // term serves stochastic textures and stripes, where the grooves that
    // repeat at the period are not rare detail.
    if params.detail > 0.0 && !matches!(periodicity, Some(Periodicity::Grid(_))) {
        let mut detail = detail_term(&features, &map, params.detail_patch, within)?;
        if let Some(Periodicity::Stripes(v)) = periodicity {
            let regular = regularity(&features, v, params.detail_patch);
            detail.data_mut().iter_mut().zip(regular.data()).for_each(|(d, r)| *d *= 1.0 - r);
        }
        if params.regular {
            let regular = local_regularity(&features, &tiles::local_periods(&features.appearance), params.detail_patch);
            detail.data_mut().iter_mut().zip(regular.data()).for_each(|(d, r)| *d *= 1.0 - r);
        }
        for (a, d) in map.data_mut().iter_mut().zip(detail.data()) {
            *a = a.max(params.detail * d);
        }
    }
    if params.regions {
        map = super::material::complete_regions(&features.appearance, &map, super::IntactParams::default().weathered_max, within);
    }
    if let Some(m) = within {
        map.data_mut().iter_mut().zip(m.bits()).for_each(|(a, &b)| *a = if b { *a } else { 0.0 });
    }
    Ok(AgeMap { map, grid: n, patch: (pw, ph), k, cell_ages, periodicity })
}

/// Rescale `values` so that `lo_q` of `reference` maps to 0 and the
/// `hi_q` quantile of `values` to 1, clamped: robust to a few extreme
/// pixels at the top and to the spread of ordinary material at the bottom.
pub(crate) fn rescale(values: &mut [f32], reference: &[f32], lo_q: f32, hi_q: f32) {
    let quantile = |v: &[f32], q: f32| quantile(&mut v.to_vec(), q).unwrap_or(0.0);
    let lo = quantile(reference, lo_q);
    let hi = quantile(values, hi_q);
    values.iter_mut().for_each(|v| *v = if hi > lo { ((*v - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.0 });
}

/// Top quantile that maps to age 1 (a few extreme pixels do not set the scale).
const TOP_QUANTILE: f32 = 0.995;

/// Per pixel, the distance from its `patch` x `patch` neighbourhood to the
/// same neighbourhood of the texture's median repeat
/// ([`tiles::median_translates`] over the detected periods). Rescaled from
/// the median (ordinary variation between repeats) to the top quantile.
fn periodic_deviation(f: &Features, periodicity: &Periodicity, patch: usize) -> Image {
    let stacked = f.stacked();
    let (w, h) = stacked.size();
    let median = tiles::median_translates(&stacked, &periodicity.vectors(), None);
    let weights = f.weights(1.0, 4.0);
    let per_pixel = Image::from_fn(w, h, 1, |x, y, p| {
        p[0] = stacked.pixel(x, y).iter().zip(median.pixel(x, y)).zip(&weights).map(|((a, b), wt)| wt * (a - b) * (a - b)).sum();
    });
    let r = patch / 2;
    let sums = SummedArea::new(w, h, |x, y| per_pixel.at(x, y, 0) as f64);
    let mut d = Image::from_fn(w, h, 1, |x, y, p| {
        let (x0, y0) = (x.saturating_sub(r), y.saturating_sub(r));
        let (x1, y1) = ((x + r + 1).min(w), (y + r + 1).min(h));
        p[0] = (sums.sum(x0, y0, x1 - x0, y1 - y0) / ((x1 - x0) * (y1 - y0)) as f64).sqrt() as f32;
    });
    let reference = d.data().to_vec();
    rescale(d.data_mut(), &reference, 0.5, TOP_QUANTILE);
    d
}

/// The source patch of cell (i, j) as a template of `channels` values per pixel.
fn cell_template(img: &Image, i: usize, j: usize, (pw, ph): (usize, usize)) -> Vec<f32> {
    img.crop(i * pw, j * ph, pw, ph).expect("cells lie inside the image").into_data()
}

/// max I and max G over a regular subset of the source patches on the
/// surface (`inside`, as [`cells_inside`] gives it), each against the
/// placements centred in cells on the surface: a background must not set
/// the scale that balances the two terms of D.
fn distance_scales(f: &Features, n: usize, (pw, ph): (usize, usize), inside: &[bool]) -> (f32, f32) {
    let stride = n.div_ceil((SCALE_SAMPLES as f64).sqrt() as usize).max(1);
    let mut cells: Vec<(usize, usize)> =
        (0..n).step_by(stride).flat_map(|j| (0..n).step_by(stride).map(move |i| (i, j))).filter(|&(i, j)| inside[j * n + i]).collect();
    if cells.is_empty() {
        // A small surface the regular subset misses: every cell on it.
        cells = (0..n * n).filter(|&c| inside[c]).map(|c| (c % n, c / n)).collect();
    }
    let (cell_x, cell_y) = placement_cells(f.appearance.size(), n, (pw, ph));
    let placements: Vec<bool> = cell_y.iter().flat_map(|&j| cell_x.iter().map(move |&i| inside[j * n + i])).collect();
    let max_of = |img: &Image| -> f32 {
        let spectral = SpectralSource::new(img, &vec![1.0; img.channels()]);
        let maxima: Vec<f32> = cells
            .par_iter()
            .map(|&(i, j)| {
                let mut q = spectral.query(pw, ph);
                spectral.add_box_term(&mut q, &cell_template(img, i, j, (pw, ph)), 1.0);
                spectral.finish(&mut q).into_iter().zip(&placements).filter(|(_, &b)| b).fold(0.0f32, |m, (v, _)| m.max(v))
            })
            .collect();
        maxima.into_iter().fold(0.0, f32::max).max(1e-12)
    };
    (max_of(&f.appearance), max_of(&f.direction))
}

/// Which grid cells, row-major, lie on the surface: at least half their
/// pixels within `within` (every cell when `None`).
fn cells_inside(within: Option<&Mask>, n: usize, (pw, ph): (usize, usize)) -> Vec<bool> {
    (0..n * n)
        .map(|c| {
            let (i, j) = (c % n, c / n);
            within.is_none_or(|m| {
                let set = (j * ph..(j + 1) * ph).map(|y| (i * pw..(i + 1) * pw).filter(|&x| m.get(x, y)).count()).sum::<usize>();
                2 * set >= pw * ph
            })
        })
        .collect()
}

/// The cell values with every cell off the surface taking the value of
/// the nearest cell on it (the first in row-major order among equals), so
/// that interpolation near the outline does not blend towards a
/// background that has no age.
fn nearest_inside(values: &[f32], n: usize, inside: &[bool]) -> Vec<f32> {
    let on: Vec<usize> = (0..n * n).filter(|&c| inside[c]).collect();
    (0..n * n)
        .map(|c| {
            if inside[c] {
                return values[c];
            }
            let d = |o: usize| (o % n).abs_diff(c % n).pow(2) + (o / n).abs_diff(c / n).pow(2);
            on.iter().min_by_key(|&&o| d(o)).map_or(0.0, |&o| values[o])
        })
        .collect()
}

/// The grid cell of each `patch`-sized placement in an image of `size`,
/// by the placement's centre (the last cell for centres past the grid):
/// its column per placement x (left edge) and its row per placement y
/// (top edge).
fn placement_cells((w, h): (usize, usize), n: usize, (pw, ph): (usize, usize)) -> (Vec<usize>, Vec<usize>) {
    let cells = |len: usize, p: usize| (0..len - p + 1).map(|v| ((v + p / 2) / p).min(n - 1)).collect();
    (cells(w, pw), cells(h, ph))
}

/// Per source cell, the minimum of D over the placements centred in each
/// grid cell, row-major (its own cell and the cells off the surface
/// infinite; a cell off the surface is not compared at all).
fn cell_minima(f: &Features, n: usize, (pw, ph): (usize, usize), (i_max, g_max): (f32, f32), inside: &[bool]) -> Vec<Vec<f32>> {
    let stacked = f.stacked();
    let spectral = SpectralSource::new(&stacked, &f.weights(i_max, g_max));
    let vw = stacked.width() - pw + 1;
    let (cell_x, cell_y) = placement_cells(stacked.size(), n, (pw, ph));
    (0..n * n)
        .into_par_iter()
        .map(|c| {
            let (i, j) = (c % n, c / n);
            if !inside[c] {
                return vec![f32::INFINITY; n * n];
            }
            let mut q = spectral.query(pw, ph);
            spectral.add_box_term(&mut q, &cell_template(&stacked, i, j, (pw, ph)), 1.0);
            let d = spectral.finish(&mut q);
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
            best[c] = f32::INFINITY;
            best.iter_mut().zip(inside).for_each(|(b, &on)| *b = if on { *b } else { f32::INFINITY });
            best
        })
        .collect()
}

/// The paper's age of every cell: the mean of its K smallest minima (0
/// off the surface).
fn k_nearest_ages(minima: &[Vec<f32>], k: usize, inside: &[bool]) -> Vec<f32> {
    minima
        .iter()
        .zip(inside)
        .map(|(m, &on)| {
            if !on {
                return 0.0;
            }
            let mut m = m.clone();
            m.sort_by(f32::total_cmp);
            m[..k].iter().sum::<f32>() / k as f32
        })
        .collect()
}

/// Closest matches that set a cell's own match scale in [`coverage_ages`].
const OWN_MATCHES: usize = 3;

/// Smallest side, in pixels, of the regions [`coverage_ages`] counts: a
/// few tile periods, so that a periodic texture's exact repeats fall in
/// every region.
pub const REGION_SIDE: usize = 48;

/// The age of every cell as the share of the image's regions (blocks of
/// cells at least [`REGION_SIDE`] px wide) that hold no match for it. A
/// match is a minimum below the cell's own scale (twice the mean of its
/// [`OWN_MATCHES`] best minima, plus a floor: the median over cells of a
/// cell's median regional minimum, its typical match), with a soft step.
/// Unlike the mean of the K smallest distances, this counts regions
/// rather than summing distances, so smooth weathering
/// (bare plaster, whose distances are all small) is not mistaken for
/// intact material when the intact material is busier, and a weathering
/// over 40% of the surface still covers fewer regions than the material
/// around it. Only cells on the surface (`inside`) are aged and only
/// regions holding one are counted; the others are 0.
fn coverage_ages(minima: &[Vec<f32>], n: usize, cell: usize, inside: &[bool]) -> Vec<f32> {
    let b = REGION_SIDE.div_ceil(cell.max(1)).clamp(1, n / 3);
    let r = n.div_ceil(b);
    let region_of = |c: usize| (c / n / b) * r + (c % n) / b;
    let mut counted = vec![false; r * r];
    (0..n * n).filter(|&c| inside[c]).for_each(|c| counted[region_of(c)] = true);
    let regional: Vec<Vec<f32>> = minima
        .iter()
        .enumerate()
        .filter(|&(c, _)| inside[c])
        .map(|(c, m)| {
            let mut out = vec![f32::INFINITY; r * r];
            for (k, &v) in m.iter().enumerate() {
                let slot = &mut out[region_of(k)];
                *slot = slot.min(v);
            }
            // Leave out the regions off the surface, and the region of
            // the cell itself.
            let own = (0..region_of(c)).filter(|&g| counted[g]).count();
            let mut out: Vec<f32> = out.into_iter().enumerate().filter(|&(g, _)| counted[g]).map(|(_, v)| v).collect();
            out.swap_remove(own);
            out
        })
        .collect();
    let own: Vec<f32> = minima
        .iter()
        .enumerate()
        .filter(|&(c, _)| inside[c])
        .map(|(_, m)| {
            let mut m = m.clone();
            m.sort_by(f32::total_cmp);
            m[..OWN_MATCHES].iter().sum::<f32>() / OWN_MATCHES as f32
        })
        .collect();
    // The floor is the median over cells of each cell's typical match (its
    // median regional minimum). Half the median own-match collapsed where
    // the texture nearly repeats itself: every cell's best matches are
    // near-exact twins, so ordinary matches elsewhere counted as none (a
    // clean brick wall texture that repeats once came out 60% weathered).
    let mut typical: Vec<f32> = regional.iter().filter_map(|m| median(&mut m.clone())).collect();
    let floor = median(&mut typical).unwrap_or(0.0);
    // A surface within a single region has no other region to be missing
    // from: nothing on it counts as rare at this scale.
    let mut ages = regional.iter().zip(&own).map(|(m, &o)| {
        let theta = (2.0 * o + floor).max(1e-12);
        let covered: f32 = m.iter().map(|&v| 1.0 / (1.0 + (v / theta).powi(4))).sum();
        if m.is_empty() {
            0.0
        } else {
            1.0 - covered / m.len() as f32
        }
    });
    (0..n * n).map(|c| if inside[c] { ages.next().expect("one age per inside cell") } else { 0.0 }).collect()
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

/// Per pixel, in [0, 1], how well its structure recurs one and two periods
/// `v` away on either side: the median over those four translates of the
/// distance between gradient-direction patches (edges, not tone: boards
/// differ in tone while their grooves line up), mapped so that the
/// image's lower quartile of that distance is 1 (fully regular) and its
/// median 0.
fn regularity(f: &Features, v: [f32; 2], patch: usize) -> Image {
    let dir = &f.direction;
    let (w, h) = dir.size();
    let r = (patch / 2) as i64;
    let shifts: Vec<(i64, i64)> =
        [-2.0f32, -1.0, 1.0, 2.0].iter().map(|k| ((k * v[0]).round() as i64, (k * v[1]).round() as i64)).collect();
    let at = |x: i64, y: i64| dir.pixel(x.clamp(0, w as i64 - 1) as usize, y.clamp(0, h as i64 - 1) as usize);
    let mut dist = vec![0f32; w * h];
    dist.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let mut ds = Vec::with_capacity(4);
        for (x, out) in row.iter_mut().enumerate() {
            ds.clear();
            for &(dx, dy) in &shifts {
                let (tx, ty) = (x as i64 + dx, y as i64 + dy);
                if tx < 0 || ty < 0 || tx >= w as i64 || ty >= h as i64 {
                    continue;
                }
                let mut sum = 0f32;
                for v in -r..=r {
                    for u in -r..=r {
                        let (a, b) = (at(x as i64 + u, y as i64 + v), at(tx + u, ty + v));
                        sum += (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
                    }
                }
                ds.push(sum);
            }
            ds.sort_by(f32::total_cmp);
            *out = if ds.is_empty() { f32::INFINITY } else { ds[(ds.len() - 1) / 2] };
        }
    });
    let mut sorted: Vec<f32> = dist.iter().copied().filter(|d| d.is_finite()).collect();
    sorted.sort_by(f32::total_cmp);
    let (q1, q2) = if sorted.is_empty() { (0.0, 0.0) } else { (sorted[sorted.len() / 4], sorted[sorted.len() / 2]) };
    let regular = dist.iter().map(|&d| if q2 > q1 { ((q2 - d) / (q2 - q1)).clamp(0.0, 1.0) } else { 0.0 }).collect();
    Image::from_data(w, h, 1, regular).expect("sizes match")
}

/// Weight of a colour difference (Lab a and b, over 100) against a
/// high-passed luminance difference in [`local_regularity`]: lichen or
/// rust on a repeated tile lip breaks the repeat, a lip that is only
/// lighter or darker than the next does not.
const RECUR_CHROMA: f32 = 4.0;
/// The ratio of a patch's distance one period away to its distance half a
/// period away (out of phase) at and below which it fully recurs, and at
/// and above which it does not recur at all.
pub const RECUR_RATIO: (f32, f32) = (0.2, 0.6);

/// Per pixel, in [0, 1], how exactly its structure recurs one period away
/// (either side, the period found in the blocks around it by
/// [`tiles::local_periods`], give or take a pixel along it: the period
/// drifts in perspective), against half a period away: 1 up to the first
/// of [`RECUR_RATIO`], 0 from the second up.
/// Patches compare luminance high-passed at the patch's scale, and
/// colour: not tone (boards and tiles differ in tone while their edges
/// line up), and not gradient directions (a surface's grain gives every
/// pixel a full-strength direction, which drowned the edge's repeat).
/// This is what keeps a roof's tile courses, louvres, vents and locker
/// seams out of the detail term: their patches are rare by density (an
/// edge at every offset) but repeat at the local period, where a crack or
/// a peel's edge does not.
fn local_regularity(f: &Features, blocks: &[tiles::LocalPeriods], patch: usize) -> Image {
    let app = &f.appearance;
    let (w, h) = app.size();
    let mut out = vec![0f32; w * h];
    if blocks.is_empty() {
        return Image::from_data(w, h, 1, out).expect("sizes match");
    }
    // Luminance high-passed at the patch's scale (an edge, not the tone
    // of the board it is on), then colour.
    let lum = app.select_channels(0..1);
    let low = gaussian_blur(&lum, patch as f32);
    let chroma = app.channels() >= 3;
    let feature = Image::from_fn(w, h, if chroma { 3 } else { 1 }, |x, y, p| {
        p[0] = lum.at(x, y, 0) - low.at(x, y, 0);
        if chroma {
            p[1] = RECUR_CHROMA * app.at(x, y, 1);
            p[2] = RECUR_CHROMA * app.at(x, y, 2);
        }
    });
    let r = (patch / 2) as i64;
    let (wi, hi) = (w as i64, h as i64);
    // Squared distance between the patches at (x, y) and (tx, ty); None
    // when the second is not wholly inside.
    let distance = |x: i64, y: i64, tx: i64, ty: i64| -> Option<f32> {
        if tx < r || ty < r || tx + r >= wi || ty + r >= hi {
            return None;
        }
        let mut sum = 0f32;
        for v in -r..=r {
            let (ay, by) = ((y + v).clamp(0, hi - 1) as usize, (ty + v) as usize);
            for u in -r..=r {
                let (ax, bx) = ((x + u).clamp(0, wi - 1) as usize, (tx + u) as usize);
                sum += feature.pixel(ax, ay).iter().zip(feature.pixel(bx, by)).map(|(a, b)| (a - b) * (a - b)).sum::<f32>();
            }
        }
        Some(sum)
    };
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            let (xi, yi) = (x as i64, y as i64);
            for block in blocks {
                let (bx, by, bw, bh) = block.rect;
                if x < bx || y < by || x >= bx + bw || y >= by + bh {
                    continue;
                }
                for v in &block.vectors {
                    let len = (v[0] * v[0] + v[1] * v[1]).sqrt().max(1e-6);
                    let (ux, uy) = (v[0] / len, v[1] / len);
                    let mut near = f32::INFINITY;
                    let (mut far, mut far_n) = (0f32, 0);
                    for s in [-1.0f32, 1.0] {
                        for j in [-1.0f32, 0.0, 1.0] {
                            let (dx, dy) = ((s * v[0] + j * ux).round() as i64, (s * v[1] + j * uy).round() as i64);
                            if let Some(d) = distance(xi, yi, xi + dx, yi + dy) {
                                near = near.min(d);
                            }
                        }
                        let (dx, dy) = ((0.5 * s * v[0]).round() as i64, (0.5 * s * v[1]).round() as i64);
                        if let Some(d) = distance(xi, yi, xi + dx, yi + dy) {
                            far += d;
                            far_n += 1;
                        }
                    }
                    if far_n == 0 || !near.is_finite() {
                        continue;
                    }
                    let far = far / far_n as f32;
                    if far > 1e-6 {
                        let (full, none) = RECUR_RATIO;
                        *o = o.max(((none - near / far) / (none - full)).clamp(0.0, 1.0));
                    }
                }
            }
        }
    });
    Image::from_data(w, h, 1, out).expect("sizes match")
}

/// Bins per axis of the appearance histograms.
const BINS: usize = 16;

/// A 16^3 histogram grid over an image's appearance features (Lab), each
/// axis spanning the image's own range.
pub(crate) struct ColourBins {
    lo: [f32; 3],
    hi: [f32; 3],
    axes: usize,
}

impl ColourBins {
    /// Bins spanning the range of `appearance`'s first three channels.
    pub(crate) fn new(appearance: &Image) -> Self {
        let axes = appearance.channels().min(3);
        let mut lo = [f32::MAX; 3];
        let mut hi = [f32::MIN; 3];
        for p in appearance.data().chunks_exact(appearance.channels()) {
            for k in 0..axes {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        ColourBins { lo, hi, axes }
    }

    /// The bin of one pixel's features.
    pub(crate) fn bin(&self, p: &[f32]) -> usize {
        let mut b = [0usize; 3];
        for k in 0..self.axes {
            let t = if self.hi[k] > self.lo[k] { (p[k] - self.lo[k]) / (self.hi[k] - self.lo[k]) } else { 0.0 };
            b[k] = ((t * BINS as f32) as usize).min(BINS - 1);
        }
        (b[0] * BINS + b[1]) * BINS + b[2]
    }

    /// The histogram of the pixels in `pick` (all when `None`), smoothed
    /// by [1 2 1] along each used axis.
    fn counts(&self, appearance: &Image, pick: Option<&Mask>) -> Vec<f32> {
        let mut hist = vec![0f32; BINS * BINS * BINS];
        for (i, p) in appearance.data().chunks_exact(appearance.channels()).enumerate() {
            if pick.is_none_or(|m| m.bits()[i]) {
                hist[self.bin(p)] += 1.0;
            }
        }
        let stride = [BINS * BINS, BINS, 1];
        for &s in &stride[..self.axes] {
            let mut out = hist.clone();
            for (i, o) in out.iter_mut().enumerate() {
                let at = (i / s) % BINS;
                let mut sum = 2.0 * hist[i];
                if at > 0 {
                    sum += hist[i - s];
                }
                if at + 1 < BINS {
                    sum += hist[i + s];
                }
                *o = sum / 4.0;
            }
            hist = out;
        }
        hist
    }

    /// The smoothed histogram of the pixels in `pick`, summing to 1.
    pub(crate) fn probabilities(&self, appearance: &Image, pick: Option<&Mask>) -> Vec<f32> {
        let mut hist = self.counts(appearance, pick);
        let total: f32 = hist.iter().sum();
        if total > 0.0 {
            hist.iter_mut().for_each(|v| *v /= total);
        }
        hist
    }
}

/// Per pixel, how common its colour is: the count of the pixels of
/// `within` (all when `None`) in its bin of a 16^3 histogram of the
/// appearance features (smoothed over the neighbouring bins).
fn colour_density(appearance: &Image, within: Option<&Mask>) -> Vec<f32> {
    let bins = ColourBins::new(appearance);
    let hist = bins.counts(appearance, within);
    appearance.data().chunks_exact(appearance.channels()).map(|p| hist[bins.bin(p)]).collect()
}

/// Share of pixels with the rarest colours that never serve as the
/// reference of the nearest-patch rarity (rust, paint, stains: material of
/// a colour the surface otherwise lacks).
pub const RARE_COLOURS: f32 = 0.15;

/// Distance from each pixel's patch to its nearest patch wholly inside
/// `pool` (not overlapping it), spread over the pixels the patch covers,
/// with the border band set from the nearest interior pixel.
fn pool_distance(appearance: &Image, pool: &Mask, patch: usize) -> Result<Image> {
    let (w, h) = appearance.size();
    let r = patch / 2;
    let domain = SourceDomain::new(w, h, r, Some(pool)).or_else(|_| SourceDomain::new(w, h, r, None))?;
    let metric = PatchMetric::mean_ssd(appearance.channels());
    let mut nnf = random_nnf(w, h, &domain, 0xa9e);
    let pm = PatchMatch { radius: r, iterations: 6, metric: &metric, uniformity: 0.0, max_search_radius: None, exclude_self: Some(patch) };
    pm.improve(appearance, appearance, &domain, &mut nnf, None, 0xa9e5);
    let clamp = |v: usize, n: usize| v.clamp(r.min(n / 2), (n - 1 - r).max(n / 2));
    let cost = Image::from_fn(w, h, 1, |x, y, p| p[0] = nnf.get(clamp(x, w), clamp(y, h)).cost.max(0.0).sqrt());
    Ok(gaussian_blur(&cost, r as f32 * 0.5 + 0.5))
}

/// Patches of the whole image each pixel's patch is compared with in
/// [`detail_term`].
pub const DENSITY_SAMPLES: usize = 256;
/// The rank, among those samples, of the neighbour whose distance measures
/// density: a patch with fewer than this many close copies among the
/// samples (3%) is rare.
pub const DENSITY_RANK: usize = 8;
/// Quantile of the density distance that maps to detail 0: the rarest
/// fifth of the pixels can show as weathered detail.
pub const DETAIL_FLOOR: f32 = 0.8;

/// Per pixel, how rare its patch is, at two scales (the `patch` at full
/// and at half resolution), by two measures, the larger of which counts:
/// - density: the distance from its patch to its [`DENSITY_RANK`]-th
///   nearest among [`DENSITY_SAMPLES`] patches drawn from the whole image
///   (a k-nearest-neighbour density estimate), rescaled from its
///   [`DETAIL_FLOOR`] quantile. A nearest-neighbour distance cannot find a
///   crack network: every crack patch has a twin somewhere; density can,
///   since only a few percent of the patches are cracks.
/// - distance to reference material: the distance to the nearest patch
///   among pixels whose coarse age is below the median, whose density is
///   ordinary and whose colour is not among the [`RARE_COLOURS`] (rust
///   blooms are too common for the density measure but their colour is
///   rare), rescaled from the [`DETAIL_QUANTILE`] of that distance over
///   the reference itself.
///
/// Pixels closer to the border than the patch radius take the value of
/// the nearest interior pixel (their patches are cut off and would look rare).
/// With `within`, the samples, the reference, the scales and the colour
/// counts come from its pixels only.
fn detail_term(f: &Features, coarse: &Image, patch: usize, within: Option<&Mask>) -> Result<Image> {
    let appearance = &f.appearance;
    let (w, h) = appearance.size();
    let (hw, hh) = (w / 2, h / 2);
    let small = (hw >= 4 * patch && hh >= 4 * patch).then(|| resize(appearance, hw, hh, Filter::Linear)).transpose()?;
    let up = |img: Image| resize(&img, w, h, Filter::Linear);
    let small_within = within.map(|m| Mask::from_fn(hw, hh, |x, y| m.get((2 * x).min(w - 1), (2 * y).min(h - 1))));
    let mut out = Image::new(w, h, 1);
    let take = |out: &mut Image, mut d: Image, reference: Option<&Mask>, floor: f32| {
        let values: Vec<f32> = match reference {
            Some(m) if m.count() > 0 => d.data().iter().zip(m.bits()).filter(|(_, &b)| b).map(|(v, _)| *v).collect(),
            _ => d.data().to_vec(),
        };
        rescale(d.data_mut(), &values, floor, TOP_QUANTILE);
        out.data_mut().iter_mut().zip(d.data()).for_each(|(o, v)| *o = o.max(*v));
    };
    // Density.
    take(&mut out, density_distance(appearance, patch, within), within, DETAIL_FLOOR);
    if let Some(s) = &small {
        take(&mut out, up(density_distance(s, patch, small_within.as_ref()))?, within, DETAIL_FLOOR);
    }
    // Distance to reference material.
    let on = |i: usize| within.is_none_or(|m| m.bits()[i]);
    let mut ages: Vec<f32> = coarse.data().iter().enumerate().filter(|&(i, _)| on(i)).map(|(_, v)| *v).collect();
    let median_age = median(&mut ages).unwrap_or(0.0);
    let colour = colour_density(appearance, within);
    let mut sorted: Vec<f32> = colour.iter().enumerate().filter(|&(i, _)| on(i)).map(|(_, v)| *v).collect();
    let rare = quantile(&mut sorted, RARE_COLOURS).unwrap_or(0.0);
    let dense = out.clone();
    let pool = Mask::from_fn(w, h, |x, y| {
        on(y * w + x) && coarse.at(x, y, 0) <= median_age && colour[y * w + x] > rare && dense.at(x, y, 0) <= 0.0
    });
    // The floor comes from pixels whose whole patch is reference material
    // (a pixel next to a crack is in the pool but its patch holds the crack).
    let core = pool.erode(patch);
    take(&mut out, pool_distance(appearance, &pool, patch)?, Some(&core), DETAIL_QUANTILE);
    if let Some(s) = &small {
        let small_pool = Mask::from_fn(hw, hh, |x, y| {
            pool.get((2 * x).min(w - 1), (2 * y).min(h - 1)) && pool.get((2 * x + 1).min(w - 1), (2 * y + 1).min(h - 1))
        });
        take(&mut out, up(pool_distance(s, &small_pool, patch)?)?, Some(&core), DETAIL_QUANTILE);
    }
    if !out.data().iter().all(|v| v.is_finite()) {
        return Err(Error::Internal("the age map's detail term is not finite".into()));
    }
    Ok(out)
}

/// Per pixel, the distance from its patch (luminance texels and mean
/// colour) to the [`DENSITY_RANK`]-th nearest of [`DENSITY_SAMPLES`]
/// patches drawn on a fixed pseudo-random pattern (centred within
/// `within`, when given), spread over the pixels the patch covers.
fn density_distance(appearance: &Image, patch: usize, within: Option<&Mask>) -> Image {
    let (w, h) = appearance.size();
    let r = patch / 2;
    let c = appearance.channels();
    let dims = patch * patch + c.saturating_sub(1);
    // A descriptor per interior pixel: the patch's L texels, then its mean a, b.
    let describe = |x: usize, y: usize, out: &mut [f32]| {
        let mut k = 0;
        let mut mean = [0f32; 2];
        for v in 0..patch {
            for u in 0..patch {
                let px = appearance.pixel(x + u - r, y + v - r);
                out[k] = px[0];
                k += 1;
                for (m, val) in mean.iter_mut().zip(&px[1..]) {
                    *m += val;
                }
            }
        }
        let area = (patch * patch) as f32;
        for (o, m) in out[k..].iter_mut().zip(mean) {
            *o = m / area;
        }
    };
    let (iw, ih) = (w - 2 * r, h - 2 * r);
    let mut g = crate::rng::generator(0xde45, &[w as u64, h as u64]);
    let count = DENSITY_SAMPLES.min(iw * ih);
    let mut samples = vec![0f32; count * dims];
    for s in samples.chunks_exact_mut(dims) {
        // Redrawn (a bounded number of times) until it lies within.
        let mut at = (r + g.gen_range(0..iw), r + g.gen_range(0..ih));
        for _ in 0..64 {
            if within.is_none_or(|m| m.get(at.0, at.1)) {
                break;
            }
            at = (r + g.gen_range(0..iw), r + g.gen_range(0..ih));
        }
        describe(at.0, at.1, s);
    }
    let rank = DENSITY_RANK.min(count).max(1);
    let clamp = |v: usize, n: usize| v.clamp(r, n - 1 - r);
    let mut rows = vec![0f32; w * h];
    rows.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let mut d = vec![0f32; dims];
        let mut best = vec![f32::INFINITY; rank];
        let yy = clamp(y, h);
        for (x, out) in row.iter_mut().enumerate() {
            describe(clamp(x, w), yy, &mut d);
            best.fill(f32::INFINITY);
            for s in samples.chunks_exact(dims) {
                let dist: f32 = d.iter().zip(s).map(|(a, b)| (a - b) * (a - b)).sum();
                if dist < best[rank - 1] {
                    let at = best.partition_point(|&b| b <= dist);
                    best.copy_within(at..rank - 1, at + 1);
                    best[at] = dist;
                }
            }
            *out = (best[rank - 1] / dims as f32).sqrt();
        }
    });
    let cost = Image::from_data(w, h, 1, rows).expect("sizes match");
    gaussian_blur(&cost, r as f32 * 0.5 + 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scales that balance D's two terms come from the surface alone:
    /// a stucco surface (the left 40% of the picture, cut on cell
    /// boundaries, with stucco on to 60% as the object band continues it)
    /// gets the same max I and max G beside flat grey as beside loud
    /// bricks. Until stop 69 the sampled cells and placements covered the
    /// background too, and the bricks set both maxima.
    #[test]
    fn a_masked_surface_sets_its_own_distance_scales() {
        let (n, side) = (10, 200);
        let patch = (side / n, side / n);
        let stucco = crate::samples::stucco(side, side, 3);
        let bricks = crate::samples::bricks(side, side, 4);
        let with_background = |loud: bool| {
            Image::from_fn(side, side, 3, |x, y, p| match (x < 120, loud) {
                (true, _) => p.copy_from_slice(stucco.pixel(x, y)),
                (false, true) => p.copy_from_slice(bricks.pixel(x, y)),
                (false, false) => p.fill(0.5),
            })
        };
        let within = Mask::from_fn(side, side, |x, _| x < 80);
        let inside = cells_inside(Some(&within), n, patch);
        let scales = |img: &Image| distance_scales(&Features::new(img, true).unwrap(), n, patch, &inside);
        let (quiet, loud) = (scales(&with_background(false)), scales(&with_background(true)));
        assert_eq!(quiet, loud, "the background changed the scales");
        let everywhere = vec![true; n * n];
        let unmasked = distance_scales(&Features::new(&with_background(true), true).unwrap(), n, patch, &everywhere);
        assert!(unmasked.0 > loud.0, "the whole picture's max I {} is not above the surface's {}", unmasked.0, loud.0);
    }
}
