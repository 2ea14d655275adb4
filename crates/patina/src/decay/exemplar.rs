//! Decay textures from a photo of decay (Hao et al. 2023 train their
//! generator on such photos; patina synthesizes from one with its engine).
//!
//! [`from_exemplar`]:
//! 1. Ages the exemplar with texture weathering's age map
//!    ([`crate::weather::age_map`], Bellini et al. 2016, section 4): the
//!    onset of each texel is its rank from oldest (onset near 0, appears
//!    first) to youngest (near 1, appears last), so a decaying object shows
//!    the exemplar's oldest damage first, and ranks make the visible share
//!    grow evenly with the degree.
//! 2. Removes the exemplar's lighting ([`lighting::separate_smooth`]: a
//!    cubic log-luminance field, which takes a vignette or a ramp but not
//!    content smaller than the photo), synthesizes colour and onset together
//!    with the engine (texture optimization; stationary, any size, seamless
//!    on a torus when asked), and lights the result flat at the exemplar's
//!    mean luminance.
//! 3. Measures the stained zone around the exemplar's decay
//!    ([`measure_transition`]) for compositing.

use super::composite::Transition;
use crate::image::color::{srgb_to_linear, with_colour};
use crate::image::{Image, Mask};
use crate::synth::lighting::{self, LightingReport, Relight};
use crate::synth::{OptimizeParams, Progress, Synthesis};
use crate::weather::{age_map, intact, AgeParams, IntactParams};
use crate::Result;

/// An exemplar smaller than this (shorter side, pixels) keeps its lighting:
/// a field fitted to it would follow its content.
pub const MIN_SEPARATED_SIDE: usize = 96;

/// The onset channel's weight in the joint synthesis, relative to colour:
/// enough to keep old and young texels in their places, not so much that
/// it overrules colour (onsets are spread over [0, 1] by rank, a stronger
/// signal than most colour differences).
const ONSET_WEIGHT: f32 = 0.5;

/// A decay texture made from a photo of decay.
pub struct FromExemplar {
    /// sRGB colour and onset at the asked size ([`super::texture::CHANNELS`]).
    pub texture: Image,
    /// The exemplar's age map (0 intact .. 1 most weathered), exemplar size.
    pub age: Image,
    /// The stained zone measured around the exemplar's decay; `None` when
    /// the exemplar has too little clean surface beside its decay to tell.
    pub transition: Option<Transition>,
    /// What lighting-aware synthesis removed; `None` for an exemplar
    /// smaller than [`MIN_SEPARATED_SIDE`].
    pub lighting: Option<LightingReport>,
}

/// Synthesize a `width` x `height` decay texture from `exemplar` (sRGB or
/// grey; a grey exemplar gives a grey texture). `tileable`: colour and
/// onset wrap around the edges ([`Synthesis::tileable`]).
pub fn from_exemplar(
    exemplar: &Image,
    width: usize,
    height: usize,
    seed: u64,
    tileable: bool,
    progress: Option<Progress>,
) -> Result<FromExemplar> {
    let rgb = with_colour(exemplar).select_channels(0..3);
    let age = age_map(&rgb, &AgeParams::default())?.map;
    let onset = onset_from_age(&age);
    let separation = (rgb.width().min(rgb.height()) >= MIN_SEPARATED_SIDE).then(|| lighting::separate_smooth(&rgb));
    let detail = separation.as_ref().map_or(&rgb, |s| &s.detail);
    let source = Image::concat_channels(&[detail, &onset.map(|o| ONSET_WEIGHT * o)])?;
    let mut synth = Synthesis::new(&source).size(width, height).seed(seed).tileable(tileable);
    if let Some(p) = progress {
        synth = synth.progress(p);
    }
    let out = synth.optimize(&OptimizeParams::default())?.image;
    let mut colour = out.select_channels(0..3);
    let lighting = match &separation {
        Some(sep) => {
            colour = lighting::relight(&colour, sep, Relight::Flat)?;
            Some(LightingReport::of(Relight::Flat, &rgb, sep))
        }
        None => None,
    };
    let synthesized_onset = out.select_channels(3..4).map(|o| (o / ONSET_WEIGHT).clamp(0.02, 0.95));
    let texture = Image::concat_channels(&[&colour.map(|v| v.clamp(0.0, 1.0)), &synthesized_onset])?;
    let transition = measure_transition(&rgb, &age);
    Ok(FromExemplar { texture, age, transition, lighting })
}

/// Onsets from an age map: each texel's rank from the oldest (0.02) to
/// the youngest (0.95). Ties keep pixel order, so the result is
/// deterministic.
pub fn onset_from_age(age: &Image) -> Image {
    let n = age.data().len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| age.data()[b].total_cmp(&age.data()[a]).then(a.cmp(&b)));
    let mut onset = vec![0f32; n];
    let last = (n - 1).max(1) as f32;
    for (rank, &i) in order.iter().enumerate() {
        onset[i] = 0.02 + 0.93 * rank as f32 / last;
    }
    Image::from_data(age.width(), age.height(), 1, onset).expect("one onset per texel")
}

/// Rings around the decay (1 px each) that [`measure_transition`] reads.
const RINGS: usize = 24;
/// Rings from this one out are the clean surface the stain is measured against.
const FAR_RING: usize = 16;
/// Fewest pixels a ring needs to count.
const MIN_RING: usize = 20;

/// The stained zone around an exemplar's decay: the pixels judged
/// weathered are those above the age map's weathered cut (Otsu's, as the
/// intact texture uses); the clean pixels around them are binned into
/// 1 px rings by distance; the tint is the mean linear colour of rings 1-2
/// over that of the clean surface (rings 16-24); the width is the distance
/// where the colour's departure from the clean surface (summed |log|
/// ratios) falls to half its value at the edge, divided by 0.674 (where the
/// zone's rim, min(1, 2 x a Gaussian blur), is half, in units of its
/// sigma). The tint is held to [0.2, 1.2]: a stain darkens or shifts the
/// hue, and a strong brightening is the age map's error, not a stain.
/// `None` when a ring has too few pixels (decay everywhere, or nowhere).
pub fn measure_transition(rgb: &Image, age: &Image) -> Option<Transition> {
    let (cut, _) = intact::weathered_cut(age, IntactParams::default().weathered_max);
    let weathered = Mask::from_fn(age.width(), age.height(), |x, y| age.at(x, y, 0) > cut);
    let distance = weathered.signed_distance();
    let mut sums = [[0f64; 3]; RINGS + 1];
    let mut counts = [0usize; RINGS + 1];
    for (i, &d) in distance.iter().enumerate() {
        if d >= 0.0 {
            continue;
        }
        let ring = (-d).ceil() as usize;
        if ring <= RINGS {
            let px = &rgb.data()[i * 3..i * 3 + 3];
            for c in 0..3 {
                sums[ring][c] += f64::from(srgb_to_linear(px[c]));
            }
            counts[ring] += 1;
        }
    }
    let mean = |rings: std::ops::RangeInclusive<usize>| -> Option<[f64; 3]> {
        let n: usize = rings.clone().map(|r| counts[r]).sum();
        (n >= MIN_RING).then(|| [0, 1, 2].map(|c| rings.clone().map(|r| sums[r][c]).sum::<f64>() / n as f64 + 1e-4))
    };
    let far = mean(FAR_RING..=RINGS)?;
    let departure = |m: [f64; 3]| (0..3).map(|c| (m[c] / far[c]).ln().abs()).sum::<f64>();
    let edge = mean(1..=2)?;
    let at_edge = departure(edge);
    let mut half = FAR_RING as f64;
    for r in 2..FAR_RING {
        if departure(mean(r..=r)?) < 0.5 * at_edge {
            half = r as f64 - 0.5;
            break;
        }
    }
    Some(Transition {
        width: (half / 0.674).clamp(0.5, 16.0) as f32,
        tint: [0, 1, 2].map(|c| (edge[c] / far[c]).clamp(0.2, 1.2) as f32),
        strength: 1.0,
        offset: [0.0, 0.0],
        drip: 0.0,
        drip_gain: 1.0,
    })
}
