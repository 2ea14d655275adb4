//! A weathering surface that is part of a photo (an object on a
//! background, a wall around a sign): what `--mask` runs on. Not in the
//! paper, whose inputs are whole textures.
//!
//! The method works on the mask's bounding box widened by a band one
//! age-map cell wide, the widest reach of a patch at the outline
//! ([`Object::new`]). The band outside the mask is filled with the
//! surface's own material ([`Synthesis::fill`], copying from the mask only),
//! so that the patches at the outline compare material with material
//! instead of with the background. Every statistic is then taken over the
//! mask's pixels only ([`super::age::age_map_within`],
//! [`super::intact::intact`], [`super::growth::future`]): the background
//! is never a match, a source, a region or a share. The results are pasted
//! back over the input ([`Object::paste`]), which keeps every pixel outside
//! the mask exactly.

use super::age::AgeParams;
use crate::error::{Error, Result};
use crate::image::{pixel_bounds, Image, Mask};
use crate::synth::{OptimizeParams, Synthesis, VoteWeights};

/// Patch side of the fill that continues the surface into its band.
const BAND_PATCH: usize = 7;

/// The part of a photo the method runs on (see the module docs).
#[derive(Clone, Debug)]
pub struct Object {
    /// Left, top, width and height of the work area in the photo.
    area: (usize, usize, usize, usize),
    /// The photo's size.
    full: (usize, usize),
    /// The work area: the photo, with the band around the mask filled with
    /// the surface's material.
    pub image: Image,
    /// The mask, cropped to the work area.
    pub within: Mask,
}

impl Object {
    /// The surface `mask` marks on `input` (the same size; set = weathers),
    /// with a filled band around it one cell of the age map `age` makes of
    /// the mask's box wide. Errors when the mask is another size or
    /// selects nothing.
    pub fn new(input: &Image, mask: &Mask, age: &AgeParams, seed: u64) -> Result<Object> {
        let (w, h) = input.size();
        if mask.size() != (w, h) {
            return Err(Error::invalid(format!("the mask is {}x{} but the input is {w}x{h}", mask.width(), mask.height())));
        }
        let (x0, y0, x1, y1) = pixel_bounds(mask.bits().iter().enumerate().filter(|(_, &b)| b).map(|(i, _)| i), w)
            .ok_or_else(|| Error::invalid("the mask selects no pixel (white = the surface to weather)"))?;
        let band = age.resolve(x1 - x0 + 1, y1 - y0 + 1).map_or(age.min_patch, |(_, (pw, ph))| pw.max(ph));
        let (x0, y0) = (x0.saturating_sub(band), y0.saturating_sub(band));
        let (x1, y1) = ((x1 + band).min(w - 1), (y1 + band).min(h - 1));
        let (cw, ch) = (x1 - x0 + 1, y1 - y0 + 1);
        let crop = input.crop(x0, y0, cw, ch)?;
        let within = Mask::from_fn(cw, ch, |x, y| mask.get(x0 + x, y0 + y));
        let reach = within.dilate(band);
        let hole = Mask::from_fn(cw, ch, |x, y| !within.get(x, y) && reach.get(x, y));
        let image = if hole.count() == 0 {
            crop
        } else {
            // As the intact texture's fill: robust votes, then verbatim
            // copies inside coherent ones (grain, not a milky wash).
            let op = OptimizeParams { patch: BAND_PATCH, vote: VoteWeights::Robust, ..OptimizeParams::default() };
            let mut filled = Synthesis::new(&crop).fill(&crop, &hole).source_mask(&within).seed(seed).optimize(&op).map_err(|e| {
                Error::invalid(format!("the mask holds no {BAND_PATCH}x{BAND_PATCH} patch of the surface to continue it from ({e})"))
            })?;
            filled.coherent_copies(&crop, &hole);
            filled.image
        };
        Ok(Object { area: (x0, y0, cw, ch), full: (w, h), image, within })
    }

    /// `img` (the photo's size; `what` names it in the error) cropped to
    /// the work area.
    pub fn crop(&self, img: &Image, what: &str) -> Result<Image> {
        if img.size() != self.full {
            return Err(Error::invalid(format!(
                "the {what} is {}x{} but the input is {}x{}",
                img.width(),
                img.height(),
                self.full.0,
                self.full.1
            )));
        }
        let (x0, y0, w, h) = self.area;
        img.crop(x0, y0, w, h)
    }

    /// `input` with the mask's pixels taken from `part` (a result on the
    /// work area, of `input`'s channels, or one channel over a black
    /// photo when `input` is `None`: an age map, 0 outside the mask).
    pub fn paste(&self, input: Option<&Image>, part: &Image) -> Image {
        let (x0, y0, w, h) = self.area;
        let mut out = match input {
            Some(i) => i.clone(),
            None => Image::new(self.full.0, self.full.1, part.channels()),
        };
        for y in 0..h {
            for x in 0..w {
                if self.within.get(x, y) {
                    out.pixel_mut(x0 + x, y0 + y).copy_from_slice(part.pixel(x, y));
                }
            }
        }
        out
    }

    /// Left, top, width and height of the work area in the photo.
    pub fn area(&self) -> (usize, usize, usize, usize) {
        self.area
    }
}
