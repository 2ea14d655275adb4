//! Enlargement (Meister et al., section 6.1): texture optimization on the
//! coefficient image, with PatchMatch comparing whole time behaviours by
//! the closed-form distance (eq. 14) per parameter group, and voting
//! averaging coefficients, which is exact for polynomials (section 5.2).
//!
//! [`metric`] is that distance as the engine's pluggable group distance.
//! [`enlarge`] runs the same costs faster: in the orthonormal (shifted
//! Legendre) basis the distance is a plain SSD, so the engine's row-SSD
//! path and a proper quilt start apply.

use super::material::{Encoding, Material};
use super::poly::{Orthonormal, PolyDistance};
use crate::error::{Error, Result};
use crate::image::color::luminance;
use crate::image::Image;
use crate::synth::blend::blend_seams;
use crate::synth::lighting;
use crate::synth::{GroupDistance, OptimizeParams, PatchMetric, Progress, Relight, Synthesis};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The patch metric over a material's coefficients: one closed-form
/// polynomial distance per parameter, weighted by `weights` (one per
/// parameter; `None` = 1 each) and divided by the parameter's channels so
/// that an RGB parameter does not outweigh roughness threefold.
pub fn metric(material: &Material, weights: Option<&[f32]>) -> Result<PatchMetric> {
    if let Some(w) = weights {
        if w.len() != material.params.len() || w.iter().any(|v| !v.is_finite() || *v < 0.0) {
            return Err(Error::invalid(format!(
                "give one weight >= 0 per parameter ({} parameters: {})",
                material.params.len(),
                material.params.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", ")
            )));
        }
    }
    let m = material.degree + 1;
    let distance = Arc::new(PolyDistance::new(material.degree));
    let mut start = 0;
    let groups = material
        .params
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let weight = weights.map_or(1.0, |w| w[i]) / p.channels as f32;
            let g = (start..start + p.channels * m, GroupDistance::Custom { weight, distance: distance.clone() });
            start += p.channels * m;
            g
        })
        .collect();
    Ok(PatchMetric::from_groups(material.coefficients.channels(), groups))
}

/// The weighted-SSD twin of [`metric`] for coefficients in the orthonormal
/// basis ([`Orthonormal`]): the same costs, on the engine's fast path.
fn orthonormal_metric(material: &Material, weights: Option<&[f32]>) -> Result<PatchMetric> {
    metric(material, weights)?;
    let m = material.degree + 1;
    let w: Vec<f32> = material
        .params
        .iter()
        .enumerate()
        .flat_map(|(i, p)| std::iter::repeat_n(weights.map_or(1.0, |w| w[i]) / p.channels as f32, p.channels * m))
        .collect();
    Ok(PatchMetric::ssd(w))
}

/// How an enlargement treats the capture's lighting (a vignette, a light
/// ramp across the sample), which a fitted albedo carries as slow
/// multiplicative variation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Illumination {
    /// `Flat` for materials fitted to photos (sRGB-encoded: a capture's
    /// light is in their albedo), `Keep` for linear ones (authored or
    /// measured materials, whose large-scale variation is content: on a
    /// 64 px drying-wood material, removing a field doubled the distance
    /// of the enlarged patches to the input's).
    #[default]
    Auto,
    /// Copy it with the patches (bright and dark patches, a seam where they meet).
    Keep,
    /// Remove it and light the result evenly at the input's mean brightness.
    Flat,
    /// Remove it, then stretch the input's own field over the result.
    Stretch,
}

/// Parameters of [`enlarge`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EnlargeParams {
    /// One weight >= 0 per parameter (`None` = 1 each).
    pub weights: Option<Vec<f32>>,
    pub illumination: Illumination,
    /// Blend the seams between copied regions in the gradient domain.
    pub blend_seams: bool,
    /// Make the material tile (wrap-around synthesis, see
    /// [`Synthesis::tileable`]). The seam blend's Poisson solve does not
    /// wrap, so tileable runs skip it; lighting can be flat or kept, not
    /// stretched.
    pub tileable: bool,
    /// Inside coherent copies, each texel becomes its match's own
    /// coefficients instead of the vote's average
    /// ([`crate::synth::Synthesized::coherent_copies`]): the source's
    /// texel-scale texture is kept where the vote would smooth it.
    pub verbatim: bool,
    pub optimize: OptimizeParams,
}

impl Default for EnlargeParams {
    fn default() -> Self {
        EnlargeParams {
            weights: None,
            illumination: Illumination::Auto,
            blend_seams: true,
            tileable: false,
            verbatim: false,
            optimize: OptimizeParams::default(),
        }
    }
}

/// The time average over [0, 1] of each channel of parameter `range`:
/// the integral of sum a_k t^k is sum a_k / (k + 1).
pub fn time_average(material: &Material, range: std::ops::Range<usize>) -> Image {
    let m = material.degree + 1;
    let (w, h) = material.size();
    Image::from_fn(w, h, range.len(), |x, y, p| {
        let px = material.coefficients.pixel(x, y);
        for (o, c) in p.iter_mut().zip(range.clone()) {
            *o = px[c * m..(c + 1) * m].iter().enumerate().map(|(k, a)| a / (k + 1) as f32).sum();
        }
    })
}

/// Multiply every coefficient of the channels in `range` (parameter
/// channels) by the pixel's gain: the polynomial is scaled at every t.
fn scale_channels(coefficients: &mut Image, range: std::ops::Range<usize>, m: usize, gain: &[f32]) {
    let n = coefficients.channels();
    coefficients.data_mut().par_chunks_mut(n).zip(gain.par_iter()).for_each(|(px, g)| {
        px[range.start * m..range.end * m].iter_mut().for_each(|v| *v *= g);
    });
}

/// Enlarge (or shrink) `material` to `width` x `height`. With guides (a
/// source guide of the material's size and a target guide of the output's),
/// the synthesis follows them, e.g. gradients as in the paper's Fig. 9.
///
/// Beyond the paper, for real captures:
/// - lighting-aware synthesis (the engine's [`lighting`]): the
///   illumination field of the time-averaged albedo is divided out of every
///   coefficient of the Diffuse parameter (the capture's light multiplies
///   the albedo at every t, and the map is linear), the coefficients are
///   synthesized, and the result is re-lit as `params.illumination` says;
/// - gradient-domain seam blending ([`blend_seams`]) of the coefficients
///   (unguided runs only), exact in coefficient space since evaluation is
///   linear: the blended material evaluated at any t is the blend of the
///   evaluated frames.
///
/// The illumination field is [`lighting::separate_smooth`]'s cubic in x
/// and y: the engine's Gaussian field at 1/8 of the side took a drying
/// material's wet patches for light on 64 px samples.
pub fn enlarge(
    material: &Material,
    (width, height): (usize, usize),
    params: &EnlargeParams,
    guides: Option<(&Image, &Image, f32)>,
    seed: u64,
    progress: Option<Progress>,
) -> Result<Material> {
    let weights = params.weights.as_deref();
    let m = material.degree + 1;
    let mut coefficients = material.coefficients.clone();
    let diffuse = material.param("diffuse");
    let illumination = match params.illumination {
        Illumination::Auto if material.encoding == Encoding::Srgb => Illumination::Flat,
        Illumination::Auto => Illumination::Keep,
        chosen => chosen,
    };
    // How the result is re-lit once synthesized, when the light is removed.
    let how = if illumination == Illumination::Stretch { Relight::Stretch } else { Relight::Flat };
    if params.tileable {
        how.check_tileable("material", "capture's")?;
    }
    let separation = match (&diffuse, illumination) {
        (Some(kd), Illumination::Flat | Illumination::Stretch) => {
            let sep = lighting::separate_smooth(&time_average(material, kd.clone()));
            scale_channels(&mut coefficients, kd.clone(), m, &sep.unlit_gain());
            Some((kd.clone(), sep))
        }
        _ => None,
    };
    // Synthesis runs on the coefficients in the orthonormal basis, where the
    // closed-form distance is a plain SSD (same costs, fast path), and the
    // result is mapped back.
    let basis = Orthonormal::new(material.degree);
    basis.apply(coefficients.data_mut(), true);
    let mut problem = Synthesis::new(&coefficients)
        .size(width, height)
        .metric(orthonormal_metric(material, weights)?)
        .seed(seed)
        .tileable(params.tileable);
    if let Some((s, t, w)) = guides {
        problem = problem.guides(s, t, w);
    }
    if let Some(p) = progress {
        problem = problem.progress(p);
    }
    let mut synthesized = problem.optimize(&params.optimize)?;
    if params.verbatim {
        synthesized.coherent_copies(&coefficients, &crate::image::Mask::filled(width, height, true));
    }
    // Guided synthesis places content by the guide, not in blocks: nearly
    // every neighbour pair is a "seam", and blending would integrate the
    // source's gradients back into its own layout (a ramp re-imposed).
    let mut out = if params.blend_seams && guides.is_none() && !params.tileable {
        let positions: Vec<(u32, u32)> = synthesized.nnf.matches().iter().map(|p| (p.x, p.y)).collect();
        blend_seams(&synthesized.image, &coefficients, &positions, None)
    } else {
        synthesized.image
    };
    basis.apply(out.data_mut(), false);
    let mut result = Material::new(material.degree, material.params.clone(), out)?;
    result.encoding = material.encoding;
    if let Some((kd, sep)) = separation {
        let mean = || {
            let avg = luminance(&time_average(&result, kd.clone()));
            avg.data().iter().map(|&v| v as f64).sum::<f64>() as f32 / avg.data().len().max(1) as f32
        };
        if let Some(gain) = lighting::gain((width, height), &sep, how, mean)? {
            scale_channels(&mut result.coefficients, kd, m, &gain);
        }
    }
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stbrdf::fit::fit;
    use crate::stbrdf::procedural::{drying_wood, drying_wood_params};

    #[test]
    fn a_28_channel_material_enlarges_seamlessly_at_every_time() {
        let (frames, times) = drying_wood(64, 64, 11, 3);
        let wood = fit(&frames, &times, 3, drying_wood_params()).unwrap().material;
        assert_eq!(wood.coefficients.channels(), 28);
        let big = enlarge(&wood, (128, 128), &EnlargeParams::default(), None, 1, None).unwrap();
        assert_eq!(big.size(), (128, 128));
        for t in [0.0, 0.4, 0.7, 1.0] {
            let (a, b) = (big.evaluate(t), wood.evaluate(t));
            let sim = crate::metrics::bidirectional(&a, &b, 5, 2).unwrap();
            let own = crate::metrics::self_similarity(&b, 5, 2).unwrap();
            assert!(sim.coherence <= 1.5 * own, "t = {t}: coherence {} vs self-similarity {own}", sim.coherence);
        }
    }

    /// Fig. 9's use of guides: a material that brightens left to right,
    /// guided by a ramp and enlarged under the reversed ramp, must come out
    /// brightening right to left.
    #[test]
    fn guides_steer_where_the_material_goes() {
        let (frames, times) = drying_wood(48, 48, 5, 2);
        let mut wood = fit(&frames, &times, 2, drying_wood_params()).unwrap().material;
        let ramp = |w: usize, h: usize, flip: bool| {
            let mut g = Image::new(w, h, 1);
            for y in 0..h {
                for x in 0..w {
                    let r = x as f32 / (w - 1) as f32;
                    g.pixel_mut(x, y)[0] = if flip { 1.0 - r } else { r };
                }
            }
            g
        };
        let (w, h) = wood.size();
        for y in 0..h {
            for x in 0..w {
                wood.coefficients.pixel_mut(x, y)[0] += 0.5 * x as f32 / w as f32;
            }
        }
        let (sg, tg) = (ramp(w, h, false), ramp(96, 48, true));
        let big = enlarge(
            &wood,
            (96, 48),
            &EnlargeParams { illumination: Illumination::Keep, ..Default::default() },
            Some((&sg, &tg, 4.0)),
            3,
            None,
        )
        .unwrap();
        let band = |x0: usize, x1: usize| {
            let kd = big.evaluate(0.0);
            let (mut sum, mut n) = (0.0, 0.0);
            for y in 0..48 {
                for x in x0..x1 {
                    sum += kd.at(x, y, 0);
                    n += 1.0;
                }
            }
            sum / n
        };
        let (left, right) = (band(0, 24), band(72, 96));
        assert!(left > right + 0.2, "left quarter {left} should be brighter than right {right}");
    }
}
