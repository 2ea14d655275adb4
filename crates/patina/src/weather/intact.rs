//! The intact texture (Bellini et al. 2016, section 5): the input as it
//! was before it weathered.
//!
//! 1. Tile detection ([`super::tiles`]). With a grid, the template is the
//!    median tile: at each pixel, the median over every tile at the same
//!    offset, leaving out the most-aged samples.
//! 2. Without a grid (stochastic texture), the weathered pixels (with a
//!    margin) are re-synthesized from the rest ([`Synthesis::fill`]); every
//!    other pixel keeps the input exactly. No blend of old content is left.
//!    The fill votes with Kwatra's robust weights and then, inside coherent
//!    copies, takes the matched patch's own centre pixel
//!    ([`crate::synth::Synthesized::coherent_copies`]): verbatim material,
//!    with the vote only where copies meet. Until stop 45 a mean-vote fill
//!    was rebuilt from whole patches guided by itself, which kept its
//!    smoothness: a blind reviewer preferred the grain of this version on
//!    11 of 12 photos (milky washes on the large fills were the worst
//!    defect). On the synthetic ground truth the residue rose (stucco peel
//!    0.27 -> 0.39, stucco rust 0.14 -> 0.16): the measure is a distance to
//!    the nearest clean patch, which a smooth fill keeps small and the
//!    seams between copies do not.
//! 3. The median-tile template is rebuilt from the input's allowed patches
//!    (guide: luminance, colour, gradient direction; see
//!    [`super::rebuild`]), so the result is made of real, non-weathered
//!    material. The paper uses quilting texture transfer
//!    ([`Engine::Quilt`]); the default is guided optimization started from
//!    such a transfer (see [`IntactParams::engine`]).
//!
//! Which pixels are weathered: the paper discards a fixed 20% of the most
//! aged pixels. A crack network is 5% of the surface and a peel can be 40%,
//! so the default cut is automatic ([`weathered_cut`]): Otsu's threshold on
//! the age map, at least [`MIN_CUT`], and at most `weathered_max` of the
//! surface, plus the faint pixels linked to those above it
//! ([`allowed_sources`]). `discard` restores the paper's fixed fraction.

use super::layers::Layers;
use super::rebuild::{rebuild, Engine, RebuildParams};
use super::tiles::{self, Lattice};
use crate::error::{Error, Result};
use crate::image::region::neighbours;
use crate::image::{Image, Mask};
use crate::synth::{OptimizeParams, Synthesis, VoteWeights};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// Patch side of the fill that makes the stochastic template.
const FILL_PATCH: usize = 7;

/// Lowest age the automatic cut accepts as weathered: on a clean texture
/// Otsu's threshold would split noise.
pub const MIN_CUT: f32 = 0.25;

/// Margin, in pixels, around weathered pixels that is re-synthesized too
/// (a lip, a halo, the soft edge of the age map). At 4 px the stucco crack
/// network's residue fell from 0.25 to 0.08, but on the real photos the
/// wider holes erased the roof's course lines and the circle tiles' rims
/// (blind review, stop 39).
pub const MARGIN: usize = 2;

/// Parameters of the intact texture.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct IntactParams {
    /// Fixed fraction of the most-aged pixels treated as weathered (the
    /// paper: 20%); `None` = the automatic cut of [`weathered_cut`].
    pub discard: Option<f32>,
    /// Largest fraction of the surface the automatic cut may call weathered.
    pub weathered_max: f32,
    /// Look for a tile grid (off: always treat the texture as stochastic).
    pub detect_tiles: bool,
    /// Which synthesis rebuilds a tile grid's median-tile template (the
    /// stochastic fill has its own, see the module docs). The paper quilts; guided
    /// optimization (which starts from a quilt) is the default because on
    /// the photos of ../shared/data quilting left visible 30 px blocks in
    /// smooth rust and took 2.7x longer at 512 px.
    pub engine: Engine,
    /// How the median-tile template is rebuilt from input patches.
    pub rebuild: RebuildParams,
}

impl Default for IntactParams {
    fn default() -> Self {
        IntactParams { discard: None, weathered_max: 0.6, detect_tiles: true, engine: Engine::Optimize, rebuild: RebuildParams::default() }
    }
}

/// The intact texture and what it was made from.
#[derive(Clone, Debug)]
pub struct Intact {
    pub image: Image,
    /// The tile grid, when one was found.
    pub lattice: Option<Lattice>,
    /// The template before rebuilding (median tile), or the filled input.
    pub template: Image,
    /// Input pixels the rebuild could copy from.
    pub allowed: Mask,
    /// The age above which a pixel counted as weathered.
    pub cut: f32,
    /// The fraction of the surface judged weathered.
    pub weathered_fraction: f32,
}

/// The automatic weathered cut of an age map: Otsu's threshold (the level
/// that best splits the ages into two classes), at least [`MIN_CUT`],
/// raised until at most `max_fraction` of the pixels lie above it.
/// Returns the cut and the fraction above it.
pub fn weathered_cut(age: &Image, max_fraction: f32) -> (f32, f32) {
    const BINS: usize = 256;
    let mut hist = [0f64; BINS];
    for &v in age.data() {
        hist[((v.clamp(0.0, 1.0) * (BINS - 1) as f32).round()) as usize] += 1.0;
    }
    let total: f64 = hist.iter().sum();
    let mean_all: f64 = hist.iter().enumerate().map(|(i, c)| i as f64 * c).sum::<f64>() / total;
    let (mut w0, mut sum0, mut best, mut cut) = (0f64, 0f64, -1f64, 0usize);
    for (i, &c) in hist.iter().enumerate().take(BINS - 1) {
        w0 += c;
        sum0 += i as f64 * c;
        let w1 = total - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let (m0, m1) = (sum0 / w0, (mean_all * total - sum0) / w1);
        let between = w0 * w1 * (m0 - m1) * (m0 - m1);
        if between > best {
            (best, cut) = (between, i + 1);
        }
    }
    let mut level = (cut as f32 / (BINS - 1) as f32).max(MIN_CUT);
    let above = |l: f32| age.data().iter().filter(|&&v| v >= l).count() as f32 / age.data().len().max(1) as f32;
    if above(level) > max_fraction {
        let mut sorted = age.data().to_vec();
        sorted.sort_by(f32::total_cmp);
        level = sorted[(((1.0 - max_fraction) * sorted.len() as f32) as usize).min(sorted.len() - 1)].max(level);
    }
    (level, above(level))
}

/// `age` itself, or with `within` its values there as one row: what
/// [`weathered_cut`] reads for a masked surface.
pub fn values_within<'a>(age: &'a Image, within: Option<&Mask>) -> Cow<'a, Image> {
    match within {
        None => Cow::Borrowed(age),
        Some(m) => {
            let v: Vec<f32> = age.data().iter().zip(m.bits()).filter(|(_, &b)| b).map(|(a, _)| *a).collect();
            Cow::Owned(Image::from_data(v.len(), 1, 1, v).expect("one row"))
        }
    }
}

/// The age cut of each layer: the (1 - discard) quantile of its ages, or
/// with `discard` = `None` the automatic [`weathered_cut`]; the ages of
/// pixels within `within` only, when given.
fn layer_cuts(age: &Image, discard: Option<f32>, weathered_max: f32, layers: Option<&Layers>, within: Option<&Mask>) -> Vec<f32> {
    let label = |i: usize| layers.map_or(0, |l| l.labels[i] as usize);
    let count = layers.map_or(1, |l| l.count);
    let on = |i: usize| within.is_none_or(|m| m.bits()[i]);
    (0..count)
        .map(|l| {
            let mut sorted: Vec<f32> = age.data().iter().enumerate().filter(|(i, _)| on(*i) && label(*i) == l).map(|(_, v)| *v).collect();
            if sorted.is_empty() {
                return f32::INFINITY;
            }
            match discard {
                Some(d) if d <= 0.0 => f32::INFINITY,
                Some(d) => {
                    sorted.sort_by(f32::total_cmp);
                    sorted[(((1.0 - d) * sorted.len() as f32) as usize).min(sorted.len() - 1)]
                }
                None => weathered_cut(&Image::from_data(sorted.len(), 1, 1, sorted).expect("one row"), weathered_max).0,
            }
        })
        .collect()
}

/// Share of its layer's cut from which a pixel can join the weathered
/// pixels it touches (hysteresis, as in Canny's edge linking).
pub const LINK_SHARE: f32 = 0.65;
/// Steps (4-neighbour) a linked run may reach from a pixel above the cut.
pub const LINK_REACH: usize = 4;

/// Pixels that are not weathered: below their layer's age cut (see
/// [`layer_cuts`]) and not linked to weathered pixels (links stop at
/// `weathered_max` of the surface, and are not made with a fixed
/// `discard`). A pixel at least [`LINK_SHARE`] of the cut joins the
/// weathered pixels when a run of such pixels, at most [`LINK_REACH`]
/// steps long, leads to one: the faint
/// stretches of a crack the map rates below the cut and the soft rim of a
/// peel. Without the link they stayed in the intact texture as dashes and
/// ghost outlines, and served as its sources (`age_auc`, 256 px, residue:
/// gravel peel 0.20 -> 0.12, gravel rust 0.21 -> 0.15, gravel crack
/// network 0.17 -> 0.08, stucco cracks 0.17 -> 0.09, planks crack network
/// 0.08 -> 0.05). The cost is on clean textures, whose age maps hover near
/// their cut: the share of clean stucco judged weathered rises from 0.30
/// to 0.50 (gravel 0.31 -> 0.45, planks 0.11 -> 0.17), which the fill
/// re-makes from the same material. The reach is bounded because an
/// unbounded link judged 0.53 of clean stucco weathered.
/// With `within`, the cuts and the cap are taken over its pixels, and
/// pixels outside it are never sources.
pub fn allowed_sources(age: &Image, discard: Option<f32>, weathered_max: f32, layers: Option<&Layers>, within: Option<&Mask>) -> Mask {
    let cuts = layer_cuts(age, discard, weathered_max, layers, within);
    let label = |i: usize| layers.map_or(0, |l| l.labels[i] as usize);
    let (w, h) = age.size();
    let area = within.map_or(w * h, Mask::count);
    let mut steps = vec![usize::MAX; w * h];
    let mut queue = std::collections::VecDeque::new();
    for (i, (&a, s)) in age.data().iter().zip(steps.iter_mut()).enumerate() {
        if a >= cuts[label(i)] {
            *s = 0;
            queue.push_back(i);
        }
    }
    // Linked pixels join nearest first, while the weathered share stays
    // within `weathered_max`; the paper's fixed fraction (`discard`) is
    // kept exact, with no links.
    let cap = if discard.is_some() { 0 } else { (weathered_max * area as f32) as usize };
    let mut weathered = queue.len();
    while let Some(i) = queue.pop_front() {
        if steps[i] >= LINK_REACH {
            continue;
        }
        for (nx, ny) in neighbours(i % w, i / w, w, h) {
            let j = ny * w + nx;
            if weathered < cap && steps[j] == usize::MAX && age.data()[j] >= LINK_SHARE * cuts[label(j)] {
                steps[j] = steps[i] + 1;
                weathered += 1;
                queue.push_back(j);
            }
        }
    }
    Mask::from_fn(w, h, |x, y| steps[y * w + x] == usize::MAX && within.is_none_or(|m| m.get(x, y)))
}

/// The intact texture of `img` given its age map. With `within`, only its
/// pixels are judged, re-made and copied from (see
/// [`super::age::age_map_within`]); the others keep `img`, and no tile
/// grid is looked for unless it covers [`super::age::PERIODIC_COVER`] of
/// the image.
pub fn intact(
    img: &Image,
    age: &Image,
    layers: Option<&Layers>,
    params: &IntactParams,
    within: Option<&Mask>,
    seed: u64,
) -> Result<Intact> {
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
    if params.discard.is_some_and(|d| !(0.0..0.95).contains(&d)) || !(params.weathered_max > 0.0 && params.weathered_max < 0.95) {
        return Err(Error::invalid("the discarded fraction must be in [0, 0.95) and the weathered maximum in (0, 0.95)"));
    }
    if within.is_some_and(|m| m.size() != img.size()) {
        return Err(Error::invalid("the intact texture's mask must be the input's size"));
    }
    let (w, h) = img.size();
    let on = |x: usize, y: usize| within.is_none_or(|m| m.get(x, y));
    let area = within.map_or(w * h, Mask::count).max(1);
    let below = allowed_sources(age, params.discard, params.weathered_max, layers, within);
    let weathered_fraction = 1.0 - below.count() as f32 / area as f32;
    let cut = layer_cuts(age, params.discard, params.weathered_max, None, within)[0];
    // The weathered pixels and a margin are re-made; only whole patches
    // can be copied, so allowed slivers narrower than the fill's patch are
    // dropped (an opening by its square). Nothing left (weathering
    // everywhere, or a speckled map): every pixel may serve.
    let hole = Mask::from_fn(w, h, |x, y| on(x, y) && !below.get(x, y)).dilate(MARGIN);
    let hole = Mask::from_fn(w, h, |x, y| on(x, y) && hole.get(x, y));
    let kept = Mask::from_fn(w, h, |x, y| on(x, y) && !hole.get(x, y));
    let opened = kept.erode(FILL_PATCH / 2).dilate(FILL_PATCH / 2);
    let allowed = if opened.count() > 0 { opened } else { Mask::from_fn(w, h, on) };
    let covers = within.is_none_or(|m| m.count() as f32 >= super::age::PERIODIC_COVER * (w * h) as f32);
    let mut lattice = if params.detect_tiles && covers { tiles::detect(img) } else { None };
    let median = lattice.map(|l| tiles::median_tile(img, &l, Some(&allowed)));
    if let Some(m) = &median {
        // A lattice found on a surface seen in perspective (a roof) repeats
        // only roughly; its median tile is a blur and the texture is better
        // treated as stochastic.
        if !tiles::keeps_structure(img, m, Some(&allowed)) {
            lattice = None;
        }
    }
    let (template, image) = match (&lattice, median) {
        (Some(_), Some(m)) => {
            let image = rebuild(img, &m, Some(&allowed), params.engine, &params.rebuild, seed ^ 0x1a7)?;
            (m, image)
        }
        _ if hole.count() > 0 && allowed.count() < w * h => {
            // A mean vote averages overlapping patches that disagree into a
            // milky wash over large holes; robust votes and verbatim copies
            // keep the material's grain (see the module docs). The fill
            // keeps the input exactly outside the hole.
            let op = OptimizeParams { patch: FILL_PATCH, vote: VoteWeights::Robust, ..OptimizeParams::default() };
            let mut filled = Synthesis::new(img).fill(img, &hole).source_mask(&allowed).seed(seed).optimize(&op)?;
            filled.coherent_copies(img, &hole);
            (filled.image.clone(), filled.image)
        }
        _ => (img.clone(), img.clone()),
    };
    Ok(Intact { image, lattice, template, allowed, cut, weathered_fraction })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A blob above the cut with a faint tail (between the link share and
    /// the cut) leading away from it, and an equally faint stroke elsewhere: the tail's first
    /// [`LINK_REACH`] pixels join the blob, the lone stroke does not, and a
    /// fixed discarded fraction links nothing.
    #[test]
    fn faint_stretches_touching_damage_join_it_and_lone_ones_do_not() {
        let (w, h) = (64, 32);
        let blob_age = 0.8;
        let map = |tail_age: f32| {
            Image::from_fn(w, h, 1, |x, y, p| {
                let blob = (4..10).contains(&x) && (4..10).contains(&y);
                let tail = (10..30).contains(&x) && y == 6;
                let stroke = (40..60).contains(&x) && y == 20;
                p[0] = if blob {
                    blob_age
                } else if tail || stroke {
                    tail_age
                } else {
                    0.05
                };
            })
        };
        // The automatic cut of the map, then the faint parts just under it.
        let (level, _) = weathered_cut(&map(0.05), 0.6);
        let faint_age = 0.5 * (1.0 + LINK_SHARE) * level;
        let age = map(faint_age);
        assert_eq!(weathered_cut(&age, 0.6).0, level, "the faint parts moved the cut");
        let allowed = allowed_sources(&age, None, 0.6, None, None);
        let linked = (10..30).filter(|&x| !allowed.get(x, 6)).count();
        assert_eq!(linked, LINK_REACH, "{linked} tail pixels linked");
        assert!((40..60).all(|x| allowed.get(x, 20)), "the lone stroke was linked");
        // 1.5% discarded: the blob's pixels only.
        let fixed = allowed_sources(&age, Some(0.015), 0.6, None, None);
        assert!((10..30).all(|x| fixed.get(x, 6)), "a fixed fraction linked the tail");
    }
}
