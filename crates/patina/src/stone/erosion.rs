//! Silhouette erosion (Xue et al. 2011, section 5): pixels on the object's
//! outline lose durability at a rate set by how exposed they are, with air
//! above counting double (weather comes from above), and are removed when
//! it runs out, bleeding their colour inward first.

use super::{neighbours, set_pixels};
use crate::image::{Image, Mask};
use crate::samples::fractal_noise;
use rayon::prelude::*;

/// Size (px) of the largest chips the outline breaks into; three finer
/// octaves (down to 2 px) break it further, so the bites vary in size
/// instead of lining up as a regular scallop (one 10 px scale did).
pub const CHIP: f32 = 16.0;
/// Size (px) of the pieces the stone breaks off in ([`Erosion::new`]).
pub const CHIP_CELL: f32 = 12.0;
/// Share of the durability set per piece rather than by the noise.
pub const CHIP_CELL_SHARE: f32 = 0.6;
/// Octaves of the durability noise.
const CHIP_OCTAVES: usize = 4;
/// Half side of the exposure window (7 x 7).
const WINDOW: isize = 3;
/// Parts thinner than this (px) erode more slowly, in proportion.
pub const THIN: f32 = 16.0;
/// Slowest erosion of the thinnest parts, as a share of the full rate.
const THIN_FLOOR: f32 = 0.15;
/// Blur (px) of the standing object whose value is the stone's share of a
/// pixel on the eroded outline: about 0.7 on the stone's side of a
/// straight edge and 0.3 on the other, so the outline is about 2 px soft,
/// like a photo's own edges, and pixel steps are rounded off.
pub const EDGE_SIGMA: f32 = 1.0;
/// Standing stone within this many px of the eroded area is blended
/// across the outline.
pub const EDGE_BAND: usize = 2;

/// The erosion state: the object still standing, each pixel's remaining
/// durability and the colours (changed by bleeding).
#[derive(Clone)]
pub struct Erosion {
    pub object: Mask,
    pub colours: Image,
    durability: Vec<f32>,
    /// Per pixel, the share of the full rate it erodes at: less where the
    /// object is thin ([`thinness`]).
    protection: Vec<f32>,
    /// Share of a removed pixel's colour bled into its inner neighbours.
    pub bleed: f32,
}

impl Erosion {
    /// Start from `linear` and its object mask. Durabilities are 0.45 to 1.75,
    /// from a fractal noise at [`CHIP`] px stretched twofold, so soft
    /// pockets go fast and hard lumps stand: the stone breaks in chips
    /// rather than eroding as a smooth offset curve (0.6 to 1.4, unstretched,
    /// read as a smooth offset). [`CHIP_CELL_SHARE`] of it is one value per
    /// cell of a [`CHIP_CELL`] px Voronoi tiling, so a soft piece goes whole
    /// and leaves an angular, straight-sided bite: the noise alone bit
    /// round scallops of much the same size, which a blind review called
    /// procedural.
    pub fn new(linear: &Image, object: &Mask, bleed: f32, seed: u64) -> Self {
        let (w, h) = object.size();
        let durability = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let n = fractal_noise(seed ^ 0xd0_0b1e, x, y, CHIP, CHIP_OCTAVES);
                // Fractal noise gathers near 0.5: stretched, soft and hard stone alternate.
                let soft = ((n - 0.5) * 2.0 + 0.5).clamp(0.0, 1.0);
                let piece = crate::image::noise::Layer::new(seed ^ 0xc41b, 0).worley(x, y, CHIP_CELL).id;
                0.45 + 1.3 * (CHIP_CELL_SHARE * piece + (1.0 - CHIP_CELL_SHARE) * soft)
            })
            .collect();
        let room = room_behind(object);
        let foot = standing(object);
        let protection = thinness(object).iter().zip(room.bits()).zip(&foot).map(|((&p, &r), &f)| if r { p * f } else { 0.0 }).collect();
        Erosion { object: object.clone(), colours: linear.clone(), durability, protection, bleed }
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
            self.durability[i] -= rate * self.protection[i];
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

/// The object pixels the silhouette may lose: those within [`FILL_REACH`]
/// px of background the fill can copy from, the centre of a whole
/// [`FILL_PATCH`] px patch of background beyond the object's rim
/// ([`RIM_SKIP`]). Elsewhere the object stands against the image's frame
/// with a sliver of background, or none, between: what is behind it is
/// off the photo, and no fill can show it. The fill's last resort there,
/// the mirror of that sliver, spread a piece of a pink building beside a
/// slate into a flat mauve disc. So those sides keep their outline, as a
/// photo's frame keeps what it cuts.
fn room_behind(object: &Mask) -> Mask {
    let (w, h) = object.size();
    let beyond_rim = object.dilate(RIM_SKIP);
    let sources = Mask::from_fn(w, h, |x, y| !beyond_rim.get(x, y));
    let reach = sources.erode(FILL_PATCH / 2).dilate(FILL_REACH);
    Mask::from_fn(w, h, |x, y| object.get(x, y) && reach.get(x, y))
}

/// Per pixel, the share of the erosion rate the object's foot allows: 0
/// in the lowest [`FOOT`] of the object's height, rising smoothly to 1 over
/// the next [`FOOT`] above it.
///
/// Not in the paper, whose eq. 5 erodes every silhouette pixel. An object
/// stands on something: the ground, grass or a table runs along its lowest
/// outline, which is where it meets what it stands on, not an edge against
/// the air. Eroded there, a slab's foot, cut by the mask along the grass
/// blades in front of it, was filled with synthesized grass: dark blots,
/// see-through blades and a green haze at its base (a blind review graded
/// that background 2 of 5).
fn standing(object: &Mask) -> Vec<f32> {
    let (w, h) = object.size();
    let Some((bottom, band)) = foot(object) else {
        return vec![1.0; w * h];
    };
    let share = |y: usize| crate::image::noise::smoothstep(bottom as f32 - 2.0 * band, bottom as f32 - band, y as f32);
    (0..w * h).map(|i| 1.0 - share(i / w)).collect()
}

/// The object's lowest row and its foot's height in px ([`FOOT`] of the
/// object's), or `None` for an empty object.
pub(crate) fn foot(object: &Mask) -> Option<(usize, f32)> {
    super::bounds(set_pixels(object), object.width()).map(|(_, top, _, bottom)| (bottom, FOOT * (bottom - top + 1) as f32))
}

/// Share of the object's height along its bottom that does not erode
/// ([`standing`]); as much again above it erodes at a rising rate.
pub const FOOT: f32 = 0.08;

/// Side (px) of the fill's patches.
pub const FILL_PATCH: usize = 7;

/// Farthest (px) an eroded pixel may lie from the background the fill
/// copies from ([`room_behind`]): the fill works in [`FILL_CELL`] px cells.
const FILL_REACH: usize = FILL_CELL;

/// Per pixel, min(1, thickness / [`THIN`]) (at least [`THIN_FLOOR`]), where
/// the thickness of the object around a pixel is twice the largest
/// distance to the background (chamfer 3-4 distance transform) within
/// [`THIN`] / 2 px: the width of the part the pixel belongs to. A forearm
/// 6 px wide erodes at 6/16 of the rate of the torso, so it thins instead
/// of tearing through.
fn thinness(object: &Mask) -> Vec<f32> {
    let (w, h) = object.size();
    let dist = object.distance_inside();
    let radius = (THIN / 2.0) as usize;
    let local_max = |horizontal: bool, src: &[f32]| -> Vec<f32> {
        let mut out = vec![0f32; w * h];
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let (pos, len) = if horizontal { (x, w) } else { (y, h) };
                let (lo, hi) = (pos.saturating_sub(radius), (pos + radius + 1).min(len));
                *o = (lo..hi).map(|q| if horizontal { src[y * w + q] } else { src[q * w + x] }).fold(0.0, f32::max);
            }
        });
        out
    };
    let widest = local_max(false, &local_max(true, &dist));
    widest.iter().map(|&d| (2.0 * d / THIN).clamp(THIN_FLOOR, 1.0)).collect()
}

/// Iterations for time t: epsilon sqrt(N(I)) t.
pub fn iterations(object_pixels: usize, epsilon: f32, t: f32) -> usize {
    (epsilon * (object_pixels as f32).sqrt() * t).round().max(0.0) as usize
}

/// Fill the pixels of `eroded` (object pixels that became background) with
/// the background beyond them: each removed pixel p copies the background
/// pixel mirrored across the outline, 2b - p for b the nearest background
/// pixel (or b itself when the mirror falls off the background). Every
/// other pixel of `image` is kept.
///
/// Copied as it is, the mirror draws symmetric chevrons and bow ties in
/// grass and foliage; [`synthesize_background`] uses it only where the
/// engine has too few source patches.
pub fn fill_background(image: &Image, background: &Mask, eroded: &Mask) -> Image {
    copy_background(image, (background, &nearest_set(background)), eroded, 1.0)
}

/// `image` with each pixel p of `pixels` copied from the background pixel
/// b + `reach` (b - p), for b the nearest background pixel (`nearest`, as
/// [`nearest_set`] gives it; or b itself when that falls off the
/// background): reach 1 mirrors across the outline ([`fill_background`]),
/// 0 carries the nearest background in.
fn copy_background(image: &Image, (background, nearest): (&Mask, &[u32]), pixels: &Mask, reach: f32) -> Image {
    let (w, h) = image.size();
    let mut out = image.clone();
    for p in set_pixels(pixels) {
        let b = nearest[p];
        if b == u32::MAX {
            continue;
        }
        let (px, py, bx, by) = ((p % w) as isize, (p / w) as isize, (b as usize % w) as isize, (b as usize / w) as isize);
        let step = |b: isize, p: isize| b + (reach * (b - p) as f32).round() as isize;
        let (mx, my) = (step(bx, px), step(by, py));
        let mirrored = mx >= 0 && my >= 0 && mx < w as isize && my < h as isize && background.get(mx as usize, my as usize);
        let (sx, sy) = if mirrored { (mx as usize, my as usize) } else { (bx as usize, by as usize) };
        let source = image.pixel(sx, sy).to_vec();
        out.pixel_mut(p % w, p / w).copy_from_slice(&source);
    }
    out
}

/// Width (px) of the band of background beyond the object that the
/// synthesized fill copies from: wider took in other things' colours (the
/// table's tan into a black marker beside a statue).
pub const FILL_SOURCE: usize = 20;

/// Background within this many px of the object is never a source: it
/// holds the stone's anti-aliased rim, which copied along the hole drew a
/// ghost of the old outline.
pub const RIM_SKIP: usize = 2;

/// How far beyond the outline the colour guide looks, as a share of a
/// hole pixel's depth ([`synthesize_background`]).
pub const GUIDE_REACH: f32 = 0.5;

/// Blur (px) of the colour guide ([`synthesize_background`]).
pub const GUIDE_SIGMA: f32 = 3.0;

/// Side (px) of the cells the fill works in.
pub const FILL_CELL: usize = 64;

/// Fill `hole` (stone the silhouette loses) with background synthesized
/// by the engine, as the paper fills by texture synthesis: a hole-filling
/// texture optimization (7 px patches, robust votes, coherent copies kept
/// verbatim) from the background between [`RIM_SKIP`] and [`FILL_SOURCE`]
/// px beyond the object, guided (image analogies, weight 1) by the
/// background carried in ([`GUIDE_REACH`]: a hole pixel d px deep takes
/// the background d / 2 px beyond the outline) blurred by [`GUIDE_SIGMA`]:
/// the guide says which colours belong where (marker black beside the
/// marker, table tan beside the table), the patches give the texture
/// without the copy's chevrons. The standing stone beside the hole is
/// seen as that carried-in background too: as context, its light colour
/// drew the fill towards it. A full mirror (d px beyond) reached past a
/// thin dark line of soil along a granite slab's top into the dead leaves
/// behind it, and the revealed band came out as a pale tan ghost of the
/// old outline (blind review); the nearest background itself (0 px
/// beyond) drew sky blobs in as pillars.
///
/// The hole is a thin band along the outline, so the work goes cell by
/// cell ([`FILL_CELL`] px, in raster order), each on a crop reaching
/// [`FILL_SOURCE`] px around it, with the cells filled before it as fixed
/// context so the band continues across cell borders (the hole of the
/// cells after it is filled too, and filled again in its turn). A cell
/// with too few whole source patches takes the mirror. Pixels outside
/// `hole` are `image`'s.
pub fn synthesize_background(image: &Image, background: &Mask, hole: &Mask, seed: u64) -> crate::error::Result<Image> {
    let (w, h) = image.size();
    let near_object = Mask::from_fn(w, h, |x, y| !background.get(x, y)).dilate(RIM_SKIP);
    let nearest = nearest_set(background);
    let mirror = copy_background(image, (background, &nearest), hole, 1.0);
    // The guide, and the context the patches overlapping the standing
    // stone beside the hole see: the background carried in.
    let near_hole = hole.dilate(FILL_PATCH);
    let beside = Mask::from_fn(w, h, |x, y| near_hole.get(x, y) && !background.get(x, y));
    let extended = copy_background(image, (background, &nearest), &beside, GUIDE_REACH);
    let mut out = extended.clone();
    let margin = FILL_SOURCE + 4;
    let op = crate::synth::OptimizeParams { patch: FILL_PATCH, vote: crate::synth::VoteWeights::Robust, ..Default::default() };
    for cy in (0..h).step_by(FILL_CELL) {
        for cx in (0..w).step_by(FILL_CELL) {
            let (cx1, cy1) = ((cx + FILL_CELL).min(w), (cy + FILL_CELL).min(h));
            if !(cy..cy1).any(|y| (cx..cx1).any(|x| hole.get(x, y))) {
                continue;
            }
            let (x0, y0) = (cx.saturating_sub(margin), cy.saturating_sub(margin));
            let (cw, ch) = ((cx1 + margin).min(w) - x0, (cy1 + margin).min(h) - y0);
            let cell_hole = Mask::from_fn(cw, ch, |x, y| {
                let (gx, gy) = (x + x0, y + y0);
                (cx..cx1).contains(&gx) && (cy..cy1).contains(&gy) && hole.get(gx, gy)
            });
            // The hole of this cell and of the cells after it: those still
            // hold the stone, which as context drew a line of stone-matching
            // pixels along every cell border.
            let open = Mask::from_fn(cw, ch, |x, y| {
                let (gx, gy) = (x + x0, y + y0);
                hole.get(gx, gy) && (gy / FILL_CELL, gx / FILL_CELL) >= (cy / FILL_CELL, cx / FILL_CELL)
            });
            let sources = Mask::from_fn(cw, ch, |x, y| background.get(x + x0, y + y0) && !near_object.get(x + x0, y + y0));
            let synthesized = if sources.erode(3).count() >= 64 && cw >= 16 && ch >= 16 {
                let crop = out.crop(x0, y0, cw, ch)?;
                let guide_source = crate::image::filter::gaussian_blur(&crop, GUIDE_SIGMA);
                let guide_target = crate::image::filter::gaussian_blur(&extended.crop(x0, y0, cw, ch)?, GUIDE_SIGMA);
                let mut filled = crate::synth::Synthesis::new(&crop)
                    .fill(&crop, &open)
                    .source_mask(&sources)
                    .guides(&guide_source, &guide_target, 1.0)
                    .seed(crate::rng::derive(seed ^ 0xf111, &[cx as u64, cy as u64]))
                    .optimize(&op)?;
                filled.coherent_copies(&crop, &open);
                Some(filled.image)
            } else {
                None
            };
            for idx in set_pixels(&cell_hole) {
                let (x, y) = (idx % cw, idx / cw);
                let value = match &synthesized {
                    Some(s) => s.pixel(x, y),
                    None => mirror.pixel(x + x0, y + y0),
                };
                out.pixel_mut(x + x0, y + y0).copy_from_slice(value);
            }
        }
    }
    for idx in set_pixels(&beside) {
        if !hole.bits()[idx] {
            let (x, y) = (idx % w, idx / w);
            out.pixel_mut(x, y).copy_from_slice(image.pixel(x, y));
        }
    }
    Ok(blend_into_background(&out, background, hole))
}

/// The fill blended into the background around it (Pérez, Gangnet, Blake
/// 2003, seamless cloning with the fill's own gradients as the guidance):
/// the fill plus the membrane o that solves Laplace's equation over
/// `hole`, with o = background - fill across every edge where the hole
/// meets the background, and free (no flux) where it meets standing stone.
/// At its border the fill takes the background's level and colour, and
/// the offset spreads smoothly into it; its texture is kept.
///
/// The patches match texture, not the level of the light just beyond
/// them: a slate's revealed sky showed a step one patch darker than the
/// sky above, and a granite slab's revealed strip of dark soil came out as
/// a lighter tan band along its new top edge (blind reviews read both as a
/// ghost of the old outline). An earlier mean-offset match over 6 px bands
/// averaged the step away along the border. Solved by successive
/// over-relaxation over the hole's pixels in raster order (deterministic;
/// the hole is a thin band, so it converges in a few hundred sweeps).
fn blend_into_background(filled: &Image, background: &Mask, hole: &Mask) -> Image {
    let (w, h, c) = (filled.width(), filled.height(), filled.channels());
    let pixels: Vec<usize> = set_pixels(hole).collect();
    let mut index = vec![u32::MAX; w * h];
    pixels.iter().enumerate().for_each(|(k, &p)| index[p] = k as u32);
    // Per hole pixel: its hole neighbours, and the sum of the background's
    // offsets across its border edges and their number (per channel).
    let mut links = vec![[u32::MAX; 4]; pixels.len()];
    let mut fixed = vec![0f32; pixels.len() * c];
    let mut degree = vec![0f32; pixels.len()];
    for (k, &p) in pixels.iter().enumerate() {
        let (x, y) = (p % w, p / w);
        for (slot, (qx, qy)) in neighbours(x, y, w, h).enumerate() {
            let q = qy * w + qx;
            if hole.get(qx, qy) {
                links[k][slot] = index[q];
                degree[k] += 1.0;
            } else if background.get(qx, qy) {
                for ch in 0..c {
                    fixed[k * c + ch] += filled.at(qx, qy, ch) - filled.at(x, y, ch);
                }
                degree[k] += 1.0;
            }
        }
    }
    let mut offset = vec![0f32; pixels.len() * c];
    for _ in 0..MEMBRANE_SWEEPS {
        let mut change = 0f32;
        for k in 0..pixels.len() {
            if degree[k] == 0.0 {
                continue;
            }
            for ch in 0..c {
                let sum = links[k].iter().filter(|&&q| q != u32::MAX).map(|&q| offset[q as usize * c + ch]).sum::<f32>();
                let target = (sum + fixed[k * c + ch]) / degree[k];
                let delta = MEMBRANE_OVERRELAX * (target - offset[k * c + ch]);
                offset[k * c + ch] += delta;
                change = change.max(delta.abs());
            }
        }
        if change < MEMBRANE_TOLERANCE {
            break;
        }
    }
    let mut out = filled.clone();
    for (k, &p) in pixels.iter().enumerate() {
        out.pixel_mut(p % w, p / w).iter_mut().zip(&offset[k * c..(k + 1) * c]).for_each(|(v, o)| *v += o);
    }
    out
}

/// Most sweeps of the membrane solve ([`blend_into_background`]).
const MEMBRANE_SWEEPS: usize = 3000;
/// Over-relaxation factor of the membrane solve.
const MEMBRANE_OVERRELAX: f32 = 1.9;
/// The membrane solve stops when no value moves by more than this.
const MEMBRANE_TOLERANCE: f32 = 1e-5;

/// For every pixel, the index of the nearest set pixel of `set` (u32::MAX
/// when none is set): nearest points propagated over 8-neighbours in a
/// forward and a backward raster pass (Danielsson's vector propagation,
/// within a pixel of the exact Euclidean answer).
fn nearest_set(set: &Mask) -> Vec<u32> {
    let (w, h) = set.size();
    let mut nearest: Vec<u32> = (0..w * h).map(|i| if set.bits()[i] { i as u32 } else { u32::MAX }).collect();
    let d2 = |i: usize, n: u32| {
        let (x, y, nx, ny) = ((i % w) as i64, (i / w) as i64, (n as usize % w) as i64, (n as usize / w) as i64);
        (x - nx).pow(2) + (y - ny).pow(2)
    };
    let relax = |i: usize, dx: isize, dy: isize, nearest: &mut Vec<u32>| {
        let (x, y) = ((i % w) as isize + dx, (i / w) as isize + dy);
        if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
            return;
        }
        let candidate = nearest[y as usize * w + x as usize];
        if candidate != u32::MAX && (nearest[i] == u32::MAX || d2(i, candidate) < d2(i, nearest[i])) {
            nearest[i] = candidate;
        }
    };
    for i in 0..w * h {
        for (dx, dy) in [(-1, 0), (-1, -1), (0, -1), (1, -1)] {
            relax(i, dx, dy, &mut nearest);
        }
    }
    for i in (0..w * h).rev() {
        for (dx, dy) in [(1, 0), (1, 1), (0, 1), (-1, 1)] {
            relax(i, dx, dy, &mut nearest);
        }
    }
    nearest
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Above a slab's top edge, a thin dark line of soil, then light dead
    /// leaves further up (as above a granite slab): the band the slab's top
    /// loses is filled dark, as the soil line continues behind it, not in
    /// the leaves' tan from the far side of the line.
    #[test]
    fn a_thin_revealed_band_takes_the_colour_just_beyond_the_outline() {
        let (w, h) = (160, 120);
        let photo = Image::from_fn(w, h, 3, |x, y, p| {
            let n = crate::samples::value_noise(7, x as f32 / 2.0, y as f32 / 2.0) - 0.5;
            let v = match y {
                0..26 => 0.6 + 0.2 * n,
                26..40 => 0.08 + 0.04 * n,
                _ => 0.85 + 0.1 * n,
            };
            p.copy_from_slice(&[v, v * 0.9, v * 0.7]);
        });
        // The object as a run sees it: the cut at row 40, dilated by 4
        // (part of the soil line); the top 8 rows of stone are lost.
        let background = Mask::from_fn(w, h, |_, y| y < 36);
        let hole = Mask::from_fn(w, h, |_, y| (36..48).contains(&y));
        let filled = synthesize_background(&photo, &background, &hole, 3).unwrap();
        let mean = |rows: std::ops::Range<usize>| {
            let n = (rows.len() * w) as f32;
            rows.flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| filled.at(x, y, 0)).sum::<f32>() / n
        };
        let band = mean(40..46);
        assert!(band < 0.15, "the revealed band's mean level is {band} (soil 0.08, leaves 0.6, stone 0.85)");
    }

    #[test]
    fn a_thin_arm_thins_instead_of_tearing_through() {
        // A 60 px block with a 5 px wide arm rising 30 px from its top.
        let (w, h) = (100, 110);
        let arm = |x: usize, y: usize| (48..53).contains(&x) && (10..40).contains(&y);
        let object = Mask::from_fn(w, h, |x, y| arm(x, y) || ((20..80).contains(&x) && (40..100).contains(&y)));
        let mut erosion = Erosion::new(&Image::new(w, h, 3), &object, 0.0, 5);
        let block_top = |m: &Mask| (20..80).map(|x| (40..100).take_while(|&y| !m.get(x, y)).count()).sum::<usize>() as f32 / 60.0;
        while block_top(&erosion.object) < 2.0 {
            erosion.step();
        }
        // The block's top has worn 2 px; the arm, exposed on both sides, is
        // still there in every row, and most of it stands.
        let rows = (10..40).filter(|&y| (48..53).any(|x| erosion.object.get(x, y))).count();
        let left = (0..w * h).filter(|&i| arm(i % w, i / w) && erosion.object.bits()[i]).count();
        assert!(rows >= 28, "the arm is torn: {rows} of 30 rows left");
        assert!(left * 2 >= 150, "{left} of 150 arm pixels left");
        // Unprotected, the same wear takes the arm apart.
        let mut bare = Erosion::new(&Image::new(w, h, 3), &object, 0.0, 5);
        bare.protection.iter_mut().for_each(|p| *p = 1.0);
        while block_top(&bare.object) < 2.0 {
            bare.step();
        }
        let bare_left = (0..w * h).filter(|&i| arm(i % w, i / w) && bare.object.bits()[i]).count();
        assert!(bare_left < left, "protection made no difference: {bare_left} vs {left}");
    }

    #[test]
    fn a_side_against_the_frame_keeps_its_outline_while_the_top_erodes() {
        // A slab whose right side stands 2 px from the image's right edge;
        // below row 100 no background the fill could copy is within reach.
        let (w, h) = (120, 180);
        let object = Mask::from_fn(w, h, |x, y| (20..w - 2).contains(&x) && (30..h).contains(&y));
        let side_lost = |protected: bool| {
            let mut erosion = Erosion::new(&Image::new(w, h, 3), &object, 0.0, 3);
            if !protected {
                erosion.protection = thinness(&object);
            }
            for _ in 0..12 {
                erosion.step();
            }
            let top = (20..w - 24).filter(|&x| !erosion.object.get(x, 30)).count();
            (top, (100..h).filter(|&y| !erosion.object.get(w - 3, y)).count())
        };
        let (top, side) = side_lost(true);
        assert!(top > 40, "the top lost only {top} of its {} outline pixels", w - 44);
        assert_eq!(side, 0, "the side against the frame lost {side} px");
        assert!(side_lost(false).1 > 20, "without the check the side would erode too");
    }

    #[test]
    fn the_foot_an_object_stands_on_keeps_its_outline_while_the_top_erodes() {
        // A 100 x 150 block with background on every side.
        let (w, h) = (200, 250);
        let object = Mask::from_fn(w, h, |x, y| (50..150).contains(&x) && (50..200).contains(&y));
        let lost = |with_foot: bool| {
            let mut erosion = Erosion::new(&Image::new(w, h, 3), &object, 0.0, 7);
            if !with_foot {
                erosion.protection = thinness(&object);
            }
            for _ in 0..20 {
                erosion.step();
            }
            let gone = |xs: std::ops::Range<usize>, ys: std::ops::Range<usize>| {
                ys.flat_map(|y| xs.clone().map(move |x| (x, y))).filter(|&(x, y)| !erosion.object.get(x, y)).count()
            };
            // The top, the lowest 8% (12 rows) and the bottom edge.
            (gone(50..150, 50..60), gone(50..150, 188..200), gone(50..150, 195..200))
        };
        let (top, foot, bottom) = lost(true);
        assert!(top > 150, "the top lost only {top} px");
        assert_eq!(foot, 0, "the foot lost {foot} px");
        let (_, bare_foot, bare_bottom) = lost(false);
        assert!(
            bare_foot > 50 && bare_bottom > bottom + 50,
            "without the foot it would erode: {bare_foot} px ({bare_bottom} on the bottom edge)"
        );
    }

    #[test]
    fn the_fill_has_no_seam_where_its_cells_meet() {
        // Stone (0.8) below row 50 of a smooth mottled background (0.2 to
        // 0.7); the top 12 rows of the stone are the hole, across two cell
        // borders.
        let (w, h) = (3 * FILL_CELL, 100);
        let image = Image::from_fn(w, h, 1, |x, y, p| {
            p[0] = if y >= 50 { 0.8 } else { 0.2 + 0.5 * crate::samples::value_noise(4, x as f32 / 6.0, y as f32 / 6.0) }
        });
        let background = Mask::from_fn(w, h, |_, y| y < 50);
        let hole = Mask::from_fn(w, h, |_, y| (50..62).contains(&y));
        let filled = synthesize_background(&image, &background, &hole, 1).unwrap();
        // The mean step between a column and the next, over the hole's rows.
        let step = |x: usize| (50..62).map(|y| (filled.at(x + 1, y, 0) - filled.at(x, y, 0)).abs()).sum::<f32>() / 12.0;
        let seams = (step(FILL_CELL - 1) + step(2 * FILL_CELL - 1)) / 2.0;
        let typical = (0..w - 1).map(step).sum::<f32>() / (w - 1) as f32;
        assert!(seams < 2.5 * typical, "the step across a cell border is {seams:.3}, elsewhere {typical:.3}");
    }

    /// A filled hole `w` px wide under the background: the background
    /// (`above` of the column) above row 50, the fill at `fill` in rows 50
    /// to 61, the stone below at 0.8. Returns the image, the background
    /// and the hole.
    fn filled_strip(w: usize, above: impl Fn(usize) -> f32, fill: f32) -> (Image, Mask, Mask) {
        let h = 90;
        let filled = Image::from_fn(w, h, 1, |x, y, p| {
            p[0] = if y < 50 {
                above(x)
            } else if y < 62 {
                fill
            } else {
                0.8
            }
        });
        (filled, Mask::from_fn(w, h, |_, y| y < 50), Mask::from_fn(w, h, |_, y| (50..62).contains(&y)))
    }

    #[test]
    fn the_fill_meets_the_background_without_a_step() {
        // Background 0.6; a fill of 0.4 (the level of sources farther out).
        let (filled, background, hole) = filled_strip(80, |_| 0.6, 0.4);
        let matched = blend_into_background(&filled, &background, &hole);
        let step = (matched.at(40, 50, 0) - matched.at(40, 49, 0)).abs();
        assert!(step < 0.05, "a step of {step:.3} across the border (0.2 unmatched)");
        assert_eq!(matched.at(40, 49, 0), 0.6, "the background is kept");
        assert_eq!(matched.at(40, 70, 0), 0.8, "the stone is kept");
        assert!(matched.at(40, 61, 0) < matched.at(40, 50, 0), "the match fades into the fill");
    }

    /// The background just beyond the hole changes along it (dark and
    /// light bands 12 px wide, as soil and stones), the fill is one level:
    /// at the border the fill takes the background's level pixel by pixel.
    #[test]
    fn the_fill_takes_the_level_of_the_background_beside_it_all_along_the_border() {
        let w = 96;
        let (filled, background, hole) = filled_strip(w, |x| if (x / 12) % 2 == 0 { 0.2 } else { 0.7 }, 0.45);
        let blended = blend_into_background(&filled, &background, &hole);
        let step = (0..w).map(|x| (blended.at(x, 50, 0) - blended.at(x, 49, 0)).abs()).sum::<f32>() / w as f32;
        assert!(step < 0.1, "a mean step of {step:.3} across the border (0.25 unblended, 0.18 with a mean match over 6 px)");
        assert_eq!(blended.at(40, 70, 0), 0.8, "the stone is kept");
    }

    #[test]
    fn the_fill_copies_the_background_beyond_the_outline() {
        // Background: vertical stripes; the object was the left half.
        let (w, h) = (40, 20);
        let img = Image::from_fn(w, h, 1, |x, _, p| {
            p[0] = if x < 20 {
                0.5
            } else if x % 4 < 2 {
                0.2
            } else {
                0.8
            }
        });
        let background = Mask::from_fn(w, h, |x, _| x >= 20);
        let eroded = Mask::from_fn(w, h, |x, _| (16..20).contains(&x));
        let filled = fill_background(&img, &background, &eroded);
        for y in 0..h {
            // x = 19 mirrors across its nearest background pixel 20 to 21.
            assert_eq!(filled.at(19, y, 0), img.at(21, y, 0));
            for x in 16..20 {
                let v = filled.at(x, y, 0);
                assert!(v == 0.2 || v == 0.8, "({x}, {y}) = {v}: not a background pixel");
            }
            assert_eq!(filled.at(5, y, 0), 0.5, "pixels outside the hole are kept");
        }
    }
}
