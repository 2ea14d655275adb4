//! Transfer (Meister et al., section 6.2): carry a material's time
//! behaviour onto a static target texture. The guide is the
//! histogram-equalised luminance of the material's albedo at t0 (source)
//! and of the target (target); the coefficients are synthesized under that
//! guide (by [`super::enlarge::enlarge`], on its fast orthonormal-basis
//! path) and then scaled per texel (eq. 16), a_out = a_in p_tex / p_in(t0),
//! so that at t0 the result's albedo equals the target exactly.
//!
//! Guard (ours): the ratio s = p_tex / p_in(t0) is clamped to [1/4, 4] (and
//! taken as 1 where |p_in(t0)| < 1e-3), and what the clamped ratio misses is
//! added to the constant coefficient: a_out = s a_in + (p_tex - s p_in(t0))
//! e_0. This keeps the equality at t0 exactly; without the clamp a dark
//! source at t0 (bare soil under later snow) multiplied the target by 15
//! and blew it out to white.

use super::enlarge::{enlarge, EnlargeParams, Illumination};
use super::material::Material;
use super::poly::evaluate;
use crate::error::{Error, Result};
use crate::image::color::luminance;
use crate::image::Image;
use crate::synth::{OptimizeParams, Progress};
use serde::{Deserialize, Serialize};

/// Smallest |p_in(t0)| divided by.
const RATIO_FLOOR: f32 = 1e-3;
/// Largest scale (and smallest, inverted) eq. 16 may apply.
const RATIO_LIMIT: f32 = 4.0;

/// Ranks of a one-channel image's values mapped to [0, 1] (ties share the
/// lowest rank): its histogram-equalised version.
pub fn equalize(img: &Image) -> Image {
    let v = img.data();
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]).then(a.cmp(&b)));
    let mut out = vec![0.0f32; v.len()];
    let scale = 1.0 / (v.len().max(2) - 1) as f32;
    let mut rank = 0;
    for (i, &idx) in order.iter().enumerate() {
        if i > 0 && v[idx] != v[order[i - 1]] {
            rank = i;
        }
        out[idx] = rank as f32 * scale;
    }
    Image::from_data(img.width(), img.height(), 1, out).expect("same size")
}

/// How the target's albedo is tied to the material's at t0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Eq. 16: coefficients scaled by p_tex / p_in(t0) (clamped, see the
    /// module docs). Right for changes proportional to the base colour
    /// (wetting darkens, dust dulls).
    #[default]
    Ratio,
    /// a_0 += p_tex - p_in(t0): the material's change over time is added
    /// unscaled. Right for accumulation (snow, moss, paint) whose colour
    /// does not depend on what lies beneath. Not in the paper.
    Offset,
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
        TransferParams { t0: 0.0, guide_weight: 2.0, mode: Mode::Ratio, optimize: OptimizeParams::default() }
    }
}

/// The material's behaviour on `target` (an RGB texture, the output's size),
/// matching it exactly at time `t0`. The material needs a 3-channel
/// `Diffuse` parameter.
pub fn transfer(material: &Material, target: &Image, params: &TransferParams, seed: u64, progress: Option<Progress>) -> Result<Material> {
    let (t0, guide_weight) = (params.t0, params.guide_weight);
    if !(0.0..=1.0).contains(&t0) {
        return Err(Error::invalid(format!("t0 must be in [0, 1], got {t0}")));
    }
    let kd =
        material.param("diffuse").filter(|r| r.len() == 3).ok_or_else(|| Error::invalid("transfer needs a 3-channel Diffuse parameter"))?;
    if target.channels() < 3 {
        return Err(Error::invalid(format!("the target must be an RGB texture, it has {} channels", target.channels())));
    }
    let source_guide = equalize(&luminance(&material.evaluate(t0).select_channels(kd.clone())));
    let target_guide = equalize(&luminance(&target.select_channels(0..3)));
    let mut coefficients = enlarge(
        material,
        target.size(),
        &EnlargeParams { illumination: Illumination::Keep, optimize: params.optimize.clone(), ..EnlargeParams::default() },
        Some((&source_guide, &target_guide, guide_weight)),
        seed,
        progress,
    )?
    .coefficients;
    let m = material.degree + 1;
    for y in 0..target.height() {
        for x in 0..target.width() {
            let want = target.pixel(x, y)[..3].to_vec();
            let px = coefficients.pixel_mut(x, y);
            for (c, w) in kd.clone().zip(want) {
                let a = &mut px[c * m..(c + 1) * m];
                let at_t0 = evaluate(a, t0);
                let s = match params.mode {
                    Mode::Ratio if at_t0.abs() >= RATIO_FLOOR => (w / at_t0).clamp(1.0 / RATIO_LIMIT, RATIO_LIMIT),
                    _ => 1.0,
                };
                a.iter_mut().for_each(|v| *v *= s);
                a[0] += w - s * at_t0;
            }
        }
    }
    let mut out = Material::new(material.degree, material.params.clone(), coefficients)?;
    out.encoding = material.encoding;
    Ok(out)
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
        let params = TransferParams { t0, ..TransferParams::default() };
        let out = transfer(&wood, &target, &params, 3, None).unwrap();
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
        assert!(transfer(&wood, &target, &TransferParams { t0: 1.5, ..params.clone() }, 3, None).is_err());
        // Offset mode is exact at t0 too, and adds the change unscaled.
        let offset = transfer(&wood, &target, &TransferParams { mode: Mode::Offset, ..params }, 3, None).unwrap();
        let at = offset.evaluate(t0);
        assert!(at.data().chunks_exact(7).zip(target.data().chunks_exact(3)).all(|(a, b)| (0..3).all(|c| (a[c] - b[c]).abs() < 1e-5)));
    }

    #[test]
    fn equalization_spreads_values_evenly() {
        let img = Image::from_fn(4, 1, 1, |x, _, p| p[0] = [0.1, 0.9, 0.5, 0.11][x]);
        assert_eq!(equalize(&img).data(), &[0.0, 1.0, 2.0 / 3.0, 1.0 / 3.0]);
    }
}
