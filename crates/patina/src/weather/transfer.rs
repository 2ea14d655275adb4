//! Weathering transfer (Bellini et al. 2016, section 7, eq. 3): the
//! weathering of a source texture S carried onto a target texture T.
//!
//! Delta_S = |S - intact(S)|, normalised to [0, 1] (by its 98th
//! percentile, see [`delta_scale`]). The template at time
//! t is I_t = T (1 - Delta_S,t) + S Delta_S,t, where Delta_S,t keeps only
//! the pixels of S already weathered at t (age > 1 - t, as in the
//! de-weathering sequence), and I_t is rebuilt with patches of T.
//!
//! Departures: T's patches alone cannot show rust T never had, so the
//! exemplar of the rebuild is T beside S (T's patches where T shows,
//! S's weathered patches where the weathering shows). S is resized to T's
//! size when they differ.

use super::rebuild::{colour_distance, delta_scale, rebuild, Engine, RebuildParams};
use super::sequence::{settle, Frame};
use crate::error::{Error, Result};
use crate::image::resample::{resize, Filter};
use crate::image::Image;
use crate::rng;

/// The weathered texture S with its age map and intact texture.
#[derive(Clone, Copy, Debug)]
pub struct Source<'a> {
    pub image: &'a Image,
    pub age: &'a Image,
    pub intact: &'a Image,
}

/// Frames of T taking on S's weathering at `times` (each in (0, 1]).
pub fn transfer(
    source: &Source,
    target: &Image,
    times: &[f32],
    params: &RebuildParams,
    seed: u64,
    progress: &dyn Fn(usize),
) -> Result<Vec<Frame>> {
    let (source_age, source_intact) = (source.age, source.intact);
    let source = source.image;
    if source.channels() != target.channels() {
        return Err(Error::invalid(format!("the source has {} channels but the target has {}", source.channels(), target.channels())));
    }
    if times.iter().any(|t| !(*t > 0.0 && *t <= 1.0)) {
        return Err(Error::invalid("transfer times must lie in (0, 1]"));
    }
    let (w, h) = target.size();
    let fit = |img: &Image| if img.size() == (w, h) { Ok(img.clone()) } else { resize(img, w, h, Filter::Cubic) };
    let (s, age, s_intact) = (fit(source)?, fit(source_age)?, fit(source_intact)?);
    let delta = colour_distance(&s, &s_intact)?;
    let top = delta_scale(&delta);
    // The rebuild's exemplar: T and S side by side.
    let n = target.channels();
    let exemplar = Image::from_fn(2 * w, h, n, |x, y, p| p.copy_from_slice(if x < w { target.pixel(x, y) } else { s.pixel(x - w, y) }));
    let mut frames = Vec::with_capacity(times.len());
    let mut previous = target.clone();
    for (k, &t) in times.iter().enumerate() {
        let template = Image::from_fn(w, h, n, |x, y, p| {
            let a = age.at(x, y, 0);
            let d = if a > 1.0 - t { (delta[y * w + x] / top).min(1.0) } else { 0.0 };
            for (c, v) in p.iter_mut().enumerate() {
                *v = target.at(x, y, c) * (1.0 - d) + s.at(x, y, c) * d;
            }
        });
        let rebuilt = rebuild(&exemplar, &template, None, Engine::Optimize, params, rng::derive(seed, &[k as u64]))?;
        // Monotone: a pixel never moves back towards the clean target.
        previous = settle(&rebuilt, &template, &previous, target)?;
        frames.push(Frame { t, image: previous.clone() });
        progress(k + 1);
    }
    Ok(frames)
}
