//! Growth of weathering past the input (t > 1) by front propagation: the
//! alternative the issue proposes to the paper's eq. 2 patch blending
//! (see [`super::sequence::future`]), and the default because it grows
//! from the existing damage instead of stamping patches.
//!
//! 1. Arrival times: a weighted distance (Dijkstra over the 8-neighbour
//!    grid) from the weathered pixels (age above the cut) and from a few
//!    nucleation sites, through a speed field. The speed follows the
//!    input's own age (weathering advances first into material that is
//!    already a little aged: the halo around rust, the fine cracks that
//!    lead away from a peel) and a fractal noise, so fronts are ragged,
//!    not round. A step across the material's structure (the structure
//!    tensor's dominant gradient, measured on the clean pixels) costs up
//!    to 1 + [`ANISOTROPY`] times a step along it, so peels run along wood
//!    grain and boards instead of spreading as discs.
//! 2. Per future frame, the front advances to the arrival time that makes
//!    the weathered area reach its target: its odds grow by
//!    [`ODDS_GROWTH`] per unit of t, at least [`MIN_GROWTH`] of the
//!    surface ([`clean_share_weathered`]).
//! 3. Drawing, once for all frames ([`damage_layer`]): the guide is the
//!    signed distance to the damage's edge, clamped to a band of half a
//!    patch, beside a wide blur of the input's colour (where, at large
//!    scale, the material comes from). Source: the input's damage; target:
//!    the damage grown to the last frame. Per frame, every damaged pixel
//!    whose clamped distance moved by half the band since it was last
//!    drawn (the band the front crossed, the old rim now inside) is to be
//!    re-drawn; the union of those pixels is filled ([`Synthesis::fill`])
//!    from the input in one synthesis, inside coherent copies with the
//!    matched patch's centre pixel (verbatim material) and the vote where
//!    copies meet. Each frame takes its re-drawn pixels from that layer;
//!    every other pixel keeps the previous frame exactly. So the damage's
//!    rim moves with its front, as in the input (filling only the crossed
//!    band by age, stop 24's version, left each old rim as a ring inside
//!    the new damage), and new damage is one coherent synthesis that
//!    continues the old. Stop 30's version filled and rebuilt thin bands
//!    frame by frame; where the guide fought the content around a thin
//!    band, its vote alternated sources pixel by pixel (checkerboard
//!    specks) and drew contour scribbles.

use super::sequence::{Frame, SequenceParams};
use crate::error::{Error, Result};
use crate::image::filter::{gaussian_blur, gradients, orientation, Orientation};
use crate::image::{Image, Mask};
use crate::rng::{self, Rng};
use crate::samples::fractal_noise;
use crate::synth::{OptimizeParams, Synthesis};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Factor by which the weathered area's odds, f / (1 - f), grow per unit
/// of t: by this alone a surface 5% weathered at t = 1 is 9.5% weathered
/// at t = 2 (12% with [`MIN_GROWTH`]), one 37% weathered is 54%. Growth in
/// proportion to the damage there is.
/// Until stop 45 a fixed 20% of the still-clean surface weathered per unit
/// of t, whatever the damage: the corroded metal's 5% of small chips grew
/// into flat orange slabs over a quarter of the surface, and knot holes
/// into ink blots (t = 2 patch coherence 0.36 and 0.81 over the input's
/// own; 0.19 and 0.40 now).
pub const ODDS_GROWTH: f32 = 2.0;
/// Least share of the whole surface that weathers per unit of t, so that a
/// lightly weathered photo still visibly ages (the issue: at least 5% of
/// pixels change from t = 1 to t = 2; with 0.05 the corroded metal's
/// change was 3.6%).
pub const MIN_GROWTH: f32 = 0.07;

/// The share of the clean surface weathered by time `t` (>= 1) when a
/// fraction `weathered` of the surface is weathered at t = 1: of the two
/// growths, the odds' ([`ODDS_GROWTH`]) and the least ([`MIN_GROWTH`]),
/// the larger.
pub fn clean_share_weathered(weathered: f32, t: f32) -> f32 {
    let f1 = weathered.clamp(0.0, 1.0);
    if f1 >= 1.0 {
        return 0.0;
    }
    let odds = f1 / (1.0 - f1) * ODDS_GROWTH.powf(t - 1.0);
    let grown = odds / (1.0 + odds) - f1;
    (grown.max(MIN_GROWTH * (t - 1.0)) / (1.0 - f1)).clamp(0.0, 1.0)
}

/// Nucleation sites per 64 x 64 px of clean surface.
pub const NUCLEATION_DENSITY: f32 = 0.25;
/// How much slower the front crosses a fully coherent structure than it
/// runs along it, minus one.
pub const ANISOTROPY: f32 = 4.0;
/// How much slower the front enters a pixel on the intact material's
/// strongest edges ([`structure_barrier`] 1: grout, a tile's rim, a seam
/// between boards) than one on plain material, minus one.
pub const BARRIER: f32 = 6.0;
/// Quantile of the intact texture's edge strength at and above which a
/// pixel is a full barrier; the median is none.
const BARRIER_QUANTILE: f32 = 0.98;
/// Blur (px) of the arrival times.
const FRONT_SMOOTHING: f32 = 1.5;
/// Blur (px) of the grown damage's outline before it is thresholded.
pub(crate) const OUTLINE_SMOOTHING: f32 = 2.0;
/// Scale (px) over which the structure's orientation is averaged.
pub(crate) const STRUCTURE_SIGMA: f32 = 6.0;
/// Weight of the edge guide channel against the appearance features.
const EDGE_GUIDE: f32 = 3.0;
/// Change of a pixel's clamped edge distance, in bands, that re-draws it.
const REDRAW_STEP: f32 = 0.5;
/// Blur of the input's colour that tells where new material comes from, in patches.
const CONTEXT_SIGMA: f32 = 2.0;
/// Weight of that context against the edge guide.
const CONTEXT_GUIDE: f32 = 1.0;

/// Arrival time of the weathering at every pixel (0 on weathered pixels;
/// infinite outside `within`, when given, which the front never leaves).
/// With `nucleate`, a few clean pixels start fronts of their own.
pub fn arrival_times(
    age: &Image,
    weathered: &Mask,
    within: Option<&Mask>,
    structure: &Orientation,
    barrier: Option<&[f32]>,
    nucleate: bool,
    seed: u64,
) -> Vec<f32> {
    let (w, h) = age.size();
    let mut g = rng::generator(seed, &[0x9a0]);
    let noise_seed = rng::derive(seed, &[0x9a1]);
    // Speed: faster through already-aged material and along a ragged noise.
    let speed: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let n = fractal_noise(noise_seed, x, y, 10.0, 4);
            // Ragged fronts (a noise over a factor of about 5) that still
            // advance a few pixels per frame everywhere.
            0.3 + 1.6 * n * n + age.data()[i]
        })
        .collect();
    let across: Vec<(f32, f32, f32)> =
        structure.across.data().iter().zip(structure.coherence.data()).map(|(&a, &c)| (a.cos(), a.sin(), c)).collect();
    let mut time = vec![f32::INFINITY; w * h];
    let mut heap: BinaryHeap<Reverse<(u32, u32)>> = BinaryHeap::new();
    let key = |t: f32| (t * 1024.0) as u32;
    for (i, t) in time.iter_mut().enumerate() {
        if weathered.bits()[i] {
            *t = 0.0;
            heap.push(Reverse((0, i as u32)));
        }
    }
    // Nucleation: new sites on clean pixels, drawn in proportion to their
    // age (slightly aged spots start first), each starting a little late.
    let clean = within.map_or(w * h, Mask::count).saturating_sub(weathered.count());
    let sites = if nucleate { ((clean as f32 / 4096.0) * NUCLEATION_DENSITY).round() as usize } else { 0 };
    let weights: Vec<f32> = (0..w * h)
        .map(|i| if weathered.bits()[i] || within.is_some_and(|m| !m.bits()[i]) { 0.0 } else { age.data()[i] * age.data()[i] })
        .collect();
    let total: f32 = weights.iter().sum();
    if total > 0.0 {
        for _ in 0..sites {
            let mut pick = g.gen_range(0.0..total);
            let i = weights.iter().position(|&wt| {
                pick -= wt;
                pick <= 0.0
            });
            if let Some(i) = i {
                let start = g.gen_range(5.0f32..25.0);
                if start < time[i] {
                    time[i] = start;
                    heap.push(Reverse((key(start), i as u32)));
                }
            }
        }
    }
    while let Some(Reverse((k, i))) = heap.pop() {
        let i = i as usize;
        if k > key(time[i]) {
            continue;
        }
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        for (dx, dy, len) in
            [(1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0), (1, 1, 1.414), (1, -1, 1.414), (-1, 1, 1.414), (-1, -1, 1.414)]
        {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                continue;
            }
            let j = ny as usize * w + nx as usize;
            if within.is_some_and(|m| !m.bits()[j]) {
                continue;
            }
            // Slower across the structure than along it: peels run along
            // the grain, cracks along cracks.
            let cos = (dx as f32 * across[i].0 + dy as f32 * across[i].1) / len;
            let wall = barrier.map_or(1.0, |b| 1.0 + BARRIER * b[j]);
            let t = time[i] + len * 2.0 / (speed[i] + speed[j]) * (1.0 + ANISOTROPY * across[i].2 * cos * cos) * wall;
            if t < time[j] {
                time[j] = t;
                heap.push(Reverse((key(t), j as u32)));
            }
        }
    }
    // Across a coherent structure the 8-neighbour steps reach diagonal
    // pixels before their side neighbours, which leaves a checkerboard in
    // the front; a light blur of the times smooths it (weathered pixels
    // stay at 0).
    if time.iter().all(|t| t.is_finite()) {
        let smooth = gaussian_blur(&Image::from_data(w, h, 1, time).expect("sizes match"), FRONT_SMOOTHING);
        return smooth.data().iter().zip(weathered.bits()).map(|(&s, &b)| if b { 0.0 } else { s }).collect();
    }
    time
}

/// The smoothing [`arrival_times`] gives times that are all finite, for
/// times finite only within `within`: a blur normalised over the finite
/// times (only they are averaged), `weathered` pixels staying at 0.
fn smooth_within(time: &mut [f32], within: &Mask, weathered: &Mask) {
    let (w, h) = within.size();
    let finite = |x: usize, y: usize| within.get(x, y) && time[y * w + x].is_finite();
    let on = Image::from_fn(w, h, 1, |x, y, p| p[0] = if finite(x, y) { 1.0 } else { 0.0 });
    let masked = Image::from_fn(w, h, 1, |x, y, p| p[0] = if finite(x, y) { time[y * w + x] } else { 0.0 });
    let (sum, weight) = (gaussian_blur(&masked, FRONT_SMOOTHING), gaussian_blur(&on, FRONT_SMOOTHING));
    for (i, t) in time.iter_mut().enumerate() {
        if within.bits()[i] && !weathered.bits()[i] && t.is_finite() {
            *t = sum.data()[i] / weight.data()[i].max(1e-6);
        }
    }
}

/// Frames for t > 1 grown by front propagation (see the module docs).
/// With `within`, the damage grows only there, its shares are of that
/// surface, and its material comes from there; every other pixel keeps
/// the input.
#[allow(clippy::too_many_arguments)]
pub fn future(
    input: &Image,
    intact: &Image,
    age: &Image,
    cut: f32,
    within: Option<&Mask>,
    params: &SequenceParams,
    seed: u64,
    progress: &dyn Fn(usize),
) -> Result<Vec<Frame>> {
    let (w, h) = input.size();
    if age.size() != input.size() {
        return Err(Error::invalid("the input and its age map must have one size"));
    }
    if intact.size() != input.size() {
        return Err(Error::invalid("the input and its intact texture must have one size"));
    }
    if params.future_span.is_nan() || params.future_span <= 0.0 {
        return Err(Error::invalid("future frames need a positive span"));
    }
    if within.is_some_and(|m| m.size() != input.size()) {
        return Err(Error::invalid("the future frames' mask must be the input's size"));
    }
    let on = |x: usize, y: usize| within.is_none_or(|m| m.get(x, y));
    let weathered = Mask::from_fn(w, h, |x, y| on(x, y) && age.at(x, y, 0) >= cut);
    let clean = Mask::from_fn(w, h, |x, y| on(x, y) && !weathered.get(x, y));
    let barrier = structure_barrier(intact);
    let mut arrival =
        arrival_times(age, &weathered, within, &orientation(input, STRUCTURE_SIGMA, Some(&clean)), Some(&barrier), true, seed);
    if let Some(m) = within {
        smooth_within(&mut arrival, m, &weathered);
    }
    // Arrival times of the clean pixels, sorted: each frame's front is searched among them.
    let mut clean_times: Vec<f32> = arrival.iter().zip(clean.bits()).filter(|(_, &b)| b).map(|(t, _)| *t).collect();
    clean_times.sort_by(f32::total_cmp);
    let patch = params.rebuild.patch;
    // The guide is the signed distance to the damage's edge, clamped to
    // the band: the input's own (source) and the grown front's (target).
    // So the new front is drawn with the input's rim material, the halo
    // ahead of it with the input's halo, and the old rim, now deeper
    // inside, with interior material: the damage's edge moves with the
    // front instead of staying as a ring inside new damage.
    let band = edge_band(patch);
    let context = context(input, patch);
    // Per frame, its time and the count of pixels weathered by then: the
    // input's and the clean share weathered by t.
    let initial = weathered.count() as f32 / within.map_or(w * h, Mask::count).max(1) as f32;
    let fronts: Vec<(f32, usize)> = (1..=params.future)
        .map(|k| {
            let t = 1.0 + params.future_span * k as f32 / params.future as f32;
            let share = clean_share_weathered(initial, t);
            (t, weathered.count() + (share * clean_times.len() as f32).round() as usize)
        })
        .collect();
    // Per frame, the damaged pixels to re-draw: those whose place relative
    // to the edge moved by a visible step since they were last drawn (the
    // band the front crossed, the old rim now inside). Only masks so far.
    let was = clamped_edge(&weathered, band);
    let mut drawn = was.clone();
    let mut reached = weathered.clone();
    let mut covered = weathered.clone();
    let mut start = 0;
    let redraws: Vec<Mask> = fronts
        .iter()
        .map(|&(_, target)| {
            // The front's outline, smoothed: the arrival times' level set
            // on the pixel grid has 1 px ticks, hatching and stair-steps
            // (the 8-neighbour steps); a blur of the reached pixels,
            // thresholded at a half, keeps its shape without them (and
            // stays monotone in t, as blur and threshold both are).
            let outline = |front: f32| {
                let raw = Image::from_fn(w, h, 1, |x, y, p| p[0] = if front >= arrival[y * w + x] { 1.0 } else { 0.0 });
                let smooth = gaussian_blur(&raw, OUTLINE_SMOOTHING);
                Mask::from_fn(w, h, |x, y| reached.get(x, y) || (on(x, y) && smooth.at(x, y, 0) >= 0.5))
            };
            // The pixels to re-draw for a reached outline. Slivers under
            // 3 px wide are not re-drawn: drawn beside the previous frame's
            // pixels, they showed as flecks along cracks and edges. They
            // join a later, wider re-draw or keep the input.
            let redraw_of = |now: &Mask| {
                let edge = clamped_edge(now, band);
                let redraw = Mask::from_fn(w, h, |x, y| {
                    let i = y * w + x;
                    now.get(x, y) && (edge[i] - drawn[i]).abs() > REDRAW_STEP
                })
                .erode(1)
                .dilate(1);
                (redraw, edge)
            };
            // The front is the earliest at which the damage drawn so far
            // (the input's and every re-draw) holds the frame's share. The
            // arrival times' own quantile left fine damage (lichen dots)
            // at half its share: the outline's smoothing rounds small
            // growth away and the slivers are not drawn.
            let drawn_with = |front: f32| {
                let now = outline(front);
                let (redraw, edge) = redraw_of(&now);
                let count = (0..w * h).filter(|&i| covered.bits()[i] || redraw.bits()[i]).count();
                (now, redraw, edge, count)
            };
            let (mut lo, mut hi) = (start, clean_times.len().saturating_sub(1));
            while lo < hi {
                let mid = (lo + hi) / 2;
                if drawn_with(clean_times[mid]).3 >= target {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            start = lo;
            let front = clean_times.get(lo).copied().unwrap_or(0.0);
            let (now, redraw, edge, _) = drawn_with(front);
            reached = now;
            for (i, d) in drawn.iter_mut().enumerate() {
                if redraw.bits()[i] {
                    *d = edge[i];
                    covered.set(i % w, i / w, true);
                }
            }
            redraw
        })
        .collect();
    let hole = Mask::from_fn(w, h, |x, y| redraws.iter().any(|r| r.get(x, y)));
    let layer = damage_layer(input, input, &was, &clamped_edge(&reached, band), &hole, &context, within, params, seed)?;
    let mut previous = input.clone();
    let mut frames = Vec::with_capacity(params.future);
    for (k, (&(t, _), redraw)) in fronts.iter().zip(&redraws).enumerate() {
        previous = blend_where(&previous, &layer, &redraw.to_image());
        frames.push(Frame { t, image: previous.clone() });
        progress(k + 1);
    }
    Ok(frames)
}

/// The grown damage drawn once, for the last frame: the pixels of `hole`
/// (every pixel some frame re-draws) of `base` are filled
/// ([`Synthesis::fill`]) from the input, guided by `target_edge`, the
/// clamped edge distance ([`clamped_edge`]) of the last frame's damage
/// (source: `source_edge`, the input damage's), and by the wide blur of the
/// input's colour (`context`: where the material comes from), copying
/// from `sources` when given. Every frame
/// takes its re-drawn pixels from this layer, so new damage is one
/// coherent synthesis that continues the old, the same in every frame.
#[allow(clippy::too_many_arguments)]
fn damage_layer(
    base: &Image,
    input: &Image,
    source_edge: &[f32],
    target_edge: &[f32],
    hole: &Mask,
    context: &Image,
    sources: Option<&Mask>,
    params: &SequenceParams,
    seed: u64,
) -> Result<Image> {
    let patch = params.rebuild.patch;
    if hole.count() == 0 {
        return Ok(input.clone());
    }
    let source_edge = guide(source_edge, context)?;
    let target_edge = guide(target_edge, context)?;
    let op = OptimizeParams { patch, levels: Some(3), search_vote_iters: 6, uniformity: 0.0, ..OptimizeParams::default() };
    let mut synthesis = Synthesis::new(input).fill(base, hole).guides(&source_edge, &target_edge, params.rebuild.guide_weight);
    if let Some(m) = sources {
        synthesis = synthesis.source_mask(m);
    }
    let mut filled = synthesis.seed(rng::derive(seed, &[0xf2])).optimize(&op)?;
    // Verbatim material inside coherent copies: the mean vote alone left
    // grown interiors with a third of the input damage's pixel detail.
    filled.coherent_copies(input, hole);
    Ok(filled.image)
}

/// Per pixel, in [0, 1], how strongly the intact material's own structure
/// stops a growing front: its edge strength (Sobel magnitude after a 1 px
/// blur) from the median (0) to the [`BARRIER_QUANTILE`] (1). Only the
/// material's strongest edges count, the grout and rims of tiles, seams
/// between boards, so a stain fills its tile before it crosses to the
/// next, and plain or grainy material is no barrier.
fn structure_barrier(intact: &Image) -> Vec<f32> {
    let mut barrier = gradients(&gaussian_blur(intact, 1.0)).magnitude.data().to_vec();
    let reference = barrier.clone();
    super::age::rescale(&mut barrier, &reference, 0.5, BARRIER_QUANTILE);
    barrier
}

/// Least change of a pixel's clamped edge distance, in bands, that makes
/// it part of a receded rim (see [`Recession::frame`]).
const RIM_STEP: f32 = 0.25;

/// The past frames' receding damage: what every frame shares, computed
/// once (see [`Recession::frame`]).
pub(crate) struct Recession<'a> {
    input: &'a Image,
    intact: &'a Image,
    /// The input damage's clamped edge distance ([`clamped_edge`]).
    was: Vec<f32>,
    /// The guide's wide blur of the input's colour.
    context: Image,
    band: f32,
}

impl<'a> Recession<'a> {
    /// The damage `damage` of `input` receding over `intact`, drawn with
    /// patches of `patch` px.
    pub(crate) fn new(input: &'a Image, intact: &'a Image, damage: &Mask, patch: usize) -> Self {
        let band = edge_band(patch);
        Recession { input, intact, was: clamped_edge(damage, band), context: context(input, patch), band }
    }

    /// A past frame whose damage has receded to `present` (a subset of the
    /// input's): the intact texture outside `present`, the input inside,
    /// and a rim redrawn where `present`'s edge cuts through the damage.
    /// The rim is the band of `present` within half a patch of its edge,
    /// where the input's own edge is farther by more than [`RIM_STEP`]
    /// bands; it is filled from the input with the same guides as the
    /// future's [`damage_layer`] (source: the input's damage edge; target:
    /// `present`'s), so a receded peel keeps a peel's rim and lip instead
    /// of showing a cut through its interior. (The future's rule, a change
    /// of half a band, leaves only a sliver under 2 px wide here, which the
    /// opening that drops slivers removes.)
    pub(crate) fn frame(&self, present: &Mask, params: &SequenceParams, seed: u64) -> Result<Image> {
        let (input, intact) = (self.input, self.intact);
        let (w, h) = input.size();
        let composite = Image::from_fn(w, h, input.channels(), |x, y, p| {
            p.copy_from_slice(if present.get(x, y) { input.pixel(x, y) } else { intact.pixel(x, y) })
        });
        let now = clamped_edge(present, self.band);
        let redraw = Mask::from_fn(w, h, |x, y| {
            let i = y * w + x;
            present.get(x, y) && now[i] < 1.0 && self.was[i] - now[i] > RIM_STEP
        })
        .erode(1)
        .dilate(1);
        if redraw.count() == 0 {
            return Ok(composite);
        }
        let layer = damage_layer(&composite, input, &self.was, &now, &redraw, &self.context, None, params, seed)?;
        Ok(blend_where(&composite, &layer, &redraw.to_image()))
    }
}

/// Half-width, in pixels, of the band around the damage's edge whose look
/// depends on the distance to it (rims, halos, lifted lips): half a patch,
/// at least 3 px.
fn edge_band(patch: usize) -> f32 {
    (0.5 * patch as f32).max(3.0)
}

/// Per pixel, the signed distance to `damage`'s edge over `band`, clamped
/// to [-1, 1]: where the pixel lies relative to the damage's rim.
fn clamped_edge(damage: &Mask, band: f32) -> Vec<f32> {
    damage.signed_distance().iter().map(|d| (d / band).clamp(-1.0, 1.0)).collect()
}

/// The wide blur of `input`'s colour that tells the guides where, at large
/// scale, the material comes from, weighted by [`CONTEXT_GUIDE`].
fn context(input: &Image, patch: usize) -> Image {
    gaussian_blur(input, CONTEXT_SIGMA * patch as f32).map(|v| v * CONTEXT_GUIDE)
}

/// The guide channels: `edge` ([`clamped_edge`]) times [`EDGE_GUIDE`],
/// beside `context`.
fn guide(edge: &[f32], context: &Image) -> Result<Image> {
    let (w, h) = context.size();
    let edge = Image::from_data(w, h, 1, edge.iter().map(|e| EDGE_GUIDE * e).collect())?;
    Image::concat_channels(&[&edge, context])
}

/// `a` blended towards `b` by `weight` (one channel in [0, 1]). The fill
/// already joins its hole's border, so the band is taken with a hard edge:
/// a feathered one would change the pixels around it a second time.
fn blend_where(a: &Image, b: &Image, weight: &Image) -> Image {
    Image::from_fn(a.width(), a.height(), a.channels(), |x, y, p| {
        let wt = weight.at(x, y, 0);
        for (c, v) in p.iter_mut().enumerate() {
            *v = a.at(x, y, c) * (1.0 - wt) + b.at(x, y, c) * wt;
        }
    })
}
