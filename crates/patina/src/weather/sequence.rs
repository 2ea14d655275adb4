//! Weathering and de-weathering sequences (Bellini et al. 2016, section 6).
//!
//! Past, t in (0, 1): a pixel of age a is intact at time t when
//! a < 1 - t; otherwise its age at t is a - (1 - t), and the template
//! blends intact and input by the share of its final age it has reached,
//! (a - (1 - t)) / a. Each template is rebuilt from input patches
//! ([`super::rebuild`]). Not what [`past`] does: age maps are bimodal, so
//! those thresholds reveal whole features in one step (51-87% of the
//! change in one quarter step on real photos); [`past`] thresholds the
//! pixel's rank among the changed pixels instead, which is uniform, so the
//! weathered area grows evenly in t, and redraws the receded damage's rim.
//!
//! Future, t > 1: by default front propagation ([`super::growth`]); the
//! paper's eq. 2 with [`Growth::Patches`], as follows.
//!
//! Future, t > 1 (eq. 2), each frame from the previous one: `steps` times,
//! pick a random patch P; m = max over P of Delta = |t_i - intact| (as a
//! fraction of the input's largest Delta); find a patch Q' of the input
//! whose age is m + delta; around Q', over the eight rotations and mirrors,
//! take the patch Q whose structure (the smoothed edge map of the intact
//! texture) best agrees with P's; blend
//! t_{i+1}(P) = t_i(P) (1 - Delta_Q) + input(Q) Delta_Q, with Delta_Q
//! feathered towards the patch's edges (not in the paper: hard squares
//! showed). Then rebuild the frame from input patches.
//!
//! Monotonic, no flicker: after each rebuild, every pixel keeps whichever
//! of the new frame and the previous frame is farther from the intact
//! texture. Pixels whose template did not change keep the previous frame
//! exactly (a rebuild is a new synthesis and would otherwise add noise).

use super::rebuild::{colour_distance, delta_scale, pixel_distance, rebuild, Engine, RebuildParams};
use crate::error::{Error, Result};
use crate::image::filter::{gaussian_blur, gradients, orientation};
use crate::image::order::median;
use crate::image::summed::SummedArea;
use crate::image::{Image, Mask};
use crate::rng::{self, Rng};
use serde::{Deserialize, Serialize};

/// Parameters of the sequences.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SequenceParams {
    /// Frames between the intact texture (t = 0) and the input (t = 1).
    pub past: usize,
    /// Frames after the input, evenly spaced up to t = 1 + `future_span`.
    pub future: usize,
    /// How far past the input the last future frame lies, in t.
    pub future_span: f32,
    /// Patch blends per future frame; `None` = half the age map's
    /// cells (N^2 / 2): each frame then touches about half the area.
    pub steps: Option<usize>,
    /// delta of eq. (2): how much older than P the copied patch Q is.
    pub delta: f32,
    /// Side of the blended patches P and Q; `None` = the age map's patch.
    pub patch: Option<usize>,
    /// Half-width of the window around Q' searched for structure agreement,
    /// in patch sides.
    pub search: f32,
    /// How templates are rebuilt from input patches.
    pub rebuild: RebuildParams,
    /// How future frames grow.
    pub growth: Growth,
}

/// How future frames (t > 1) grow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Growth {
    /// Front propagation from the existing damage ([`super::growth`]).
    Front,
    /// The paper's eq. 2: blend older input patches onto random patches.
    Patches,
}

impl Default for SequenceParams {
    fn default() -> Self {
        SequenceParams {
            past: 3,
            future: 3,
            future_span: 1.0,
            steps: None,
            delta: 0.15,
            patch: None,
            search: 0.5,
            rebuild: RebuildParams::default(),
            growth: Growth::Front,
        }
    }
}

/// One frame of a sequence: its time (0 intact, 1 input, > 1 future).
#[derive(Clone, Debug)]
pub struct Frame {
    pub t: f32,
    pub image: Image,
}

/// Pixels whose change exceeds this (colour distance) take the rebuilt frame.
const CHANGED: f32 = 0.02;

/// `rebuilt` where the template moved away from `previous`, `previous`
/// elsewhere, and per pixel the one farther from `intact`.
pub(crate) fn settle(rebuilt: &Image, template: &Image, previous: &Image, intact: &Image) -> Result<Image> {
    let moved = colour_distance(template, previous)?;
    let moved = Image::from_data(template.width(), template.height(), 1, moved)?;
    // Feather the changed region over a couple of pixels.
    let weight = gaussian_blur(&moved.map(|v| if v > CHANGED { 1.0 } else { 0.0 }), 1.0);
    let d_new = colour_distance(rebuilt, intact)?;
    let d_old = colour_distance(previous, intact)?;
    let n = previous.channels();
    let mut out = previous.clone();
    let mut blend = vec![0f32; n];
    for (i, px) in out.data_mut().chunks_exact_mut(n).enumerate() {
        let w = (weight.data()[i] * 2.0).min(1.0);
        if w > 0.0 && d_new[i] > d_old[i] {
            let r = &rebuilt.data()[i * n..(i + 1) * n];
            blend.iter_mut().zip(px.iter().zip(r)).for_each(|(b, (p, q))| *b = p + w * (q - p));
            // A partial blend can point elsewhere than the rebuilt pixel:
            // keep it only when it too is farther from intact.
            if pixel_distance(&blend, &intact.data()[i * n..(i + 1) * n]) > d_old[i] {
                px.copy_from_slice(&blend);
            }
        }
    }
    Ok(out)
}

/// Frames for t in (0, 1), oldest last, given the input, its intact
/// texture and its age map. The damage (the pixels where the input
/// differs from its intact texture) grows from its oldest points within
/// its own extent: a pixel is present at t when its reveal rank q (see
/// [`change_ranks`]) is at least 1 - t, so the change grows evenly in t,
/// and the present damage's outline is smoothed as the future's is
/// ([`super::growth::OUTLINE_SMOOTHING`]). Each frame is the intact
/// texture outside the present damage and the input inside, with a rim
/// redrawn where the receded edge cuts through the damage
/// ([`super::growth::Recession::frame`]).
///
/// Until stop 50 a frame was a per-pixel blend of intact and input with a
/// soft edge in t, revealed core first by depth and age: cut-outs of the
/// damage's interior with no rim. In a blind review of 15 photos the
/// redrawn rims (with a front receding from the unchanged pixels) were
/// preferred on 6, the blend on 2 (moss, cracked wood), 7 ties. The paper
/// instead rebuilds cross-faded templates, which here only added noise
/// and a jump at t = 1.
pub fn past(
    input: &Image,
    intact: &Image,
    age: &Image,
    params: &SequenceParams,
    seed: u64,
    progress: &dyn Fn(usize),
) -> Result<Vec<Frame>> {
    check_sizes(input, intact, age)?;
    let rank = change_ranks(input, intact, age, seed)?;
    let (w, h) = input.size();
    let damage = Mask::from_fn(w, h, |x, y| rank.at(x, y, 0) > 0.0);
    let recession = super::growth::Recession::new(input, intact, &damage, params.rebuild.patch);
    let mut frames = Vec::with_capacity(params.past);
    for k in 1..=params.past {
        let t = k as f32 / (params.past + 1) as f32;
        let raw = rank.map(|q| if q > 0.0 && q >= 1.0 - t { 1.0 } else { 0.0 });
        let smooth = gaussian_blur(&raw, super::growth::OUTLINE_SMOOTHING);
        let present = Mask::from_fn(w, h, |x, y| damage.get(x, y) && smooth.at(x, y, 0) >= 0.5);
        let image = recession.frame(&present, params, rng::derive(seed, &[k as u64]))?;
        frames.push(Frame { t, image });
        progress(k);
    }
    Ok(frames)
}

/// Weight of a pixel's depth inside the damage (up to [`CORE_DEPTH`])
/// against its arrival time in the reveal order (see [`change_ranks`]).
pub const DEPTH_SHARE: f32 = 0.5;
/// Depth (px) beyond which a pixel counts as a damage's core.
const CORE_DEPTH: f32 = 6.0;

/// Per pixel, its reveal rank in (0, 1] among the pixels where the input
/// differs from the intact texture (0 elsewhere), as the share of the
/// change revealed by then: thresholds on it pace the past frames evenly
/// by change. The order is each piece of damage growing inside its own
/// extent from its oldest point: the arrival time of a front
/// ([`super::growth::arrival_times`], ragged, faster through older
/// damage, slower across the intact material's structure) that never
/// leaves the damage and starts, in each connected piece, at the pixel
/// with the highest score (smoothed age plus a tenth of its depth, up to
/// 10 px). The key is minus that time over its 90th percentile, plus
/// [`DEPTH_SHARE`] of the depth over [`CORE_DEPTH`], so thick damage also
/// shrinks towards its own outline's core. A crack or a seam grows along
/// its length from its oldest point, a spall from where it started. A
/// wide piece that holds older colonies (rust blooms merged into one mass)
/// also recedes towards each of them ([`colony_seeds`]): with one seed per
/// piece, one corner of a wide mass was done by t = 0.25 while the far
/// side had not begun (the spatial spread of the share revealed at t =
/// 0.5 over 4 x 4 blocks, mean of the 15 photos at 384 px: 0.269 with one
/// seed, 0.188 with colonies; in a blind review preferred on 5 photos,
/// the single seed on 3, 7 ties).
///
/// Until stop 50 the order was half the age's rank and half the depth:
/// thin damage (one or two pixels deep everywhere) was revealed by noise,
/// so cracks and plank seams came back as chains of dashes (a synthetic
/// crack network at t = 0.5: 35.9 pieces per 1000 damaged pixels; now
/// 3.7). In a blind review of the past frames of 15 photos this order was
/// preferred on 8, the older one on 2 (damask, shutters), 5 ties; the
/// grades summed 27 -> 33. Tried and not kept: extra seeds, one per 2048
/// damaged pixels, broke a single spall into a scatter of pill-shaped
/// islands (preferred 7 to 5, grades equal).
fn change_ranks(input: &Image, intact: &Image, age: &Image, seed: u64) -> Result<Image> {
    let d = colour_distance(input, intact)?;
    let (w, h) = input.size();
    let changed = Mask::from_fn(w, h, |x, y| d[y * w + x] > CHANGED);
    // A lightly smoothed age orders whole regions, not speckle.
    let smooth = gaussian_blur(age, 1.5);
    let depth = changed.distance_inside();
    let (labels, count) = crate::image::region::components(changed.bits(), w, h);
    let mut oldest = vec![(f32::NEG_INFINITY, usize::MAX); count];
    for (i, &l) in labels.iter().enumerate() {
        let score = smooth.data()[i] + 0.1 * depth[i].min(10.0);
        if l != u32::MAX && score > oldest[l as usize].0 {
            oldest[l as usize] = (score, i);
        }
    }
    let mut seeds = Mask::filled(w, h, false);
    for &(_, i) in &oldest {
        seeds.set(i % w, i / w, true);
    }
    for i in colony_seeds(&labels, count, &smooth, &depth, w, h) {
        seeds.set(i % w, i / w, true);
    }
    let structure = orientation(intact, super::growth::STRUCTURE_SIGMA, None);
    let arrival = super::growth::arrival_times(&smooth, &seeds, Some(&changed), &structure, None, false, seed);
    let mut times: Vec<f32> = changed.bits().iter().zip(&arrival).filter(|(&b, t)| b && t.is_finite()).map(|(_, &t)| t).collect();
    let scale = if times.is_empty() {
        1.0
    } else {
        let k = times.len() * 9 / 10;
        *times.select_nth_unstable_by(k, f32::total_cmp).1
    }
    .max(1e-6);
    // Earliest arrival and deepest, first revealed: the largest key.
    let mut keyed: Vec<(f32, usize)> = changed
        .bits()
        .iter()
        .enumerate()
        .filter(|(_, &b)| b)
        .map(|(i, _)| (-arrival[i].min(1e9) / scale + DEPTH_SHARE * (depth[i] / CORE_DEPTH).min(1.0), i))
        .collect();
    keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    // The rank is the share of the whole change (not of the pixels) up to
    // and including the pixel, so each step brings an even share of it:
    // by pixel count, the many pixels the intact rebuild changes only
    // slightly ranked last and the first step brought 58% of the change
    // on the demo's rusty tiles.
    let total: f64 = keyed.iter().map(|&(_, i)| d[i] as f64).sum::<f64>().max(1e-12);
    let mut rank = vec![0f32; d.len()];
    let mut done = 0f64;
    for &(_, i) in &keyed {
        done += d[i] as f64;
        rank[i] = (done / total) as f32;
    }
    Image::from_data(input.width(), input.height(), 1, rank)
}

/// Radius (px) within which a wide piece of damage has one colony seed.
pub const COLONY_RADIUS: usize = 24;
/// How much older (smoothed age) than its piece's median a colony seed is.
pub const COLONY_MARGIN: f32 = 0.1;
/// Least depth (px) inside its piece of a colony seed: thin damage (a crack
/// network) keeps one seed per piece and shortens along its length.
pub const COLONY_DEPTH: f32 = 4.0;

/// Extra seeds of the wide pieces of damage (over pi COLONY_RADIUS^2
/// pixels), where they hold older colonies: pixels whose smoothed age is
/// the highest of their piece within [`COLONY_RADIUS`], at least
/// [`COLONY_MARGIN`] above their piece's median and [`COLONY_DEPTH`]
/// inside it. A spall of one even age keeps its one seed.
fn colony_seeds(labels: &[u32], count: usize, smooth: &Image, depth: &[f32], w: usize, h: usize) -> Vec<usize> {
    let r = COLONY_RADIUS;
    let mut sizes = vec![0usize; count];
    labels.iter().filter(|&&l| l != u32::MAX).for_each(|&l| sizes[l as usize] += 1);
    let wide = |l: u32| l != u32::MAX && sizes[l as usize] as f32 > std::f32::consts::PI * (r * r) as f32;
    let age = |i: usize| smooth.data()[i];
    let mut per: Vec<Vec<f32>> = vec![Vec::new(); count];
    for (i, &l) in labels.iter().enumerate() {
        if wide(l) {
            per[l as usize].push(age(i));
        }
    }
    let floor: Vec<f32> = per.iter_mut().map(|v| median(v).map_or(f32::INFINITY, |m| m + COLONY_MARGIN)).collect();
    (0..w * h)
        .filter(|&i| wide(labels[i]) && depth[i] >= COLONY_DEPTH && age(i) >= floor[labels[i] as usize])
        .filter(|&i| {
            let (x, y, l, a) = (i % w, i / w, labels[i], age(i));
            (y.saturating_sub(r)..(y + r + 1).min(h)).all(|v| {
                (x.saturating_sub(r)..(x + r + 1).min(w)).all(|u| {
                    let j = v * w + u;
                    labels[j] != l || age(j) < a || (age(j) == a && j >= i)
                })
            })
        })
        .collect()
}

/// The eight rotations and mirrors of a square patch of side `s`: local
/// (u, v) to offsets inside the source patch.
fn orient(o: usize, u: usize, v: usize, s: usize) -> (usize, usize) {
    let (u, v) = if o & 4 != 0 { (s - 1 - u, v) } else { (u, v) };
    match o & 3 {
        0 => (u, v),
        1 => (s - 1 - v, u),
        2 => (s - 1 - u, s - 1 - v),
        _ => (v, s - 1 - u),
    }
}

/// Frames for t > 1, each grown from the previous by eq. (2).
#[allow(clippy::too_many_arguments)]
pub fn future(
    input: &Image,
    intact: &Image,
    age: &Image,
    grid_cells: usize,
    age_patch: usize,
    params: &SequenceParams,
    seed: u64,
    progress: &dyn Fn(usize),
) -> Result<Vec<Frame>> {
    check_sizes(input, intact, age)?;
    let (w, h, n) = (input.width(), input.height(), input.channels());
    let s = params.patch.unwrap_or(age_patch).clamp(3, w.min(h));
    let valid = (0.0..=1.0).contains(&params.delta) && params.future_span > 0.0 && params.search >= 0.0;
    if !valid {
        return Err(Error::invalid("future frames need delta in [0, 1], a positive span and a non-negative search window"));
    }
    let steps = params.steps.unwrap_or(grid_cells / 2);
    // Delta of the input, normalised to [0, 1] over the texture.
    let delta_in = colour_distance(input, intact)?;
    let scale = delta_scale(&delta_in);
    let delta_in: Vec<f32> = delta_in.iter().map(|d| (d / scale).min(1.0)).collect();
    // Smoothed edge map of the intact texture: the structure P and Q must share.
    let edges = gaussian_blur(&gradients(intact).magnitude, 1.5);
    // Mean age of every s x s patch (summed-area table).
    let (vw, vh) = (w - s + 1, h - s + 1);
    let patch_age = box_means(age, s);
    let radius = ((params.search * s as f32) as usize).max(1);
    // Feathering of the pasted patch (not in the paper): without it every
    // blend is a hard square and rust grows in visible square steps.
    let window: Vec<f32> = (0..s * s)
        .map(|i| {
            let f = |k: usize| (std::f32::consts::PI * (k as f32 + 0.5) / s as f32).sin();
            (2.0 * f(i % s) * f(i / s)).min(1.0)
        })
        .collect();
    let mut current = input.clone();
    let mut frames = Vec::with_capacity(params.future);
    for k in 1..=params.future {
        let t = 1.0 + params.future_span * k as f32 / params.future as f32;
        let mut g = rng::generator(seed, &[0xf0, k as u64]);
        let mut template = current.clone();
        for _ in 0..steps {
            let (px, py) = (g.gen_range(0..vw), g.gen_range(0..vh));
            // m: the most weathered value of Delta over P.
            let mut m = 0f32;
            for v in 0..s {
                for u in 0..s {
                    let i = (py + v) * w + px + u;
                    let d = pixel_distance(&template.data()[i * n..(i + 1) * n], &intact.data()[i * n..(i + 1) * n]);
                    m = m.max((d / scale).min(1.0));
                }
            }
            let want = (m + params.delta).min(1.0);
            // Q': a random patch among the 16 whose mean age is nearest `want`.
            let qprime = nearest_age(&patch_age, want, 16, &mut g);
            let (qx0, qy0) = (qprime % vw, qprime / vw);
            // Q: around Q', the placement and orientation whose intact
            // structure agrees best with P's.
            let mut best = (f32::INFINITY, qx0, qy0, 0);
            let step = (s / 8).max(1);
            for qy in (qy0.saturating_sub(radius)..=(qy0 + radius).min(vh - 1)).step_by(step) {
                for qx in (qx0.saturating_sub(radius)..=(qx0 + radius).min(vw - 1)).step_by(step) {
                    for o in 0..8 {
                        let mut cost = 0f32;
                        for v in (0..s).step_by(2) {
                            for u in (0..s).step_by(2) {
                                let (du, dv) = orient(o, u, v, s);
                                let d = edges.at(px + u, py + v, 0) - edges.at(qx + du, qy + dv, 0);
                                cost += d * d;
                            }
                            if cost >= best.0 {
                                break;
                            }
                        }
                        if cost < best.0 {
                            best = (cost, qx, qy, o);
                        }
                    }
                }
            }
            let (_, qx, qy, o) = best;
            for v in 0..s {
                for u in 0..s {
                    let (du, dv) = orient(o, u, v, s);
                    let (sx, sy) = (qx + du, qy + dv);
                    let dq = delta_in[sy * w + sx] * window[v * s + u];
                    let src = input.pixel(sx, sy);
                    let dst = template.pixel_mut(px + u, py + v);
                    for c in 0..n {
                        dst[c] = dst[c] * (1.0 - dq) + src[c] * dq;
                    }
                }
            }
        }
        let rebuilt = rebuild(input, &template, None, Engine::Optimize, &params.rebuild, rng::derive(seed, &[0xf1, k as u64]))?;
        current = settle(&rebuilt, &template, &current, intact)?;
        frames.push(Frame { t, image: current.clone() });
        progress(k);
    }
    Ok(frames)
}

/// Mean of a one-channel image over every s x s placement, row-major over
/// (w - s + 1) x (h - s + 1).
fn box_means(img: &Image, s: usize) -> Vec<f32> {
    let (w, h) = img.size();
    let sums = SummedArea::new(w, h, |x, y| img.at(x, y, 0) as f64);
    let (vw, vh) = (w - s + 1, h - s + 1);
    let area = (s * s) as f64;
    (0..vw * vh).map(|i| (sums.sum(i % vw, i / vw, s, s) / area) as f32).collect()
}

/// A random index among the `k` values nearest `want` (ties by index).
fn nearest_age(values: &[f32], want: f32, k: usize, g: &mut impl Rng) -> usize {
    // A strided scan from a random offset: each step looks at a quarter
    // of the placements.
    let stride = 4;
    let mut best: Vec<(f32, usize)> = Vec::with_capacity(k + 1);
    let offset = g.gen_range(0..stride);
    for i in (offset..values.len()).step_by(stride) {
        let d = (values[i] - want).abs();
        if best.len() < k || d < best[best.len() - 1].0 {
            let at = best.partition_point(|e| e.0 <= d);
            best.insert(at, (d, i));
            best.truncate(k);
        }
    }
    best[g.gen_range(0..best.len())].1
}

fn check_sizes(input: &Image, intact: &Image, age: &Image) -> Result<()> {
    if intact.size() != input.size() || age.size() != input.size() {
        return Err(Error::invalid(format!(
            "input ({}x{}), intact texture ({}x{}) and age map ({}x{}) must have one size",
            input.width(),
            input.height(),
            intact.width(),
            intact.height(),
            age.width(),
            age.height()
        )));
    }
    if intact.channels() != input.channels() {
        return Err(Error::invalid("the intact texture and the input have different channel counts"));
    }
    Ok(())
}
