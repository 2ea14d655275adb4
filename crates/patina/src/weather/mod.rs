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
//!
//! [`weather`] runs the whole method on one image.

pub mod age;
pub mod features;
pub mod growth;
pub mod intact;
pub mod layers;
pub mod material;
pub mod rebuild;
pub mod sequence;
pub mod tiles;
pub mod transfer;

pub use age::{age_map, AgeMap, AgeParams};
pub use features::Features;
pub use intact::{intact, Intact, IntactParams};
pub use sequence::{Frame, Growth, SequenceParams};

use crate::error::{Error, Result};
use crate::image::Image;
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
/// layer when there are layers.
pub fn resolve_age(
    input: &Image,
    params: &AgeParams,
    user: Option<&Image>,
    layers: Option<&layers::Layers>,
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
            let a = age_map(input, params)?;
            (a.map, Some((a.grid, a.patch, a.k)))
        }
    };
    let age = match layers {
        Some(l) => l.normalise_age(&age),
        None => age,
    };
    Ok((age, grid))
}

/// The whole method on `input` (sRGB colour or grey, values in [0, 1]).
pub fn weather(
    input: &Image,
    params: &WeatherParams,
    overrides: Overrides,
    seed: u64,
    progress: &(dyn Fn(Stage) + Sync),
) -> Result<Weathered> {
    let layers = resolve_layers(input, params.layers, overrides.labels, seed)?;
    let (age, age_grid) = resolve_age(input, &params.age, overrides.age, layers.as_ref())?;
    progress(Stage::AgeMap);
    let (intact_img, lattice, weathered) = match overrides.intact {
        Some(i) => {
            if i.size() != input.size() || i.channels() != input.channels() {
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
            (i.clone(), None, None)
        }
        None => {
            let r = intact(input, &age, layers.as_ref(), &params.intact, crate::rng::derive(seed, &[1]))?;
            (r.image, r.lattice, Some((r.cut, r.weathered_fraction)))
        }
    };
    progress(Stage::Intact);
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
                None => intact::weathered_cut(&age, params.intact.weathered_max).0,
            };
            growth::future(input, &intact_img, &age, cut, sp, crate::rng::derive(seed, &[3]), &future_progress)?
        }
        Growth::Patches => sequence::future(input, &intact_img, &age, cells, patch, sp, crate::rng::derive(seed, &[3]), &future_progress)?,
    };
    let mut frames = vec![Frame { t: 0.0, image: intact_img.clone() }];
    frames.extend(past);
    frames.push(Frame { t: 1.0, image: input.clone() });
    frames.extend(future);
    Ok(Weathered { age, age_grid, intact: intact_img, lattice, weathered, layers, frames })
}
