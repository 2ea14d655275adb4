//! Fitting a material to parameter maps sampled at N times (Meister et
//! al., section 4.1): per texel and channel, the least-squares polynomial,
//! computed with the one pseudo-inverse all texels share.

use super::material::{Material, Param};
use super::poly::{evaluate, Fitter};
use crate::error::{Error, Result};
use crate::image::Image;
use rayon::prelude::*;

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
