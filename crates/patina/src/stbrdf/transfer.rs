//! Transfer (Meister et al., section 6.2): carry a material's time
//! behaviour onto a static target texture. The guide is the
//! histogram-equalised luminance of the material's albedo at t0 (source)
//! and of the target (target); the coefficients are synthesized under that
//! guide (by [`super::enlarge::enlarge`], on its fast orthonormal-basis
//! path), then tied to the target so that at t0 the result's albedo equals
//! it exactly, in one of these [`Mode`]s:
//!
//! - [`Mode::Ratio`], eq. 16: a_out = a_in p_tex / p_in(t0). Guard (ours):
//!   the ratio s is clamped to [1/4, 4] (and taken as 1 where
//!   |p_in(t0)| < 1e-3), and what the clamped ratio misses is added to the
//!   constant coefficient: a_out = s a_in + (p_tex - s p_in(t0)) e_0.
//!   Without the clamp a dark source at t0 (bare soil under later snow)
//!   multiplied the target by 15 and blew it out to white.
//! - [`Mode::Offset`] (not in the paper): a_0 += p_tex - p_in(t0), the
//!   change added unscaled.
//! - [`Mode::Auto`] picks ratio for changes small against p_in(t0)
//!   (wetting, dulling) and offset for large ones (a new material covering
//!   the old).
//! - [`Mode::Grow`] (not in the paper): the material arrives on the target
//!   in its own spatial pattern. Ratio and offset move every texel at once,
//!   which on a photo reads as a tint over all of it; in grow mode each
//!   texel takes the material on at its own arrival time A(x), with a
//!   short front: c(x, t) = smoothstep(A - w, A + w, tau), tau = (t - t0)
//!   / (t_D - t0) (t_D = 1, or 0 when t0 > 0.5), w = [`GROW_FRONT`], so
//!   what has arrived stays, and a spot grows as its front passes
//!   instead of fading in whole.
//!   - A texel's progress is the projection of p(x, t) - p(x, t0) on
//!     D(x) = p(x, t_D) - p(x, t0), over |D(x)|^2 (changes in other
//!     directions, bare steel brightening before it rusts or a capture's
//!     drift, do not count); its onset o is when progress passes 0.5, and
//!     its own arrival is o for the full change, later for weaker ones
//!     ([`Timing::arrival`]): cores before rims. The size of its change
//!     is D's component along the material's mean change (a texel that
//!     changes against it, a glint brightening, has none).
//!   - The target's guided synthesis starts from a coarse quilt
//!     ([`TransferParams::optimize`]).
//!   - The source's pace ([`Pace`]): the result's texels are chosen and
//!     timed by rank so that the share covered at each time is the
//!     source's ([`paced`]), or, by default, grows evenly to the source's
//!     final share ([`Tempo`]). Rank goes by the result's own strength and
//!     arrival, brought forward by the target's exposure ([`exposure`]:
//!     crevices, chips and bolt shadows darker than their surroundings,
//!     and the object's rim), so rust takes hold there first.
//!   - out(x, t) = target(x) + c(x, t) o(x) (S(x) p'(x, t_D) - target(x)):
//!     what the material becomes there (rust, not the bare steel it was
//!     before it rusted), its own end state p(x, t_D), over the target
//!     with the opacity o(x) of the share of a spot the texel holds, rims
//!     taking the material's hue and the darkest lifted ([`end_state`]);
//!     S is the target's luminance over its median
//!     (its shading, so the arriving material is lit like the object), at
//!     the scale of its form ([`SHADING_SIGMA`]) and limited ([`SHADING_RANGE`]).
//!   - The arrivals are dithered by fine noise ([`dither`]), so a passing
//!     front is a grain, not a translucent blur.
//!   - With a mask, wet places (the object's bottom and rims) take more
//!     of the material ([`WET_CHOICE`]) and are reached first
//!     ([`WET_LEAD`]), so the rust climbs the object and gathers low.
//!   - The material gathers in patches ([`clusters`]: a noise field, as
//!     decay's degree maps are), which take it first and most, and with a
//!     mask covers only part of the source's share
//!     ([`TransferParams::coverage`]), so it does not lie at the capture's
//!     density over the whole object.
//!   - [`TransferParams::scale`] draws the material's features larger or
//!     smaller on the target ([`Material::scaled`]); by default, on an
//!     object, so that the object spans [`OBJECT_SPANS`] of the material's
//!     sides ([`TransferParams::auto_scale`]).
//!   - What has arrived glazes the target around it and runs down below
//!     it in streaks ([`stain`], [`TransferParams::halo`] and
//!     [`TransferParams::runoff`]), and stands proud of it: its upper edge
//!     lit and the surface just below it shadowed ([`lips`]).
//!   - The synthesis is guided, given a mask, by the material's density of
//!     change against where water stands on the object ([`density_guides`]),
//!     lightly, and without one runs unguided
//!     ([`TransferParams::guide_weight`]); it keeps the source's own
//!     coefficients inside coherent copies ([`EnlargeParams::verbatim`]),
//!     so the spots keep the material's shapes and inner texture.
//!   - The result is refitted per texel by least squares, with the
//!     polynomial pinned to the target at t0 ([`Fitter::anchored`]), at
//!     degree 6 at least ([`GROW_DEGREE`]); the front's width w is what a
//!     degree-6 polynomial follows without ringing.
//!
//! With a mask, only the object changes: the result is blended with the
//! target by the mask's value, and texels outside it hold the target as a
//! constant polynomial (bit-identical at every t).

use super::enlarge::{enlarge, EnlargeParams};
use super::material::{Encoding, Material};
use super::poly::{evaluate, Fitter};
use crate::error::{Error, Result};
use crate::image::color::{linear_to_srgb, luminance, pixel_luminance, srgb_to_linear};
use crate::image::filter::{equalize, gaussian_blur};
use crate::image::order::median;
use crate::image::stain::Transition;
use crate::image::{Image, Mask};
use crate::synth::{Init, OptimizeParams, Progress};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Smallest |p_in(t0)| divided by.
const RATIO_FLOOR: f32 = 1e-3;
/// Largest scale (and smallest, inverted) eq. 16 may apply.
const RATIO_LIMIT: f32 = 4.0;
/// [`Mode::Auto`] picks offset when the median texel's largest change is at
/// least this share of its value at t0.
const AUTO_OFFSET_CHANGE: f32 = 0.5;
/// The quantile of the whole change over the object that counts as the
/// material's full change ([`Timing::top`]).
const GROW_TOP: f32 = 0.9;
/// Smallest degree of [`Mode::Grow`]'s result: a cubic cannot follow a
/// texel's cover switching on, and rang (a spot darkening, lightening,
/// then darkening again).
const GROW_DEGREE: usize = 6;
/// Limits of the target's shading that [`Mode::Grow`] lights the arriving
/// material with: its luminance, blurred at [`SHADING_SIGMA`], over its
/// median. Unblurred, the ratio turned rust in crevices near-black and let
/// the paint's gloss and grain show through; its square root left the
/// material flat against the object's light (review).
const SHADING_RANGE: (f32, f32) = (0.5, 1.6);

/// How the target's albedo is tied to the material's at t0 (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Ratio or offset, from the size of the material's change.
    Auto,
    /// Eq. 16: coefficients scaled by p_tex / p_in(t0), clamped.
    Ratio,
    /// a_0 += p_tex - p_in(t0).
    Offset,
    /// The material covers the target texel by texel as its change arrives.
    #[default]
    Grow,
}

/// Parameters of [`transfer`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TransferParams {
    /// The time at which the result equals the target.
    pub t0: f32,
    /// Weight of the guides (0 = unguided; `None` = the mode's default,
    /// [`TransferParams::weight`]). Ratio and offset compare the material's
    /// equalised luminance at t0 with the target's (weight 2). Grow, given a
    /// mask, compares the material's density of change with where water
    /// stands on the object ([`density_guides`], weight
    /// [`GROW_GUIDE_WEIGHT`]), and without one runs unguided: the
    /// luminance guide matched bare, even steel to the target's light and
    /// shade and forced the synthesis onto a few smooth patches, so spots
    /// came out flat, blotchy and too few (review).
    pub guide_weight: Option<f32>,
    pub mode: Mode,
    /// [`Mode::Grow`]: width (sigma, px) of the glaze the material bleeds
    /// into the target around what has arrived ([`stain`]); 0 for none.
    pub halo: f32,
    /// [`Mode::Grow`]: how far (px) the glaze runs down the image below
    /// what has arrived, in streaks; 0 for none.
    pub runoff: f32,
    /// [`Mode::Grow`]: how the covered share grows over time.
    pub tempo: Tempo,
    /// [`Mode::Grow`]: how strongly the material gathers in patches over
    /// the object ([`clusters`]); 0 spreads it evenly (but for where water
    /// stands and the target's chips).
    pub clustering: f32,
    /// The material's size on the target: 0.5 draws its features at half
    /// their captured size ([`Material::scaled`]); `None`:
    /// [`TransferParams::auto_scale`].
    pub scale: Option<f32>,
    /// [`Mode::Grow`]: the share of the source's final visible material
    /// the target takes on, in (0, 1]; `None`: [`MASKED_COVERAGE`] with a
    /// mask, 1 without.
    pub coverage: Option<f32>,
    /// The guided synthesis of the material over the target. By default
    /// it starts from a coarse guided quilt ([`Init::Quilt`]) that the
    /// optimization reshapes at every level, not from a full-resolution
    /// quilt whose block interiors it keeps ([`Init::QuiltSeams`],
    /// enlargement's default): guided blocks of dense and clean source
    /// cut the grown rust along straight block edges into letter-shaped
    /// blotches of one size, a "camouflage print" (blind review, 65/35 for
    /// the coarse start on the hydrant).
    pub optimize: OptimizeParams,
}

/// How [`Mode::Grow`]'s covered share grows over time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Tempo {
    /// At the source's own pace: the share covered at each time is the
    /// source's (rusting steel's rust bursts after t = 0.75).
    Source,
    /// Evenly (the default): the same texels arrive in the same order,
    /// at times spread evenly over [t0, t_D], so the covered share grows
    /// linearly to the source's final share. A capture's pace is the
    /// camera's schedule more than the material's; at the source's, the
    /// hydrant sat still for three quarters of the time and then filled
    /// with rust in one step, and a blind reviewer preferred even 70/30
    /// (d 3 against 2: "clearly spreads from the base ... up the barrel").
    #[default]
    Even,
}

/// [`TransferParams::halo`]'s default, about a quarter of a rust spot of
/// the rusting-steel capture. At 6 px (and [`RUNOFF`] 80) the glaze of
/// spots spread over a whole hydrant dulled all of its paint (98.5% of it
/// changed, review), and the gaps between runoff streaks read as pale
/// stripes.
pub const HALO: f32 = 3.0;
/// [`TransferParams::runoff`]'s default.
pub const RUNOFF: f32 = 60.0;
/// How dense the runoff is against the glaze's rim it leaves from
/// ([`Transition::drip_gain`]). At 1 (and [`RUNOFF`] 40) it darkened the
/// paint below rust by 0.014 on average and no reviewer saw it (three
/// reviews: "no run-off streaks below the nozzles, the bonnet seam or the
/// flange"); at 3 the streaks below the bonnet rim and the nozzles show.
const RUNOFF_GAIN: f32 = 3.0;
/// The smallest side of a material drawn at [`TransferParams::scale`].
const MIN_SCALED_SIDE: usize = 16;
/// [`TransferParams::coverage`]'s default with a mask. A capture of bare
/// metal rusts over half of it; a coated object rusts where its coat
/// fails, and the choice then decides where that is (its bottom, chips,
/// patches) instead of every spot of the material showing. At 1 the
/// hydrant's lower body was an even camouflage print with 97% of it
/// changed (review); 0.6 leaves its dry and sheltered parts clean.
pub const MASKED_COVERAGE: f32 = 0.6;
/// [`TransferParams::clustering`]'s default. At 1 the patches' field
/// outweighed the object's crevices and wet bottom, and reviewers saw
/// "a diagonal band ... placement that follows a noise pattern".
pub const CLUSTERING: f32 = 0.6;

/// [`Mode::Grow`]'s default guide weight. Stronger guides copied fewer and
/// fewer spots (at 0.5, a third fewer changed at t = 1 on the hydrant) and
/// drew them as horizontal dashes along the rows of the bottom's gradient.
pub const GROW_GUIDE_WEIGHT: f32 = 0.1;
/// The other modes' default guide weight.
pub const LUMINANCE_GUIDE_WEIGHT: f32 = 2.0;

impl TransferParams {
    /// The guide weight used: the one given, or the mode's default.
    pub fn weight(&self) -> f32 {
        self.guide_weight.unwrap_or(if self.mode == Mode::Grow { GROW_GUIDE_WEIGHT } else { LUMINANCE_GUIDE_WEIGHT })
    }
}

impl Default for TransferParams {
    fn default() -> Self {
        TransferParams {
            t0: 0.0,
            guide_weight: None,
            mode: Mode::Grow,
            halo: HALO,
            runoff: RUNOFF,
            tempo: Tempo::default(),
            clustering: CLUSTERING,
            scale: None,
            coverage: None,
            optimize: OptimizeParams { init: Init::Quilt, ..OptimizeParams::default() },
        }
    }
}

/// A transferred material, the mode and the scale used (auto resolved).
#[derive(Clone, Debug)]
pub struct Transferred {
    pub material: Material,
    pub mode: Mode,
    pub scale: f32,
}

/// How many times the material's side the object's spans at
/// [`TransferParams::auto_scale`].
pub const OBJECT_SPANS: f32 = 2.5;
/// Limits of [`TransferParams::auto_scale`].
pub const AUTO_SCALE_RANGE: (f32, f32) = (1.0, 4.0);

impl TransferParams {
    /// The scale used when none is given. Growing on an object (a mask),
    /// the material is drawn so that the object spans [`OBJECT_SPANS`]
    /// times its side (sides as square roots of areas), within
    /// [`AUTO_SCALE_RANGE`]: a capture's spots drawn texel for texel on a
    /// photo several times its size are specks of one size (the rusting
    /// steel capture, 117x105 once registered, on the 768x1024 hydrant at
    /// scale 1: "a leopard print"; a blind review preferred the same at
    /// scale 2 by 65/35, and auto gives 1.88 there).
    /// Otherwise 1, the texel size the material was captured at. A
    /// stand-in for the capture's and the object's physical sizes, which
    /// the images do not hold.
    pub fn auto_scale(&self, material: (usize, usize), mask: Option<&Image>) -> f32 {
        match (self.scale, mask) {
            (Some(s), _) => s,
            (None, Some(m)) if self.mode == Mode::Grow => {
                let object = m.data().iter().map(|v| v.clamp(0.0, 1.0)).sum::<f32>().sqrt();
                let side = ((material.0 * material.1) as f32).sqrt();
                (object / (OBJECT_SPANS * side)).clamp(AUTO_SCALE_RANGE.0, AUTO_SCALE_RANGE.1)
            }
            (None, _) => 1.0,
        }
    }
}

/// The material's behaviour on `target` (an RGB texture in the material's
/// encoding, the output's size), matching it exactly at time `t0`, inside
/// `mask` (one channel of the target's size, 0 = unchanged, 1 = the
/// object; soft values blend) or everywhere. The material needs a
/// 3-channel `Diffuse` parameter.
pub fn transfer(
    material: &Material,
    target: &Image,
    mask: Option<&Image>,
    params: &TransferParams,
    seed: u64,
    progress: Option<Progress>,
) -> Result<Transferred> {
    let (t0, guide_weight) = (params.t0, params.weight());
    if !(0.0..=1.0).contains(&t0) {
        return Err(Error::invalid(format!("t0 must be in [0, 1], got {t0}")));
    }
    if !(params.clustering.is_finite() && params.clustering >= 0.0) {
        return Err(Error::invalid(format!("the clustering must be a number >= 0, got {}", params.clustering)));
    }
    let coverage = params.coverage.unwrap_or(if mask.is_some() { MASKED_COVERAGE } else { 1.0 });
    if !(coverage.is_finite() && coverage > 0.0 && coverage <= 1.0) {
        return Err(Error::invalid(format!("the coverage must be in (0, 1], got {coverage}")));
    }
    let scale = params.auto_scale(material.size(), mask);
    let resized;
    let material = if scale == 1.0 {
        material
    } else {
        resized = material.scaled(scale)?;
        let (w, h) = resized.size();
        if w.min(h) < MIN_SCALED_SIDE {
            return Err(Error::invalid(format!(
                "at scale {scale} the material is {w}x{h}, under the {MIN_SCALED_SIDE} px a side its synthesis needs"
            )));
        }
        &resized
    };
    let kd =
        material.param("diffuse").filter(|r| r.len() == 3).ok_or_else(|| Error::invalid("transfer needs a 3-channel Diffuse parameter"))?;
    if target.channels() < 3 {
        return Err(Error::invalid(format!("the target must be an RGB texture, it has {} channels", target.channels())));
    }
    if let Some(m) = mask {
        if m.size() != target.size() {
            return Err(Error::invalid(format!(
                "the mask is {}x{} but the target is {}x{}",
                m.width(),
                m.height(),
                target.width(),
                target.height()
            )));
        }
    }
    // The source's timing, which the grow guides and the pace both read.
    let source_timing = Timing::of(material, kd.clone(), t0);
    let guides = match params.mode {
        _ if guide_weight <= 0.0 => None,
        Mode::Grow => mask.map(|m| density_guides(material.size(), &source_timing, &wetness(m, RIM_SHARE))),
        _ => {
            let source_guide = equalize(&luminance(&material.evaluate(t0).select_channels(kd.clone())));
            let target_guide = equalize(&luminance(&target.select_channels(0..3)));
            Some((source_guide, target_guide))
        }
    };
    let synthesized = enlarge(
        material,
        target.size(),
        &EnlargeParams { optimize: params.optimize.clone(), verbatim: params.mode == Mode::Grow, ..EnlargeParams::default() },
        guides.as_ref().map(|(s, t)| (s, t, guide_weight)),
        seed,
        progress,
    )?;
    let mode = match params.mode {
        Mode::Auto if relative_change(material, kd.clone(), t0) >= AUTO_OFFSET_CHANGE => Mode::Offset,
        Mode::Auto => Mode::Ratio,
        chosen => chosen,
    };
    let (degree, coefficients) = match mode {
        Mode::Grow => {
            let mut pace = Pace::of(material, kd.clone(), &source_timing);
            if params.tempo == Tempo::Even {
                let n = pace.arrivals.len();
                pace.arrivals = (0..n).map(|k| (k as f32 + 0.5) / n as f32).collect();
            }
            let glaze = Transition {
                width: params.halo,
                tint: glaze_tint(&pace, material.encoding),
                strength: GLAZE,
                offset: [0.0; 2],
                drip: params.runoff,
                drip_gain: RUNOFF_GAIN,
            };
            // The choice and the timing lean to the object's bottom only:
            // with its rims as well, the rust outlined the object (review).
            let low = mask.map(|m| wetness(m, 0.0));
            let place = Place { mask, wet: low.as_ref(), pace: &pace, glaze: &glaze, clustering: params.clustering, coverage };
            grow(&synthesized, target, kd, t0, &place, seed)?
        }
        _ => (material.degree, scaled(&synthesized, target, kd, t0, mode)),
    };
    let mut out = Material::new(degree, material.params.clone(), coefficients)?;
    out.encoding = material.encoding;
    if let Some(m) = mask {
        keep_outside(&mut out, target, m, t0);
    }
    Ok(Transferred { material: out, mode, scale })
}

/// Scale (sigma, px) at which [`density_guides`] measures how much of the
/// material changes around a texel, and smooths where water stands.
const DENSITY_SIGMA: f32 = 6.0;
/// The target guide's value on the driest part of the object: the least
/// rusted of the material's places go there, not the bare ones.
const DENSITY_FLOOR: f32 = 0.3;
/// The weight of the object's rims against its bottom in [`density_guides`].
const RIM_SHARE: f32 = 0.3;

/// [`Mode::Grow`]'s guides (weighted by [`TransferParams::guide_weight`]):
/// - source: how much of the material (of size `(w, h)`, timed by
///   `timing`) changes around each texel, its whole change |D| blurred at [`DENSITY_SIGMA`], equalised to [0, 1];
/// - target: where water stands on the object ([`Mask::wet_places`]: its
///   rims and its bottom), blurred the same, scaled from [`DENSITY_FLOOR`]
///   on the driest part to 1 on the wettest.
///
/// So the synthesis puts the material's densest rust where rust gathers
/// and its sparsest where the object sheds water; unguided, the spots lay
/// evenly over the whole object like a print (review). Only with a mask:
/// a texture without one has no rims, and its bottom is not the object's.
/// The guide costs some of the rust's inner texture (the rusted texels'
/// luminance spread on the test material falls from 0.80 to 0.67 of the
/// source's).
fn density_guides((w, h): (usize, usize), timing: &Timing, wet: &Image) -> (Image, Image) {
    let change = Image::from_data(w, h, 1, timing.size.clone()).expect("one value per texel");
    let source = equalize(&gaussian_blur(&change, DENSITY_SIGMA));
    let guide = wet.map(|v| DENSITY_FLOOR + (1.0 - DENSITY_FLOOR) * v);
    (source, guide)
}

/// Where water stands on the object `mask`, in [0, 1] (1 on the wettest
/// texel): its rims and its bottom ([`Mask::wet_places_weighted`]) blurred at
/// [`DENSITY_SIGMA`], the rims weighing `rim` (the guide's [`RIM_SHARE`]:
/// at full weight the rust drew the object's outline as a stroke, review:
/// 79% of the texels within 8 px of it rusted against 29% inside).
fn wetness(mask: &Image, rim: f32) -> Image {
    let (w, h) = mask.size();
    let wet = Image::from_data(w, h, 1, Mask::from_image(mask).wet_places_weighted(rim)).expect("one value per pixel");
    let mut wet = gaussian_blur(&wet, DENSITY_SIGMA);
    let top = wet.data().iter().copied().fold(0.0f32, f32::max).max(1e-3);
    wet.data_mut().iter_mut().for_each(|v| *v /= top);
    wet
}

/// The median over texels of the largest change of the Diffuse luminance
/// over [0, 1] relative to its value at t0.
fn relative_change(material: &Material, kd: std::ops::Range<usize>, t0: f32) -> f32 {
    let at0 = luminance(&material.evaluate(t0).select_channels(kd.clone()));
    let mut largest = vec![0f32; at0.data().len()];
    for k in 0..=10 {
        let lum = luminance(&material.evaluate(k as f32 / 10.0).select_channels(kd.clone()));
        for ((l, v), a) in largest.iter_mut().zip(lum.data()).zip(at0.data()) {
            *l = l.max((v - a).abs() / a.abs().max(RATIO_FLOOR));
        }
    }
    median(&mut largest).unwrap_or(0.0)
}

/// Eq. 16 (ratio) or the offset: the synthesized coefficients tied to the target at t0.
fn scaled(material: &Material, target: &Image, kd: std::ops::Range<usize>, t0: f32, mode: Mode) -> Image {
    let m = material.degree + 1;
    let mut coefficients = material.coefficients.clone();
    let n = coefficients.channels();
    coefficients.data_mut().par_chunks_mut(n).zip(target.data().par_chunks(target.channels())).for_each(|(px, want)| {
        for (c, &w) in kd.clone().zip(want) {
            let a = &mut px[c * m..(c + 1) * m];
            let at_t0 = evaluate(a, t0);
            let s = match mode {
                Mode::Ratio if at_t0.abs() >= RATIO_FLOOR => (w / at_t0).clamp(1.0 / RATIO_LIMIT, RATIO_LIMIT),
                _ => 1.0,
            };
            a.iter_mut().for_each(|v| *v *= s);
            a[0] += w - s * at_t0;
        }
    });
    coefficients
}

/// Progress towards its end state at which a texel's change counts as under way.
const ONSET_PROGRESS: f32 = 0.5;
/// Steps of the search for that moment over [t0, t_D].
const ONSET_STEPS: usize = 32;
/// [`Mode::Grow`]: strength (whole change over the 90th percentile's,
/// [`GROW_TOP`]) at which the material arrives last, at t_D; weaker texels
/// never take it on.
const GROW_CUT: f32 = 0.6;
/// How much later than its onset a texel at the cut arrives, as a share of
/// the time left after it (a spot's rims a little after its core; more
/// pushed the source's early spots' growth to the very end).
const GROW_RIM_DELAY: f32 = 0.25;
/// Half-width of a texel's arrival, in units of t_D - t0. The front's
/// width in pixels is this over the arrival time's gradient; narrower
/// arrivals ring in the degree-6 refit.
const GROW_FRONT: f32 = 0.1;
/// The whole change below which nothing counts as the material's (an RGB
/// distance; keeps a material that barely changes from arriving at all).
const GROW_MIN_TOP: f32 = 0.1;

/// When each texel of a material takes on its change (module docs): its
/// whole change D = p(t_D) - p(t0) of the Diffuse, measured along the
/// material's mean change u (the unit mean of D over its texels) as
/// max(0, D . u), and its onset, the first time its progress (the
/// projection of p(t) - p(t0) on D, over |D|^2) passes
/// [`ONSET_PROGRESS`], in units of t_D - t0 (0 at t0, 1 at t_D).
///
/// Measured as |D|, a change against the material's (the rusting steel
/// capture's glints and bare patches brightening) counted as rust: it
/// arrived on the target as slate-blue cores with ochre rings, and the
/// strongest texels were scattered specks. Along u they do not arrive,
/// and the rust joins into connected, spreading areas (blind review
/// 60/40: "reads as corrosion advancing", against "scattered stamps").
struct Timing {
    size: Vec<f32>,
    onset: Vec<f32>,
    /// t_D: 1, or 0 when t0 is past the middle.
    end_at: f32,
    /// t0.
    start_at: f32,
}

impl Timing {
    fn of(material: &Material, kd: std::ops::Range<usize>, t0: f32) -> Timing {
        let m = material.degree + 1;
        let end_at = if t0 <= 0.5 { 1.0 } else { 0.0 };
        let n = material.coefficients.channels();
        let value = |a: &[f32], t: f32| -> [f32; 3] {
            std::array::from_fn(|i| {
                let c = (kd.start + i) * m;
                evaluate(&a[c..c + m], t)
            })
        };
        let change = |a: &[f32]| -> [f32; 3] {
            let (at0, end) = (value(a, t0), value(a, end_at));
            std::array::from_fn(|i| end[i] - at0[i])
        };
        // The material's mean change, the direction its own change is
        // measured along (summed in texel order, so any thread count gives
        // the same direction).
        let changes: Vec<[f32; 3]> = material.coefficients.data().par_chunks(n).map(change).collect();
        let sum = changes.iter().fold([0f64; 3], |s, d| std::array::from_fn(|i| s[i] + d[i] as f64));
        let norm = sum.iter().map(|v| v * v).sum::<f64>().sqrt();
        let along = (norm > 0.0).then(|| sum.map(|v| (v / norm) as f32));
        let (size, onset) = material
            .coefficients
            .data()
            .par_chunks(n)
            .zip(changes.par_iter())
            .map(|(a, &end)| {
                let at0 = value(a, t0);
                let delta = |t: f32| -> [f32; 3] {
                    let v = value(a, t);
                    std::array::from_fn(|i| v[i] - at0[i])
                };
                let whole = end.iter().map(|v| v * v).sum::<f32>();
                let size = match along {
                    Some(u) => (end[0] * u[0] + end[1] * u[1] + end[2] * u[2]).max(0.0),
                    None => whole.sqrt(),
                };
                // No change along the material's (or none at all).
                if size <= 0.0 {
                    return (0.0, 1.0);
                }
                let mut before = 0.0;
                for k in 1..=ONSET_STEPS {
                    let tau = k as f32 / ONSET_STEPS as f32;
                    let d = delta(t0 + tau * (end_at - t0));
                    let progress = (d[0] * end[0] + d[1] * end[1] + d[2] * end[2]) / whole;
                    if progress >= ONSET_PROGRESS {
                        let within = (ONSET_PROGRESS - before) / (progress - before).max(1e-6);
                        return (size, (tau - (1.0 - within) / ONSET_STEPS as f32).clamp(0.0, 1.0));
                    }
                    before = progress;
                }
                (size, 1.0)
            })
            .unzip();
        Timing { size, onset, end_at, start_at: t0 }
    }

    /// The largest change that counts as the material's full change: the
    /// [`GROW_TOP`] quantile, at least [`GROW_MIN_TOP`]. Taken on the
    /// source material: on a result that copied few of its spots, the
    /// result's own quantile made bare steel's drift count as rust.
    fn top(&self) -> f32 {
        quantile(&self.size, GROW_TOP).max(GROW_MIN_TOP)
    }

    /// Texel `i`'s own arrival, in units of t_D - t0: a texel with the full
    /// change (strength s = |D| / top >= 1) arrives at its onset o, weaker
    /// ones a little later, A = o + r (1 - o) (1 - s) / (1 - [`GROW_CUT`])
    /// with r = [`GROW_RIM_DELAY`], so that a spot's rim follows its core;
    /// texels weaker than GROW_CUT never arrive (A past 1 by more than the
    /// arrival's width, growing as s falls).
    fn arrival(&self, i: usize, top: f32) -> f32 {
        let s = (self.size[i] / top).min(1.0);
        if s < GROW_CUT {
            1.0 + GROW_FRONT + (GROW_CUT - s)
        } else {
            own_arrival(s, self.onset[i])
        }
    }
}

/// The arrival of a texel of strength `s` (in [`GROW_CUT`], 1) and onset
/// `o` ([`Timing::arrival`]): o + r (1 - o) (1 - s) / (1 - GROW_CUT).
fn own_arrival(s: f32, o: f32) -> f32 {
    o + GROW_RIM_DELAY * (1.0 - o) * (1.0 - s) / (1.0 - GROW_CUT)
}

/// The source material's pace, which [`Mode::Grow`] gives the result.
struct Pace {
    /// The arrivals (<= 1) of the source's texels, sorted.
    arrivals: Vec<f32>,
    /// The share of the source's texels that take on the change.
    share: f32,
    /// The mean Diffuse at t_D of those texels: what the material becomes
    /// where a texel of the result has too little change of its own.
    colour: [f32; 3],
    /// The median strength (|D| / top) of the texels that take the change on.
    strength: f32,
    /// Their mean opacity over a target ([`end_state`] without exposure).
    opacity: f32,
    /// Their mean Diffuse at t0.
    bare: [f32; 3],
    top: f32,
}

impl Pace {
    /// The pace of `material`, whose Diffuse is channels `kd`, from its `timing`.
    fn of(material: &Material, kd: std::ops::Range<usize>, timing: &Timing) -> Pace {
        let top = timing.top();
        let (arriving, mut arrivals): (Vec<usize>, Vec<f32>) =
            (0..timing.size.len()).map(|i| (i, timing.arrival(i, top))).filter(|&(_, a)| a <= 1.0).unzip();
        arrivals.sort_by(f32::total_cmp);
        // The mean albedo of the arriving texels at `t`, read from their
        // own coefficients.
        let (m, channels) = (material.degree + 1, material.coefficients.channels());
        let n = arriving.len().max(1) as f32;
        let mean_at = |t: f32| -> [f32; 3] {
            let sum = arriving.iter().fold([0f32; 3], |mut sum, &i| {
                let a = albedo_at(&material.coefficients.data()[i * channels + kd.start * m..i * channels + kd.end * m], m, t);
                sum.iter_mut().zip(a).for_each(|(s, v)| *s += v);
                sum
            });
            sum.map(|s| s / n)
        };
        let colour = mean_at(timing.end_at);
        let total = timing.size.len();
        let strengths: Vec<f32> = arriving.iter().map(|&i| timing.size[i] / top).collect();
        let strength = if strengths.is_empty() { 1.0 } else { quantile(&strengths, 0.5) };
        let bare = mean_at(timing.start_at);
        let mut pace = Pace { arrivals, share: arriving.len() as f32 / total.max(1) as f32, colour, strength, opacity: 0.0, bare, top };
        pace.opacity = arriving.iter().map(|&i| pace.own(timing.size[i])).sum::<f32>() / n;
        pace
    }

    /// The share of a spot a texel of whole change `size` holds: its
    /// strength (size / top) over the median arriving strength, at most 1
    /// ([`end_state`]'s opacity before exposure).
    fn own(&self, size: f32) -> f32 {
        (size / self.top / self.strength).min(1.0)
    }
}

/// How far ahead of its rank (a share of the object's texels) the most
/// exposed texel ([`exposure`]) is chosen to take the material on.
const EXPOSURE_LEAD: f32 = 1.0;

/// Each texel's arrival time on the target, from the source's pace:
/// - which texels take on the material: as many as hold `coverage`
///   ([`TransferParams::coverage`]) times the source's share of visible
///   material (over the object, and separately off it; each counts its
///   opacity, [`end_state`]), those of the highest strength
///   (own |D| / top, at most 1) plus [`EXPOSURE_LEAD`] times their
///   exposure, plus (with a mask) [`WET_CHOICE`] times their wetness over
///   0.5, plus, for texels that hold a spot (strength at least
///   [`GROW_CUT`]), the patches' field ([`clusters`]). Guided synthesis
///   under-copies rare spots (on the rusting steel capture onto a painted
///   test texture, 8% of the result against 28% of the source had rusted
///   at t = 1), so the result's own strongest changes are completed to
///   the source's share, crevices first;
/// - when: the chosen texels are ordered by their own arrival (strength
///   floored at [`GROW_CUT`]) as a rank r in [0, 1], half of it by their
///   depth in the chosen region, brought forward by [`NEAR_LEAD`] times
///   their nearness to exposed places, by [`CLUSTER_LEAD`] times the
///   patches' field, and with a mask by [`WET_LEAD`] times how wet it
///   is ([`wetness`]), and given the source's arrival at the share of
///   the visible material ranked before it. So the covered share grows
///   at the source's pace (0.1% of the result's texels had changed before
///   t = 0.5 against 5.6% of the source's, on the capture onto a photo),
///   and within it the result's own spots lead, cores before rims,
///   crevices before open paint.
///
/// Texels that never take it on get an arrival past 1 (no cover).
fn paced(
    timing: &Timing,
    exposure: &Image,
    mask: Option<&Image>,
    wet: Option<&Image>,
    pace: &Pace,
    patches: &[f32],
    coverage: f32,
) -> Vec<f32> {
    let n = timing.size.len();
    let mut out = vec![1.0 + 2.0 * GROW_FRONT; n];
    if pace.arrivals.is_empty() {
        return out;
    }
    let e = exposure.data();
    // Nearness to exposed places, for the timing: the exposure spread over
    // NEAR_SIGMA and scaled to 1 at its top percentile, so the spots beside
    // a chip or seam arrive with it and rust grows out from there onto the
    // open surface (with the exposure itself, the first three quarters of
    // the time only darkened chips and seams already dark: review).
    let spread = gaussian_blur(exposure, NEAR_SIGMA);
    let peak = quantile(&on_object(spread.data(), mask), 0.99).max(1e-3);
    let near: Vec<f32> = spread.data().iter().zip(e).map(|(v, e)| (v / peak).min(1.0).max(*e)).collect();
    let strength = |i: usize| (timing.size[i] / pace.top).min(1.0);
    // A texel's opacity over the target ([`end_state`]).
    let opacity = |i: usize| pace.own(timing.size[i]).max(e[i].min(1.0));
    // Patches favour the texels that hold a spot: weak texels a patch took
    // in showed as a flat, translucent wash with the patch's hard outline
    // (review: "a flat mud-brown layer ... like dirt or a stencil").
    let patch_at = |i: usize| if strength(i) >= GROW_CUT { patches[i] } else { 0.0 };
    let last = (pace.arrivals.len() - 1) as f32;
    let by = |a: &(f32, usize), b: &(f32, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
    for on in [true, false] {
        let group: Vec<usize> = (0..n).filter(|&i| mask.is_none_or(|m| (m.data()[i] > 0.5) == on)).collect();
        let wet_at = |i: usize| wet.map_or(0.0, |m| WET_CHOICE * (m.data()[i] - 0.5));
        let mut chosen: Vec<(f32, usize)> =
            group.iter().map(|&i| (-(strength(i) + EXPOSURE_LEAD * e[i] + NEAR_CHOICE * near[i] + wet_at(i) + patch_at(i)), i)).collect();
        chosen.sort_by(by);
        // As many as hold the source's share of visible material (the sum
        // of the opacities [`end_state`] gives them): with patches, the
        // weak texels a patch takes in show little, and a count of texels
        // left the result with two thirds of the source's rust.
        let budget = coverage * pace.share * pace.opacity * group.len() as f32;
        let mut held = 0.0;
        let take = chosen
            .iter()
            .position(|&(_, i)| {
                held += opacity(i);
                held > budget
            })
            .unwrap_or(chosen.len());
        chosen.truncate(take);
        let mut own: Vec<(f32, usize)> =
            chosen.iter().map(|&(_, i)| (own_arrival(strength(i).max(GROW_CUT), timing.onset[i]), i)).collect();
        own.sort_by(by);
        let span = own.len().max(2) as f32 - 1.0;
        // Depth inside the chosen region: a blotch grows from its middle out.
        let mut region = vec![false; n];
        own.iter().for_each(|&(_, i)| region[i] = true);
        let (w, h) = exposure.size();
        let depth = Mask::from_fn(w, h, |x, y| region[y * w + x]).distance_inside();
        let mut keyed: Vec<(f32, usize)> = own
            .iter()
            .enumerate()
            .map(|(r, &(_, i))| {
                let shallow = 1.0 - (depth[i] / GROW_DEPTH).min(1.0);
                let wet = wet.map_or(0.0, |m| m.data()[i]);
                (
                    (1.0 - GROW_FROM_MIDDLE) * r as f32 / span + GROW_FROM_MIDDLE * shallow
                        - NEAR_LEAD * near[i]
                        - WET_LEAD * wet
                        - CLUSTER_LEAD * patches[i],
                    i,
                )
            })
            .collect();
        keyed.sort_by(by);
        // Timed by the share of the visible material arrived before them
        // (their opacities summed in order), so the visible cover follows
        // the pace even where a patch took in weak texels.
        let total: f32 = keyed.iter().map(|&(_, i)| opacity(i)).sum::<f32>().max(1e-6);
        let mut before = 0.0;
        for &(_, i) in &keyed {
            let o = opacity(i);
            out[i] = pace.arrivals[(((before + 0.5 * o) / total).min(1.0) * last).round() as usize];
            before += o;
        }
    }
    out
}

/// How far ahead of its rank in time (a share of the chosen texels) a
/// texel arrives where water stands most ([`wetness`], with a mask): rust
/// takes hold at the object's bottom and rims and climbs from there,
/// instead of specks appearing evenly over it until the last quarter of
/// the time (review: "nothing happens on the body until t = 0.75"). On
/// the hydrant at t = 0.75, the share of its top / middle / bottom thirds
/// changed by over 30 levels goes from 0.02 / 0.06 / 0.18 without it to
/// 0.00 / 0.03 / 0.24 (0.5 gave 0.01 / 0.04 / 0.22); t = 1 is unchanged.
const WET_LEAD: f32 = 1.0;

/// How much where water stands ([`wetness`], with a mask) weighs in the
/// choice of texels that take the material on, against their own strength
/// (0 to 1): the object's dry top gives up its weaker spots and rims to
/// its wet bottom, whose spots then merge, so the final rust follows the
/// object's form (review: "spots cover everything at roughly the same
/// density"). On the hydrant at t = 1, the thirds changed by over 30
/// levels go from 0.31 / 0.48 / 0.71 (top / middle / bottom) to
/// 0.17 / 0.42 / 0.84 (0.6 gave 0.22 / 0.45 / 0.80); the share is the
/// source's either way.
const WET_CHOICE: f32 = 1.2;

/// Wavelength of [`clusters`]' largest octave, as a share of the side of
/// a square of the object's area (the target's without a mask).
const CLUSTER_SCALE: f32 = 0.3;
/// How far ahead of its rank in time (a share of the chosen texels) a
/// texel one unit of [`clusters`] into a patch arrives, relative to its
/// weight in the choice: patches take hold first and spread.
const CLUSTER_LEAD: f32 = 0.3;

/// Where the material gathers in patches, per texel: a domain-warped fBm
/// field (3 octaves from [`CLUSTER_SCALE`] of the object's side down,
/// warped by half that) standardised over the target to mean 0 and std
/// `weight`, added to the choice of the texels that hold a spot ([`paced`];
/// in units of a texel's own strength, 0 to 1) and, times [`CLUSTER_LEAD`],
/// to their head start in time. Corrosion is not even over an object: it
/// takes whole areas where the coat failed first and leaves others nearly
/// clean. Without it, the material's spots, copied at the capture's
/// density over the whole object, read as camouflage (review: "even,
/// blocky blobs"). A stand-in for the coat's unknown local failure, as
/// decay's degree maps are (Hao et al. 2023); all zeros at weight 0.
fn clusters((w, h): (usize, usize), mask: Option<&Image>, weight: f32, seed: u64) -> Vec<f32> {
    if weight <= 0.0 {
        return vec![0.0; w * h];
    }
    let area = mask.map_or((w * h) as f32, |m| m.data().iter().map(|v| v.clamp(0.0, 1.0)).sum::<f32>()).max(1.0);
    let scale = CLUSTER_SCALE * area.sqrt();
    let layer = crate::image::noise::Layer::new(seed, 0xc105);
    let field: Vec<f32> = (0..w * h).into_par_iter().map(|i| layer.warped((i % w) as f32, (i / w) as f32, scale, 3, 0.5 * scale)).collect();
    Mask::filled(w, h, true).standardise(&field).into_iter().map(|z| z * weight).collect()
}

/// How much nearness to exposed places (chips, seams) weighs in the
/// choice, against a texel's own strength: the rust grows out of the
/// chips the photo already has (review: "the rust ignores the paint chips
/// already in the photo ... new spots appear at random").
const NEAR_CHOICE: f32 = 0.5;

/// Reach (sigma, px) of an exposed place's head start in time ([`paced`]).
const NEAR_SIGMA: f32 = 6.0;
/// How far ahead of its rank in time (a share of the chosen texels) a
/// texel next to an exposed place arrives.
const NEAR_LEAD: f32 = 0.5;

/// How much a texel's depth inside the region that takes the material on
/// decides its rank, against its own arrival: a blotch that arrives in
/// the source within a few frames grows on the target from its middle out
/// instead of appearing whole. Depth counts up to [`GROW_DEPTH`] px.
const GROW_FROM_MIDDLE: f32 = 0.5;
const GROW_DEPTH: f32 = 6.0;

/// What texel `i` becomes at t_D over the target, as a colour and its
/// opacity, from its own end state `end` (RGB) and its exposure
/// `e`: the material covers the target as much as the texel holds of a
/// spot, its strength s = |D| / top over the source's median arriving
/// strength s_m (texture optimization and the source's own rims mix spots
/// with bare surface; a rim is part rust, so the target shows through it as
/// a bleed of the rust's colour into the paint), and at least as much as
/// the target is exposed there (a crevice the pace chose takes the
/// material's mean end state, [`Pace::colour`]). Earlier versions drew
/// every chosen texel opaque: weak ones un-mixed from the source's
/// background (which amplified the rims' hue into olive) or filled with the
/// mean (flat, camouflage-like blotches, review).
///
/// A rim texel's own colour is part bare surface (rusting steel's grey):
/// it keeps its own colour in the square of the share of it that is spot,
/// and takes the mean end state's hue at its own luminance, no paler than
/// the mean's, in the rest (grey feathered edges, then pale yellow-grey
/// fringes, reviews).
///
/// The darkest of the material's end states are its polynomials' ends
/// (where a fit is least sure); under the target's shade they went
/// near-black and hue-less (review: "black pits", a blue-grey cast). A
/// colour darker than [`DARKEST`] of the mean end state's luminance is
/// lifted to it by adding the mean end state's own hue.
fn end_state(timing: &Timing, pace: &Pace, i: usize, end: [f32; 3], e: f32) -> ([f32; 3], f32) {
    let own = pace.own(timing.size[i]);
    let opacity = own.max(e.min(1.0));
    if opacity <= 0.0 {
        return (end, 0.0);
    }
    let mean = pixel_luminance(&pace.colour).max(1e-3);
    let tint = (pixel_luminance(&end) / mean).min(1.0);
    let grey = own * own;
    let rim: [f32; 3] = std::array::from_fn(|c| grey * end[c] + (1.0 - grey) * tint * pace.colour[c]);
    let mut colour: [f32; 3] = std::array::from_fn(|c| (own * rim[c] + (opacity - own) * pace.colour[c]) / opacity);
    let l = pixel_luminance(&colour);
    if l < DARKEST * mean {
        let lift = (DARKEST * mean - l) / mean;
        colour.iter_mut().zip(pace.colour).for_each(|(v, m)| *v += lift * m);
    }
    (colour, opacity)
}

/// The Diffuse (3 channels of `m` coefficients each) at `t`, as an albedo
/// in [0, 1] whatever the polynomial gives past its samples: the end of a
/// fit to a noisy capture (or of its resampling, `--scale`) can undershoot
/// below 0, and a blue of -0.12 turned a grey highlight under arriving rust
/// into pure crimson (0.48, 0.06, 0) on the hydrant's flange.
fn albedo_at(diffuse: &[f32], m: usize, t: f32) -> [f32; 3] {
    std::array::from_fn(|k| evaluate(&diffuse[k * m..(k + 1) * m], t).clamp(0.0, 1.0))
}

/// The darkest luminance [`end_state`] gives, relative to the material's
/// mean end state ([`Pace::colour`]): rusting steel's darkest frame pixels
/// are about 0.7 of its mean rust's.
const DARKEST: f32 = 0.7;

/// Spread of the arrival times' per-texel dither, in units of the front's
/// half-width [`GROW_FRONT`].
const ARRIVAL_DITHER: f32 = 1.5;
/// Grain size (px) of that dither.
const DITHER_SCALE: f32 = 2.5;

/// Per-texel dither of the arrivals (those that arrive, <= 1): fBm noise
/// of grain [`DITHER_SCALE`], within +-[`ARRIVAL_DITHER`] [`GROW_FRONT`]: a front the polynomial can only
/// follow as a ramp of 2 GROW_FRONT in time shows as a grain of texels
/// partly arrived, not as a soft translucent blur over a whole blotch.
fn dither(arrivals: &mut [f32], width: usize, seed: u64) {
    let layer = crate::image::noise::Layer::new(seed, 0x57b0);
    for (i, a) in arrivals.iter_mut().enumerate() {
        if *a <= 1.0 {
            let u = layer.fbm((i % width) as f32, (i / width) as f32, DITHER_SCALE, 2, 0.5);
            *a += u.clamp(-1.0, 1.0) * ARRIVAL_DITHER * GROW_FRONT;
        }
    }
}

/// Where and how [`Mode::Grow`]'s material lands on the target.
struct Place<'a> {
    /// The object ([`transfer`]'s mask), if any.
    mask: Option<&'a Image>,
    /// Where water stands on it ([`wetness`]), with a mask.
    wet: Option<&'a Image>,
    /// The source's pace.
    pace: &'a Pace,
    /// The glaze around what has arrived.
    glaze: &'a Transition,
    /// [`TransferParams::clustering`].
    clustering: f32,
    /// [`TransferParams::coverage`] resolved.
    coverage: f32,
}

/// [`Mode::Grow`] (module docs): per texel, the cover c(t) from its arrival
/// ([`Timing::arrival`]), the Diffuse pulled from the target towards what
/// the material becomes there (lit by the target's shading) by c, every
/// other parameter from its t0 value towards its value then by c, refitted
/// pinned at t0.
fn grow(material: &Material, target: &Image, kd: std::ops::Range<usize>, t0: f32, place: &Place, seed: u64) -> Result<(usize, Image)> {
    let Place { mask, wet, pace, glaze, clustering, coverage } = *place;
    let m = material.degree + 1;
    let out_degree = material.degree.max(GROW_DEGREE);
    let samples = 4 * (out_degree + 1);
    let times: Vec<f32> = (0..samples).map(|i| i as f32 / (samples - 1) as f32).collect();
    let fitter = Fitter::anchored(&times, out_degree, t0)?;
    let mo = out_degree + 1;
    let channels = material.channels();
    let timing = Timing::of(material, kd.clone(), t0);
    let end_at = timing.end_at;
    let exposed = exposure(target, mask);
    let patches = clusters(target.size(), mask, clustering, seed);
    let mut arrivals = paced(&timing, &exposed, mask, wet, pace, &patches, coverage);
    dither(&mut arrivals, target.width(), seed);
    let coefficients = &material.coefficients;
    let n = coefficients.channels();
    let mut ends: Vec<([f32; 3], f32)> = coefficients
        .data()
        .par_chunks(n)
        .enumerate()
        .map(|(i, a)| {
            let end = albedo_at(&a[kd.start * m..kd.end * m], m, end_at);
            end_state(&timing, pace, i, end, exposed.data()[i])
        })
        .collect();
    antialias(target.size(), &mut arrivals, &mut ends, pace);
    let visible: Vec<Image> = (1..=KEYS).map(|k| visible_at(target.size(), &arrivals, &ends, k as f32 / KEYS as f32)).collect();
    let glazes = stain(glaze, &visible, mask, seed);
    let lips = lips(&visible);
    let linear = material.encoding == Encoding::Srgb;
    let taus: Vec<f32> = times.iter().map(|t| (t - t0) / (end_at - t0)).collect();
    // The target's shading, relative to its median luminance (over the
    // object), at the scale of its form: the paint's grain and gloss do
    // not show through the material.
    let fine = luminance(&target.select_channels(0..3));
    let lum = gaussian_blur(&fine, SHADING_SIGMA);
    // The object's relief finer than that (bolt edges, lettering, seams),
    // kept at [`RELIEF`] strength so it shows through the material: with
    // the blurred shading alone, rust flattened the hardware (review).
    let relief: Vec<f32> = fine
        .data()
        .iter()
        .zip(lum.data())
        .map(|(f, b)| (f.max(1e-3) / b.max(1e-3)).powf(RELIEF).clamp(RELIEF_RANGE.0, RELIEF_RANGE.1))
        .collect();
    let lums = on_object(lum.data(), mask);
    let median = if lums.is_empty() { 1.0 } else { quantile(&lums, 0.5).max(1e-3) };
    let mut out = Image::new(coefficients.width(), coefficients.height(), channels * mo);
    out.data_mut()
        .par_chunks_mut(channels * mo)
        .zip(coefficients.data().par_chunks(n))
        .zip(target.data().par_chunks(target.channels()))
        .zip(lum.data().par_iter())
        .enumerate()
        .for_each_init(
            || (vec![0f32; samples], vec![0f32; samples], vec![0f32; samples], vec![0f32; samples]),
            |(cover, q, glazing, lip), (i, (((o, a), want), &l))| {
                let shading = (l / median).clamp(SHADING_RANGE.0, SHADING_RANGE.1) * relief[i];
                cover.iter_mut().zip(&taus).for_each(|(c, &tau)| *c = cover_at(arrivals[i], tau));
                let (colour, opacity) = ends[i];
                // The glaze's weight and the lip's factor over time, shared by
                // the Diffuse channels.
                for ((g, f), &tau) in glazing.iter_mut().zip(lip.iter_mut()).zip(&taus) {
                    *g = keyed(&glazes, i, tau);
                    *f = 1.0 + LIP * keyed(&lips, i, tau);
                }
                for c in 0..channels {
                    let poly = &a[c * m..(c + 1) * m];
                    let diffuse = kd.contains(&c);
                    let base = if diffuse { want[c - kd.start] } else { evaluate(poly, t0) };
                    let arrived = if diffuse {
                        arrived_colour(base, shading * colour[c - kd.start], pace.bare[c - kd.start], opacity)
                    } else {
                        evaluate(poly, end_at)
                    };
                    // The glaze multiplies the target (in linear light) where
                    // the material has not arrived itself.
                    let glazed = if diffuse && !glazes.is_empty() {
                        let tint = glaze.tint[c - kd.start];
                        if linear {
                            linear_to_srgb(srgb_to_linear(base.clamp(0.0, 1.0)) * tint) - base
                        } else {
                            base * tint - base
                        }
                    } else {
                        0.0
                    };
                    for (k, (qk, &ck)) in q.iter_mut().zip(cover.iter()).enumerate() {
                        let value = base + ck * (arrived - base) + glazing[k] * glazed;
                        // The arrived material's lip (Diffuse only).
                        *qk = if diffuse { value * lip[k] } else { value } - base;
                    }
                    let dst = &mut o[c * mo..(c + 1) * mo];
                    fitter.fit_into(q, dst);
                    dst[0] += base;
                }
            },
        );
    Ok((out_degree, out))
}

/// One Diffuse channel of what texel of the target `base` becomes where
/// the material's end state `end` (lit) arrives with `opacity`, the
/// material having been `bare` there before (its mean at t0): over the
/// target (base + o (end - base)) where it is opaque, and as a stain of
/// the target (base (end / bare)^o, the material's change as a ratio, as
/// eq. 16 carries it) where it is partial, weighed by o^[`OVER_POWER`].
/// Laid over the paint, a spot's partial rim is a mix of the paint with
/// the capture's grey steel and yellow-brown fringe, which beside orange
/// paint read as a khaki or grey-olive ring round every spot (four
/// reviews, the last at o^2: "outlined, like a decal"); as a stain it
/// darkens and browns the paint in its own hue.
fn arrived_colour(base: f32, end: f32, bare: f32, opacity: f32) -> f32 {
    let over = base + opacity * (end - base);
    let ratio = (end / bare.max(1e-3)).clamp(STAIN_RATIO.0, STAIN_RATIO.1);
    let w = opacity.powi(OVER_POWER);
    w * over + (1.0 - w) * base * ratio.powf(opacity)
}

/// The power of the opacity that weighs [`arrived_colour`]'s cover against
/// its stain: at 8 a rim texel of opacity 0.8 is 17% cover (41% at 4, 64%
/// at 2); cores, of opacity 1, are all cover. A blind review preferred 8
/// to 2, 60/40 ("the ring is darker and redder, blends into the paint").
const OVER_POWER: i32 = 8;

/// Limits of [`arrived_colour`]'s ratio.
const STAIN_RATIO: (f32, f32) = (0.05, 1.5);

/// Width (sigma, px) of the fringe [`antialias`] gives what arrives.
const FRINGE_SIGMA: f32 = 0.6;

/// Anti-aliases the outlines of what arrives: a texel that does not take
/// the material on but borders texels that do takes it on in part, with
/// the opacity of their opacity blurred at [`FRINGE_SIGMA`], at their mean
/// arrival, in the material's mean end state ([`Pace::colour`], not the
/// texel's own bare colour: a fringe of that read as grey haze, review).
/// Each texel's cover is all or nothing, so without it outlines were
/// stair-stepped at the target's pixels (review: "blocky, jagged spot
/// edges").
fn antialias((w, h): (usize, usize), arrivals: &mut [f32], ends: &mut [([f32; 3], f32)], pace: &Pace) {
    let opacity = Image::from_fn(w, h, 1, |x, y, p| {
        let i = y * w + x;
        p[0] = if arrivals[i] <= 1.0 { ends[i].1 } else { 0.0 };
    });
    let timed = Image::from_fn(w, h, 1, |x, y, p| p[0] = opacity.at(x, y, 0) * arrivals[y * w + x].min(1.0));
    let (opacity, timed) = (gaussian_blur(&opacity, FRINGE_SIGMA), gaussian_blur(&timed, FRINGE_SIGMA));
    for (i, (a, end)) in arrivals.iter_mut().zip(ends.iter_mut()).enumerate() {
        let o = opacity.data()[i];
        if *a > 1.0 && o > 0.02 {
            *a = (timed.data()[i] / o).min(1.0);
            *end = (pace.colour, o);
        }
    }
}

/// Strength of [`Mode::Grow`]'s glaze at the rim of a large arrived patch.
const GLAZE: f32 = 0.8;
/// Times (evenly spaced over (t0, t_D]) at which the glaze and the lips
/// are laid out; between them a texel's are interpolated linearly in time.
const KEYS: usize = 6;

/// The visible weight of what has arrived at progress `tau`: each texel's
/// cover (as `grow` times it) times its opacity (`ends`).
fn visible_at((w, h): (usize, usize), arrivals: &[f32], ends: &[([f32; 3], f32)], tau: f32) -> Image {
    let mut visible = Image::new(w, h, 1);
    visible.data_mut().par_iter_mut().enumerate().for_each(|(i, v)| {
        if arrivals[i] <= 1.0 {
            *v = ends[i].1 * cover_at(arrivals[i], tau);
        }
    });
    visible
}

/// The cover of a texel arriving at `arrival` at progress `tau` (0 at t0,
/// 1 at t_D): 0 up to t0, then a smoothstep of half-width [`GROW_FRONT`]
/// around the arrival, which is never before GROW_FRONT (nothing has
/// arrived at t0 itself) and, for texels that arrive (<= 1), never after
/// 1 - GROW_FRONT (what arrives is all there at t_D, not a see-through
/// wash). It only grows away from t0: what has arrived stays.
fn cover_at(arrival: f32, tau: f32) -> f32 {
    if tau <= 0.0 {
        return 0.0;
    }
    let arrival = if arrival <= 1.0 { arrival.clamp(GROW_FRONT, 1.0 - GROW_FRONT) } else { arrival };
    smoothstep(arrival - GROW_FRONT, arrival + GROW_FRONT, tau)
}

/// Strength of the arrived material's lip: the share by which the top edge
/// of a patch brightens and the surface just below it darkens.
const LIP: f32 = 0.4;
/// Softness (sigma, px) of the lip.
const LIP_SIGMA: f32 = 0.8;

/// Per key, the lip of what has arrived: rust scale stands
/// proud of the paint it lifts, so under light from above a patch's upper
/// edge catches the light and it shadows the surface just below it
/// (review: "no blistered or flaking paint edges", spots read as flat
/// decals). The visible weight v blurred at [`LIP_SIGMA`], the texel below
/// minus the texel above, in [-1, 1], times v where it lights (the
/// material's own edge) and 1 - v where it shadows (the surface below):
/// lighting the paint above a spot too turned the paint between dense
/// spots pale salmon. Texel-major, as [`keyed`] reads it. Simplification: the light is taken
/// from above, as most photos are lit; the photo's own light direction
/// is not estimated.
fn lips(visible: &[Image]) -> Vec<f32> {
    texel_major(
        visible
            .iter()
            .map(|v| {
                let b = gaussian_blur(v, LIP_SIGMA);
                let (w, h) = b.size();
                (0..w * h)
                    .map(|i| {
                        let e = b.at(i % w, (i / w + 1).min(h - 1), 0) - b.at(i % w, (i / w).saturating_sub(1), 0);
                        // The material's own upper edge is lit; the surface
                        // below it is shadowed.
                        let own = v.data()[i];
                        if e > 0.0 {
                            e * own
                        } else {
                            e * (1.0 - own)
                        }
                    })
                    .collect()
            })
            .collect(),
    )
}

/// The glaze's tint (a factor in linear light): a film of a quarter of
/// the material's optical depth (Beer-Lambert: its mean end state
/// [`Pace::colour`], linear, to the power 1/4). Rust's dark brown gives
/// about (0.51, 0.35, 0.24), a brown glaze that shows on orange paint as
/// well as on grey; a white material gives none. Normalised to keep the
/// red channel whole, it only reddened orange paint, and nobody saw it.
fn glaze_tint(pace: &Pace, encoding: Encoding) -> [f32; 3] {
    pace.colour.map(|v| if encoding == Encoding::Srgb { srgb_to_linear(v.clamp(0.0, 1.0)) } else { v.clamp(0.0, 1.0) }.powf(GLAZE_DEPTH))
}

/// The glaze's share of the material's optical depth ([`glaze_tint`]).
const GLAZE_DEPTH: f32 = 0.25;

/// [`Mode::Grow`]'s glaze ([`crate::image::stain`]): around what has
/// arrived, and in streaks below it, the material's colour soaks into the
/// target as a translucent film (rust bleeding into paint and running
/// down it; reviewers read the rust without it as flat pasted spots). At
/// each key, the `visible` weight ([`visible_at`]) is laid out as a stain
/// zone; the result is the zone's weight per key, texel-major (empty for
/// no zone, or nothing arriving). Inside a mask only: its outside is the
/// target's anyway.
fn stain(glaze: &Transition, visible: &[Image], mask: Option<&Image>, seed: u64) -> Vec<f32> {
    let Some(last) = visible.last() else { return Vec::new() };
    let (w, h) = last.size();
    let Some(field) = glaze.field(w, h, seed) else { return Vec::new() };
    if last.data().iter().all(|&v| v <= 0.0) {
        return Vec::new();
    }
    let begun = mask.cloned().unwrap_or_else(|| Image::from_fn(w, h, 1, |_, _, p| p[0] = 1.0));
    texel_major(visible.iter().map(|v| field.weights(v, &begun)).collect())
}

/// Per-key maps (one per key) interleaved texel by texel, as [`keyed`] reads them.
fn texel_major(keys: Vec<Vec<f32>>) -> Vec<f32> {
    let n = keys.first().map_or(0, Vec::len);
    let mut out = vec![0f32; n * keys.len()];
    out.par_chunks_mut(keys.len()).enumerate().for_each(|(i, px)| px.iter_mut().zip(&keys).for_each(|(o, k)| *o = k[i]));
    out
}

/// Texel `i`'s value at progress `tau` (0 at t0, 1 at t_D) in per-key
/// `values` (texel-major: [`KEYS`] values per texel, at tau = k / KEYS):
/// linear between the keys, 0 at tau <= 0 and for empty `values`.
fn keyed(values: &[f32], i: usize, tau: f32) -> f32 {
    if tau <= 0.0 || values.is_empty() {
        return 0.0;
    }
    let x = (tau * KEYS as f32).min(KEYS as f32);
    let k = x.floor() as usize;
    let a = x - k as f32;
    let at = |k: usize| if k == 0 { 0.0 } else { values[i * KEYS + k - 1] };
    if k >= KEYS {
        return at(KEYS);
    }
    at(k) + a * (at(k + 1) - at(k))
}

/// Strength (an exponent) and limits of the target's fine relief over its
/// shading that [`Mode::Grow`] keeps in the arriving material. At full
/// strength it turned crevice rust near-black and showed the paint's gloss
/// and grain through it (review); at 0.5 within (0.75, 1.25) the rust
/// smothered the hydrant's bolts and flange steps (reviews: "bolt heads
/// disappear under flat blotches").
const RELIEF: f32 = 0.8;
const RELIEF_RANGE: (f32, f32) = (0.55, 1.6);
/// Scale (sigma, px) of the target's shading that lights the material.
const SHADING_SIGMA: f32 = 2.0;
/// Cavity contrast that counts as fully exposed: a texel this much darker
/// than its surroundings (relative to them) is a crevice, chip or bolt.
const EXPOSED_CAVITY: f32 = 0.25;
/// Scale (sigma, px) of the surroundings a cavity is measured against.
const CAVITY_SIGMA: f32 = 4.0;
/// Width (sigma, px) of the object's rim, and its exposure there.
const RIM_SIGMA: f32 = 3.0;
const RIM_EXPOSURE: f32 = 0.15;

/// How exposed each texel of the target is to weathering, in [0, 1]:
/// where rust starts and moss takes hold. Crevices, chips and the shadows
/// around bolts are darker than their surroundings (the cavity term:
/// (B - L) / B over [`EXPOSED_CAVITY`], B the luminance L blurred at
/// [`CAVITY_SIGMA`]), and the object's rim (from the mask) is its edges.
/// A simple stand-in for curvature and accessibility, which a single
/// photo does not give.
fn exposure(target: &Image, mask: Option<&Image>) -> Image {
    let lum = luminance(&target.select_channels(0..3));
    let around = gaussian_blur(&lum, CAVITY_SIGMA);
    let rim = mask.map(|m| gaussian_blur(m, RIM_SIGMA));
    let (w, h) = lum.size();
    let raw = Image::from_fn(w, h, 1, |x, y, p| {
        let (l, b) = (lum.at(x, y, 0), around.at(x, y, 0));
        let cavity = ((b - l) / b.max(0.05) / EXPOSED_CAVITY).clamp(0.0, 1.0);
        let edge = match (&rim, mask) {
            (Some(r), Some(m)) if m.at(x, y, 0) > 0.5 => (2.0 * (1.0 - r.at(x, y, 0))).clamp(0.0, 1.0) * RIM_EXPOSURE,
            _ => 0.0,
        };
        p[0] = cavity.max(edge);
    });
    gaussian_blur(&raw, 1.5)
}

/// The values of the texels on the object: where the mask is over 0.5, or all.
fn on_object(values: &[f32], mask: Option<&Image>) -> Vec<f32> {
    match mask {
        Some(mk) => values.iter().zip(mk.data()).filter(|(_, w)| **w > 0.5).map(|(v, _)| *v).collect(),
        None => values.to_vec(),
    }
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The `q` quantile of `values` (not empty).
fn quantile(values: &[f32], q: f32) -> f32 {
    let mut v = values.to_vec();
    let at = ((v.len() - 1) as f32 * q).round() as usize;
    *v.select_nth_unstable_by(at, f32::total_cmp).1
}

/// Blend `material` with the target by the mask: each coefficient's change
/// from the target's constant polynomial scaled by the mask's value, so
/// texels outside (0) hold exactly the target (Diffuse) and their value at
/// t0 (other parameters) at every t.
fn keep_outside(material: &mut Material, target: &Image, mask: &Image, t0: f32) {
    let m = material.degree + 1;
    let kd = material.param("diffuse").expect("checked");
    let n = material.coefficients.channels();
    let channels = material.channels();
    material
        .coefficients
        .data_mut()
        .par_chunks_mut(n)
        .zip(target.data().par_chunks(target.channels()))
        .zip(mask.data().par_iter())
        .for_each(|((px, want), &w)| {
            let w = w.clamp(0.0, 1.0);
            if w >= 1.0 {
                return;
            }
            for c in 0..channels {
                let a = &mut px[c * m..(c + 1) * m];
                let base = if kd.contains(&c) { want[c - kd.start] } else { evaluate(a, t0) };
                if w <= 0.0 {
                    a.fill(0.0);
                    a[0] = base;
                } else {
                    a[0] = base + w * (a[0] - base);
                    a[1..].iter_mut().for_each(|v| *v *= w);
                }
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stbrdf::fit::fit;
    use crate::stbrdf::procedural::{drying_wood, drying_wood_params};

    /// A black, hue-less end state (a polynomial's end undershooting) comes
    /// out rust-hued at [`DARKEST`] of the mean rust's luminance; a rim
    /// texel's steel grey takes the rust's hue; a strong texel of ordinary
    /// brightness keeps its own colour.
    #[test]
    fn the_arriving_rust_is_never_black_and_its_rims_are_not_grey() {
        let timing = Timing { size: vec![1.0, 0.4, 1.0], onset: vec![0.5; 3], end_at: 1.0, start_at: 0.0 };
        let pace =
            Pace { arrivals: vec![0.5], share: 0.5, colour: [0.3, 0.16, 0.07], strength: 1.0, opacity: 1.0, bare: [0.6; 3], top: 1.0 };
        let light = |v: [f32; 3]| pixel_luminance(&v);
        let (black, opacity) = end_state(&timing, &pace, 0, [0.01, 0.01, 0.02], 0.0);
        assert_eq!(opacity, 1.0);
        assert!(light(black) >= DARKEST * light(pace.colour) - 1e-4, "{black:?}");
        assert!(black[0] > 2.0 * black[2], "rust-hued, not blue-grey: {black:?}");
        let grey = [0.5, 0.5, 0.52];
        let (rim, opacity) = end_state(&timing, &pace, 1, grey, 0.0);
        assert!((opacity - 0.4).abs() < 1e-5, "a rim is part rust: {opacity}");
        assert!(rim[0] > 1.3 * rim[2], "its colour leans to the rust's hue: {rim:?}");
        // A pale rim read as a yellow-grey fringe around the spots (review):
        // 1.28x the rust's luminance here, 2.7x with the rim's own
        // luminance and a linear share of its grey.
        assert!(light(rim) <= 1.5 * light(pace.colour), "{rim:?} against {:?}", pace.colour);
        let brown = [0.45, 0.25, 0.12];
        assert_eq!(end_state(&timing, &pace, 2, brown, 0.0), (brown, 1.0));
    }

    /// A Diffuse whose polynomial undershoots at its end (blue at -0.12)
    /// arrives as an albedo: no channel below 0 or above 1.
    #[test]
    fn an_end_state_past_the_albedo_range_is_clamped() {
        // Degree 1 per channel: (0.5, 0.4, 0.3) at t = 0, (0.31, 0.04, -0.12) at t = 1.
        let diffuse = [0.5, -0.19, 0.4, -0.36, 0.3, -0.42];
        let end = albedo_at(&diffuse, 2, 1.0);
        assert!((end[0] - 0.31).abs() < 1e-6 && (end[1] - 0.04).abs() < 1e-6 && end[2] == 0.0, "{end:?}");
        assert_eq!(albedo_at(&[0.5, 0.8, 0.5, 0.0, 0.5, 0.0], 2, 1.0), [1.0, 0.5, 0.5]);
        assert_eq!(albedo_at(&diffuse, 2, 0.0), [0.5, 0.4, 0.3]);
    }

    /// Growing on an object, the material is drawn so that the object
    /// spans 2.5 of its sides; a scale given is kept, and without a mask
    /// (or in ratio mode) it is 1.
    #[test]
    fn the_scale_by_default_sizes_the_material_to_the_object() {
        // A 400 x 400 object, a 64 x 64 material: 400 / (2.5 x 64) = 2.5.
        let mask = Image::from_fn(600, 500, 1, |x, y, p| p[0] = if x < 400 && y < 400 { 1.0 } else { 0.0 });
        let grow = TransferParams::default();
        assert!((grow.auto_scale((64, 64), Some(&mask)) - 2.5).abs() < 1e-4);
        // Never below 1 (a material larger than the object keeps its texel size) nor above 4.
        assert_eq!(grow.auto_scale((400, 400), Some(&mask)), 1.0);
        assert_eq!(grow.auto_scale((16, 16), Some(&mask)), 4.0);
        assert_eq!(grow.auto_scale((64, 64), None), 1.0);
        assert_eq!(TransferParams { mode: Mode::Ratio, ..TransferParams::default() }.auto_scale((64, 64), Some(&mask)), 1.0);
        assert_eq!(TransferParams { scale: Some(0.5), ..TransferParams::default() }.auto_scale((64, 64), Some(&mask)), 0.5);
    }

    /// A texel whose change goes against the material's (a glint that
    /// brightens while the steel around it rusts darker) has no change of
    /// the material's and never arrives; measured as |D| it was as strong
    /// as the rust and arrived as a slate-blue core.
    #[test]
    fn a_change_against_the_materials_does_not_count_as_its_arrival() {
        let diffuse = vec![crate::stbrdf::material::Param { name: "Diffuse".into(), channels: 3 }];
        // Degree 1: p(t) = a0 + a1 t per channel. Eight texels rust from
        // grey to brown, two brighten to near white.
        let (rust, glint) = ([-0.3, -0.42, -0.5], [0.3, 0.3, 0.32]);
        let coefficients = Image::from_fn(10, 1, 6, |x, _, p| {
            let d = if x < 8 { rust } else { glint };
            for c in 0..3 {
                p[2 * c] = 0.6;
                p[2 * c + 1] = d[c];
            }
        });
        let material = Material::new(1, diffuse, coefficients).unwrap();
        let timing = Timing::of(&material, 0..3, 0.0);
        let top = timing.top();
        assert!(timing.size[..8].iter().all(|&s| s > 0.5), "the rust counts: {:?}", timing.size);
        assert!(timing.size[8..].iter().all(|&s| s == 0.0), "the glints do not: {:?}", timing.size);
        assert!((0..8).all(|i| timing.arrival(i, top) <= 1.0) && (8..10).all(|i| timing.arrival(i, top) > 1.0));
    }

    /// Where the material arrives opaque it is its own colour; where it is
    /// partial it stains the target in the target's hue instead of mixing
    /// its yellow-brown fringe into orange paint (a khaki ring, reviews):
    /// at half opacity the result's green over red is 0.44, under the
    /// paint's 0.51, where a plain mix raises it to 0.56.
    #[test]
    fn partial_rust_stains_the_paint_in_its_hue() {
        let (paint, rust, steel) = ([0.84, 0.43, 0.24], [0.42, 0.27, 0.13], [0.6, 0.6, 0.6]);
        let at = |o: f32| -> [f32; 3] { std::array::from_fn(|c| arrived_colour(paint[c], rust[c], steel[c], o)) };
        let mix = |o: f32| -> [f32; 3] { std::array::from_fn(|c| paint[c] + o * (rust[c] - paint[c])) };
        assert!(at(1.0).iter().zip(rust).all(|(a, b)| (a - b).abs() < 1e-6), "opaque: {:?}", at(1.0));
        assert!(at(0.0).iter().zip(paint).all(|(a, b)| (a - b).abs() < 1e-6));
        let (stained, mixed) = (at(0.5), mix(0.5));
        let hue = |v: [f32; 3]| v[1] / v[0];
        assert!(hue(stained) <= hue(paint) + 0.01 && hue(mixed) > hue(paint) + 0.04, "{stained:?} against {mixed:?}");
        assert!(pixel_luminance(&stained) < 0.9 * pixel_luminance(&paint), "and it darkens: {stained:?}");
        // A rim texel (opacity 0.8) whose own end state is the capture's
        // grey-ochre fringe stays as saturated as the paint (0.72 against
        // 0.71); laid over at o^2 it greyed to 0.54, a grey-olive ring.
        let fringe = [0.55, 0.5, 0.42];
        let rim: [f32; 3] = std::array::from_fn(|c| arrived_colour(paint[c], fringe[c], steel[c], 0.8));
        let saturation = |v: [f32; 3]| (v[0] - v[2]) / v[0];
        assert!(saturation(rim) > 0.95 * saturation(paint), "a rim keeps the paint's saturation: {rim:?}");
    }

    /// A square that arrives gets a one-texel fringe that arrives with it,
    /// part opaque, in the material's mean end state; texels further out
    /// stay bare.
    #[test]
    fn arriving_outlines_are_antialiased() {
        let (w, h) = (24, 24);
        let inside = |x: usize, y: usize| (8..16).contains(&x) && (8..16).contains(&y);
        let mut arrivals: Vec<f32> = (0..w * h).map(|i| if inside(i % w, i / w) { 0.5 } else { 2.0 }).collect();
        let mut ends = vec![([0.5, 0.4, 0.3], 1.0); w * h];
        let pace =
            Pace { arrivals: vec![0.5], share: 0.1, colour: [0.3, 0.16, 0.07], strength: 1.0, opacity: 1.0, bare: [0.6; 3], top: 1.0 };
        antialias((w, h), &mut arrivals, &mut ends, &pace);
        let at = |x: usize, y: usize| y * w + x;
        for (x, y) in [(7, 12), (16, 12), (12, 7), (12, 16)] {
            let (a, (colour, o)) = (arrivals[at(x, y)], ends[at(x, y)]);
            assert!((a - 0.5).abs() < 1e-5 && (0.1..0.6).contains(&o) && colour == pace.colour, "edge ({x}, {y}): {a} {o} {colour:?}");
        }
        assert!(arrivals[at(5, 12)] > 1.0 && arrivals[at(12, 12)] == 0.5 && ends[at(12, 12)] == ([0.5, 0.4, 0.3], 1.0));
    }

    #[test]
    fn the_result_equals_the_target_at_t0_and_follows_its_pattern() {
        let (frames, times) = drying_wood(48, 48, 11, 4);
        let wood = fit(&frames, &times, 3, drying_wood_params()).unwrap().material;
        let target = crate::samples::cobbles(64, 56, 2);
        let t0 = 1.0;
        let params = TransferParams { t0, mode: Mode::Ratio, ..TransferParams::default() };
        let out = transfer(&wood, &target, None, &params, 3, None).unwrap().material;
        let at = out.evaluate(t0);
        let err = (0..56)
            .flat_map(|y| (0..64).map(move |x| (x, y)))
            .map(|(x, y)| (0..3).map(|c| (at.pixel(x, y)[c] - target.pixel(x, y)[c]).abs()).fold(0.0f32, f32::max))
            .fold(0.0f32, f32::max);
        assert!(err < 1e-5, "{err}");
        // Earlier, wet: darker than the target where it was transferred.
        let wet = out.evaluate(0.0);
        let mean = |img: &Image| img.data().chunks_exact(img.channels()).map(|p| p[0]).sum::<f32>() / (64.0 * 56.0);
        assert!(mean(&wet) < 0.9 * mean(&target), "wet {} vs target {}", mean(&wet), mean(&target));
        assert!(transfer(&wood, &target, None, &TransferParams { t0: 1.5, ..params.clone() }, 3, None).is_err());
        // Offset mode is exact at t0 too, and adds the change unscaled.
        let offset = transfer(&wood, &target, None, &TransferParams { mode: Mode::Offset, ..params }, 3, None).unwrap().material;
        let at = offset.evaluate(t0);
        assert!(at.data().chunks_exact(7).zip(target.data().chunks_exact(3)).all(|(a, b)| (0..3).all(|c| (a[c] - b[c]).abs() < 1e-5)));
    }
}
