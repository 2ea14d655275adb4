//! Natural image decay (Hao, Iizuka, Hara, Kataoka, Fukui, "Natural Image
//! Decay With a Decay Effects Generator", IEEE Access 2023): make a clean
//! object in a photo rust, peel, crack or grow moss, over time.
//!
//! The pipeline: a decay texture of the photo's size ([`texture`]), the
//! object's shading ([`shading`]), an initial degree map ([`degree::initial`],
//! Algorithm 1, or a user's painting), its diffusion over the frames
//! ([`degree::Diffuser`], eqs. 4-7), and Lab compositing ([`composite`], eq. 3).
//! The sequence starts from the clean photo and Algorithm 1's patches are
//! grown from their first texels over the first frames (not in the paper;
//! see [`sequence`]).
//! [`prepare`] does the once-per-photo work, [`sequence`] renders frames.

pub mod composite;
pub mod degree;
pub mod exemplar;
pub mod layer;
pub mod shading;
pub mod texture;

pub use composite::Transition;
pub use degree::Diffusion;
pub use shading::ShadingParams;
pub use texture::{DecayClass, Style, Substrate};

use crate::image::color::{to_lab, with_colour};
use crate::image::filter::gaussian_blur;
use crate::image::noise::smoothstep;
use crate::image::{Image, Mask};
use crate::synth::Progress;
use crate::{Error, Result};
use serde::Serialize;

/// Pixels by which a found object's mask (`--mask auto`) is widened: a
/// cut follows the middle of the photo's soft silhouette, and the pixels
/// of the rest of it are decayed by their share of object
/// ([`composite::matted_coverage`]), not left with the object's colour.
pub const AUTO_MASK_PAD: usize = 2;

/// Parameters of a decay run, with the paper's defaults.
#[derive(Clone, Debug, Serialize)]
pub struct DecayParams {
    /// The decay class (the generator's class label).
    pub class: DecayClass,
    /// Target fraction of the mask covered by the initial degree map
    /// (Algorithm 1's area; 0.25).
    pub area: f32,
    /// Blob size of the initial degree map as a fraction of the longer
    /// side (Algorithm 1's continuity; 0.06).
    pub continuity: f32,
    /// Diffusion and self-growth per frame.
    pub diffusion: Diffusion,
    /// The shading estimate.
    pub shading: ShadingParams,
}

impl DecayParams {
    /// The paper's defaults for `class`.
    pub fn new(class: DecayClass) -> Self {
        DecayParams { class, area: 0.25, continuity: 0.06, diffusion: Diffusion::default(), shading: ShadingParams::default() }
    }

    /// Refuse diffusion and shading parameters outside [0, 1] (the area and
    /// continuity are checked by [`degree::initial`], which uses them).
    pub fn check(&self) -> Result<()> {
        let (d, s) = (&self.diffusion, &self.shading);
        for (name, v) in [("--spread", d.spread), ("--growth", d.growth), ("--shading-radius", s.radius), ("--shading-eps", s.eps)] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return Err(Error::invalid(format!("{name} must be in [0, 1], got {v}")));
            }
        }
        Ok(())
    }
}

/// How the material under a peeled skin differs from the surface of an
/// unpainted object, as (L*, b*) shifts: weathered stone spalls to
/// fresher, paler stone ([`Substrate::Stone`]) ...
const FRESH_STONE: [f32; 2] = [8.0, 1.0];
/// ... and a white coat peels off a darker, warmer body (raw plaster or
/// stone) ([`Substrate::Coated`], and paint of low chroma).
const UNDER_A_COAT: [f32; 2] = [-10.0, 5.0];

/// Whether the object of `photo_lab` inside `mask` is coated white: its
/// brightest parts (its 95th-percentile L*) are at least the scene's
/// white ([`composite::scene_white`], the whole photo's 95th percentile). One shift for both kinds
/// of grey object read wrongly on one of them: darker and warmer on a
/// grey gravestone under a bright sky (ratio 0.93) as brown stains, paler
/// on a white Buddha cast (ratio 1.09) as white frosting.
pub fn is_coated_white(photo_lab: &Image, mask: &Mask) -> bool {
    let mut object: Vec<f32> = photo_lab.data().chunks_exact(3).zip(mask.bits()).filter(|(_, &m)| m).map(|(p, _)| p[0]).collect();
    crate::image::order::quantile(&mut object, 0.95).unwrap_or(0.0) >= composite::scene_white(photo_lab)
}

/// The photo's recesses, in [0, 1]: where its fine relief ([`shading::relief`],
/// a luminance factor) is darker than the shading around it, from 5% (0)
/// to 30% (1) darker in log luminance, softened by a 1 px Gaussian so a
/// groove's floor and walls count alike. 0 outside the object (relief 1).
pub fn cavities(relief: &Image) -> Image {
    let dark = relief.map(|r| smoothstep(0.05, 0.3, -r.max(1e-6).ln() / shading::RELIEF));
    gaussian_blur(&dark, 1.0)
}

/// Gaussian scale (pixels) above which [`flattened`] damps a texture's lightness.
pub const FLATTEN_SCALE: f32 = 8.0;

/// `texture_lab` with `share` of its lightness variation above
/// [`FLATTEN_SCALE`] removed (L* moved towards its mean by that share of
/// its blurred deviation), its fine grain and its colour kept; see
/// [`DecayClass::flatten`].
fn flattened(mut texture_lab: Image, share: f32) -> Image {
    if share <= 0.0 {
        return texture_lab;
    }
    let lightness = texture_lab.select_channels(0..1);
    let n = lightness.data().len().max(1) as f64;
    let mean = (lightness.data().iter().map(|&v| v as f64).sum::<f64>() / n) as f32;
    let broad = gaussian_blur(&lightness, FLATTEN_SCALE);
    texture_lab.data_mut().chunks_exact_mut(3).zip(broad.data()).for_each(|(px, b)| {
        px[0] = (px[0] - share * (b - mean)).clamp(0.0, 100.0);
    });
    texture_lab
}

/// What [`sequence`] needs, computed once per photo.
pub struct Prepared {
    /// The photo (sRGB), and in Lab.
    pub photo: Image,
    photo_lab: Image,
    /// The object mask.
    pub mask: Mask,
    /// What the object is taken to be made of (its texture's substrate).
    pub substrate: Substrate,
    /// Pixels by which the mask was widened past the object ([`Inputs::mask_pad`]).
    pub mask_pad: usize,
    /// The decay texture as made (sRGB + onset), before colour transfer.
    pub texture: Image,
    texture_lab: Image,
    onset: Image,
    /// Relative shading and fine relief (linear luminance ratio, mean 1 in the log domain; see [`shading::relief`]).
    pub shading: Image,
    /// The initial degree map (Algorithm 1's or painted).
    pub degree: Image,
    /// Draws Algorithm 1 needed (0 for a painted degree map).
    pub draws: u64,
    /// The blur (pixels) that matched the texture's sharpness to the photo's ([`composite::focus_blur`]).
    pub focus: f32,
    /// Per-pixel rate (the user's regularisation map), if any.
    pub rate: Option<Image>,
    /// The stained zone around the decay.
    pub transition: Transition,
    /// Towards the photo's light, in the image plane ([`layer::light_direction`]).
    pub light: [f32; 2],
    /// The decay layer's relief on this object ([`DecayClass::relief`]).
    pub relief: layer::Relief,
    /// The texture is the photo seen through a stain ([`composite::stained_photo`]).
    pub stained: bool,
    params: DecayParams,
}

/// One rendered frame.
pub struct Frame {
    /// The degree map D of this frame.
    pub degree: Image,
    /// The decayed photo.
    pub image: Image,
}

/// The inputs of [`prepare`] besides the photo.
#[derive(Default)]
pub struct Inputs<'a> {
    /// Object mask (white = may decay); default: the whole photo.
    pub mask: Option<&'a Mask>,
    /// Pixels by which `mask` was widened past the object's outline to
    /// take in its soft edge ([`AUTO_MASK_PAD`] for a found object, 0 for
    /// a user's mask): those pixels decay only as much as their colour
    /// says they are object ([`composite::matted_coverage`]).
    pub mask_pad: usize,
    /// A ready decay texture (sRGB + onset, the photo's size), e.g. from
    /// [`exemplar::from_exemplar`]; default: the procedural generator.
    pub texture: Option<&'a Image>,
    /// A painted initial degree map (mean of its colour channels, in [0, 1]); default: Algorithm 1.
    pub degree: Option<&'a Image>,
    /// Spatial regularisation (mean of its colour channels): 0.5 = normal speed, 1 = twice, 0 = none.
    pub rate: Option<&'a Image>,
    /// The stained zone around the decay (e.g. measured on an exemplar by
    /// [`exemplar::from_exemplar`]); default: the class's.
    pub transition: Option<Transition>,
}

/// Check sizes, make or take the texture, estimate the shading and the
/// initial degree map.
/// A gray photo is decayed as RGB (the decay brings colour to it).
pub fn prepare(photo: &Image, inputs: Inputs, params: &DecayParams, seed: u64) -> Result<Prepared> {
    params.check()?;
    let (w, h) = photo.size();
    let photo = &with_colour(photo);
    let same = |what: &str, (a, b): (usize, usize)| {
        if (a, b) == (w, h) {
            Ok(())
        } else {
            Err(Error::invalid(format!("the {what} is {a}x{b} but the photo is {w}x{h}")))
        }
    };
    let mask = match inputs.mask {
        Some(m) => {
            same("mask", m.size())?;
            m.clone()
        }
        None => Mask::filled(w, h, true),
    };
    let photo_lab = to_lab(photo);
    let substrate = Substrate::of(composite::mean_chroma(&photo_lab, &mask), is_coated_white(&photo_lab, &mask));
    // The object's form (shading) and the photo's light, which the texture is drawn under.
    let form = shading::estimate(photo, &mask, &params.shading);
    let light = layer::light_direction(&form, &mask);
    let texture = match inputs.texture {
        Some(t) => {
            same("texture", t.size())?;
            if t.channels() != texture::CHANNELS {
                return Err(Error::invalid("a decay texture needs 4 channels (sRGB and onset)"));
            }
            t.clone()
        }
        // A texture that tiles, so texture.png is a seamless material too,
        // its own relief lit as the photo is.
        None => texture::generate_tiling_lit(params.class, seed, w, h, substrate, light)?,
    };
    let mut onset = texture.select_channels(3..4);
    // The texture's colour as the photo's lens would show it (its onsets stay sharp).
    let focus = composite::focus_blur(photo, &mask, &texture);
    let soften = if inputs.texture.is_none() { focus.max(params.class.edge_softness()) } else { focus };
    let focused = gaussian_blur(&texture.select_channels(0..3), soften);
    // The form (shading) and the fine relief both light the decay; the
    // highlight is removed from their product as the class's gloss says.
    let relief = shading::relief(photo, &mask, &form, shading::RELIEF);
    let mut lit = shading::under_a_layer(&form, &mask, params.class.thickness(substrate));
    let through = params.class.relief_through(substrate);
    lit.data_mut().iter_mut().zip(relief.data()).for_each(|(s, r)| *s *= r.powf(through));
    let shading = shading::with_gloss(&lit, &mask, params.class.gloss());
    let pull = params.class.cavity_pull();
    if pull > 0.0 {
        let cavity = cavities(&relief);
        onset.data_mut().iter_mut().zip(cavity.data()).for_each(|(o, c)| {
            if *c > 0.0 {
                *o = (*o * (1.0 - pull * c).powi(2)).max(0.02);
            }
        });
    }
    let stained = params.class.stains(substrate) && inputs.texture.is_none();
    let texture_lab = if params.class.photo_relative() && inputs.texture.is_none() {
        composite::darkened_photo(photo, &focused, &shading, texture::CRACKED_SURFACE)
    } else if stained {
        composite::stained_photo(photo, &focused, &shading, seed)
    } else {
        // The texture's own material under the photo's light, then (for
        // peeling on an unpainted object) moved to the object's colours.
        let mut texture_lab = to_lab(&focused);
        composite::adapt_to_scene(&mut texture_lab, &photo_lab);
        let strength = params.class.colour_transfer(composite::mean_chroma(&photo_lab, &mask));
        if strength > 0.0 {
            composite::transfer_colour(&mut texture_lab, &onset, &photo_lab, &mask, strength);
            if params.class == DecayClass::Peeling {
                let under = if substrate == Substrate::Stone { FRESH_STONE } else { UNDER_A_COAT };
                let shift = under.map(|v| v * strength);
                texture_lab.data_mut().chunks_exact_mut(3).for_each(|px| {
                    px[0] = (px[0] + shift[0]).clamp(0.0, 100.0);
                    px[2] += shift[1];
                });
            }
        }
        texture_lab
    };
    let texture_lab = flattened(texture_lab, params.class.flatten());
    let (degree, draws) = match inputs.degree {
        Some(painting) => (degree::from_painting(painting, &mask)?, 0),
        None => {
            let affinity = degree::affinity(params.class, &form, &relief, &mask);
            // Each class lays out its own patches (one seed gave every class the same blobs).
            let layout = crate::rng::derive(seed, &[0xdec, params.class as u64]);
            degree::initial(&mask, params.area, params.continuity, affinity.as_ref(), layout)?
        }
    };
    let rate = match inputs.rate {
        Some(r) => {
            same("rate map", r.size())?;
            Some(degree::channel_mean(r).map(|v| (2.0 * v).clamp(0.0, 2.0)))
        }
        None => None,
    };
    Ok(Prepared {
        photo: photo.clone(),
        photo_lab,
        mask,
        mask_pad: inputs.mask_pad,
        texture,
        texture_lab,
        onset,
        shading,
        degree,
        draws,
        focus,
        rate,
        transition: inputs.transition.unwrap_or_else(|| params.class.transition()),
        substrate,
        light,
        // A stain has no thickness of its own.
        relief: if stained { layer::Relief::FLAT } else { params.class.relief(substrate) },
        stained,
        params: params.clone(),
    })
}

/// Render `frames` frames. With Algorithm 1's degree map and more than
/// one frame, frame 0 is the clean photo and the next frames grow the
/// initial map's patches from their first texels (the map scaled by a
/// factor rising from 0, so each patch shows its lowest onsets where its
/// degree is highest first) and then run diffusion and growth, one
/// simulated frame per frame, paced so the visible decay grows evenly.
/// A painted map is the user's frame 0 and is shown as painted; so is any
/// map when only one frame is asked for.
///
/// Not in the paper, whose first frame shows the initial map whole: a
/// blind reviewer read patches that arrive full-size as "patches appear
/// nearly full-size in frame 1", and seeds already showing in frame 0 as
/// a sequence that does not start from the photo.
pub fn sequence(prep: &Prepared, frames: usize, seed: u64, progress: Option<Progress>) -> Result<Vec<Frame>> {
    if frames == 0 {
        return Err(Error::invalid("--frames must be at least 1"));
    }
    // Simulate every frame's degree map (eqs. 4-7), then re-time them so
    // the visible share grows evenly (see `paced`), from the clean photo
    // (a zero map) when the initial map is Algorithm 1's.
    let mut simulated = Vec::with_capacity(frames + 1);
    if frames > 1 && prep.draws > 0 {
        simulated.push(Image::new(prep.degree.width(), prep.degree.height(), 1));
    }
    simulated.push(prep.degree.clone());
    let diffuser = degree::Diffuser::new(&prep.mask, prep.rate.as_ref(), &prep.params.diffusion);
    for k in 1..frames {
        let mut d = simulated.last().expect("the initial map").clone();
        diffuser.step(&mut d, seed, k as u64);
        simulated.push(d);
    }
    let stain = prep.transition.field(prep.photo.width(), prep.photo.height(), seed);
    let coverage = composite::matted_coverage(&prep.mask, prep.mask_pad, &prep.photo_lab);
    let ends = (
        visible_share(&simulated[0], &prep.onset, &prep.mask),
        visible_share(simulated.last().expect("the initial map"), &prep.onset, &prep.mask),
    );
    let mut out = Vec::with_capacity(frames);
    for k in 0..frames {
        let degree = paced(&simulated, (k, frames), ends, &prep.onset, &prep.mask);
        let layers = composite::Layers {
            texture_lab: &prep.texture_lab,
            onset: &prep.onset,
            shading: &prep.shading,
            stain: stain.as_ref(),
            young: prep.params.class.young_opacity(),
            relief: prep.relief,
            light: prep.light,
            coverage: coverage.as_ref(),
            focus: prep.focus,
        };
        let image = composite::composite(&prep.photo, &prep.photo_lab, &layers, &degree);
        out.push(Frame { degree, image });
        if let Some(p) = progress {
            p(k as u64 + 1, frames as u64);
        }
    }
    Ok(out)
}

/// The share of the object the texture covers at `degree`: the mean
/// composite weight ([`composite::weight`]) over the mask.
pub fn visible_share(degree: &Image, onset: &Image, mask: &Mask) -> f64 {
    mean_weight(degree.data().iter().copied(), onset, mask)
}

/// The mean composite weight over the mask of the per-pixel `degrees`.
fn mean_weight(degrees: impl Iterator<Item = f32>, onset: &Image, mask: &Mask) -> f64 {
    let (mut sum, mut n) = (0f64, 0usize);
    for ((d, o), &m) in degrees.zip(onset.data()).zip(mask.bits()) {
        if m {
            sum += f64::from(composite::weight(d, *o));
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

/// Frame `k` of `frames`' degree map, re-timed so the visible share grows
/// evenly from the first simulated map's to the last's. Diffusion and
/// growth spread the degree fast at first and then saturate (99% of the
/// mask by frame 3 of 8), while what shows follows the texture's onsets;
/// so frame k shows the simulation at the fractional time whose visible
/// share is k/(K-1) of the way, interpolating between consecutive
/// simulated maps. Each pixel still only grows, as the simulated maps do.
fn paced(simulated: &[Image], (k, frames): (usize, usize), (v0, v1): (f64, f64), onset: &Image, mask: &Mask) -> Image {
    let last = simulated.len() - 1;
    if last == 0 || k == 0 || k + 1 >= frames {
        return simulated[if k == 0 { 0 } else { last }].clone();
    }
    // Simulated time f: between maps i and i + 1, with weight w on the later.
    let split = |f: f64| {
        let i = (f.floor() as usize).min(last - 1);
        (i, (f - i as f64).clamp(0.0, 1.0) as f32)
    };
    let share_at = |f: f64| {
        let (i, w) = split(f);
        let between = simulated[i].data().iter().zip(simulated[i + 1].data()).map(|(x, y)| x + w * (y - x));
        mean_weight(between, onset, mask)
    };
    let target = v0 + (v1 - v0) * k as f64 / (frames - 1) as f64;
    let (_, hi) = bisect((0.0, last as f64), |f| share_at(f) < target);
    let (i, w) = split(hi);
    let mut d = simulated[i].clone();
    d.data_mut().iter_mut().zip(simulated[i + 1].data()).for_each(|(x, y)| *x += w * (y - *x));
    d
}

/// 24 halvings of `(lo, hi)` around where `below` stops holding (it holds
/// at lo and not at hi, and changes once in between): the last interval.
fn bisect((mut lo, mut hi): (f64, f64), below: impl Fn(f64) -> bool) -> (f64, f64) {
    for _ in 0..24 {
        let mid = 0.5 * (lo + hi);
        if below(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo, hi)
}
