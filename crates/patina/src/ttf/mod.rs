//! Time-varying texture synthesis from a time-lapse (Enrique, Koudelka,
//! Belhumeur, Dorsey, Nayar, Ramamoorthi, "Time-varying textures:
//! definition, acquisition and synthesis"): a larger surface that changes
//! the way a small time-lapsed sample did, with no flicker and no event
//! happening in lockstep everywhere.
//!
//! - Cuboid quilting (section 5.1): the engine's image quilting, run once on
//!   a per-pixel description of each pixel's whole time column, so the
//!   overlap error is summed over all frames (eq. 3) and one minimum-error
//!   seam serves every frame; each frame is then rendered from the same
//!   plan, copying whole time columns.
//! - The cuts healed ([`heal`]; not in the paper): texture optimization of
//!   5 x 5 patches of whole time columns around the cut lines, started
//!   from the quilt's correspondence and searching only a few pixels from
//!   it, so a block's straight edge becomes a join of shifted
//!   continuations of the blocks that meet there; one correspondence
//!   serves every frame, so the joins cannot flicker.
//! - SVD-compressed comparison (section 5.2, [`svd`]): that description is
//!   the top-k SVD coefficients of each pixel's time series, weighted by the
//!   singular values; `rank = 0` compares all frames instead.
//! - Elongated blocks (section 5.3): any block width and height.
//! - Time jitter (eqs. 6-7, [`warp`]), each block's warp chosen frame by
//!   frame to stay in step with its neighbours wherever a change crosses
//!   its seam, to change its offset (a held or skipped frame) seldom where
//!   it moves fast, and never to show a frame whose block-scale colour differs
//!   visibly from the output time's (a fast change of the whole surface),
//!   and rate maps (section 6, [`rate`]).
//! - Low-frequency normalisation (section 5.3) by the engine's
//!   lighting-aware synthesis ([`crate::synth::lighting`]): the frames are
//!   divided by the illumination of their temporal mean, the detail is
//!   quilted, and the output is re-lit (flat by default). Automatic when
//!   the input's large-scale variation is high. The same separation takes
//!   out the capture's exposure flicker
//!   ([`crate::synth::lighting::steady_exposure`]), a specular streak
//!   fixed in the frame ([`crate::synth::highlight`]) and the first
//!   frame's light where later frames still show it
//!   ([`crate::synth::start_light`]), which quilting would otherwise paste
//!   with every block.
//! - Material shares kept to the input's ([`FAMILIES`]): a minority
//!   material the reuse penalty would starve is favoured again.
//! - Seams hidden in the gradient domain ([`crate::synth::blend`]), their
//!   brightness steps over whole blocks and their colour steps only near
//!   the seam ([`CHROMA_REACH`]), at key
//!   frames every 8 frames (the first, and every frame of a burst of
//!   change, solved on its own frame), interpolated between, so no seam
//!   flickers.

pub mod rate;
pub mod svd;
pub mod warp;

pub use rate::RateMap;
pub use svd::TemporalBasis;
pub use warp::TimeWarp;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::image::Mask;
use crate::rng;
use crate::synth::highlight::{remove_fixed_highlight, HighlightReport};
use crate::synth::lighting::{relight_sequence, separate_sequence, sequence_luminance, steady_exposure, LightingReport, Relight};
use crate::synth::start_light::{remove_start_light, StartLightReport};
use crate::synth::{Init, OptimizeParams, PatchMetric, Progress, QuiltParams, QuiltPlan, Synthesis};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// How the input's lighting is treated (section 5.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SequenceLighting {
    /// `Flat` when the frames' temporal mean has a large-scale variation
    /// ([`crate::metrics::nonstationarity`]) above [`AUTO_LIGHTING`] and
    /// the input is at least [`AUTO_MIN_SIDE`] on its shorter side, else `Keep`.
    #[default]
    Auto,
    /// Quilt the frames as they are (the lighting is copied block by block).
    Keep,
    /// Divide out the lighting, quilt the detail, light the output evenly.
    Flat,
    /// Divide out the lighting and put it back stretched to the output's size.
    Stretch,
}

/// Large-scale variation of the temporal mean above which `Auto` lighting
/// separates. The procedural stationary textures measure 0.01-0.06, a
/// procedural rust sequence 0.04-0.05 and under a vignette of strength 0.4
/// 0.07-0.11; the four real time-lapses in ../shared/data/timelapse
/// measure 0.10-0.18 (uneven light, a specular streak on copper), and
/// separating them removed the dark-block patchwork the clay showed.
pub const AUTO_LIGHTING: f32 = 0.08;

/// The default overlap is the block over this (the engine's is a sixth):
/// one cut serves every frame, so it needs more room to wander around the
/// features of all of them. On copper_patinating (256 -> 512 px) a sixth
/// left straight 64 px block edges; a third gives irregular cuts, at 10%
/// more time.
const OVERLAP_SHARE: usize = 3;

/// Smallest input side `Auto` lighting separates: the field's low-pass
/// has sigma = 1/8 of the side, so below about 96 px it is the size of the
/// features themselves (rust spots) and takes content for light.
pub const AUTO_MIN_SIDE: usize = 96;

/// The reuse penalty of time-lapse quilting ([`QuiltParams::reuse`]). On a
/// vignetted rust sequence (96 -> 192 px, 4 seeds) the middle frame's
/// near-verbatim repeated share was 0.14-0.31 without it, 0.06-0.07 at 1
/// and 0.07-0.14 at the engine's 1.5. It trades against the frame-to-frame
/// change: without it the quilt reuses calm blocks (0.93-1.13x the input's
/// change); with it the output holds as many events as the input's busiest
/// parts (1.23-1.36x at 1).
pub const REUSE: f32 = 1.0;

/// Rare-feature penalty for time-lapses ([`QuiltParams::rarity`]): off by
/// default. On the vignetted rust sequence of the tests it raised the
/// middle frame's near-verbatim repeated share from 0.07 to 0.11: the
/// rarest time columns there are the spots, and avoiding them fills the
/// output with copies of the calm steel around them.
pub const RARITY: f32 = 0.0;

/// Material-share control for time-lapses ([`QuiltParams::families`]),
/// with the families clustered on the frames' temporal mean colour (the
/// time columns' first channels are one colour's coefficients). The reuse
/// penalty starves a material that fills a small part of the input:
/// copper_patinating's teal patina covers 0.30 of the input's middle frame
/// and 0.40 of its last, and came out at 0.13 and 0.23 (means over seeds
/// 1-6; 0.25 and 0.40 without the penalty, whose repeats it is there for).
/// At 2 they are 0.17 and 0.30 (at 1 0.18 / 0.31, at 4 0.19 / 0.33:
/// the rest of the gap was the seam blend's, see [`CHROMA_REACH`]); the
/// material drift of the middle frame ([`crate::metrics::material_drift`],
/// examples/ttf_quality, seed 1) fell on all four real sequences (copper
/// 0.28 -> 0.24, clay 0.22 -> 0.19, sprouts 0.22 -> 0.15, steel 0.31 ->
/// 0.20).
pub const FAMILIES: f32 = 2.0;

/// Relative overlap costs for time-lapses ([`QuiltParams::relative`]): off
/// by default. With it on, a flickering capture comes out as a patchwork
/// of exposures again: in the tests' flashed rusting sequence frame 5's
/// large-scale variation is 0.0182, against 0.0126 from the steady
/// capture (the bound is 1.3x).
pub const RELATIVE: f32 = 0.0;

/// Every parameter of the method, with the paper's defaults where it has
/// them ([`TtfParams::paper`] turns every addition off).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TtfParams {
    /// k, singular vectors kept for block comparison (section 5.2); 0
    /// compares every frame (slow; for checking).
    pub rank: usize,
    /// When set, k is instead the smallest rank whose relative RMS
    /// reconstruction error is at most this (e.g. 0.05).
    pub max_error: Option<f64>,
    /// Block and overlap sizes (elongated blocks allowed, section 5.3; the
    /// overlap defaults to a third of the block here), candidate tolerance, seams (blended in the gradient domain by default) and the reuse penalty.
    pub quilt: QuiltParams,
    /// E, the most frames a block's time may drift from the output's (eq.
    /// 7); 0 = no jitter; `None` = a twelfth of the frames.
    pub jitter: Option<f32>,
    /// Lighting separation.
    pub lighting: SequenceLighting,
    /// Weight each frame's share of the block cost by the inverse of its
    /// fine-detail contrast (not in the paper; see [`frame_balance`]).
    pub balance: bool,
    /// Make every frame tile: the time columns are quilted round a torus
    /// ([`crate::synth::Synthesis::tileable`]). The seams' gradient-domain
    /// blend does not wrap, so tileable runs keep the cuts; lighting can be
    /// flat or kept, not stretched.
    pub tile: bool,
    /// Heal the cuts in the time columns' own description ([`heal`]):
    /// texture optimization around the quilt's cut lines, started from the
    /// quilt's correspondence, so a block's straight edge becomes a join
    /// of patches that continue both sides in every frame. Not with `tile`
    /// (the heal does not wrap) or a feather (which softens the cuts
    /// instead). Off by default: a blind review of the four real
    /// time-lapses preferred it on rusting_steel (jagged cuts through the
    /// smooth early frames became soft joins), found the others alike or
    /// worse (the vote's haze over sprouts' moving leaves, faint new joins
    /// in copper's first frames), and on the tests' vignetted rust
    /// sequence it raised the near-verbatim share from 0.10-0.13 to
    /// 0.14-0.15 (seeds 3-6): joins completed rust spots that another
    /// block already showed whole.
    pub heal: bool,
}

impl Default for TtfParams {
    fn default() -> Self {
        TtfParams {
            rank: 15,
            max_error: None,
            quilt: QuiltParams {
                feather: 0,
                blend: true,
                reuse: REUSE,
                rarity: RARITY,
                families: FAMILIES,
                relative: RELATIVE,
                ..QuiltParams::default()
            },
            jitter: None,
            lighting: SequenceLighting::Auto,
            balance: true,
            tile: false,
            heal: false,
        }
    }
}

impl TtfParams {
    /// The paper's method alone: hard minimum-error cuts on a regular grid
    /// of blocks, no blending, no reuse penalty, no jitter, no lighting
    /// separation, eq. (3) unweighted.
    pub fn paper() -> Self {
        TtfParams {
            quilt: QuiltParams {
                feather: 0,
                blend: false,
                reuse: 0.0,
                rarity: 0.0,
                families: 0.0,
                stagger: false,
                relative: 0.0,
                ..QuiltParams::default()
            },
            jitter: Some(0.0),
            lighting: SequenceLighting::Keep,
            balance: false,
            ..TtfParams::default()
        }
    }

    /// E in frames for a sequence of `n` frames.
    pub fn jitter_frames(&self, n: usize) -> f32 {
        self.jitter.unwrap_or(n.saturating_sub(1) as f32 / 12.0)
    }
}

/// What the SVD kept.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Compression {
    pub rank: usize,
    /// ||A - A_k||_F / ||A||_F of the matrix the blocks were compared on:
    /// the frames as given, or flattened and balanced when those are on.
    pub relative_rms: f64,
    /// All singular values, largest first.
    pub singular_values: Vec<f64>,
}

/// The result of [`synthesize`].
#[derive(Clone, Debug)]
pub struct Ttf {
    /// The output frames (as many as the input, or as the rate map sets;
    /// those of the chunk asked for, see [`synthesize_chunk`]).
    pub frames: Vec<Image>,
    /// The index of `frames[0]` in the whole output (0 unless chunked).
    pub first_frame: usize,
    /// Blocks and seams, shared by every frame.
    pub plan: QuiltPlan,
    /// Each block's time warp (identity without jitter), in plan order.
    pub warps: Vec<TimeWarp>,
    /// The lighting separation, when one was made.
    pub lighting: Option<LightingReport>,
    /// The highlight fixed in the input's frame that the lighting
    /// separation took out ([`crate::synth::highlight`]), when it found one;
    /// it is not put back, whatever the re-lighting.
    pub highlight: Option<HighlightReport>,
    /// The largest exposure correction the lighting separation made to a
    /// frame ([`crate::synth::lighting::steady_exposure`]), as |gain - 1|;
    /// 0 without a separation.
    pub exposure_flicker: f32,
    /// The first frame's light the lighting separation took out
    /// ([`crate::synth::start_light`]); `None` without a separation.
    pub start_light: Option<StartLightReport>,
    /// `None` when every frame was compared (`rank = 0`).
    pub compression: Option<Compression>,
}

/// Synthesize a `width` x `height` time-varying texture from `frames`.
/// With a `rate` map (the output's size), each pixel runs at its own speed.
pub fn synthesize(
    frames: &[Image],
    size: (usize, usize),
    params: &TtfParams,
    rate: Option<&RateMap>,
    seed: u64,
    progress: Option<Progress>,
) -> Result<Ttf> {
    synthesize_chunk(frames, size, params, rate, seed, None, progress)
}

/// The number of output frames [`synthesize`] makes from `frames`.
pub fn output_frames(frames: &[Image], size: (usize, usize), params: &TtfParams, rate: Option<&RateMap>) -> Result<usize> {
    Ok(check_input(frames, size, params, rate)?.1)
}

/// [`synthesize`], making only the output frames in `chunk` (all when
/// `None`). The layout, time warps and seam corrections are the whole
/// run's, so chunks rendered separately (on different machines) are
/// byte-identical to the same frames of one whole run and join without
/// overlap or blending. Each chunk repeats the layout search (the SVD and
/// the quilt); it saves the rendering, the seam solves of other chunks'
/// key frames, the encoding and the memory of the other frames.
pub fn synthesize_chunk(
    frames: &[Image],
    (width, height): (usize, usize),
    params: &TtfParams,
    rate: Option<&RateMap>,
    seed: u64,
    chunk: Option<Range<usize>>,
    progress: Option<Progress>,
) -> Result<Ttf> {
    let (n, out_frames) = check_input(frames, (width, height), params, rate)?;
    let chunk = chunk.unwrap_or(0..out_frames);
    if chunk.is_empty() || chunk.end > out_frames {
        return Err(Error::invalid(format!("frames {}..{} are not a part of the output's {out_frames} frames", chunk.start, chunk.end)));
    }
    let report = |done: u64| {
        if let Some(p) = progress {
            p(done, 100);
        }
    };
    // The input's large-scale variation, measured once: `Auto` decides on
    // it and the lighting report states it.
    let variation = match params.lighting {
        SequenceLighting::Keep => None,
        _ => Some(input_nonstationarity(frames)?),
    };
    let relight = match params.lighting {
        SequenceLighting::Keep => Relight::Keep,
        SequenceLighting::Flat => Relight::Flat,
        SequenceLighting::Stretch => Relight::Stretch,
        SequenceLighting::Auto
            if frames[0].width().min(frames[0].height()) >= AUTO_MIN_SIDE && variation.is_some_and(|v| v > AUTO_LIGHTING) =>
        {
            Relight::Flat
        }
        SequenceLighting::Auto => Relight::Keep,
    };
    if params.tile {
        relight.check_tileable("time-lapse", "input's")?;
    }
    let mut separated = if matches!(relight, Relight::Keep) { None } else { Some(separate_sequence(frames)?) };
    // A highlight fixed in the frame (a specular streak) is lighting too:
    // it comes out of the detail that is quilted, or every block holding a
    // piece of it pastes another streak.
    let highlight = separated.as_mut().and_then(|(_, detail)| remove_fixed_highlight(detail));
    // So is the capture's exposure flicker: time jitter would show blocks
    // of differently exposed frames side by side.
    let exposure_flicker = separated.as_mut().map_or(0.0, |(_, detail)| steady_exposure(detail));
    // And the light of the first frame, which the surface's change covers
    // (a polished plate's reflections): quilted, it is a patchwork of
    // bright and dark blocks over the first frames.
    let start_light = separated.as_mut().and_then(|(_, detail)| remove_start_light(detail));
    let frames = separated.as_ref().map_or(frames, |(_, detail)| detail.as_slice());
    let weights = if params.balance { frame_balance(frames) } else { vec![1.0; n] };
    let (features, compression) = if params.rank == 0 && params.max_error.is_none() {
        (stack(frames, &weights)?, None)
    } else {
        let basis = TemporalBasis::weighted(frames, &weights)?;
        let rank = params.max_error.map_or(params.rank.min(n), |e| basis.rank_for(e));
        let c = Compression { rank, relative_rms: basis.relative_rms(rank), singular_values: basis.singular_values.clone() };
        (basis.coefficients(frames, rank)?, Some(c))
    };
    report(10);
    // Eq. (3): the cost sums squared differences over every frame; dividing
    // by n only sets its scale.
    let metric = PatchMetric::ssd(vec![1.0 / n as f32; features.channels()]);
    let quilt_progress = |d: u64, t: u64| report(10 + 50 * d / t.max(1));
    let mut quilt = params.quilt.clone();
    if quilt.overlap.is_none() {
        let ((bw, bh), _) = quilt.resolve(features.width(), features.height())?;
        quilt.overlap = Some(((bw / OVERLAP_SHARE).max(2), (bh / OVERLAP_SHARE).max(2)));
    }
    // The families are clustered only when the share control is on.
    let materials = if params.quilt.families > 0.0 { Some(crate::image::sequence::temporal_mean(frames)?) } else { None };
    let mut synthesis = Synthesis::new(&features);
    if let Some(m) = &materials {
        synthesis = synthesis.materials(m);
    }
    let quilted = synthesis
        .size(width, height)
        .metric(metric.clone())
        .seed(rng::derive(seed, &[1]))
        .progress(&quilt_progress)
        .tileable(params.tile)
        .quilt(&quilt)?;
    let plan = quilted.plan;
    report(60);
    // Output pixel -> the source pixel its time column comes from, and the
    // pixels rendered as the vote of the patches around them.
    let layout = plan.source_positions();
    let healed = if params.heal && !params.tile && params.quilt.feather == 0 {
        Some(heal(&features, &layout, (width, height), &metric, rng::derive(seed, &[3]))?)
    } else {
        None
    };
    drop(features);
    let (field, band) = match &healed {
        Some((field, band)) => (field.as_slice(), Some(band)),
        None => (layout.as_slice(), None),
    };
    // The block each pixel's time comes from, for rendering a healed field.
    let labels = if healed.is_some() { plan.labels() } else { Vec::new() };
    // Each frame's change to the next: it sets the jitter's clock and
    // which frames are bursts.
    let changes = frame_changes(frames);
    let warps = warp::seam_aligned(&plan, frames, params.jitter_frames(n), &clock(&changes), rng::derive(seed, &[2]));
    let channels = frames[0].channels();
    // A jittered time between two frames is rounded to the nearer:
    // cross-fading them ghosts anything that moves (sprouts showed double
    // exposures). A rate map's slow pixels do blend, as holding frames
    // there would stutter.
    let time = |warp: &TimeWarp, t: usize, (x, y): (usize, usize)| match rate {
        Some(r) => warp.at(t as f32 * r.rate(x, y)),
        None => warp.at(t as f32).round(),
    };
    let render = |t: usize| {
        if healed.is_none() {
            // The plan's own blocks (feathered when asked).
            return plan.render_with(channels, |i, (sx, sy), o, px| sample(frames, sx, sy, time(&warps[i], t, o), px));
        }
        let mut img = Image::new(width, height, channels);
        img.data_mut().par_chunks_mut(width * channels).enumerate().for_each(|(y, row)| {
            let mut value = vec![0f32; channels];
            for (x, out) in row.chunks_exact_mut(channels).enumerate() {
                let tau = time(&warps[labels[y * width + x] as usize], t, (x, y));
                if !band.is_some_and(|b| b.get(x, y)) {
                    let (sx, sy) = field[y * width + x];
                    sample(frames, sx as usize, sy as usize, tau, out);
                    continue;
                }
                // The vote (eq. 2 of Kwatra et al. 2005) of the healed
                // patches covering the pixel, all at the pixel's own time.
                out.iter_mut().for_each(|o| *o = 0.0);
                let mut count = 0f32;
                for qy in y.saturating_sub(HEAL_RADIUS)..(y + HEAL_RADIUS + 1).min(height) {
                    for qx in x.saturating_sub(HEAL_RADIUS)..(x + HEAL_RADIUS + 1).min(width) {
                        let (mx, my) = field[qy * width + qx];
                        let (sx, sy) = ((mx as usize + x).wrapping_sub(qx), (my as usize + y).wrapping_sub(qy));
                        sample(frames, sx, sy, tau, &mut value);
                        out.iter_mut().zip(&value).for_each(|(o, v)| *o += v);
                        count += 1.0;
                    }
                }
                out.iter_mut().for_each(|o| *o /= count);
            }
        });
        img
    };
    // Seams are hidden in the gradient domain at key frames, each solved
    // on the mean of the frames around it (the blend is linear in the
    // composite and the source, so this is the mean of their corrections)
    // against the input frames of the same times, and every frame adds the
    // correction interpolated between its two keys. Blending each frame on
    // its own lets a spot growing across a seam send a glow around it that
    // changes every frame (on a vignetted rust sequence, 1.7-2.0x the
    // input's frame-to-frame change, against 1.2-1.3x unblended). Keys are
    // KEY_STEP frames apart. The first key is solved on frame 0 alone: its
    // one-sided window gave frame 0 the seams of frames 0-8, a jigsaw of
    // tone steps on copper_patinating and rusting_steel, whose first frames
    // change fast (tone steps along the cuts 1.5x the blocks' insides,
    // now 0.9-0.95x). The same holds for any burst of change (a frame
    // that changes from or to its neighbour more than BURST times the
    // sequence's mean change): copper_patinating's frames 1-3, where
    // salt crust covers half the plate in two frames, showed the keys'
    // interpolated seams as a jigsaw of dark and pink blocks, so burst
    // frames are keys solved on their own frame. Tried and not kept: keys
    // spaced by the input's pace (no visible gain once blocks keep in
    // step, more flicker on the vignetted test), and the last key on its
    // own frame too (1.6-1.78x the input's frame-to-frame change there,
    // against 1.4-1.6x). Simplification: a jittered or rate-warped block
    // is continued across its seam with that frame's gradients, not its
    // own warped time's; these differ only slightly, and the brightness
    // steps are what the blend removes.
    let corrections: Vec<(usize, Vec<f32>)> = if params.quilt.blend && params.quilt.boundary_cut && !params.tile {
        // Frames of a burst are keys of their own (below); not under a
        // rate map, whose output frames are not the input's times.
        let bursts = if rate.is_none() { burst_frames(&changes) } else { Vec::new() };
        let mut keys: Vec<usize> = (0..out_frames).filter(|&t| t % KEY_STEP == 0 || bursts.contains(&t)).collect();
        if keys.last() != Some(&(out_frames - 1)) {
            keys.push(out_frames - 1);
        }
        // The keys the chunk's frames interpolate between.
        let first = keys.iter().position(|&k| k >= chunk.start).unwrap_or(0).saturating_sub(1);
        let last = keys.iter().position(|&k| k + 1 >= chunk.end).unwrap_or(keys.len() - 1);
        keys[first..=last]
            .to_vec()
            .into_par_iter()
            .map(|t| {
                // The first key's and a burst's own frame only (see above).
                let window =
                    if t == 0 || bursts.contains(&t) { t..t + 1 } else { t.saturating_sub(KEY_STEP)..(t + KEY_STEP + 1).min(out_frames) };
                let k = 1.0 / window.len() as f32;
                let mut mean = Image::new(width, height, frames[0].channels());
                let mut src = Image::new(frames[0].width(), frames[0].height(), frames[0].channels());
                for u in window {
                    mean.data_mut().iter_mut().zip(render(u).data()).for_each(|(m, v)| *m += k * v);
                    src.data_mut().iter_mut().zip(frames[u.min(n - 1)].data()).for_each(|(m, v)| *m += k * v);
                }
                let blended = crate::synth::blend::blend_seams_keeping_chroma(&mean, &src, field, band, Some(SEAM_OUTLIER), CHROMA_REACH);
                let sigma = DRIFT_BLOCKS * plan.block.0.max(plan.block.1) as f32;
                let blended = crate::synth::blend::without_drift(&blended, &mean, sigma);
                (t, blended.data().iter().zip(mean.data()).map(|(b, a)| b - a).collect())
            })
            .collect()
    } else {
        Vec::new()
    };
    report(70);
    let done = std::sync::atomic::AtomicU64::new(0);
    let count = chunk.len();
    let mut out: Vec<Image> = chunk
        .clone()
        .into_par_iter()
        .map(|t| {
            let mut img = render(t);
            if let Some(k) = corrections.iter().position(|(key, _)| *key >= t) {
                let (t1, c1) = &corrections[k];
                let (t0, c0) = &corrections[k.saturating_sub(1)];
                let w = if t1 > t0 { (t - t0) as f32 / (t1 - t0) as f32 } else { 1.0 };
                img.data_mut().iter_mut().zip(c0.iter().zip(c1)).for_each(|(v, (a, b))| *v += a + w * (b - a));
            }
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            report(70 + 30 * d / count as u64);
            img
        })
        .collect();
    let lighting = match &separated {
        Some((sep, detail)) => {
            // Lit at the detail frames' mean brightness (the whole input's,
            // so every chunk gets the same gain).
            relight_sequence(&mut out, sep, relight, || sequence_luminance(detail))?;
            Some(LightingReport {
                relight: relight.name(),
                exemplar_nonstationarity: variation.unwrap_or_default(),
                detail_nonstationarity: input_nonstationarity(detail)?,
                sigma: sep.sigma,
            })
        }
        None => None,
    };
    Ok(Ttf { frames: out, first_frame: chunk.start, plan, warps, compression, lighting, highlight, exposure_flicker, start_light })
}

/// Patch radius of [`heal`] (5 x 5 patches, EbSynth's). 7 x 7 patches
/// scored the healed joins slightly better (examples/ttf_quality's seam
/// figure) at 1.6x the time of the whole synthesis; 3 x 3 left more
/// repeats on the tests' rusting sequence.
const HEAL_RADIUS: usize = 2;

/// How far (px) [`heal`]'s random search looks from each pixel's current
/// match ([`OptimizeParams::search_radius`]): the joins are re-made from
/// shifted continuations of the blocks that meet there, not from patches
/// anywhere in the input (which pasted new copies of features the rest of
/// the output already shows).
const HEAL_REACH: usize = 4;

/// Heal the cuts of a time-column quilt: texture optimization on the time
/// columns' description `features` (the SVD coefficients of eq. 3's
/// comparison), started from the quilt's correspondence `layout` and
/// searching around its cut lines ([`Synthesis::heal_layout`], the
/// engine's quilt-then-optimize). One correspondence serves every frame,
/// so the healed joins cannot flicker, and the blocks' interiors stay
/// verbatim time columns with their events' timing. Returns the healed
/// correspondence and the pixels to render as a vote: those whose
/// (2 [`HEAL_RADIUS`] + 1)² window is not one coherent copy (elsewhere
/// the vote equals the copy).
fn heal(
    features: &Image,
    layout: &[(u32, u32)],
    (w, h): (usize, usize),
    metric: &PatchMetric,
    seed: u64,
) -> Result<(Vec<(u32, u32)>, Mask)> {
    let params =
        OptimizeParams { patch: 2 * HEAL_RADIUS + 1, init: Init::QuiltSeams, search_radius: Some(HEAL_REACH), ..OptimizeParams::default() };
    let healed = Synthesis::new(features).size(w, h).metric(metric.clone()).seed(seed).heal_layout(layout).optimize(&params)?;
    let field: Vec<(u32, u32)> = healed.nnf.matches().iter().map(|m| (m.x, m.y)).collect();
    let offset = |i: usize| (field[i].0 as i64 - (i % w) as i64, field[i].1 as i64 - (i / w) as i64);
    let joins = Mask::from_fn(w, h, |x, y| {
        let i = y * w + x;
        (x + 1 < w && offset(i + 1) != offset(i)) || (y + 1 < h && offset(i + w) != offset(i))
    });
    Ok((field, joins.dilate(HEAL_RADIUS + 1)))
}

/// Seam mismatches are clamped to this many median absolute deviations
/// around their seam's median before blending
/// ([`crate::synth::blend::blend_seams`]), so spots growing across a seam
/// send no changing glow around them while whole-seam tone steps are hidden.
const SEAM_OUTLIER: f32 = 3.0;

/// Chroma steps at the seams are blended within about this many pixels
/// ([`crate::synth::blend::blend_seams_keeping_chroma`]); brightness steps
/// over whole blocks. Blended like brightness, a teal patina block's
/// colour step to its brown neighbours was spread over it: the teal cover
/// of copper_patinating's middle frame was 0.17 (seeds 1-6), 0.23 with
/// plain cuts, and is 0.22 with this (0.21 at 16 px), its frame 25 0.032
/// -> 0.063 (the input's 0.116), with no block outlines. The vignetted rust
/// sequence's near-verbatim share (examples/ttf_quality, seeds 1-4) rose
/// from 0.104 to 0.119: copies of one block no longer differ in tint.
const CHROMA_REACH: f32 = 6.0;

/// The seam corrections lose their large-scale part, above a Gaussian of
/// this many blocks ([`crate::synth::blend::without_drift`]). On
/// growing_sprouts (2x, seed 1) the blend made a ramp: the left quarter of
/// frames 40-66 came out 1.42-1.55x as bright as the right (the input's is
/// 0.75-0.84x, the output cut without blending 1.02-1.15x); now
/// 1.08-1.22x. At 1 block the ramp went entirely, but the vignetted test
/// sequence's near-verbatim share rose to 0.114 (0.081 at 1.5; the test's
/// bound is 0.08): the blend's slow tone offsets had been telling copies
/// of one block apart.
const DRIFT_BLOCKS: f32 = 2.0;

/// A frame whose change from or to its neighbour is more than this many
/// times the sequence's mean change is a burst: its seams are blended on
/// its own ([`synthesize`]). copper_patinating's frames 0-3 are bursts
/// (changes 2.6-5.2x the mean), rusting_steel's fast last rust growth
/// (frames 83-96) too, growing_sprouts' jerks only at 42-43 and 58-59.
/// At 2 the vignetted rust test's frame-to-frame change rose to 1.68x the
/// input's (bound 1.6x): each frame blended on its own lets the glow
/// around spots growing across a seam move.
const BURST: f64 = 2.5;

/// The frames in a burst of change (see [`BURST`]), from each frame's
/// change to the next ([`frame_changes`]).
fn burst_frames(change: &[f64]) -> Vec<usize> {
    let mean = change.iter().sum::<f64>() / change.len().max(1) as f64;
    (0..change.len() + 1)
        .filter(|&t| {
            let before = t.checked_sub(1).map_or(0.0, |u| change[u]);
            let after = change.get(t).copied().unwrap_or(0.0);
            mean > 0.0 && before.max(after) > BURST * mean
        })
        .collect()
}

/// Frames between the key frames seams are blended at, and on either side
/// of a key whose mean it is blended on ([`synthesize`]).
const KEY_STEP: usize = 8;

/// The input's pace for time jitter: each frame's time on a clock that
/// runs one unit per frame while the sequence changes at its average pace
/// or slower, and faster while it changes faster: r^2 units for a frame
/// whose change to the next is r > 1 times the mean change per frame. Each
/// block's random warp (eqs. 6-7) is drawn on this clock, so it drifts
/// less where the whole surface changes at once (copper turning green in
/// three frames); [`warp::seam_aligned`] then also keeps every block to
/// the offsets that keep its colour there. With that colour band, the
/// square and a linear clock (r units) give block-scale colour differences
/// from the jitter-free output within 0.3 points (of 0-5%) of each other
/// on copper_patinating and rusting_steel.
pub fn pace(frames: &[Image]) -> Vec<f32> {
    clock(&frame_changes(frames))
}

/// [`pace`]'s clock from each frame's change to the next.
fn clock(change: &[f64]) -> Vec<f32> {
    let mean = (change.iter().sum::<f64>() / change.len().max(1) as f64).max(1e-12);
    let mut clock = vec![0f32; change.len() + 1];
    for t in 1..clock.len() {
        clock[t] = clock[t - 1] + (change[t - 1] / mean).max(1.0).powi(2) as f32;
    }
    clock
}

/// Mean absolute change of each frame to the next.
fn frame_changes(frames: &[Image]) -> Vec<f64> {
    frames
        .par_windows(2)
        .map(|w| w[0].data().iter().zip(w[1].data()).map(|(a, b)| f64::from((a - b).abs())).sum::<f64>() / w[0].data().len().max(1) as f64)
        .collect()
}

/// Validate the inputs; the input and output frame counts.
fn check_input(frames: &[Image], (width, height): (usize, usize), params: &TtfParams, rate: Option<&RateMap>) -> Result<(usize, usize)> {
    let first = frames.first().ok_or_else(|| Error::invalid("the sequence has no frames"))?;
    if frames.iter().any(|f| f.size() != first.size() || f.channels() != first.channels()) {
        return Err(Error::invalid("the frames of a sequence must share one size and channel count"));
    }
    if params.jitter.is_some_and(|j| !j.is_finite() || j < 0.0) {
        return Err(Error::invalid(format!("the time jitter must be a finite number >= 0, got {}", params.jitter.unwrap_or(0.0))));
    }
    if params.max_error.is_some_and(|e| !(0.0..1.0).contains(&e)) {
        return Err(Error::invalid("the SVD error target must be in [0, 1)"));
    }
    if let Some(r) = rate {
        if r.image().size() != (width, height) {
            let (rw, rh) = r.image().size();
            return Err(Error::invalid(format!("the rate map is {rw}x{rh} but the output is {width}x{height}")));
        }
    }
    let n = frames.len();
    let out_frames = rate.map_or(Ok(n), |r| r.output_frames(n))?;
    let c = first.channels() as u128;
    let bytes = 4 * c * ((out_frames as u128) * (width * height) as u128 + 2 * (n * first.width() * first.height()) as u128);
    crate::image::budget::check(|| format!("{out_frames} frames of {width}x{height}"), bytes)?;
    let k = if params.rank == 0 || params.max_error.is_some() { n } else { params.rank.min(n) };
    crate::image::budget::check_working_set("time-lapse quilting", width, height, first.channels() * k)?;
    Ok((n, out_frames))
}

/// Large-scale variation ([`crate::metrics::nonstationarity`]) of the
/// frames' temporal mean: the lighting every frame shares.
pub fn input_nonstationarity(frames: &[Image]) -> Result<f32> {
    Ok(crate::metrics::nonstationarity(&crate::image::sequence::temporal_mean(frames)?))
}

/// Per-frame weights that give every frame the same say in the block cost.
///
/// Eq. (3) sums squared differences over frames as they are, so a
/// high-contrast late frame (dark rust on bright steel) outweighs the smooth
/// early frames, and seams get cut where only the late frames match: the
/// early frames then show a patchwork of blocks. A seam is as visible as its
/// step is large against the texture's own detail, so each frame is weighted
/// by 1 / (its RMS fine detail: the difference from a 2 px Gaussian blur),
/// normalised to a mean square of 1.
pub fn frame_balance(frames: &[Image]) -> Vec<f64> {
    let detail: Vec<f64> = frames
        .par_iter()
        .map(|f| {
            let blur = crate::image::filter::gaussian_blur(f, 2.0);
            let ss: f64 = f.data().iter().zip(blur.data()).map(|(a, b)| f64::from(a - b).powi(2)).sum();
            (ss / f.data().len() as f64).sqrt()
        })
        .collect();
    let floor = detail.iter().copied().fold(0.0f64, f64::max) * 1e-3 + 1e-9;
    let w: Vec<f64> = detail.iter().map(|d| 1.0 / d.max(floor)).collect();
    let norm = (w.iter().map(|v| v * v).sum::<f64>() / w.len() as f64).sqrt();
    w.iter().map(|v| v / norm).collect()
}

/// All frames, scaled by `weights`, stacked as channels (channel c * n + f
/// = frame f, channel c): the uncompressed description of each pixel's
/// time column, which `rank = 0` quilts on.
pub fn stack(frames: &[Image], weights: &[f64]) -> Result<Image> {
    let (w, h, c, n) = (frames[0].width(), frames[0].height(), frames[0].channels(), frames.len());
    let data = (0..w * h)
        .flat_map(|p| (0..c).flat_map(move |ch| frames.iter().zip(weights).map(move |(f, wt)| f.data()[p * c + ch] * *wt as f32)))
        .collect();
    Image::from_data(w, h, c * n, data)
}

/// Pixel (x, y) at source time `tau`, blending the two nearest frames.
fn sample(frames: &[Image], x: usize, y: usize, tau: f32, out: &mut [f32]) {
    let last = frames.len() - 1;
    let tau = tau.clamp(0.0, last as f32);
    let i = (tau as usize).min(last);
    let w = tau - i as f32;
    let a = frames[i].pixel(x, y);
    if w <= 0.0 || i == last {
        out.copy_from_slice(a);
        return;
    }
    let b = frames[i + 1].pixel(x, y);
    for ((o, p), q) in out.iter_mut().zip(a).zip(b) {
        *o = p + w * (q - p);
    }
}
