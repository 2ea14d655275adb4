//! Enlargement (Meister et al., section 6.1): texture optimization on the
//! coefficient image, with PatchMatch comparing whole time behaviours by
//! the closed-form distance (eq. 14) per parameter group, and voting
//! averaging coefficients, which is exact for polynomials (section 5.2).
//!
//! [`metric`] is that distance as the engine's pluggable group distance.
//! [`enlarge`] runs the same costs faster: in the orthonormal (shifted
//! Legendre) basis the distance is a plain SSD, so the engine's row-SSD
//! path and a proper quilt start apply.

use super::material::Material;
use super::poly::{Orthonormal, PolyDistance};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::synth::{GroupDistance, OptimizeParams, PatchMetric, Progress, Synthesis};
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

/// Enlarge (or shrink) `material` to `width` x `height`. With guides (a
/// source guide of the material's size and a target guide of the output's),
/// the synthesis follows them, e.g. gradients as in the paper's Fig. 9.
pub fn enlarge(
    material: &Material,
    (width, height): (usize, usize),
    weights: Option<&[f32]>,
    guides: Option<(&Image, &Image, f32)>,
    params: &OptimizeParams,
    seed: u64,
    progress: Option<Progress>,
) -> Result<Material> {
    // Synthesis runs on the coefficients in the orthonormal basis, where the
    // closed-form distance is a plain SSD (same costs, fast path), and the
    // result is mapped back.
    let basis = Orthonormal::new(material.degree);
    let mut coefficients = material.coefficients.clone();
    basis.apply(coefficients.data_mut(), true);
    let mut problem = Synthesis::new(&coefficients).size(width, height).metric(orthonormal_metric(material, weights)?).seed(seed);
    if let Some((s, t, w)) = guides {
        problem = problem.guides(s, t, w);
    }
    if let Some(p) = progress {
        problem = problem.progress(p);
    }
    let mut out = problem.optimize(params)?.image;
    basis.apply(out.data_mut(), false);
    Material::new(material.degree, material.params.clone(), out)
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
        let big = enlarge(&wood, (128, 128), None, None, &OptimizeParams::default(), 1, None).unwrap();
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
        let big = enlarge(&wood, (96, 48), None, Some((&sg, &tg, 4.0)), &OptimizeParams::default(), 3, None).unwrap();
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
