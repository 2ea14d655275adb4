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
//!   plan, copying whole time columns ([`crate::synth::QuiltPlan::render_with`]).
//! - SVD-compressed comparison (section 5.2, [`svd`]): that description is
//!   the top-k SVD coefficients of each pixel's time series, weighted by the
//!   singular values; `rank = 0` compares all frames instead.
//! - Elongated blocks (section 5.3): any block width and height.
//! - Time jitter (eqs. 6-7, [`warp`]) and rate maps (section 6, [`rate`]).
//! - Low-frequency normalisation (section 5.3, [`flatten`]).

pub mod flatten;
pub mod rate;
pub mod svd;
pub mod warp;

pub use rate::RateMap;
pub use svd::TemporalBasis;
pub use warp::TimeWarp;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::rng;
use crate::synth::{PatchMetric, Progress, QuiltParams, QuiltPlan, Synthesis};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Every parameter of the method, with the paper's defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TtfParams {
    /// k, singular vectors kept for block comparison (section 5.2); 0
    /// compares every frame (slow; for checking).
    pub rank: usize,
    /// When set, k is instead the smallest rank whose relative RMS
    /// reconstruction error is at most this (e.g. 0.05).
    pub max_error: Option<f64>,
    /// Block and overlap sizes (elongated blocks allowed, section 5.3),
    /// candidate tolerance and seams (feathered over 2 px by default).
    pub quilt: QuiltParams,
    /// E, the most frames a block's time may drift from the output's (eq. 7); 0 = no jitter.
    pub jitter: f32,
    /// Divide the sequence by its low-frequency lighting before synthesis (section 5.3).
    pub flatten: bool,
    /// With `flatten`: multiply the lighting back into the result.
    pub keep_gradient: bool,
    /// Low-pass sigma for `flatten`, as a fraction of the larger side.
    pub flatten_sigma: f32,
    /// Weight each frame's share of the block cost by the inverse of its
    /// fine-detail contrast (not in the paper; see [`frame_balance`]).
    pub balance: bool,
}

impl Default for TtfParams {
    fn default() -> Self {
        TtfParams {
            rank: 15,
            max_error: None,
            // Per-frame gradient-domain blending is available (quilt.blend)
            // but off: it changes the copied time columns, and its effect
            // on real time-lapses is not yet measured (issue 17).
            quilt: QuiltParams { feather: 2, blend: false, ..QuiltParams::default() },
            jitter: 0.0,
            flatten: false,
            keep_gradient: false,
            flatten_sigma: 0.125,
            balance: true,
        }
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
    /// The output frames (as many as the input, or as the rate map sets).
    pub frames: Vec<Image>,
    /// Blocks and seams, shared by every frame.
    pub plan: QuiltPlan,
    /// Each block's time warp (identity without jitter), in plan order.
    pub warps: Vec<TimeWarp>,
    /// `None` when every frame was compared (`rank = 0`).
    pub compression: Option<Compression>,
}

/// Synthesize a `width` x `height` time-varying texture from `frames`.
/// With a `rate` map (the output's size), each pixel runs at its own speed.
pub fn synthesize(
    frames: &[Image],
    (width, height): (usize, usize),
    params: &TtfParams,
    rate: Option<&RateMap>,
    seed: u64,
    progress: Option<Progress>,
) -> Result<Ttf> {
    let (n, out_frames) = check_input(frames, (width, height), params, rate)?;
    let report = |done: u64| {
        if let Some(p) = progress {
            p(done, 100);
        }
    };
    let lighting = params.flatten.then(|| flatten::Lighting::estimate(frames, params.flatten_sigma));
    let flat = lighting.as_ref().map(|l| l.divide(frames));
    let frames = flat.as_deref().unwrap_or(frames);
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
    let quilted = Synthesis::new(&features)
        .size(width, height)
        .metric(metric)
        .seed(rng::derive(seed, &[1]))
        .progress(&quilt_progress)
        .quilt(&params.quilt)?;
    drop(features);
    let plan = quilted.plan;
    let warps: Vec<TimeWarp> =
        (0..plan.placements.len()).map(|i| TimeWarp::jittered(n, params.jitter, rng::derive(seed, &[2, i as u64]))).collect();
    let done = std::sync::atomic::AtomicU64::new(0);
    // Seams are blended per frame in the gradient domain, against the input
    // frame of the same time (jittered or rate-warped blocks differ from it
    // only slightly in their gradients, and their brightness jumps are what
    // the blend removes).
    let positions = (params.quilt.blend && params.quilt.boundary_cut).then(|| plan.source_positions());
    let mut out: Vec<Image> = (0..out_frames)
        .into_par_iter()
        .map(|t| {
            let img = plan.render_with(frames[0].channels(), |i, (sx, sy), (ox, oy), px| {
                let s = match rate {
                    Some(r) => t as f32 * r.rate(ox, oy),
                    None => t as f32,
                };
                sample(frames, sx, sy, warps[i].at(s), px);
            });
            let img = match &positions {
                Some(p) => crate::synth::blend::blend_seams(&img, &frames[t.min(n - 1)], p),
                None => img,
            };
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            report(60 + 40 * d / out_frames as u64);
            img
        })
        .collect();
    if let (Some(l), true) = (&lighting, params.keep_gradient) {
        l.restore(&mut out)?;
    }
    Ok(Ttf { frames: out, plan, warps, compression })
}

/// Validate the inputs; the input and output frame counts.
fn check_input(frames: &[Image], (width, height): (usize, usize), params: &TtfParams, rate: Option<&RateMap>) -> Result<(usize, usize)> {
    let first = frames.first().ok_or_else(|| Error::invalid("the sequence has no frames"))?;
    if frames.iter().any(|f| f.size() != first.size() || f.channels() != first.channels()) {
        return Err(Error::invalid("the frames of a sequence must share one size and channel count"));
    }
    if !params.jitter.is_finite() || params.jitter < 0.0 {
        return Err(Error::invalid(format!("the time jitter must be a finite number >= 0, got {}", params.jitter)));
    }
    if params.max_error.is_some_and(|e| !(0.0..1.0).contains(&e)) {
        return Err(Error::invalid("the SVD error target must be in [0, 1)"));
    }
    if !(params.flatten_sigma > 0.0 && params.flatten_sigma.is_finite()) {
        return Err(Error::invalid("the flattening sigma must be positive"));
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
