//! Fitting a material to parameter maps sampled at N times (Meister et
//! al., section 4.1): per texel and channel, the least-squares polynomial,
//! computed with the one pseudo-inverse all texels share.

use super::material::{param_range, Material, Param};
use super::poly::{evaluate, Fitter};
use crate::error::{Error, Result};
use crate::image::Image;
use rayon::prelude::*;

/// Eq. (9): STAF-style specular albedo coupled with a Gaussian lobe of
/// width sigma, decoupled so that it lies in [0, 1] whatever the roughness:
/// Ks* = Ks sigma^2 pi (1 - exp(-1 / sigma^2)).
pub fn decouple_specular(ks: f32, sigma: f32) -> f32 {
    let s2 = (sigma * sigma).max(1e-8);
    ks * s2 * std::f32::consts::PI * (1.0 - (-1.0 / s2).exp())
}

/// Apply [`decouple_specular`] to the `Specular` channels of every frame,
/// with sigma from the `Roughness` channel (in place).
pub fn decouple_frames(frames: &mut [Image], params: &[Param]) -> Result<()> {
    let (ks, rough) = match (param_range(params, "specular"), param_range(params, "roughness")) {
        (Some(k), Some(r)) => (k, r.start),
        _ => return Err(Error::invalid("decoupling Ks (eq. 9) needs Specular and Roughness parameters")),
    };
    for f in frames.iter_mut() {
        let c = f.channels();
        for px in f.data_mut().chunks_exact_mut(c) {
            let sigma = px[rough];
            for v in &mut px[ks.clone()] {
                *v = decouple_specular(*v, sigma);
            }
        }
    }
    Ok(())
}

/// A fitted material and its per-channel RMS error over the samples.
#[derive(Clone, Debug)]
pub struct Fitted {
    pub material: Material,
    /// One RMS error per parameter channel, over every texel and time.
    pub rms: Vec<f32>,
}

/// Fit degree-`degree` polynomials to `frames` (one image per time in
/// `times`, channels as `params` lists them).
pub fn fit(frames: &[Image], times: &[f32], degree: usize, params: Vec<Param>) -> Result<Fitted> {
    let first = frames.first().ok_or_else(|| Error::invalid("fitting needs at least one time step"))?;
    if frames.len() != times.len() {
        return Err(Error::invalid(format!("{} frames but {} times", frames.len(), times.len())));
    }
    let c: usize = params.iter().map(|p| p.channels).sum();
    if let Some(i) = frames.iter().position(|f| f.size() != first.size() || f.channels() != c) {
        return Err(Error::invalid(format!(
            "time step {i} is {}x{} with {} channels; expected {}x{} with {c}",
            frames[i].width(),
            frames[i].height(),
            frames[i].channels(),
            first.width(),
            first.height()
        )));
    }
    let fitter = Fitter::new(times, degree)?;
    let (w, h) = first.size();
    let m = degree + 1;
    let n = frames.len();
    let mut coefficients = Image::new(w, h, c * m);
    // Per row: coefficients and the squared error of each channel.
    let errors: Vec<Vec<f64>> = coefficients
        .data_mut()
        .par_chunks_mut(w * c * m)
        .enumerate()
        .map(|(y, row)| {
            let mut samples = vec![0.0f32; n];
            let mut err = vec![0.0f64; c];
            for x in 0..w {
                for ch in 0..c {
                    for (s, f) in samples.iter_mut().zip(frames) {
                        *s = f.pixel(x, y)[ch];
                    }
                    let a = &mut row[(x * c + ch) * m..(x * c + ch + 1) * m];
                    fitter.fit_into(&samples, a);
                    err[ch] += samples.iter().zip(times).map(|(s, t)| f64::from(evaluate(a, *t) - s).powi(2)).sum::<f64>();
                }
            }
            err
        })
        .collect();
    let rms = (0..c).map(|ch| (errors.iter().map(|e| e[ch]).sum::<f64>() / (w * h * n) as f64).sqrt() as f32).collect();
    Ok(Fitted { material: Material::new(degree, params, coefficients)?, rms })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decoupled_specular_follows_eq_9() {
        // sigma = 1: Ks pi (1 - 1/e).
        assert!((decouple_specular(0.5, 1.0) - 0.5 * std::f32::consts::PI * (1.0 - (-1.0f32).exp())).abs() < 1e-6);
        // Narrow lobes: Ks* ~ Ks sigma^2 pi.
        assert!((decouple_specular(1.0, 0.1) - 0.01 * std::f32::consts::PI).abs() < 1e-6);
        let params = crate::stbrdf::procedural::drying_wood_params();
        let mut frames = vec![Image::from_fn(2, 1, 7, |_, _, p| p.copy_from_slice(&[0.3, 0.3, 0.3, 0.5, 0.5, 0.5, 1.0]))];
        decouple_frames(&mut frames, &params).unwrap();
        assert!((frames[0].pixel(1, 0)[4] - decouple_specular(0.5, 1.0)).abs() < 1e-6);
        assert_eq!(frames[0].pixel(1, 0)[0], 0.3, "diffuse untouched");
    }
}
