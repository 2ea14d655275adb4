//! Tile detection for the age map and the intact texture (Bellini et al.
//! 2016, section 5): is the texture a regular grid of tiles, or boards,
//! and with which period?
//!
//! The periods are the synthesis engine's ([`crate::synth::lattice`]: peaks
//! of the normalised autocorrelation of the high-passed appearance, kept
//! only when the structure also repeats at twice the period). The paper
//! finds tile positions by matching a central patch and voting on their
//! offsets; patina's own version of that (stop 24) missed the circle tiles
//! and the damask of ../shared/data and found "stripes" on lichen, rust
//! blooms and a hydrant, so both engine and age map now use one detector.
//!
//! [`median_tile`] then builds the template of section 5: at each pixel,
//! the per-channel median over every tile at the same offset.

use super::features;
use crate::image::filter;
use crate::image::order::median;
use crate::image::{Image, Mask};
use rayon::prelude::*;
use serde::Serialize;

/// The lattice of a tiled texture: the shifts a and b map the tiles onto
/// each other.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Lattice {
    pub a: [f32; 2],
    pub b: [f32; 2],
}

/// Detect a tile grid; `None` means a stochastic texture (or one periodic
/// in a single direction only, see [`periods`]).
pub fn detect(img: &Image) -> Option<Lattice> {
    match periods(img)? {
        Periodicity::Grid(l) => Some(l),
        Periodicity::Stripes(_) => None,
    }
}

/// How a texture repeats.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Periodicity {
    /// A tile grid.
    Grid(Lattice),
    /// Repeats along one direction only (boards, siding, grooves): the
    /// shortest period vector.
    Stripes([f32; 2]),
}

impl Periodicity {
    /// The period vectors: one for stripes, two for a grid.
    pub fn vectors(&self) -> Vec<[f32; 2]> {
        match self {
            Periodicity::Grid(l) => vec![l.a, l.b],
            Periodicity::Stripes(v) => vec![*v],
        }
    }
}

/// Detect how the texture repeats (see the module docs) in its appearance
/// features, every channel weighted alike: one period is
/// [`Periodicity::Stripes`], two a grid, `None` a stochastic texture.
pub fn periods(img: &Image) -> Option<Periodicity> {
    let appearance = features::appearance(img, true).ok()?;
    let lattice = crate::synth::lattice::Lattice::detect(&appearance, &vec![1.0; appearance.channels()])?;
    match lattice.periods[..] {
        [a, b] => Some(Periodicity::Grid(Lattice { a, b })),
        [v] => Some(Periodicity::Stripes(v)),
        _ => None,
    }
}

/// Side of the blocks [`local_periods`] searches, as a share of the
/// image's smaller side (at least [`LOCAL_MIN_SIDE`] px).
pub const LOCAL_SHARE: f32 = 0.5;
/// Smallest block side of [`local_periods`].
pub const LOCAL_MIN_SIDE: usize = 96;

/// A block of the image and the periods its structure repeats at there.
#[derive(Clone, Debug, PartialEq)]
pub struct LocalPeriods {
    /// Left, top, width, height.
    pub rect: (usize, usize, usize, usize),
    /// One (stripes) or two (a grid) period vectors, in pixels.
    pub vectors: Vec<[f32; 2]>,
}

/// Regular structure that repeats only locally: tile courses seen in
/// perspective, louvres, a row of vents or locker doors beside a plain
/// wall. The whole-image detector ([`periods`]) misses them, since their
/// period drifts across the image or holds in part of it only. The same
/// detector runs in overlapping blocks (half a block apart, side
/// [`LOCAL_SHARE`] of the image's smaller side) on the `appearance`
/// features; blocks with no repeat are left out.
pub fn local_periods(appearance: &Image) -> Vec<LocalPeriods> {
    let (w, h) = appearance.size();
    let side = ((LOCAL_SHARE * w.min(h) as f32) as usize).max(LOCAL_MIN_SIDE);
    if side > w || side > h {
        return Vec::new();
    }
    let starts = |n: usize| -> Vec<usize> {
        let step = (side / 2).max(1);
        let mut s: Vec<usize> = (0..=n - side).step_by(step).collect();
        if *s.last().expect("n >= side") != n - side {
            s.push(n - side);
        }
        s
    };
    let rects: Vec<(usize, usize, usize, usize)> =
        starts(h).into_iter().flat_map(|y| starts(w).into_iter().map(move |x| (x, y, side, side))).collect();
    let weights = vec![1.0; appearance.channels()];
    rects
        .into_par_iter()
        .filter_map(|rect| {
            let block = appearance.crop(rect.0, rect.1, rect.2, rect.3).ok()?;
            let lattice = crate::synth::lattice::Lattice::detect(&block, &weights)?;
            Some(LocalPeriods { rect, vectors: lattice.periods })
        })
        .collect()
}

/// Share of the image's edge strength a median repeat must keep to count
/// as the texture's template (see [`keeps_structure`]).
pub const SHARPNESS: f32 = 0.6;

/// Whether `template` (a median repeat of `img`) keeps `img`'s structure
/// over the `allowed` pixels (all when `None`): its mean Sobel gradient
/// magnitude there is at least [`SHARPNESS`] of the image's.
///
/// A lattice found on a surface that repeats only roughly (tiles in
/// perspective) has a median tile that is a blur, which would make a soft
/// intact texture. Sharpness is what tells them apart, not colour: tiles
/// stained each in its own shade (the stained circle tiles of
/// ../shared/data) keep sharp outlines in their median (0.80 of the
/// image's edge strength; the damask 0.91), but their colours differ from
/// the median by 0.7 of their own spread, and an earlier colour test
/// (residual under half the spread) threw their grid away, leaving a
/// stochastic fill that erased the tiles' rims.
pub fn keeps_structure(img: &Image, template: &Image, allowed: Option<&Mask>) -> bool {
    let mean_edge = |im: &Image| {
        let g = filter::gradients(im).magnitude;
        let (mut sum, mut count) = (0f64, 0usize);
        for (i, &m) in g.data().iter().enumerate() {
            if allowed.is_none_or(|a| a.bits()[i]) {
                sum += m as f64;
                count += 1;
            }
        }
        sum / count.max(1) as f64
    };
    let own = mean_edge(img);
    own > 0.0 && mean_edge(template) >= SHARPNESS as f64 * own
}

/// Inverse of the 2x2 matrix with columns a and b.
fn invert(a: [f32; 2], b: [f32; 2]) -> Option<[[f32; 2]; 2]> {
    let det = a[0] * b[1] - b[0] * a[1];
    (det.abs() > 1e-6).then(|| [[b[1] / det, -b[0] / det], [-a[1] / det, a[0] / det]])
}

/// Bilinear sample of all channels at (x, y), or `None` outside the image.
fn sample(img: &Image, x: f32, y: f32, out: &mut [f32]) -> bool {
    let (w, h) = img.size();
    if x < 0.0 || y < 0.0 || x > (w - 1) as f32 || y > (h - 1) as f32 {
        return false;
    }
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let (p00, p10, p01, p11) = (img.pixel(x0, y0), img.pixel(x1, y0), img.pixel(x0, y1), img.pixel(x1, y1));
    for c in 0..out.len() {
        out[c] = (p00[c] * (1.0 - fx) + p10[c] * fx) * (1.0 - fy) + (p01[c] * (1.0 - fx) + p11[c] * fx) * fy;
    }
    true
}

/// The median tile: each pixel is the per-channel median of the image at
/// the same offset in every tile (bilinear, so sub-pixel periods line up).
/// With `allowed`, samples at pixels outside it are left out wherever at
/// least one sample is allowed.
pub fn median_tile(img: &Image, lattice: &Lattice, allowed: Option<&Mask>) -> Image {
    median_translates(img, &[lattice.a, lattice.b], allowed)
}

/// Each pixel the per-channel median of the image at every translate by
/// whole multiples of the period `vectors` (one or two of them) that lands
/// inside it: the median tile of a grid, the median board of stripes.
/// `allowed` as in [`median_tile`].
pub fn median_translates(img: &Image, vectors: &[[f32; 2]], allowed: Option<&Mask>) -> Image {
    let (w, h, n) = (img.width(), img.height(), img.channels());
    let a = vectors.first().copied().unwrap_or([0.0, 0.0]);
    let b = vectors.get(1).copied().unwrap_or([0.0, 0.0]);
    // Multiples that can carry a pixel of the image onto another: the
    // lattice coordinates of the image's corners, relative to each other.
    let corners = [[0.0, 0.0], [w as f32, 0.0], [0.0, h as f32], [w as f32, h as f32]];
    let coords = |p: [f32; 2]| -> [f32; 2] {
        match (vectors.len(), invert(a, b)) {
            (2, Some(inv)) => [inv[0][0] * p[0] + inv[0][1] * p[1], inv[1][0] * p[0] + inv[1][1] * p[1]],
            _ => [(p[0] * a[0] + p[1] * a[1]) / (a[0] * a[0] + a[1] * a[1]).max(1e-6), 0.0],
        }
    };
    let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
    for c in corners {
        let ij = coords(c);
        for k in 0..2 {
            lo[k] = lo[k].min(ij[k]);
            hi[k] = hi[k].max(ij[k]);
        }
    }
    let ra = (hi[0] - lo[0]).ceil() as i32 + 1;
    let rb = if vectors.len() > 1 { (hi[1] - lo[1]).ceil() as i32 + 1 } else { 0 };
    let mut data = vec![0f32; w * h * n];
    data.par_chunks_mut(w * n).enumerate().for_each(|(y, row)| {
        let mut values: Vec<Vec<f32>> = vec![Vec::new(); n];
        let mut rejected: Vec<Vec<f32>> = vec![Vec::new(); n];
        let mut px = vec![0f32; n];
        for x in 0..w {
            values.iter_mut().chain(rejected.iter_mut()).for_each(Vec::clear);
            for i in -ra..=ra {
                for j in -rb..=rb {
                    let sx = x as f32 + i as f32 * a[0] + j as f32 * b[0];
                    let sy = y as f32 + i as f32 * a[1] + j as f32 * b[1];
                    if sample(img, sx, sy, &mut px) {
                        let ok = allowed.is_none_or(|m| m.get(sx.round() as usize, sy.round() as usize));
                        let into = if ok { &mut values } else { &mut rejected };
                        for c in 0..n {
                            into[c].push(px[c]);
                        }
                    }
                }
            }
            if values[0].is_empty() {
                std::mem::swap(&mut values, &mut rejected);
            }
            for c in 0..n {
                let v = &mut values[c];
                row[x * n + c] = median(v).unwrap_or_else(|| img.at(x, y, c));
            }
        }
    });
    let mut out = Image::from_data(w, h, n, data).expect("sizes match");
    out.set_groups(img.groups().to_vec()).expect("same channels");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::filter::gaussian_blur;
    use crate::samples;

    /// The median tile of discs each in its own shade keeps their outlines
    /// and counts as their template; a blurred copy of the same image (what
    /// a roughly repeating surface's median looks like) does not.
    #[test]
    fn a_median_tile_counts_by_its_sharpness_not_its_colour() {
        let p = 40;
        let img = samples::disc_grid(200, 200, p, 5);
        let lattice = Lattice { a: [p as f32, 0.0], b: [0.0, p as f32] };
        let median = median_tile(&img, &lattice, None);
        assert!(keeps_structure(&img, &median, None), "the discs' median tile was refused");
        for sigma in [1.5, 3.0] {
            assert!(!keeps_structure(&img, &gaussian_blur(&img, sigma), None), "a {sigma} px blur passed as a template");
        }
    }
}
