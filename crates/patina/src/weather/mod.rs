//! Texture weathering from a single image (Bellini, Kleiman, Cohen-Or,
//! "Time-varying Weathering in Texture Space", SIGGRAPH 2016).
//!
//! - [`age`]: the age map (section 4), what is weathered and how much;
//!   [`material`] raises the plain interiors of wide damage by colour.
//! - [`tiles`] and [`intact`]: the texture before it weathered (section 5).
//! - [`sequence`]: de-weathering and weathering frames (section 6).
//! - [`transfer`]: weathering of one texture carried onto another (section 7).
//! - [`layers`]: colour layers aged separately.
//! - [`rebuild`]: templates made real with input patches (all sections).
//! - [`object`]: a surface that is only part of the photo (`--mask`).
//!
//! [`weather`] runs the whole method on one image.

pub mod age;
pub mod features;
pub mod growth;
pub mod intact;
pub mod layers;
pub mod material;
pub mod object;
pub mod rebuild;
pub mod sequence;
pub mod tiles;
pub mod transfer;

pub use age::{age_map, AgeMap, AgeParams};
pub use features::Features;
pub use intact::{intact, Intact, IntactParams};
pub use sequence::{Frame, Growth, SequenceParams};

use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use serde::{Deserialize, Serialize};

/// Every parameter of the method, with the paper's defaults.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct WeatherParams {
    pub age: AgeParams,
    pub intact: IntactParams,
    pub sequence: SequenceParams,
    /// Colour layers aged separately (k-means in Lab); 0 or 1 = one layer.
    pub layers: usize,
}

/// Inputs that replace automatic steps.
#[derive(Clone, Copy, Debug, Default)]
pub struct Overrides<'a> {
    /// A user-painted age map (one channel, [0, 1], white = weathered).
    pub age: Option<&'a Image>,
    /// A user-provided intact texture.
    pub intact: Option<&'a Image>,
    /// A user label image for the layers (one grey level per layer).
    pub labels: Option<&'a Image>,
    /// The surface to weather, when it is only part of the photo (set =
    /// weathers; see [`object`]): every frame keeps the input outside it
    /// exactly, and the age map is 0 there. With [`Growth::Patches`] the
    /// patch blends are still chosen over the whole work area and only
    /// pasted inside the mask.
    pub mask: Option<&'a Mask>,
    /// A pixel (x, y) the user knows is weathering. Prevalence calls the
    /// commoner material intact, which is wrong where the weathering
    /// covers most of the surface (a hydrant more rust than paint, stone
    /// under lichen); when the age map judges this pixel intact (below its
    /// automatic cut), the age map is turned over (1 - age on the surface).
    pub weathered_at: Option<(usize, usize)>,
}

/// Stages of [`weather`], reported to the progress callback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    AgeMap,
    Intact,
    /// Past frame k of n is done.
    Past(usize, usize),
    /// Future frame k of n is done.
    Future(usize, usize),
}

/// The result of [`weather`].
#[derive(Clone, Debug)]
pub struct Weathered {
    /// The age map (one channel, 0 intact .. 1 most weathered).
    pub age: Image,
    /// Grid N, patch size and K of the automatic age map (`None` when given).
    pub age_grid: Option<AgeGrid>,
    pub intact: Image,
    /// The tile grid, when one was found.
    pub lattice: Option<tiles::Lattice>,
    /// The age cut and the fraction of the surface judged weathered (`None`
    /// with a user intact texture).
    pub weathered: Option<(f32, f32)>,
    /// Whether the age map was turned over to match
    /// [`Overrides::weathered_at`].
    pub flipped: bool,
    /// The colour layers, when asked for.
    pub layers: Option<layers::Layers>,
    /// Every frame in time order: intact (t = 0), past, input (t = 1), future.
    pub frames: Vec<Frame>,
}

/// Grid N, patch size and K of an automatic age map.
pub type AgeGrid = (usize, (usize, usize), usize);

/// The colour layers asked for: the label image when given, else k-means
/// into `count` layers when `count` > 1, else none.
pub fn resolve_layers(input: &Image, count: usize, labels: Option<&Image>, seed: u64) -> Result<Option<layers::Layers>> {
    match labels {
        Some(l) if l.size() != input.size() => Err(Error::invalid(format!(
            "the label image is {}x{} but the input is {}x{}",
            l.width(),
            l.height(),
            input.width(),
            input.height()
        ))),
        Some(l) => Ok(Some(layers::Layers::from_label_image(l)?)),
        None if count > 1 => Ok(Some(layers::Layers::kmeans(input, count, crate::rng::derive(seed, &[4]))?)),
        None => Ok(None),
    }
}

/// The age map the method uses: the user's (its luminance, clamped to
/// [0, 1]) or the automatic one with its grid, normalised within each
/// layer when there are layers; 0 outside `within` when given (see
/// [`age::age_map_within`]).
pub fn resolve_age(
    input: &Image,
    params: &AgeParams,
    user: Option<&Image>,
    layers: Option<&layers::Layers>,
    within: Option<&Mask>,
) -> Result<(Image, Option<AgeGrid>)> {
    let (age, grid) = match user {
        Some(a) => {
            if a.size() != input.size() {
                return Err(Error::invalid(format!(
                    "the age map is {}x{} but the input is {}x{}",
                    a.width(),
                    a.height(),
                    input.width(),
                    input.height()
                )));
            }
            (crate::image::color::luminance(a).map(|v| v.clamp(0.0, 1.0)), None)
        }
        None => {
            let a = age::age_map_within(input, params, within)?;
            (a.map, Some((a.grid, a.patch, a.k)))
        }
    };
    let mut age = match layers {
        Some(l) => l.normalise_age(&age),
        None => age,
    };
    if let Some(m) = within {
        age.data_mut().iter_mut().zip(m.bits()).for_each(|(v, &b)| *v = if b { *v } else { 0.0 });
    }
    Ok((age, grid))
}

/// How far [`weather_until`] goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Until {
    /// The age map only: the result's intact texture is the input itself
    /// and it has no frames.
    AgeMap,
    /// The age map and the intact texture: the frames are the intact
    /// texture (t = 0) and the input (t = 1).
    Intact,
    /// Everything.
    Frames,
}

/// The whole method on `input` (sRGB colour or grey, values in [0, 1]).
/// With a mask ([`Overrides::mask`]) it runs on the masked surface's
/// [`object::Object`] and pastes every result back over the input.
pub fn weather(
    input: &Image,
    params: &WeatherParams,
    overrides: Overrides,
    seed: u64,
    progress: &(dyn Fn(Stage) + Sync),
) -> Result<Weathered> {
    weather_until(input, params, overrides, seed, progress, Until::Frames)
}

/// [`weather`] up to the stage `until`.
pub fn weather_until(
    input: &Image,
    params: &WeatherParams,
    overrides: Overrides,
    seed: u64,
    progress: &(dyn Fn(Stage) + Sync),
    until: Until,
) -> Result<Weathered> {
    // Before any work, and against the whole photo (with a mask, `run`
    // sees only the object's work area).
    if let Some(i) = overrides.intact.filter(|i| i.size() != input.size() || i.channels() != input.channels()) {
        return Err(Error::invalid(format!(
            "the intact texture ({}x{}, {} channels) must match the input ({}x{}, {} channels)",
            i.width(),
            i.height(),
            i.channels(),
            input.width(),
            input.height(),
            input.channels()
        )));
    }
    let layers = resolve_layers(input, params.layers, overrides.labels, seed)?;
    let mask = match overrides.mask {
        Some(m) if m.size() != input.size() => {
            return Err(Error::invalid(format!(
                "the mask is {}x{} but the input is {}x{}",
                m.width(),
                m.height(),
                input.width(),
                input.height()
            )))
        }
        // A mask of the whole photo is no mask.
        Some(m) if m.count() == m.width() * m.height() => None,
        m => m,
    };
    if let Some((x, y)) = overrides.weathered_at {
        if x >= input.width() || y >= input.height() || mask.is_some_and(|m| !m.get(x, y)) {
            let place = if mask.is_some() { "the mask" } else { "the image" };
            return Err(Error::invalid(format!("the weathered pixel {x},{y} is outside {place}")));
        }
    }
    let Some(mask) = mask else {
        return run(input, None, params, overrides, layers, seed, progress, until);
    };
    let object = object::Object::new(input, mask, &params.age, crate::rng::derive(seed, &[5]))?;
    let age = overrides.age.map(|a| object.crop(a, "age map")).transpose()?;
    let intact_img = overrides.intact.map(|i| object.crop(i, "intact texture")).transpose()?;
    let part_layers = layers.as_ref().map(|l| l.crop(object.area()));
    let (x0, y0, _, _) = object.area();
    let weathered_at = overrides.weathered_at.map(|(x, y)| (x - x0, y - y0));
    let part_overrides = Overrides { age: age.as_ref(), intact: intact_img.as_ref(), labels: None, mask: None, weathered_at };
    let part = run(&object.image, Some(&object.within), params, part_overrides, part_layers, seed, progress, until)?;
    Ok(Weathered {
        age: object.paste(None, &part.age),
        age_grid: part.age_grid,
        intact: object.paste(Some(input), &part.intact),
        lattice: part.lattice,
        weathered: part.weathered,
        flipped: part.flipped,
        layers,
        frames: part.frames.into_iter().map(|f| Frame { t: f.t, image: object.paste(Some(input), &f.image) }).collect(),
    })
}

/// The whole method on `input` up to `until`, judging and changing only
/// `within` when given (see [`object`]).
#[allow(clippy::too_many_arguments)]
fn run(
    input: &Image,
    within: Option<&Mask>,
    params: &WeatherParams,
    overrides: Overrides,
    layers: Option<layers::Layers>,
    seed: u64,
    progress: &(dyn Fn(Stage) + Sync),
    until: Until,
) -> Result<Weathered> {
    let (mut age, age_grid) = resolve_age(input, &params.age, overrides.age, layers.as_ref(), within)?;
    // Turned over, the weathering is what the map had judged intact, most
    // of the surface: the cap on the weathered share rises to it (at most
    // MAX_FLIPPED_SHARE).
    let mut intact_params = params.intact.clone();
    let judged = overrides.weathered_at.map(|at| judged_intact(&age, at, within, params.intact.weathered_max));
    let flipped = judged.is_some_and(|(intact, _)| intact);
    if let Some((true, share)) = judged {
        turn_over(&mut age, within);
        intact_params.weathered_max = intact_params.weathered_max.max((1.0 - share).min(MAX_FLIPPED_SHARE));
    }
    let params = &WeatherParams { intact: intact_params, ..params.clone() };
    progress(Stage::AgeMap);
    if until == Until::AgeMap {
        return Ok(Weathered { age, age_grid, intact: input.clone(), lattice: None, weathered: None, flipped, layers, frames: Vec::new() });
    }
    let (intact_img, lattice, weathered) = match overrides.intact {
        // Checked against the whole photo in `weather_until`.
        Some(i) => (i.clone(), None, None),
        None => {
            let r = intact(input, &age, layers.as_ref(), &params.intact, within, crate::rng::derive(seed, &[1]))?;
            (r.image, r.lattice, Some((r.cut, r.weathered_fraction)))
        }
    };
    progress(Stage::Intact);
    if until == Until::Intact {
        let frames = vec![Frame { t: 0.0, image: intact_img.clone() }, Frame { t: 1.0, image: input.clone() }];
        return Ok(Weathered { age, age_grid, intact: intact_img, lattice, weathered, flipped, layers, frames });
    }
    let sp = &params.sequence;
    let past = sequence::past(input, &intact_img, &age, sp, crate::rng::derive(seed, &[2]), &|k| progress(Stage::Past(k, sp.past)))?;
    let (cells, patch) = match age_grid {
        Some((n, (pw, ph), _)) => (n * n, pw.min(ph)),
        None => {
            let (n, (pw, ph)) = params.age.resolve(input.width(), input.height())?;
            (n * n, pw.min(ph))
        }
    };
    let future_progress = |k| progress(Stage::Future(k, sp.future));
    let future = match sp.growth {
        Growth::Front => {
            let cut = match weathered {
                Some((cut, _)) => cut,
                None => intact::weathered_cut(&intact::values_within(&age, within), params.intact.weathered_max).0,
            };
            growth::future(input, &intact_img, &age, cut, within, sp, crate::rng::derive(seed, &[3]), &future_progress)?
        }
        Growth::Patches => sequence::future(input, &intact_img, &age, cells, patch, sp, crate::rng::derive(seed, &[3]), &future_progress)?,
    };
    let mut frames = vec![Frame { t: 0.0, image: intact_img.clone() }];
    frames.extend(past);
    frames.push(Frame { t: 1.0, image: input.clone() });
    frames.extend(future);
    Ok(Weathered { age, age_grid, intact: intact_img, lattice, weathered, flipped, layers, frames })
}

/// Quantile of a turned-over age map (on the surface) that becomes 0.
pub const TURNED_FLOOR: f32 = 0.02;

/// `age` turned over on the surface (`within`, or all of it): 1 - age,
/// rescaled so that its [`TURNED_FLOOR`] quantile is 0 and its largest
/// value 1. The material prevalence had judged weathered (the minority,
/// rated middling as a whole, say 0.4) would otherwise come out as a
/// middling 0.6 all over, not as intact.
fn turn_over(age: &mut Image, within: Option<&Mask>) {
    let on = |i: usize| within.is_none_or(|m| m.bits()[i]);
    let turned: Vec<f32> = age.data().iter().enumerate().filter(|&(i, _)| on(i)).map(|(_, v)| 1.0 - v).collect();
    let mut scaled = turned.clone();
    age::rescale(&mut scaled, &turned, TURNED_FLOOR, 1.0);
    let mut next = scaled.into_iter();
    for (i, v) in age.data_mut().iter_mut().enumerate() {
        *v = if on(i) { next.next().expect("one value per surface pixel") } else { 0.0 };
    }
}

/// Largest share of the surface a turned-over age map may call weathered
/// (see [`Overrides::weathered_at`]).
pub const MAX_FLIPPED_SHARE: f32 = 0.9;

/// Whether `age` judges the pixel `at` intact (the mean age of its 7 x 7
/// neighbourhood on the surface lies below the automatic cut), and the
/// share of the surface the cut judges weathered.
fn judged_intact(age: &Image, (x, y): (usize, usize), within: Option<&Mask>, weathered_max: f32) -> (bool, f32) {
    let (cut, share) = intact::weathered_cut(&intact::values_within(age, within), weathered_max);
    let (w, h) = age.size();
    let (mut sum, mut n) = (0f32, 0usize);
    for v in y.saturating_sub(3)..(y + 4).min(h) {
        for u in x.saturating_sub(3)..(x + 4).min(w) {
            if within.is_none_or(|m| m.get(u, v)) {
                sum += age.at(u, v, 0);
                n += 1;
            }
        }
    }
    (sum / (n.max(1) as f32) < cut, share)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map that rated the majority 0.05 and the minority a middling 0.4,
    /// turned over: the minority is intact (0, not 0.6), the majority fully
    /// weathered, and off the surface stays 0.
    #[test]
    fn a_turned_over_map_rates_the_former_minority_intact() {
        let (w, h) = (40, 20);
        let minority = |x: usize| x < 12;
        let mut age = Image::from_fn(w, h, 1, |x, y, p| p[0] = if minority(x) { 0.4 + 0.001 * y as f32 } else { 0.05 });
        let within = Mask::from_fn(w, h, |x, _| x < 36);
        turn_over(&mut age, Some(&within));
        let at = |x: usize, y: usize| age.at(x, y, 0);
        assert!((0..h).all(|y| at(3, y) < 0.05), "the minority became {:.2}", at(3, 0));
        assert!((0..h).all(|y| at(20, y) > 0.99 && at(38, y) == 0.0));
    }
}
