//! "Reconstruct the template from input patches" (Bellini et al. 2016,
//! sections 5-7): every template the method builds (the intact texture, a
//! blend of intact and input for a past frame, a blend towards older
//! material for a future frame, a transfer blend) is a guide; the frame is
//! then made of real patches of an exemplar that follow it, so blends turn
//! into real material instead of ghosted cross-fades.
//!
//! Two engines, both from [`crate::synth`]:
//! - [`Engine::Quilt`]: image-quilting texture transfer (Efros & Freeman),
//!   as the paper does for the intact texture. One FFT per block.
//! - [`Engine::Optimize`]: guided texture optimization (PatchMatch + vote
//!   over two pyramid levels) started from the template itself, as in
//!   Wexler et al.: smoother joins and 2-3x faster at 512 px; the default.
//!
//! The guide compares luminance, colour and gradient direction
//! ([`Features`]), the distance of eq. (1).

use super::features::Features;
use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use crate::synth::{OptimizeParams, QuiltParams, Synthesis};
use serde::{Deserialize, Serialize};

/// Which synthesis rebuilds a template.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Engine {
    Quilt,
    Optimize,
}

/// Settings of one rebuild.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RebuildParams {
    /// Weight of the guide (the template) against the exemplar's own
    /// coherence, per value.
    pub guide_weight: f32,
    /// Quilting block side; `None` = a sixteenth of the smaller side, at least 12.
    pub block: Option<usize>,
    /// Quilting transfer passes (N of Efros & Freeman).
    pub passes: usize,
    /// Texture-optimization patch side.
    pub patch: usize,
}

impl Default for RebuildParams {
    fn default() -> Self {
        RebuildParams { guide_weight: 2.0, block: None, passes: 2, patch: 7 }
    }
}

/// Rebuild `template` (the exemplar's size and channels) from patches of
/// `exemplar`, using only `allowed` exemplar pixels when given.
pub fn rebuild(
    exemplar: &Image,
    template: &Image,
    allowed: Option<&Mask>,
    engine: Engine,
    params: &RebuildParams,
    seed: u64,
) -> Result<Image> {
    rebuild_with(exemplar, template, allowed, None, engine, params, seed)
}

/// [`rebuild`] with a further guide pair (exemplar's, template's) beside
/// the template's features: e.g. where the template's pixels lie relative
/// to the damage's edge, so the rebuild keeps the layout it was given.
pub fn rebuild_with(
    exemplar: &Image,
    template: &Image,
    allowed: Option<&Mask>,
    extra: Option<(&Image, &Image)>,
    engine: Engine,
    params: &RebuildParams,
    seed: u64,
) -> Result<Image> {
    let mut sg = Features::new(exemplar, true)?.stacked();
    let mut tg = Features::new(template, true)?.stacked();
    if let Some((se, te)) = extra {
        sg = Image::concat_channels(&[&sg, se])?;
        tg = Image::concat_channels(&[&tg, te])?;
    }
    let mut problem = Synthesis::new(exemplar).size(template.width(), template.height()).guides(&sg, &tg, params.guide_weight).seed(seed);
    if let Some(m) = allowed {
        problem = problem.source_mask(m);
    }
    match engine {
        Engine::Quilt => {
            let auto = (exemplar.width().min(exemplar.height()) / 16).max(12);
            let mut block = params.block.unwrap_or(auto).min(exemplar.width()).min(exemplar.height());
            // A scattered mask may leave no room for a whole block: shrink it.
            loop {
                let qp = QuiltParams { block: Some((block, block)), transfer_passes: params.passes, ..QuiltParams::default() };
                match problem.quilt(&qp) {
                    Ok(q) => return Ok(q.image),
                    Err(e) if block <= 6 => return Err(e),
                    Err(_) => block = block * 2 / 3,
                }
            }
        }
        Engine::Optimize => {
            // No uniformity penalty: a template may need some material (rust)
            // far more often than the exemplar shows it.
            // Start from the template itself, two pyramid levels: the
            // template already holds the layout, the optimization only
            // swaps its blends for real patches.
            let op = OptimizeParams { patch: params.patch, uniformity: 0.0, levels: Some(2), ..OptimizeParams::default() };
            Ok(problem.start_from(template).optimize(&op)?.image)
        }
    }
}

/// Colour distance between two pixels of the same channel count: over the
/// first three channels, or (grey) channel 0 counted as three, as
/// [`super::features::rgb`] reads it.
#[inline]
pub fn pixel_distance(a: &[f32], b: &[f32]) -> f32 {
    if a.len() >= 3 {
        a[..3].iter().zip(&b[..3]).map(|(x, y)| (x - y) * (x - y)).sum::<f32>().sqrt()
    } else {
        let d = a[0] - b[0];
        (3.0 * d * d).sqrt()
    }
}

/// Per-pixel colour distance between two images (see [`pixel_distance`]).
pub fn colour_distance(a: &Image, b: &Image) -> Result<Vec<f32>> {
    if a.size() != b.size() || a.channels() != b.channels() {
        return Err(Error::invalid("cannot compare images of different sizes or channel counts"));
    }
    let n = a.channels();
    Ok(a.data().chunks_exact(n).zip(b.data().chunks_exact(n)).map(|(p, q)| pixel_distance(p, q)).collect())
}

/// The scale that maps a per-pixel weathering amount Delta to [0, 1]: its
/// 98th percentile rather than its maximum, so a few extreme pixels do not
/// leave all other weathering half transparent (in eq. 2 and eq. 3).
pub fn delta_scale(delta: &[f32]) -> f32 {
    let mut sorted = delta.to_vec();
    sorted.sort_by(f32::total_cmp);
    sorted[((sorted.len() - 1) as f32 * 0.98) as usize].max(1e-6)
}
