//! The intact texture (Bellini et al. 2016, section 5): the input as it
//! was before it weathered.
//!
//! 1. Tile detection ([`super::tiles`]). With a grid, the template is the
//!    median tile: at each pixel, the median over every tile at the same
//!    offset, leaving out the most-aged samples.
//! 2. Without a grid (stochastic texture), the `discard` fraction of most
//!    aged pixels may not be copied from, and the template is the input with
//!    those pixels filled in from the rest ([`Synthesis::fill`]).
//! 3. Either template is rebuilt from the input's allowed patches (guide:
//!    luminance, colour, gradient direction; see [`super::rebuild`]), so
//!    the result is made of real, non-weathered material. The paper uses
//!    quilting texture transfer ([`Engine::Quilt`]); the default is guided
//!    optimization started from such a transfer (see [`IntactParams::engine`]).

use super::layers::Layers;
use super::rebuild::{rebuild, Engine, RebuildParams};
use super::tiles::{self, Lattice};
use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use crate::synth::{OptimizeParams, Synthesis};
use serde::{Deserialize, Serialize};

/// Parameters of the intact texture.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct IntactParams {
    /// Fraction of the most-aged pixels never used as sources. Paper: 20%.
    pub discard: f32,
    /// Look for a tile grid (off: always treat the texture as stochastic).
    pub detect_tiles: bool,
    /// Which synthesis rebuilds the template. The paper quilts; guided
    /// optimization (which starts from a quilt) is the default because on
    /// the photos of ../shared/data quilting left visible 30 px blocks in
    /// smooth rust and took 2.7x longer at 512 px.
    pub engine: Engine,
    /// How the template is rebuilt from input patches.
    pub rebuild: RebuildParams,
}

impl Default for IntactParams {
    fn default() -> Self {
        IntactParams { discard: 0.2, detect_tiles: true, engine: Engine::Optimize, rebuild: RebuildParams::default() }
    }
}

/// The intact texture and what it was made from.
#[derive(Clone, Debug)]
pub struct Intact {
    pub image: Image,
    /// The tile grid, when one was found.
    pub lattice: Option<Lattice>,
    /// The template before rebuilding (median tile or filled input).
    pub template: Image,
    /// Input pixels the rebuild could copy from.
    pub allowed: Mask,
}

/// Pixels whose age is below the (1 - discard) quantile (of their own
/// layer, with layers).
pub fn allowed_sources(age: &Image, discard: f32, layers: Option<&Layers>) -> Mask {
    let label = |i: usize| layers.map_or(0, |l| l.labels[i] as usize);
    let count = layers.map_or(1, |l| l.count);
    let cuts: Vec<f32> = (0..count)
        .map(|l| {
            let mut sorted: Vec<f32> = age.data().iter().enumerate().filter(|(i, _)| label(*i) == l).map(|(_, v)| *v).collect();
            sorted.sort_by(f32::total_cmp);
            if sorted.is_empty() {
                return f32::INFINITY;
            }
            sorted[(((1.0 - discard) * sorted.len() as f32) as usize).min(sorted.len() - 1)]
        })
        .collect();
    let w = age.width();
    Mask::from_fn(w, age.height(), |x, y| discard <= 0.0 || age.at(x, y, 0) < cuts[label(y * w + x)])
}

/// Whether the median tile explains the allowed (intact) pixels: their
/// mean colour distance to it is below half their mean distance to the
/// image's mean colour. A lattice found on a surface seen in perspective
/// (a roof) repeats only roughly; its median tile is a blur and the
/// texture is better treated as stochastic.
fn explains(img: &Image, median: &Image, allowed: &Mask) -> bool {
    let n = img.channels().min(3);
    let count = allowed.count().max(1) as f64;
    let mut mean = vec![0f64; n];
    for (p, _) in img.data().chunks_exact(img.channels()).zip(allowed.bits()).filter(|(_, &a)| a) {
        mean.iter_mut().zip(p).for_each(|(m, v)| *m += *v as f64 / count);
    }
    let (mut residual, mut spread) = (0f64, 0f64);
    for ((p, q), _) in
        img.data().chunks_exact(img.channels()).zip(median.data().chunks_exact(img.channels())).zip(allowed.bits()).filter(|(_, &a)| a)
    {
        residual += (0..n).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum::<f64>().sqrt();
        spread += (0..n).map(|c| (p[c] as f64 - mean[c]).powi(2)).sum::<f64>().sqrt();
    }
    residual < 0.5 * spread
}

/// The intact texture of `img` given its age map.
pub fn intact(img: &Image, age: &Image, layers: Option<&Layers>, params: &IntactParams, seed: u64) -> Result<Intact> {
    if age.size() != img.size() || age.channels() != 1 {
        return Err(Error::invalid(format!(
            "the age map ({}x{}, {} channels) must be one channel the input's size ({}x{})",
            age.width(),
            age.height(),
            age.channels(),
            img.width(),
            img.height()
        )));
    }
    if !(0.0..0.95).contains(&params.discard) {
        return Err(Error::invalid("the discarded fraction must be in [0, 0.95)"));
    }
    let allowed = allowed_sources(age, params.discard, layers);
    let mut lattice = if params.detect_tiles { tiles::detect(img) } else { None };
    let median = lattice.map(|l| tiles::median_tile(img, &l, Some(&allowed)));
    if let Some(m) = &median {
        if !explains(img, m, &allowed) {
            lattice = None;
        }
    }
    let template = match (&lattice, median) {
        (Some(_), Some(m)) => m,
        _ if params.discard > 0.0 => {
            let hole = Mask::from_fn(img.width(), img.height(), |x, y| !allowed.get(x, y)).dilate(1);
            let op = OptimizeParams { patch: 7, ..OptimizeParams::default() };
            Synthesis::new(img).fill(img, &hole).source_mask(&allowed).seed(seed).optimize(&op)?.image
        }
        _ => img.clone(),
    };
    let image = rebuild(img, &template, Some(&allowed), params.engine, &params.rebuild, seed ^ 0x1a7)?;
    Ok(Intact { image, lattice, template, allowed })
}
