//! The multi-channel f32 image at the bottom of every patina method, and the
//! operations on it: codecs ([`io`]), colour ([`color`]), filters
//! ([`filter`]) and resampling ([`resample`]).
//!
//! Pixels are interleaved (all channels of a pixel are adjacent), so a patch
//! row is one contiguous slice whatever the channel count: the layout the
//! patch-synthesis engine reads fastest. Channels are grouped under names
//! (`rgb`, `alpha`, `guide`, `kd`, ...) so a 28-channel material stays readable.

pub mod budget;
pub(crate) mod cluster;
pub mod color;
pub mod filter;
pub mod fourier;
pub mod grabcut;
pub mod io;
pub mod maxflow;
pub mod noise;
pub mod order;
pub mod region;
pub mod register;
pub mod resample;
pub mod sequence;
pub mod stain;
pub mod summed;

use crate::error::{Error, Result};
use std::ops::Range;

/// A named run of consecutive channels, e.g. `rgb` = channels 0..3.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChannelGroup {
    pub name: String,
    pub channels: Range<usize>,
}

/// Largest width or height patina accepts for any image (guards against
/// absurd sizes before anything is allocated).
pub const MAX_SIDE: usize = 1 << 16;

/// A width x height image with any number of f32 channels, interleaved.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: usize,
    height: usize,
    channels: usize,
    data: Vec<f32>,
    groups: Vec<ChannelGroup>,
}

fn default_groups(channels: usize) -> Vec<ChannelGroup> {
    let g = |name: &str, r: Range<usize>| ChannelGroup { name: name.to_string(), channels: r };
    match channels {
        1 => vec![g("gray", 0..1)],
        2 => vec![g("gray", 0..1), g("alpha", 1..2)],
        3 => vec![g("rgb", 0..3)],
        4 => vec![g("rgb", 0..3), g("alpha", 3..4)],
        n => vec![g("data", 0..n)],
    }
}

impl Image {
    /// A black image. Panics only on a zero channel count (a programming error).
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        assert!(channels > 0, "an image needs at least one channel");
        Image { width, height, channels, data: vec![0.0; width * height * channels], groups: default_groups(channels) }
    }

    /// An image over existing interleaved data.
    pub fn from_data(width: usize, height: usize, channels: usize, data: Vec<f32>) -> Result<Self> {
        if channels == 0 || data.len() != width * height * channels {
            return Err(Error::invalid(format!(
                "image data of {} values does not fit {width}x{height} with {channels} channels",
                data.len()
            )));
        }
        Ok(Image { width, height, channels, data, groups: default_groups(channels) })
    }

    /// An image whose every pixel is `f(x, y, out)`, with `out` the pixel's channels.
    pub fn from_fn(width: usize, height: usize, channels: usize, mut f: impl FnMut(usize, usize, &mut [f32])) -> Self {
        let mut img = Image::new(width, height, channels);
        for y in 0..height {
            for x in 0..width {
                f(x, y, img.pixel_mut(x, y));
            }
        }
        img
    }

    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    pub fn channels(&self) -> usize {
        self.channels
    }
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }
    /// All values, interleaved: index `(y * width + x) * channels + c`.
    pub fn data(&self) -> &[f32] {
        &self.data
    }
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }
    pub fn into_data(self) -> Vec<f32> {
        self.data
    }
    /// One row's values (`width * channels` floats).
    pub fn row(&self, y: usize) -> &[f32] {
        let n = self.width * self.channels;
        &self.data[y * n..(y + 1) * n]
    }
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }
    pub fn pixel_mut(&mut self, x: usize, y: usize) -> &mut [f32] {
        let i = (y * self.width + x) * self.channels;
        &mut self.data[i..i + self.channels]
    }
    /// Value of channel `c` at (x, y).
    pub fn at(&self, x: usize, y: usize, c: usize) -> f32 {
        self.data[(y * self.width + x) * self.channels + c]
    }

    /// The named channel groups, in channel order.
    pub fn groups(&self) -> &[ChannelGroup] {
        &self.groups
    }
    /// Replace the channel groups. They must cover channels without overlap.
    pub fn set_groups(&mut self, groups: Vec<ChannelGroup>) -> Result<()> {
        let mut covered = vec![false; self.channels];
        for g in &groups {
            if g.channels.end > self.channels || g.channels.is_empty() {
                return Err(Error::invalid(format!("channel group {} is outside the image's {} channels", g.name, self.channels)));
            }
            for c in g.channels.clone() {
                if std::mem::replace(&mut covered[c], true) {
                    return Err(Error::invalid(format!("channel {c} is in two groups")));
                }
            }
        }
        self.groups = groups;
        Ok(())
    }
    /// The channel range of the group called `name`.
    pub fn group(&self, name: &str) -> Option<Range<usize>> {
        self.groups.iter().find(|g| g.name == name).map(|g| g.channels.clone())
    }

    /// A new image holding channels `range` of this one.
    pub fn select_channels(&self, range: Range<usize>) -> Image {
        assert!(range.end <= self.channels && !range.is_empty());
        let n = range.len();
        let mut data = Vec::with_capacity(self.width * self.height * n);
        for px in self.data.chunks_exact(self.channels) {
            data.extend_from_slice(&px[range.clone()]);
        }
        let mut img = Image { width: self.width, height: self.height, channels: n, data, groups: default_groups(n) };
        let groups: Vec<ChannelGroup> = self
            .groups
            .iter()
            .filter(|g| g.channels.start >= range.start && g.channels.end <= range.end)
            .map(|g| ChannelGroup { name: g.name.clone(), channels: g.channels.start - range.start..g.channels.end - range.start })
            .collect();
        if groups.iter().map(|g| g.channels.len()).sum::<usize>() == n {
            img.groups = groups;
        }
        img
    }

    /// Stack images of one size channel-wise; groups keep their names.
    pub fn concat_channels(images: &[&Image]) -> Result<Image> {
        let first = images.first().ok_or_else(|| Error::invalid("no images to stack"))?;
        let (w, h) = first.size();
        if let Some(bad) = images.iter().find(|i| i.size() != (w, h)) {
            return Err(Error::invalid(format!("cannot stack a {}x{} image onto {w}x{h} images", bad.width, bad.height)));
        }
        let channels: usize = images.iter().map(|i| i.channels).sum();
        let mut data = Vec::with_capacity(w * h * channels);
        for p in 0..w * h {
            for img in images {
                data.extend_from_slice(&img.data[p * img.channels..(p + 1) * img.channels]);
            }
        }
        let mut groups = Vec::new();
        let mut start = 0;
        for img in images {
            for g in &img.groups {
                groups.push(ChannelGroup { name: g.name.clone(), channels: g.channels.start + start..g.channels.end + start });
            }
            start += img.channels;
        }
        Ok(Image { width: w, height: h, channels, data, groups })
    }

    /// Apply `f` to every value.
    pub fn map(&self, f: impl Fn(f32) -> f32) -> Image {
        let mut out = self.clone();
        out.data.iter_mut().for_each(|v| *v = f(*v));
        out
    }

    /// The sub-image with top-left corner (x, y) and size w x h.
    pub fn crop(&self, x: usize, y: usize, w: usize, h: usize) -> Result<Image> {
        if x + w > self.width || y + h > self.height || w == 0 || h == 0 {
            return Err(Error::invalid(format!("crop {w}x{h}+{x}+{y} is outside the {}x{} image", self.width, self.height)));
        }
        let c = self.channels;
        let mut data = Vec::with_capacity(w * h * c);
        for yy in y..y + h {
            let start = (yy * self.width + x) * c;
            data.extend_from_slice(&self.data[start..start + w * c]);
        }
        Ok(Image { width: w, height: h, channels: c, data, groups: self.groups.clone() })
    }

    /// Smallest and largest value over all channels.
    pub fn value_range(&self) -> (f32, f32) {
        self.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
    }
}

/// A per-pixel yes/no map (e.g. "may be used", "to synthesize").
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mask {
    width: usize,
    height: usize,
    bits: Vec<bool>,
}

impl Mask {
    /// A mask with every pixel set to `value`.
    pub fn filled(width: usize, height: usize, value: bool) -> Self {
        Mask { width, height, bits: vec![value; width * height] }
    }
    /// A mask from a predicate on pixel positions.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> bool) -> Self {
        let bits = (0..width * height).map(|i| f(i % width, i / width)).collect();
        Mask { width, height, bits }
    }
    /// Pixels of channel 0 above 0.5 are set.
    pub fn from_image(img: &Image) -> Self {
        Mask::from_fn(img.width(), img.height(), |x, y| img.at(x, y, 0) > 0.5)
    }
    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }
    pub fn get(&self, x: usize, y: usize) -> bool {
        self.bits[y * self.width + x]
    }
    pub fn set(&mut self, x: usize, y: usize, v: bool) {
        self.bits[y * self.width + x] = v;
    }
    pub fn bits(&self) -> &[bool] {
        &self.bits
    }
    pub fn count(&self) -> usize {
        self.bits.iter().filter(|&&b| b).count()
    }

    /// `values` (one per pixel) as z-scores over the set pixels: mean 0 and
    /// standard deviation 1 there (floored at 1e-6), every pixel shifted
    /// and scaled alike.
    pub fn standardise(&self, values: &[f32]) -> Vec<f32> {
        let inside: Vec<f64> = values.iter().zip(self.bits()).filter(|(_, &m)| m).map(|(&v, _)| v as f64).collect();
        let n = inside.len().max(1) as f64;
        let mean = inside.iter().sum::<f64>() / n;
        let std = (inside.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt().max(1e-6);
        values.iter().map(|&v| ((v as f64 - mean) / std) as f32).collect()
    }
    /// Where water stands on an object, in [0, 1.6]: up to 1 near its
    /// outline (within about a twentieth of its size; the mask blurred at
    /// that width is a half at the outline and 1 deep inside) plus up to 0.6
    /// towards its bottom. A mask that covers the whole photo has no outline,
    /// and only the bottom term. Decay's rust starts there.
    pub fn wet_places(&self) -> Vec<f32> {
        self.wet_places_weighted(1.0)
    }
    /// [`Mask::wet_places`] with its outline term weighted by `rim`
    /// (grown stbrdf transfer's rust gathers mostly low).
    pub fn wet_places_weighted(&self, rim: f32) -> Vec<f32> {
        let (w, h) = self.size();
        let Some((left, top, right, bottom)) = pixel_bounds(self.bits().iter().enumerate().filter(|(_, &m)| m).map(|(i, _)| i), w) else {
            return vec![0.0; w * h];
        };
        let size = (bottom - top).max(right - left) as f32 + 1.0;
        let depth = filter::gaussian_blur(&self.to_image(), (0.05 * size).max(1.0));
        let span = (bottom - top).max(1) as f32;
        (0..w * h)
            .map(|i| {
                let outline = (2.0 * (1.0 - depth.data()[i])).clamp(0.0, 1.0);
                let low = ((i / w) as f32 - top as f32).max(0.0) / span;
                rim * outline + 0.6 * low
            })
            .collect()
    }
    /// A 1-channel image with 1 where set.
    pub fn to_image(&self) -> Image {
        Image::from_fn(self.width, self.height, 1, |x, y, p| p[0] = if self.get(x, y) { 1.0 } else { 0.0 })
    }
    /// Set pixels with a set pixel within Chebyshev distance `r`.
    pub fn dilate(&self, r: usize) -> Mask {
        self.morph(r, true)
    }
    /// Pixels whose whole (2r+1)^2 square is set and inside the mask's bounds.
    pub fn erode(&self, r: usize) -> Mask {
        self.morph(r, false)
    }
    /// Per pixel, the distance (px, chamfer 3-4, within 6% of Euclidean) from
    /// a set pixel to the nearest unset one; 0 on unset pixels. Outside the
    /// bounds counts as set: the frame is not an edge.
    pub fn distance_inside(&self) -> Vec<f32> {
        let (w, h) = (self.width, self.height);
        let big = (w + h) as f32 * 4.0;
        let mut dist: Vec<f32> = self.bits.iter().map(|&b| if b { big } else { 0.0 }).collect();
        let mut pass = |order: &mut dyn Iterator<Item = usize>, s: isize| {
            for i in order {
                if dist[i] == 0.0 {
                    continue;
                }
                let (x, y) = ((i % w) as isize, (i / w) as isize);
                for (dx, dy, c) in [(s, 0, 3.0), (0, s, 3.0), (s, s, 4.0), (-s, s, 4.0)] {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx >= 0 && ny >= 0 && nx < w as isize && ny < h as isize {
                        let v = dist[ny as usize * w + nx as usize] + c;
                        if v < dist[i] {
                            dist[i] = v;
                        }
                    }
                }
            }
        };
        pass(&mut (0..w * h), -1);
        pass(&mut (0..w * h).rev(), 1);
        dist.iter().map(|d| if *d >= big { f32::INFINITY } else { d / 3.0 }).collect()
    }
    /// Per pixel, the signed distance (px, chamfer as [`Mask::distance_inside`])
    /// to the mask's boundary: positive on set pixels, negative on unset
    /// ones, +-0.5 on the two sides of the boundary. Outside the bounds
    /// continues the nearest edge pixel, so the frame is not a boundary;
    /// a mask with no set (or no unset) pixel is infinitely far from one.
    pub fn signed_distance(&self) -> Vec<f32> {
        let inside = self.distance_inside();
        let complement = Mask { width: self.width, height: self.height, bits: self.bits.iter().map(|b| !b).collect() };
        let outside = complement.distance_inside();
        inside.iter().zip(&outside).map(|(&i, &o)| if i > 0.0 { i - 0.5 } else { 0.5 - o }).collect()
    }
    fn morph(&self, r: usize, dilate: bool) -> Mask {
        // Separable max/min filter; outside the bounds counts as unset.
        let (w, h) = (self.width, self.height);
        let pass = |src: &[bool], horizontal: bool| -> Vec<bool> {
            let mut out = vec![false; w * h];
            for y in 0..h {
                for x in 0..w {
                    let (pos, len) = if horizontal { (x, w) } else { (y, h) };
                    let lo = pos as isize - r as isize;
                    let hi = pos + r;
                    let mut any = false;
                    let mut all = lo >= 0 && hi < len;
                    for q in lo.max(0) as usize..=hi.min(len - 1) {
                        let v = if horizontal { src[y * w + q] } else { src[q * w + x] };
                        any |= v;
                        all &= v;
                    }
                    out[y * w + x] = if dilate { any } else { all };
                }
            }
            out
        };
        let tmp = pass(&self.bits, true);
        Mask { width: w, height: h, bits: pass(&tmp, false) }
    }
}

/// Inclusive bounding box (x0, y0, x1, y1) of row-major pixel indices in an
/// image `w` wide; `None` when there are none.
pub fn pixel_bounds(pixels: impl Iterator<Item = usize>, w: usize) -> Option<(usize, usize, usize, usize)> {
    pixels.fold(None, |b, i| {
        let (x, y) = (i % w, i / w);
        Some(b.map_or((x, y, x, y), |(x0, y0, x1, y1)| (x0.min(x), y0.min(y), x1.max(x), y1.max(y))))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concat_then_select_round_trips_and_keeps_group_names() {
        let a = Image::from_fn(4, 3, 3, |x, y, p| p.copy_from_slice(&[x as f32, y as f32, 1.0]));
        let b = Image::from_fn(4, 3, 1, |x, _, p| p[0] = 10.0 + x as f32);
        let ab = Image::concat_channels(&[&a, &b]).unwrap();
        assert_eq!(ab.channels(), 4);
        assert_eq!(ab.group("rgb"), Some(0..3));
        assert_eq!(ab.group("gray"), Some(3..4));
        assert_eq!(ab.select_channels(0..3), a);
        assert_eq!(ab.select_channels(3..4), b);
        assert!(Image::concat_channels(&[&a, &Image::new(2, 2, 1)]).is_err());
    }

    #[test]
    fn erode_and_dilate_treat_outside_as_unset() {
        let m = Mask::from_fn(9, 9, |x, y| (2..7).contains(&x) && (2..7).contains(&y));
        assert_eq!(m.erode(1).count(), 9);
        assert_eq!(m.dilate(1).count(), 49);
        assert_eq!(Mask::filled(5, 5, true).erode(1).count(), 9);
    }
}
