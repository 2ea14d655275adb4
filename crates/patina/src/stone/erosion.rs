//! Silhouette erosion (Xue et al. 2011, section 5): pixels on the object's
//! outline lose durability at a rate set by how exposed they are, with air
//! above counting double (weather comes from above), and are removed when
//! it runs out, bleeding their colour inward first.

use super::{bounds, neighbours, set_pixels};
use crate::image::{Image, Mask};
use crate::samples::fractal_noise;
use crate::synth::{OptimizeParams, Synthesis};
use crate::Result;
use rayon::prelude::*;

/// Half side of the exposure window (7 x 7).
const WINDOW: isize = 3;

/// The erosion state: the object still standing, each pixel's remaining
/// durability and the colours (changed by bleeding).
#[derive(Clone)]
pub struct Erosion {
    pub object: Mask,
    pub colours: Image,
    durability: Vec<f32>,
    /// Share of a removed pixel's colour bled into its inner neighbours.
    pub bleed: f32,
}

impl Erosion {
    /// Start from `linear` and its object mask. Durabilities are 0.6 to 1.4,
    /// from a 3-octave noise at 6 px so the stone breaks in grains and
    /// chips rather than eroding as a smooth offset curve.
    pub fn new(linear: &Image, object: &Mask, bleed: f32, seed: u64) -> Self {
        let (w, h) = object.size();
        let durability = (0..w * h).map(|i| 0.6 + 0.8 * fractal_noise(seed ^ 0xd0_0b1e, (i % w) as f32, (i / w) as f32, 6.0, 3)).collect();
        Erosion { object: object.clone(), colours: linear.clone(), durability, bleed }
    }

    /// Eq. (5), the erosion rate of a silhouette pixel: the exposed share of
    /// its 7 x 7 window, air / (air + stone), where air pixels above it
    /// count 2 and everything else 1. Outside the image counts as stone (the
    /// frame is not an outline).
    fn rate(&self, x: usize, y: usize) -> f32 {
        let (w, h) = self.object.size();
        let (mut air, mut stone) = (0f32, 0f32);
        for dy in -WINDOW..=WINDOW {
            for dx in -WINDOW..=WINDOW {
                if dx == 0 && dy == 0 {
                    continue;
                }
                let (qx, qy) = (x as isize + dx, y as isize + dy);
                let inside = qx >= 0 && qy >= 0 && qx < w as isize && qy < h as isize;
                if !inside || self.object.get(qx as usize, qy as usize) {
                    stone += 1.0;
                } else {
                    air += if dy < 0 { 2.0 } else { 1.0 };
                }
            }
        }
        air / (air + stone)
    }

    /// A silhouette pixel: an object pixel with a 4-neighbour (in the
    /// image) outside the object.
    fn on_silhouette(&self, x: usize, y: usize) -> bool {
        let (w, h) = self.object.size();
        self.object.get(x, y) && neighbours(x, y, w, h).any(|(a, b)| !self.object.get(a, b))
    }

    /// One iteration: every silhouette pixel's durability drops by its rate
    /// (rates from the outline as it was at the start of the iteration);
    /// those at or below 0 bleed `bleed` of their colour into their inner
    /// 4-neighbours (in row-major order) and become background.
    pub fn step(&mut self) {
        let (w, h) = self.object.size();
        let this = &*self;
        let rates: Vec<(usize, f32)> = (0..h)
            .into_par_iter()
            .flat_map_iter(|y| (0..w).filter(move |&x| this.on_silhouette(x, y)).map(move |x| (y * w + x, this.rate(x, y))))
            .collect();
        let mut removed = Vec::new();
        for (i, rate) in rates {
            self.durability[i] -= rate;
            if self.durability[i] <= 0.0 {
                removed.push(i);
            }
        }
        for &i in &removed {
            self.object.set(i % w, i / w, false);
        }
        let c = self.colours.channels();
        for &i in &removed {
            let (x, y) = (i % w, i / w);
            let colour: Vec<f32> = self.colours.pixel(x, y).to_vec();
            for (a, b) in neighbours(x, y, w, h) {
                if self.object.get(a, b) {
                    let px = self.colours.pixel_mut(a, b);
                    for ch in 0..c {
                        px[ch] = (1.0 - self.bleed) * px[ch] + self.bleed * colour[ch];
                    }
                }
            }
        }
    }
}

/// Iterations for time t: epsilon sqrt(N(I)) t.
pub fn iterations(object_pixels: usize, epsilon: f32, t: f32) -> usize {
    (epsilon * (object_pixels as f32).sqrt() * t).round().max(0.0) as usize
}

/// Fill the pixels of `eroded` (object pixels that became background) from
/// the background around them with the engine's patch-based hole filling,
/// on a crop around the hole, at one pyramid level (the holes are a few
/// pixels wide, and coarser levels of a thin background strip hold no
/// whole patch). When the background holds no whole patch at all, a
/// diffusion fill is used instead. Every other pixel of `image` is kept.
pub fn fill_background(image: &Image, background: &Mask, eroded: &Mask, seed: u64) -> Result<Image> {
    let (w, h) = image.size();
    let Some((x0, y0, x1, y1)) = bounds(set_pixels(eroded), w) else {
        return Ok(image.clone());
    };
    let margin = 24;
    let (cx, cy) = (x0.saturating_sub(margin), y0.saturating_sub(margin));
    let (cw, ch) = ((x1 + margin + 1).min(w) - cx, (y1 + margin + 1).min(h) - cy);
    let crop = image.crop(cx, cy, cw, ch)?;
    let hole = Mask::from_fn(cw, ch, |x, y| eroded.get(cx + x, cy + y));
    let allowed = Mask::from_fn(cw, ch, |x, y| background.get(cx + x, cy + y));
    let op = OptimizeParams { patch: 7, levels: Some(1), ..OptimizeParams::default() };
    let filled = match Synthesis::new(&crop).fill(&crop, &hole).source_mask(&allowed).seed(seed).optimize(&op) {
        Ok(s) => s.image,
        Err(_) => diffuse(&crop, &hole),
    };
    let mut out = image.clone();
    for y in 0..ch {
        for x in 0..cw {
            if hole.get(x, y) {
                out.pixel_mut(cx + x, cy + y).copy_from_slice(filled.pixel(x, y));
            }
        }
    }
    Ok(out)
}

/// Harmonic fill: hole pixels start at the mean of the known pixels and
/// relax to the average of their 4-neighbours (Gauss-Seidel sweeps in
/// row-major order, deterministic).
fn diffuse(image: &Image, hole: &Mask) -> Image {
    let (w, h) = image.size();
    let c = image.channels();
    let mut out = image.clone();
    let known = (0..w * h).filter(|&i| !hole.bits()[i]).count().max(1) as f32;
    for ch in 0..c {
        let mean = (0..w * h).filter(|&i| !hole.bits()[i]).map(|i| image.at(i % w, i / w, ch)).sum::<f32>() / known;
        (0..w * h).filter(|&i| hole.bits()[i]).for_each(|i| out.pixel_mut(i % w, i / w)[ch] = mean);
    }
    for _ in 0..w.max(h) {
        for y in 0..h {
            for x in 0..w {
                if !hole.get(x, y) {
                    continue;
                }
                for ch in 0..c {
                    let (mut sum, mut n) = (0.0, 0.0);
                    for (a, b) in neighbours(x, y, w, h) {
                        sum += out.at(a, b, ch);
                        n += 1.0;
                    }
                    out.pixel_mut(x, y)[ch] = sum / n;
                }
            }
        }
    }
    out
}
