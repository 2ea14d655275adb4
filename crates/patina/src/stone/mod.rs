//! Stone weathering in a photograph (Xue, Dorsey, Rushmeier, EGSR 2011).
//!
//! From one photo and an object mask: the weathering tendency d(x)
//! ([`tendency`]), patches from a graph segmentation of it ([`segment`]),
//! smoothing by borrowing calmer patches' Laplacians and solving Poisson
//! problems ([`update`]), fractal roughening learned from a rough-stone
//! sample ([`roughen`]), silhouette erosion with the background behind
//! it synthesized by the engine ([`erosion`]) and a final luminance
//! histogram match to the original. The wear changes shading, not colour
//! (`keep_colour`), except where it fills a deep shadow in, which takes
//! the lit stone's colour. The photo's own pits stay open
//! ([`pits::OwnPits`]) and plants over the stone stay as they are
//! ([`select::plants`]). Work is in linear light
//! (gamma 2.2, as the paper), frames are returned in sRGB-like gamma 2.2.
//!
//! ```no_run
//! # use patina::{image::io, stone::{self, StoneParams}};
//! let photo = io::load("statue.jpg").unwrap();
//! let prepared = stone::prepare(&photo, None, None, &StoneParams::default()).unwrap();
//! let frames = stone::sequence(&prepared, &[0.0, 50.0, 100.0], 7, None).unwrap();
//! ```

pub mod erosion;
pub mod pits;
pub mod roughen;
pub mod segment;
pub mod select;
pub mod tendency;
pub mod update;

use crate::error::{Error, Result};
use crate::image::color::luminance;
use crate::image::{Image, Mask};
use crate::synth::Progress;
use erosion::Erosion;
use roughen::Fractal;
use segment::{Patch, SegmentParams};
use serde::Serialize;
use update::{MatchParams, SearchMaps};

pub(crate) use crate::image::region::neighbours;

pub(crate) use crate::image::pixel_bounds as bounds;

/// Row-major indices of the set pixels of `mask`.
pub(crate) fn set_pixels(mask: &Mask) -> impl Iterator<Item = usize> + '_ {
    mask.bits().iter().enumerate().filter(|(_, &b)| b).map(|(i, _)| i)
}

/// Scale (px) of the grain/relief split: detail finer than this Gaussian
/// is the finest band, whose energy weathering keeps.
pub const GRAIN_SIGMA: f32 = 2.5;

/// Gamma used to linearise LDR input (the paper's 2.2).
pub const GAMMA: f32 = 2.2;

/// Every parameter of the method, with the paper's defaults.
#[derive(Clone, Debug, Serialize)]
pub struct StoneParams {
    /// eta: d = (v / v*)^eta.
    pub eta: f32,
    /// m: tendency window radius r = sqrt(N(I)) / m.
    pub m: f32,
    /// FH scale K.
    pub seg_k: f32,
    /// n: minimum patch size Omega = N(I) / n.
    pub n: f32,
    /// Patches over this many Omega are bisected.
    pub max_patch: f32,
    /// w_d of eq. (1).
    pub wd: f32,
    /// k of eq. (2): w = exp(-k mean d t).
    pub k: f32,
    /// nu: roughening weight beta = d^nu.
    pub nu: f32,
    /// Roughen at all.
    pub roughen: bool,
    /// Open pits where the stone weathers ([`pits`]).
    pub pits: bool,
    /// Erode the silhouette (needs a mask or alpha with background).
    pub erosion: bool,
    /// epsilon: erosion iterations = epsilon sqrt(N(I)) t.
    pub erosion_speed: f32,
    /// alpha: colour share a removed pixel bleeds into its inner neighbours.
    pub bleed: f32,
    /// Pixels a (partial) object mask is dilated by, to take in the
    /// object's anti-aliased rim.
    pub mask_dilation: usize,
    /// Width (px) over which the weathering fades in from the given mask's
    /// edge (0: none; the dilated ring beyond it is never weathered). Used
    /// with masks that may be off by a few pixels, such as
    /// [`select::auto_mask`]'s, so their outline does not show.
    pub feather: f32,
}

impl Default for StoneParams {
    fn default() -> Self {
        StoneParams {
            eta: 0.6,
            m: 60.0,
            seg_k: 100.0,
            n: 3200.0,
            max_patch: 4.0,
            wd: 1.0,
            k: 0.01,
            nu: 3.0,
            roughen: true,
            pits: true,
            erosion: true,
            erosion_speed: 0.0002,
            bleed: 0.2,
            mask_dilation: 2,
            feather: 0.0,
        }
    }
}

/// Everything that does not depend on t, computed once per photo.
pub struct Prepared {
    /// The photo in linear light, RGB.
    pub linear: Image,
    /// The photo as given (sRGB), RGB: background pixels are copied from it.
    pub original: Image,
    /// The object: the given mask dilated by `params.mask_dilation`.
    pub mask: Mask,
    /// The object proper: the given mask. The ring `mask` adds around it
    /// (the anti-aliased rim, part stone and part background) erodes with
    /// the object but, while it stands, keeps the photo's colours.
    pub object: Mask,
    /// The only pixels weathered stone is borrowed from: the object proper
    /// (the given mask; the rim is part stone, part background) less a band
    /// along its outline ([`sources`]).
    pub sources: Mask,
    /// Whether the mask came from the user (or alpha); erosion needs one.
    pub masked: bool,
    pub tendency: Image,
    pub patches: Vec<Patch>,
    /// Each patch's best-match offset c1 - c0 under eq. (1).
    pub offsets: Vec<(isize, isize)>,
    /// The relief: `original` (gamma-encoded) without its finest band (a
    /// Gaussian of [`GRAIN_SIGMA`]).
    pub base: Image,
    /// `original - base`: the finest band, the stone's grain and the sharpest
    /// carved edges. The patch update treats it apart ([`update::update`]).
    pub grain: Image,
    /// The patch scale (px): sqrt(object pixels / patches). The update
    /// follows borrowed gradients up to this scale.
    pub scale: f32,
    /// What the update borrows, the same at every t.
    pub borrowing: update::Borrowing,
    pub fractal: Fractal,
    /// The photo's own pits, which the wear opens instead of healing.
    pub own_pits: pits::OwnPits,
    /// Plants over the object ([`select::plants`]), kept as they are in
    /// every frame: each pixel's share of the photo kept (0 to 1).
    pub plants: Image,
    pub params: StoneParams,
}

/// One output time.
pub struct Frame {
    pub t: f32,
    /// RGB, gamma 2.2 (sRGB-like), ready to save.
    pub image: Image,
    /// The object still standing at t.
    pub mask: Mask,
    /// Strength of the histogram match used (see [`match_luminance`]).
    pub contrast: f32,
}

/// Side of the built-in rough-stone sample the default fractal is learned from.
const SAMPLE_SIDE: usize = 256;

/// Check the inputs and compute tendency, patches, matches and fractal.
/// `photo` is gamma-encoded RGB (a gray photo is used as RGB; a 4th channel
/// is alpha and, without `mask`, gives the object as alpha > 0.5).
pub fn prepare(photo: &Image, mask: Option<&Mask>, rough_sample: Option<&Image>, params: &StoneParams) -> Result<Prepared> {
    let (w, h) = photo.size();
    if w < 16 || h < 16 {
        return Err(Error::invalid(format!("the photo is {w}x{h}; stone needs at least 16x16 pixels")));
    }
    check_params(params)?;
    let rgb = Image::from_fn(w, h, 3, |x, y, p| {
        let px = photo.pixel(x, y);
        p.copy_from_slice(&if px.len() >= 3 { [px[0], px[1], px[2]] } else { [px[0]; 3] })
    });
    let (mask, masked) = match mask {
        Some(m) if m.size() != (w, h) => {
            return Err(Error::invalid(format!("the mask is {}x{} but the photo is {w}x{h}", m.width(), m.height())));
        }
        Some(m) => (m.clone(), true),
        None if photo.channels() == 4 || photo.channels() == 2 => {
            let a = photo.channels() - 1;
            (Mask::from_fn(w, h, |x, y| photo.at(x, y, a) > 0.5), true)
        }
        None => (Mask::filled(w, h, true), false),
    };
    // The object's anti-aliased rim (pixels part stone, part background)
    // lies just outside a tight mask; it joins the object so that erosion
    // removes it too instead of leaving it as a ghost outline.
    let tight = mask;
    let mask = if masked && params.mask_dilation > 0 && tight.count() < w * h { tight.dilate(params.mask_dilation) } else { tight.clone() };
    if mask.count() < 64 {
        return Err(Error::invalid(format!("the mask covers {} pixels; stone needs an object of at least 64", mask.count())));
    }
    let linear = rgb.map(|v| v.max(0.0).powf(GAMMA));
    // The tendency is measured on the object proper (the rim's mix with the
    // background would read as busy stone) and carried out over the rim.
    let tendency = tendency::extend(&tendency::tendency(&linear, &tight, params.eta, params.m), &tight, &mask);
    let seg = SegmentParams { k: params.seg_k, n: params.n, max_factor: params.max_patch };
    let patches = segment::segment(&tendency, &mask, &seg);
    let intensity = luminance(&linear);
    let scale = (mask.count() as f32 / patches.len().max(1) as f32).sqrt();
    let sources = sources(&tight, scale);
    let maps = SearchMaps { intensity: &intensity, tendency: &tendency, mask: &sources };
    let offsets = update::best_offsets(&patches, &maps, &MatchParams { wd: params.wd, ..Default::default() });
    let sample = match rough_sample {
        Some(s) => luminance(&s.map(|v| v.max(0.0).powf(GAMMA))),
        None => crate::samples::rough_stone(SAMPLE_SIDE, SAMPLE_SIDE, 1).map(|v| v.powf(GAMMA)),
    };
    let mean = sample.data().iter().sum::<f32>() / sample.data().len() as f32;
    if sample.width() < 16 || sample.height() < 16 || mean <= 1e-4 {
        return Err(Error::invalid(format!(
            "the rough-stone sample must be at least 16x16 and not black (got {}x{})",
            sample.width(),
            sample.height()
        )));
    }
    let fractal = Fractal::learn(&sample.map(|v| v / mean));
    // The relief is worn in the photo's gamma encoding: in linear light a
    // shadow's gradients are small and survived while highlights went, so
    // raised letters turned into dark smudges.
    let base = crate::image::filter::gaussian_blur(&rgb, GRAIN_SIGMA);
    let grain = Image::from_fn(w, h, 3, |x, y, p| {
        p.iter_mut().zip(rgb.pixel(x, y).iter().zip(base.pixel(x, y))).for_each(|(o, (l, b))| *o = l - b)
    });
    let borrowing = update::Borrowing::new(&tendency, &grain, &mask, (&patches, &offsets), scale);
    let own_pits = pits::OwnPits::find(&linear, &tight);
    let plants = crate::image::filter::gaussian_blur(&select::plants(&rgb, &tight).dilate(1).to_image(), PLANT_EDGE_SIGMA)
        .map(|v| v.clamp(0.0, 1.0));
    Ok(Prepared {
        linear,
        original: rgb,
        mask,
        object: tight,
        sources,
        masked,
        tendency,
        patches,
        offsets,
        base,
        grain,
        scale,
        borrowing,
        fractal,
        own_pits,
        plants,
        params: params.clone(),
    })
}

/// Where weathered stone is borrowed from: the object proper without a
/// band of one patch scale along its outline (at most [`MAX_SOURCE_MARGIN`]
/// px), or the whole object proper if that leaves under a quarter of it.
///
/// Not in the paper. The outline band is where an object turns away: a
/// bevel, a sawn foot, a side face, with its own texture. Calm (so chosen
/// by eq. 1) and borrowed by every patch, the sawn foot of a granite slab
/// put its horizontal saw marks all over the face.
fn sources(tight: &Mask, scale: f32) -> Mask {
    let margin = (scale.round() as usize).clamp(2, MAX_SOURCE_MARGIN);
    let inner = tight.erode(margin);
    if inner.count() * 4 >= tight.count() {
        inner
    } else {
        tight.clone()
    }
}

/// Blur (px) of the plants' mask: their outline is anti-aliased.
const PLANT_EDGE_SIGMA: f32 = 0.7;

/// Widest band (px) along the outline that is never borrowed from.
pub const MAX_SOURCE_MARGIN: usize = 24;

fn check_params(p: &StoneParams) -> Result<()> {
    let positive = [("eta", p.eta), ("m", p.m), ("K", p.seg_k), ("n", p.n), ("max patch", p.max_patch)];
    for (name, v) in positive {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::invalid(format!("{name} must be a positive number, got {v}")));
        }
    }
    let non_negative = [("wd", p.wd), ("k", p.k), ("nu", p.nu), ("erosion speed", p.erosion_speed)];
    for (name, v) in non_negative {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::invalid(format!("{name} must be a number >= 0, got {v}")));
        }
    }
    if !(0.0..=1.0).contains(&p.bleed) {
        return Err(Error::invalid(format!("bleed must be in [0, 1], got {}", p.bleed)));
    }
    Ok(())
}

/// The weathered photo at each of `times` (ascending, >= 0; the paper uses
/// 0 to 100). Erosion carries over from one time to the next, so the
/// object only shrinks.
pub fn sequence(prep: &Prepared, times: &[f32], seed: u64, progress: Option<Progress>) -> Result<Vec<Frame>> {
    if times.is_empty() || times.iter().any(|t| !t.is_finite() || *t < 0.0) || times.windows(2).any(|p| p[1] < p[0]) {
        return Err(Error::invalid("times must be finite, >= 0 and ascending"));
    }
    let p = &prep.params;
    let (w, h) = prep.linear.size();
    let fractal = prep.fractal.render(w, h, seed);
    let erode = p.erosion && prep.masked && prep.mask.count() < w * h;
    let mut erosion = Erosion::new(&prep.linear, &prep.mask, p.bleed, seed);
    let object_pixels = prep.mask.count();
    let chips = update::chips(w, h, seed);
    // Roughening and pits follow the tendency where the photo is sharp
    // ([`update::Borrowing::sharpness`]).
    let sharpness = prep.borrowing.sharpness();
    let focused = Image::from_fn(w, h, 1, |x, y, p| p[0] = prep.tendency.at(x, y, 0) * sharpness.at(x, y, 0));
    // The background behind everything the silhouette loses by the last
    // time, synthesized once: erosion only grows, so every frame's rim
    // takes its fill from the same image and the fill does not flicker.
    let behind = if erode {
        let mut last = erosion.clone();
        let end = erosion::iterations(object_pixels, p.erosion_speed, times[times.len() - 1]);
        (0..end).for_each(|_| last.step());
        let lost = Mask::from_fn(w, h, |x, y| prep.mask.get(x, y) && !last.object.get(x, y));
        let near = lost.dilate(erosion::EDGE_BAND);
        let hole = Mask::from_fn(w, h, |x, y| prep.mask.get(x, y) && near.get(x, y));
        let background = Mask::from_fn(w, h, |x, y| !prep.mask.get(x, y));
        Some(erosion::synthesize_background(&prep.original, &background, &hole, seed)?)
    } else {
        None
    };
    let lit = lit_chromaticity(&prep.linear, &prep.mask, prep.scale);
    let photo_relief = relief(&prep.linear);
    // The share of the weathering each standing pixel shows: none on the
    // rim ring (weathered as stone, the board or the shadow it half holds
    // turned into an orange fringe or a grey line where the foot kept it),
    // fading in over `feather` px inside the object proper.
    let inside = prep.object.distance_inside();
    let fade: Vec<f32> = inside.iter().map(|&d| if p.feather > 0.0 { (d / p.feather).min(1.0) } else { f32::from(d > 0.0) }).collect();
    let mut done = 0;
    let mut frames = Vec::with_capacity(times.len());
    for (i, &t) in times.iter().enumerate() {
        let weights = prep.borrowing.weights(&prep.mask, (p.k, t), &chips);
        let smoothed = update::update((&prep.base, &prep.grain), &weights, (&prep.mask, &prep.sources), &prep.borrowing)
            .map(|v| v.max(0.0).powf(GAMMA));
        let smoothed = keep_shade(&keep_colour(&smoothed, &prep.linear, &lit), &photo_relief);
        let rough = if p.roughen { roughen::roughen(&smoothed, &focused, &fractal, p.nu, p.k, t) } else { smoothed };
        let rough = if p.pits { prep.own_pits.keep(&pits::pit(&rough, &focused, p.k, t, seed), p.k, t) } else { rough };
        let (mut weathered, contrast) = match_luminance(&rough, &prep.linear, &prep.mask, prep.scale);
        if erode {
            let target = erosion::iterations(object_pixels, p.erosion_speed, t);
            while done < target {
                erosion.step();
                done += 1;
            }
            // Bleeding is tracked on the original colours; carry its change over.
            for (idx, v) in weathered.data_mut().iter_mut().enumerate() {
                *v += erosion.colours.data()[idx] - prep.linear.data()[idx];
            }
        }
        let object = if erode { erosion.object.clone() } else { prep.mask.clone() };
        let encode = |v: f32| v.clamp(0.0, 1.0).powf(1.0 / GAMMA);
        let mut image = prep.original.clone();
        for y in 0..h {
            for x in 0..w {
                if object.get(x, y) {
                    let (px, f) = (weathered.pixel(x, y), fade[y * w + x]);
                    image.pixel_mut(x, y).iter_mut().zip(px).for_each(|(o, &v)| *o += f * (encode(v) - *o));
                }
            }
        }
        if erode {
            // Anti-aliased outline, on both sides of it: the standing stone
            // near the eroded area and the eroded pixels both get the
            // background fill behind them and show the stone by the
            // standing object blurred ([`erosion::EDGE_SIGMA`]), so the cut
            // is neither a pixel staircase nor a one-sided fade.
            let eroded = Mask::from_fn(w, h, |x, y| prep.mask.get(x, y) && !object.get(x, y));
            let near = eroded.dilate(erosion::EDGE_BAND);
            let rim = Mask::from_fn(w, h, |x, y| eroded.get(x, y) || (near.get(x, y) && object.get(x, y)));
            let filled = behind.as_ref().expect("made when eroding");
            let coverage = crate::image::filter::gaussian_blur(&object.to_image(), erosion::EDGE_SIGMA);
            for idx in set_pixels(&rim) {
                let (x, y) = (idx % w, idx / w);
                let a = coverage.data()[idx].clamp(0.0, 1.0);
                let standing = object.get(x, y);
                for (c, (o, &fill)) in image.pixel_mut(x, y).iter_mut().zip(filled.pixel(x, y)).enumerate() {
                    let stone = if standing { *o } else { encode(weathered.at(x, y, c)) };
                    *o = a * stone + (1.0 - a) * fill;
                }
            }
        }
        // Plants stay as they are, over standing and eroded stone alike.
        for idx in set_pixels(&prep.mask) {
            let keep = prep.plants.data()[idx];
            if keep > 0.0 {
                let (x, y) = (idx % w, idx / w);
                let was = prep.original.pixel(x, y);
                image.pixel_mut(x, y).iter_mut().zip(was).for_each(|(o, v)| *o += keep * (v - *o));
            }
        }
        frames.push(Frame { t, image, mask: object, contrast });
        if let Some(report) = progress {
            report(i as u64 + 1, times.len() as u64);
        }
    }
    Ok(frames)
}

/// The update's luminance with the photo's colour: each pixel of `worn`
/// keeps the original's chromaticity (linear RGB over luminance) at its
/// new luminance, as a change of shading scales the light every channel
/// reflects; where the wear lightens a pixel by more than
/// [`LIFT_KEEPS_TINT`] times, its chromaticity moves towards the lit
/// stone's around it (`lit`, [`lit_chromaticity`]), all the way at
/// [`MAX_SHADING_GAIN`] times and above.
///
/// Not in the paper, which updates each channel. Grime in a carving's
/// hollows, stains and lichen are colour on the stone, not relief: worn
/// channel by channel they faded towards the stone's prevailing colour,
/// and the beige grime between a Buddha's curls turned blue-white (a
/// "frost" in two blind reviews). But a deep shadow's tint is the light's,
/// not the stone's: a sky-lit groove filled in by the wear kept its blue
/// (granite letters lifted 2.7 times turned into flat blue patches), and a
/// near-black fleck lifted fourfold turned into a vivid orange dot. Those
/// lifts are far above what grime in a worn groove gets, so the share of
/// the lit stone's colour grows with the lift.
fn keep_colour(worn: &Image, linear: &Image, lit: &Image) -> Image {
    let (a, b) = (luminance(worn), luminance(linear));
    let span = (MAX_SHADING_GAIN / LIFT_KEEPS_TINT).ln();
    Image::from_fn(linear.width(), linear.height(), 3, |x, y, px| {
        let (new, old) = (a.at(x, y, 0).max(0.0), b.at(x, y, 0).max(0.0));
        let share = if old > 0.0 { ((new / old / LIFT_KEEPS_TINT).max(1.0).ln() / span).min(1.0) } else { 1.0 };
        let own = linear.pixel(x, y);
        for ((p, &v), &l) in px.iter_mut().zip(own).zip(lit.pixel(x, y)) {
            let tint = if old > 0.0 { v / old } else { l };
            *p = new * (tint + share * (l - tint));
        }
    })
}

/// The worn relief with its recesses kept in shade: where the update
/// lightens the relief ([`relief`]) above the photo's (`photo_relief`),
/// only [`LIFT_SHARE`] of that lift is kept, and each pixel's
/// colour is scaled by the same ratio (the grain on it keeps its contrast).
///
/// Not in the paper, whose Poisson update lowers a carving's ridges and
/// raises its hollows alike. Weathered carvings keep dark hollows: grime
/// and crust gather where rain does not wash, while the exposed ridges wear
/// down. Raised evenly, the hollows between a Buddha's curls and around a
/// slab's raised letters turned into a pale haze ("lifted shadows look like
/// fog" in two blind reviews), a loss of contrast that reads as a washed
/// or defocused photo rather than worn stone.
fn keep_shade(worn: &Image, photo_relief: &Image) -> Image {
    let lum = luminance(worn);
    let (now, was) = (crate::image::filter::gaussian_blur(&lum, GRAIN_SIGMA), photo_relief);
    let mut out = worn.clone();
    out.data_mut().chunks_exact_mut(3).enumerate().for_each(|(i, px)| {
        let (l, lift) = (lum.data()[i], now.data()[i] - was.data()[i]);
        if lift > 0.0 && l > 1e-6 {
            let ratio = ((l - (1.0 - LIFT_SHARE) * lift) / l).max(0.0);
            px.iter_mut().for_each(|v| *v *= ratio);
        }
    });
    out
}

/// The relief [`keep_shade`] compares: luminance blurred by [`GRAIN_SIGMA`].
fn relief(linear: &Image) -> Image {
    crate::image::filter::gaussian_blur(&luminance(linear), GRAIN_SIGMA)
}

/// Share of the wear's lift of the relief that [`keep_shade`] keeps.
pub const LIFT_SHARE: f32 = 0.3;

/// Lift (new over old luminance) up to which the wear keeps a pixel's own
/// tint whole ([`keep_colour`]).
const LIFT_KEEPS_TINT: f32 = 1.25;
/// Lift from which a pixel takes the lit stone's tint whole.
const MAX_SHADING_GAIN: f32 = 3.0;

/// The chromaticity of the lit stone around each pixel of `object`:
/// linear RGB over luminance, both summed over a Gaussian of `sigma` px on
/// the object, so the bright pixels, which hold most of the light, set it.
fn lit_chromaticity(linear: &Image, object: &Mask, sigma: f32) -> Image {
    let (w, h) = linear.size();
    let on = |x: usize, y: usize| if object.get(x, y) { 1.0 } else { 0.0 };
    let masked = Image::from_fn(w, h, 3, |x, y, p| p.iter_mut().zip(linear.pixel(x, y)).for_each(|(o, v)| *o = v * on(x, y)));
    let light = crate::image::filter::gaussian_blur(&masked, sigma);
    let lum = luminance(&light);
    Image::from_fn(w, h, 3, |x, y, p| {
        let l = lum.at(x, y, 0);
        p.iter_mut().zip(light.pixel(x, y)).for_each(|(o, v)| *o = if l > 1e-6 { v / l } else { 1.0 })
    })
}

/// KS distance the contrast step settles for (the issue's tolerance).
pub const CONTRAST_KS: f32 = 0.05;

/// The contrast step: bring the object's luminance histogram back to the
/// original's, on the object's form, and scale the colour channels by the
/// same ratio. Outside the mask the image is unchanged.
///
/// Departures from an exact match:
/// - The match is made on the luminance blurred at the patch scale
///   `scale` (the form), and the detail above it is carried over as it
///   is. An exact per-pixel match restores the shadows the wear removed by
///   darkening whatever is darkest in the worn areas: on a gravestone it
///   cut the letters back to full depth, and on a test relief it raised
///   the carvings' band energy above the original.
/// - The exact (rank to quantile) match of the form is blended in with the
///   smallest strength s in 0, 1/16, ..., 1 whose result is within
///   [`CONTRAST_KS`] of the original form's histogram. Returns the image
///   and s.
pub fn match_luminance(image: &Image, reference: &Image, mask: &Mask, scale: f32) -> (Image, f32) {
    let w = image.width();
    let form = |img: &Image| crate::image::filter::gaussian_blur(&luminance(img), scale);
    let (lum, reference_lum) = (form(image), form(reference));
    let inside: Vec<usize> = set_pixels(mask).collect();
    let mut order = inside.clone();
    order.sort_unstable_by(|&a, &b| lum.data()[a].total_cmp(&lum.data()[b]).then(a.cmp(&b)));
    let mut target: Vec<f32> = inside.iter().map(|&i| reference_lum.data()[i]).collect();
    target.sort_unstable_by(f32::total_cmp);
    let mut matched = vec![0f32; lum.data().len()];
    for (rank, &i) in order.iter().enumerate() {
        matched[i] = target[rank];
    }
    // Walking `order`, both the luminance and its exact match ascend, so
    // every blend of them is sorted (up to rounding, which the check below
    // catches): the per-candidate sort is almost always skipped.
    let mut blended = vec![0f32; order.len()];
    let mut within = |s: f32| {
        for (v, &i) in blended.iter_mut().zip(&order) {
            *v = lum.data()[i] + s * (matched[i] - lum.data()[i]);
        }
        if blended.windows(2).any(|p| p[1] < p[0]) {
            blended.sort_unstable_by(f32::total_cmp);
        }
        crate::metrics::ks_distance_sorted(&blended, &target) <= CONTRAST_KS
    };
    let strength = (0..=16).map(|k| k as f32 / 16.0).find(|&s| within(s)).unwrap_or(1.0);
    let mut out = image.clone();
    let pixel_lum = luminance(image);
    for &i in &inside {
        let old = pixel_lum.data()[i];
        let new = old + strength * (matched[i] - lum.data()[i]);
        let px = out.pixel_mut(i % w, i / w);
        if old > 1e-5 {
            px.iter_mut().for_each(|v| *v *= new / old);
        } else {
            px.iter_mut().for_each(|v| *v += new - old);
        }
    }
    (out, strength)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A carving's groove and ridge both worn halfway flat: the groove
    /// keeps most of its shade (only LIFT_SHARE of its lift), the ridge
    /// wears down in full, and flat stone is untouched.
    #[test]
    fn worn_hollows_keep_their_shade_and_ridges_wear_down() {
        let (w, h) = (96, 48);
        let profile = |x: usize| match x {
            20..32 => -0.2,
            60..72 => 0.2,
            _ => 0.0,
        };
        let photo = Image::from_fn(w, h, 3, |x, _, p| p.fill(0.4 + profile(x)));
        let worn = Image::from_fn(w, h, 3, |x, _, p| p.fill(0.4 + 0.5 * profile(x)));
        let kept = keep_shade(&worn, &relief(&photo));
        let column = |img: &Image, x: usize| img.at(x, h / 2, 0);
        let lift = column(&kept, 26) - column(&photo, 26);
        assert!((lift - LIFT_SHARE * 0.1).abs() < 0.01, "the groove's centre rose by {lift}");
        assert!((column(&kept, 66) - column(&worn, 66)).abs() < 1e-6, "the ridge wears as the update says");
        assert!((column(&kept, 45) - 0.4).abs() < 1e-6 && (column(&kept, 90) - 0.4).abs() < 1e-6);
    }

    #[test]
    fn stone_is_not_borrowed_from_the_band_along_the_outline_unless_the_object_is_small() {
        // A 200 x 100 slab at a patch scale of 12: the 12 px band along its
        // outline is never a source.
        let slab = Mask::from_fn(240, 140, |x, y| (20..220).contains(&x) && (20..120).contains(&y));
        let inner = sources(&slab, 12.0);
        assert!(inner.get(40, 40) && inner.get(120, 70), "the face is a source");
        assert!(!inner.get(25, 70) && !inner.get(120, 115) && !inner.get(215, 30), "the outline band is not");
        assert!((inner.count() as f32 - 176.0 * 76.0).abs() < 0.05 * 176.0 * 76.0, "{} source pixels", inner.count());
        // A thin strip would lose more than three quarters: it keeps its own.
        let strip = Mask::from_fn(240, 140, |x, y| (20..220).contains(&x) && (60..80).contains(&y));
        assert_eq!(sources(&strip, 12.0).count(), strip.count());
    }
}
