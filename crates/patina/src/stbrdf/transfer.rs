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
//!   texel is covered by the material as far as its own change has come:
//!   c(x, t) = smoothstep(0.05, 0.3, g(x, t)), never shrinking away
//!   from t0 (what has arrived stays), with g the texel's
//!   progress towards its end state (t_D = 1, or 0 when t0 > 0.5):
//!   the projection of p(x, t) - p(x, t0) on D(x) = p(x, t_D) - p(x, t0),
//!   over |D(x)|^2. Changes in other
//!   directions (bare steel brightening before it rusts, a capture's
//!   drift) do not count, a spot counts as arrived before it has darkened
//!   all the way. The material arrives only on texels whose whole change
//!   |D| passes 0.5 to 0.8 of the 90th percentile's (the spots, not
//!   rusting steel's pale background, which washed the object out);
//!   out(x, t) = target(x) + c(x, t) (S(x) p(x, t_D) - target(x)), where
//!   p(x, t_D) is what the material becomes there (rust, not the bare
//!   steel it was before it rusted) and S is the target's
//!   luminance over its median (its shading, so the arriving material is
//!   lit like the object). A spot that
//!   appears late in the source appears late on the target, where the
//!   guided synthesis put it. The result is refitted per texel by least
//!   squares, with the polynomial pinned to the target at t0
//!   ([`Fitter::anchored`]), at degree 6 at least ([`GROW_DEGREE`]).
//!
//! With a mask, only the object changes: the result is blended with the
//! target by the mask's value, and texels outside it hold the target as a
//! constant polynomial (bit-identical at every t).

use super::enlarge::{enlarge, EnlargeParams};
use super::material::Material;
use super::poly::{evaluate, Fitter};
use crate::error::{Error, Result};
use crate::image::color::luminance;
use crate::image::filter::equalize;
use crate::image::Image;
use crate::synth::{OptimizeParams, Progress};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Smallest |p_in(t0)| divided by.
const RATIO_FLOOR: f32 = 1e-3;
/// Largest scale (and smallest, inverted) eq. 16 may apply.
const RATIO_LIMIT: f32 = 4.0;
/// [`Mode::Auto`] picks offset when the median texel's largest change is at
/// least this share of its value at t0.
const AUTO_OFFSET_CHANGE: f32 = 0.5;
/// [`Mode::Grow`]'s cover ramps over this band of a texel's progress
/// towards its largest change (module docs).
const GROW_PROGRESS: (f32, f32) = (0.05, 0.3);
/// The material arrives on texels whose whole change (an RGB distance)
/// passes this band of the 90th percentile's ([`GROW_TOP`]), and never
/// where it is below [`GROW_MIN_CHANGE`].
const GROW_TOP: f32 = 0.9;
const GROW_BAND: (f32, f32) = (0.5, 0.8);
const GROW_MIN_CHANGE: (f32, f32) = (0.04, 0.12);
/// Smallest degree of [`Mode::Grow`]'s result: a cubic cannot follow a
/// texel's cover switching on, and rang (a spot darkening, lightening,
/// then darkening again).
const GROW_DEGREE: usize = 6;
/// Limits of the target's shading (luminance over its median) that
/// [`Mode::Grow`] lights the arriving material with.
const SHADING_RANGE: (f32, f32) = (0.2, 2.0);

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
    /// Weight of the equalised-luminance guides.
    pub guide_weight: f32,
    pub mode: Mode,
    pub optimize: OptimizeParams,
}

impl Default for TransferParams {
    fn default() -> Self {
        TransferParams { t0: 0.0, guide_weight: 2.0, mode: Mode::Grow, optimize: OptimizeParams::default() }
    }
}

/// A transferred material and the mode used (auto resolved).
#[derive(Clone, Debug)]
pub struct Transferred {
    pub material: Material,
    pub mode: Mode,
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
    let (t0, guide_weight) = (params.t0, params.guide_weight);
    if !(0.0..=1.0).contains(&t0) {
        return Err(Error::invalid(format!("t0 must be in [0, 1], got {t0}")));
    }
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
    let source_guide = equalize(&luminance(&material.evaluate(t0).select_channels(kd.clone())));
    let target_guide = equalize(&luminance(&target.select_channels(0..3)));
    let synthesized = enlarge(
        material,
        target.size(),
        &EnlargeParams { optimize: params.optimize.clone(), ..EnlargeParams::default() },
        Some((&source_guide, &target_guide, guide_weight)),
        seed,
        progress,
    )?;
    let mode = match params.mode {
        Mode::Auto if relative_change(material, kd.clone(), t0) >= AUTO_OFFSET_CHANGE => Mode::Offset,
        Mode::Auto => Mode::Ratio,
        chosen => chosen,
    };
    let (degree, coefficients) = match mode {
        Mode::Grow => grow(&synthesized, target, mask, kd, t0)?,
        _ => (material.degree, scaled(&synthesized, target, kd, t0, mode)),
    };
    let mut out = Material::new(degree, material.params.clone(), coefficients)?;
    out.encoding = material.encoding;
    if let Some(m) = mask {
        keep_outside(&mut out, target, m, t0);
    }
    Ok(Transferred { material: out, mode })
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
    let mid = largest.len() / 2;
    *largest.select_nth_unstable_by(mid, f32::total_cmp).1
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

/// [`Mode::Grow`] (module docs): per texel, the cover c(t) from the
/// synthesized Diffuse's progress towards its end state, the Diffuse
/// pulled from the target towards what the material becomes there (lit by
/// the target's shading) by c, every other parameter from its t0 value
/// towards its value then by c, refitted pinned at t0.
fn grow(material: &Material, target: &Image, mask: Option<&Image>, kd: std::ops::Range<usize>, t0: f32) -> Result<(usize, Image)> {
    let m = material.degree + 1;
    let out_degree = material.degree.max(GROW_DEGREE);
    let samples = 4 * (out_degree + 1);
    let times: Vec<f32> = (0..samples).map(|i| i as f32 / (samples - 1) as f32).collect();
    let fitter = Fitter::anchored(&times, out_degree, t0)?;
    let mo = out_degree + 1;
    let channels = material.channels();
    // The Diffuse change since t0 at each sample time.
    let delta = |a: &[f32], t: f32| -> [f32; 3] {
        std::array::from_fn(|i| {
            let c = kd.start + i;
            evaluate(&a[c * m..(c + 1) * m], t) - evaluate(&a[c * m..(c + 1) * m], t0)
        })
    };
    let coefficients = &material.coefficients;
    let n = coefficients.channels();
    // Each texel's cover is its progress towards its own end state (t = 1,
    // or t = 0 when t0 is past the middle): the projection of the change so
    // far on the whole change. Changes in other directions (bare steel
    // brightening before it rusts, the capture's drift) do not count, and
    // a spot counts as arrived well before it has darkened all the way.
    let end_at = if t0 <= 0.5 { 1.0 } else { 0.0 };
    let whole = |a: &[f32]| delta(a, end_at).iter().map(|v| v * v).sum::<f32>().sqrt();
    // Which texels the material arrives on: those whose whole change is
    // near the largest (the 90th percentile over the object). The rest of
    // the material (rusting steel's pale background) stays the target's:
    // covering the paint with it washed the object out.
    let sizes: Vec<f32> = coefficients.data().par_chunks(n).map(whole).collect();
    let inside = on_object(&sizes, mask);
    let top = if inside.is_empty() { 1.0 } else { quantile(&inside, GROW_TOP) };
    let band = ((GROW_BAND.0 * top).max(GROW_MIN_CHANGE.0), (GROW_BAND.1 * top).max(GROW_MIN_CHANGE.1));
    // What has arrived stays: the cover only grows away from t0, forwards
    // from the first sample at or after it and backwards from the one before.
    let first_after = times.iter().position(|&t| t >= t0).unwrap_or(times.len());
    let cover_of = |a: &[f32], cover: &mut [f32]| {
        let end = delta(a, end_at);
        let size = end.iter().map(|v| v * v).sum::<f32>();
        let matters = smoothstep(band.0, band.1, size.sqrt());
        for (c, &t) in cover.iter_mut().zip(&times) {
            let d = delta(a, t);
            let progress = if size > 0.0 { (d[0] * end[0] + d[1] * end[1] + d[2] * end[2]) / size } else { 0.0 };
            *c = matters * smoothstep(GROW_PROGRESS.0, GROW_PROGRESS.1, progress);
        }
        for k in first_after + 1..cover.len() {
            cover[k] = cover[k].max(cover[k - 1]);
        }
        for k in (0..first_after.saturating_sub(1)).rev() {
            cover[k] = cover[k].max(cover[k + 1]);
        }
    };
    // The target's shading, relative to its median luminance (over the object).
    let lum = luminance(&target.select_channels(0..3));
    let lums = on_object(lum.data(), mask);
    let median = if lums.is_empty() { 1.0 } else { quantile(&lums, 0.5).max(1e-3) };
    let mut out = Image::new(coefficients.width(), coefficients.height(), channels * mo);
    out.data_mut()
        .par_chunks_mut(channels * mo)
        .zip(coefficients.data().par_chunks(n))
        .zip(target.data().par_chunks(target.channels()))
        .zip(lum.data().par_iter())
        .for_each_init(
            || (vec![0f32; samples], vec![0f32; samples]),
            |(cover, q), (((o, a), want), &l)| {
                let shading = (l / median).clamp(SHADING_RANGE.0, SHADING_RANGE.1);
                cover_of(a, cover);
                for c in 0..channels {
                    let poly = &a[c * m..(c + 1) * m];
                    let diffuse = kd.contains(&c);
                    let base = if diffuse { want[c - kd.start] } else { evaluate(poly, t0) };
                    let arrived = if diffuse { shading } else { 1.0 } * evaluate(poly, end_at);
                    for (qk, &ck) in q.iter_mut().zip(cover.iter()) {
                        *qk = ck * (arrived - base);
                    }
                    let dst = &mut o[c * mo..(c + 1) * mo];
                    fitter.fit_into(q, dst);
                    dst[0] += base;
                }
            },
        );
    Ok((out_degree, out))
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
