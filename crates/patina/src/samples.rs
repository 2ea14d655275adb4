//! Procedural textures patina makes itself, for the demo and the tests:
//! no data files needed. Each is a deterministic function of its size and
//! seed.

use crate::image::{Image, Mask};
use crate::rng::{self, Rng};

/// A hash of lattice point (x, y) under `seed`, uniform in [0, 1).
fn lattice(seed: u64, x: i64, y: i64) -> f32 {
    (rng::derive(seed, &[x as u64, y as u64]) >> 40) as f32 / (1u64 << 24) as f32
}

/// Smooth value noise at (x, y) with lattice spacing 1, in [0, 1).
pub fn value_noise(seed: u64, x: f32, y: f32) -> f32 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let s = |t: f32| t * t * (3.0 - 2.0 * t);
    let (sx, sy) = (s(fx), s(fy));
    let (ix, iy) = (x0 as i64, y0 as i64);
    let a = lattice(seed, ix, iy) * (1.0 - sx) + lattice(seed, ix + 1, iy) * sx;
    let b = lattice(seed, ix, iy + 1) * (1.0 - sx) + lattice(seed, ix + 1, iy + 1) * sx;
    a * (1.0 - sy) + b * sy
}

/// Fractal value noise: `octaves` octaves from wavelength `scale` pixels
/// down, each half the amplitude; result in about [0, 1).
pub fn fractal_noise(seed: u64, x: f32, y: f32, scale: f32, octaves: usize) -> f32 {
    let (mut sum, mut amp, mut norm, mut freq) = (0.0, 1.0, 0.0, 1.0 / scale);
    for o in 0..octaves {
        sum += amp * value_noise(seed.wrapping_add(o as u64 * 0x9e37), x * freq, y * freq);
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    sum / norm
}

/// `img` under a capture's lighting: a vignette (0.55 at the corners) times
/// a left-to-right ramp from 0.55 to 1.0, on every channel. The ground
/// truth for lighting-aware synthesis.
pub fn lit(img: &Image) -> Image {
    let (w, h) = img.size();
    Image::from_fn(w, h, img.channels(), |x, y, p| {
        let g = light_gain(x, y, w, h);
        p.iter_mut().zip(img.pixel(x, y)).for_each(|(o, c)| *o = c * g);
    })
}

/// The gain [`lit`] applies at pixel (x, y) of a `w` x `h` image.
pub fn light_gain(x: usize, y: usize, w: usize, h: usize) -> f32 {
    let (u, v) = (x as f32 / w as f32 - 0.5, y as f32 / h as f32 - 0.5);
    (1.0 - 0.9 * (u * u + v * v)) * (0.55 + 0.45 * x as f32 / w as f32)
}

/// Running-bond brick wall: bricks of 30 x 12 px with 3 px mortar, a colour
/// per brick and grain noise. Strong regular structure: seams and
/// misaligned mortar lines show at once.
pub fn bricks(width: usize, height: usize, seed: u64) -> Image {
    let (bw, bh, mortar) = (30usize, 12usize, 3usize);
    Image::from_fn(width, height, 3, |x, y, p| {
        let row = y / (bh + mortar);
        let shift = if row % 2 == 1 { (bw + mortar) / 2 } else { 0 };
        let xs = x + shift;
        let col = xs / (bw + mortar);
        let (in_x, in_y) = (xs % (bw + mortar), y % (bh + mortar));
        let grain = fractal_noise(seed ^ 0x51, x as f32, y as f32, 6.0, 3) - 0.5;
        if in_x >= bw || in_y >= bh {
            let v = 0.72 + 0.12 * grain;
            p.copy_from_slice(&[v, v * 0.97, v * 0.92]);
        } else {
            let tone = lattice(seed ^ 0xb1, col as i64, row as i64);
            let base = [0.55 + 0.2 * tone, 0.22 + 0.1 * tone, 0.15 + 0.05 * tone];
            // Darker rim inside each brick, for relief.
            let edge = in_x.min(bw - 1 - in_x).min(in_y).min(bh - 1 - in_y) as f32;
            let shade = 0.8 + 0.2 * (edge / 2.0).min(1.0);
            for c in 0..3 {
                p[c] = (base[c] * shade + 0.18 * grain).clamp(0.0, 1.0);
            }
        }
    })
}

/// The Voronoi cell of a point on a jittered unit grid.
struct Voronoi {
    /// Distances to the nearest and second-nearest feature points.
    d1: f32,
    d2: f32,
    /// Grid cell of the nearest feature point.
    id: (i64, i64),
    /// The point minus its nearest feature point.
    offset: (f32, f32),
}

/// Voronoi cell of (fx, fy) (grid units) among feature points placed one
/// per cell at `margin` + (1 - 2 `margin`) x a hash of the cell under
/// `seeds` (one seed per axis).
fn voronoi(fx: f32, fy: f32, seeds: (u64, u64), margin: f32) -> Voronoi {
    let (cx, cy) = (fx.floor() as i64, fy.floor() as i64);
    let span = 1.0 - 2.0 * margin;
    let mut v = Voronoi { d1: f32::MAX, d2: f32::MAX, id: (0, 0), offset: (0.0, 0.0) };
    for j in -1..=1 {
        for i in -1..=1 {
            let (gx, gy) = (cx + i, cy + j);
            let px = gx as f32 + margin + span * lattice(seeds.0, gx, gy);
            let py = gy as f32 + margin + span * lattice(seeds.1, gx, gy);
            let d = ((px - fx).powi(2) + (py - fy).powi(2)).sqrt();
            if d < v.d1 {
                (v.d2, v.d1, v.id, v.offset) = (v.d1, d, (gx, gy), (fx - px, fy - py));
            } else if d < v.d2 {
                v.d2 = d;
            }
        }
    }
    v
}

/// Cobbles: Voronoi cells on a jittered 24 px grid, each cell its own stone
/// colour, dark joints, speckle noise. Irregular structure.
pub fn cobbles(width: usize, height: usize, seed: u64) -> Image {
    let cell = 24.0f32;
    Image::from_fn(width, height, 3, |x, y, p| {
        let Voronoi { d1, d2, id, .. } = voronoi(x as f32 / cell, y as f32 / cell, (seed, seed ^ 0x77), 0.15);
        let joint = ((d2 - d1) * cell / 3.0).clamp(0.0, 1.0);
        let tone = lattice(seed ^ 0x99, id.0, id.1);
        let speck = fractal_noise(seed ^ 0x5e, x as f32, y as f32, 3.0, 2) - 0.5;
        let dome = 1.0 - 0.35 * d1;
        let base = [0.45 + 0.25 * tone, 0.42 + 0.2 * tone, 0.38 + 0.12 * tone];
        for c in 0..3 {
            p[c] = ((base[c] * dome + 0.15 * speck) * (0.25 + 0.75 * joint)).clamp(0.0, 1.0);
        }
    })
}

/// Gravel: pebbles on a jittered 7 px grid, each its own grey-brown tone
/// with a lit top, dark gaps between them. Stationary and stochastic: no
/// period, every region looks alike.
pub fn gravel(width: usize, height: usize, seed: u64) -> Image {
    let cell = 7.0f32;
    Image::from_fn(width, height, 3, |x, y, p| {
        let Voronoi { d1, d2, id, offset: off } = voronoi(x as f32 / cell, y as f32 / cell, (seed, seed ^ 0x31), 0.1);
        let gap = ((d2 - d1) * cell / 1.5).clamp(0.0, 1.0);
        let tone = lattice(seed ^ 0x5a, id.0, id.1);
        let warm = lattice(seed ^ 0x6b, id.0, id.1);
        let lit = 1.0 - 0.5 * (off.1 + 0.3 * off.0).clamp(-1.0, 1.0);
        let base = [0.35 + 0.35 * tone + 0.08 * warm, 0.33 + 0.33 * tone + 0.03 * warm, 0.3 + 0.3 * tone - 0.04 * warm];
        for c in 0..3 {
            p[c] = (base[c] * lit * (0.3 + 0.7 * gap)).clamp(0.0, 1.0);
        }
    })
}

/// Fractal colour noise (lichen-like blotches): a stochastic texture.
pub fn blotches(width: usize, height: usize, seed: u64) -> Image {
    Image::from_fn(width, height, 3, |x, y, p| {
        let a = fractal_noise(seed, x as f32, y as f32, 16.0, 4);
        let b = fractal_noise(seed ^ 0xabc, x as f32, y as f32, 5.0, 3);
        let t = ((a - 0.45) * 6.0).clamp(0.0, 1.0);
        let grey = 0.45 + 0.3 * (b - 0.5);
        p[0] = grey * (1.0 - t) + (0.75 + 0.2 * (b - 0.5)) * t;
        p[1] = grey * (1.0 - t) + (0.68 + 0.2 * (b - 0.5)) * t;
        p[2] = grey * (1.0 - t) + 0.2 * t;
    })
}

/// Stucco: warm grey plaster with a fractal relief lit from the top left
/// and fine sand speckle. Stochastic and fine-grained: the surface thin
/// cracks and peeling paint weather in real photos.
pub fn stucco(width: usize, height: usize, seed: u64) -> Image {
    let relief = |x: f32, y: f32| fractal_noise(seed ^ 0x57, x, y, 10.0, 4);
    Image::from_fn(width, height, 3, |x, y, p| {
        let (fx, fy) = (x as f32, y as f32);
        let shade = 4.0 * (relief(fx, fy) - relief(fx + 1.0, fy + 1.0));
        let sand = fractal_noise(seed ^ 0x58, fx, fy, 1.5, 2) - 0.5;
        let tone = fractal_noise(seed ^ 0x59, fx, fy, 60.0, 2) - 0.5;
        let v = 0.66 + 0.5 * shade + 0.12 * sand + 0.08 * tone;
        for (c, tint) in [1.0, 0.96, 0.88].iter().enumerate() {
            p[c] = (v * tint).clamp(0.0, 1.0);
        }
    })
}

/// Period, in pixels, of [`planks`] across the boards.
pub const PLANK_PERIOD: usize = 26;

/// Upright boards (grey, one channel) seen from below: `top` px wide at
/// the top, widening evenly to `bottom` px at the bottom and spreading
/// from the centre, with dark gaps and fine grain. With `top == bottom`
/// they repeat with one period; otherwise the period drifts, as a
/// structure photographed at an angle does.
pub fn receding_boards(width: usize, height: usize, top: f32, bottom: f32, seed: u64) -> Image {
    let mut g = rng::generator(seed, &[0xb0]);
    let grain: Vec<f32> = (0..width * height).map(|_| g.gen_range(0.0..0.04)).collect();
    Image::from_fn(width, height, 1, |x, y, p| {
        let u = (x as f32 - width as f32 / 2.0) / (top + (bottom - top) * y as f32 / height as f32);
        let across = u - u.floor();
        p[0] = if across < 0.12 { 0.1 } else { 0.45 + 0.25 * (across - 0.5).abs() } + grain[y * width + x];
    })
}

/// Wooden planks: horizontal boards [`PLANK_PERIOD`] px apart with a
/// 2 px dark gap, each board its own tone, long grain streaks and board
/// ends staggered from row to row. Regular across the boards, stochastic
/// along them: the grooves repeat and must not count as weathering.
pub fn planks(width: usize, height: usize, seed: u64) -> Image {
    let (period, length) = (PLANK_PERIOD, 150usize);
    Image::from_fn(width, height, 3, |x, y, p| {
        let row = y / period;
        let shift = (lattice(seed ^ 0x91, row as i64, 0) * length as f32) as usize;
        let board = (x + shift) / length;
        let along = (x + shift) % length;
        let gap = y % period < 2 || along < 2;
        let tone = lattice(seed ^ 0x92, row as i64, board as i64);
        let grain = fractal_noise(seed ^ 0x93, x as f32 * 0.08, y as f32 * 1.0, 3.0, 3);
        let fine = fractal_noise(seed ^ 0x94, x as f32 * 0.5, y as f32 * 2.0, 2.0, 2);
        let base = [0.55 + 0.15 * tone, 0.38 + 0.1 * tone, 0.22 + 0.06 * tone];
        let streak = 0.75 + 0.4 * (grain - 0.5) + 0.12 * (fine - 0.5);
        for c in 0..3 {
            p[c] = if gap { base[c] * 0.3 } else { (base[c] * streak).clamp(0.0, 1.0) };
        }
    })
}

/// Round tiles on a square grid of `period` px, each disc its own shade of
/// green with its own blotchy stain, on a darker ground with a light rim:
/// exactly periodic in layout and different in every cell (the stained
/// circle tiles of ../shared/data, whose layout synthesis must keep).
pub fn disc_grid(width: usize, height: usize, period: usize, seed: u64) -> Image {
    let p = period as f32;
    Image::from_fn(width, height, 3, |x, y, px| {
        let (i, j) = ((x / period) as i64, (y / period) as i64);
        let (u, v) = ((x % period) as f32 + 0.5 - p / 2.0, (y % period) as f32 + 0.5 - p / 2.0);
        let r = (u * u + v * v).sqrt() / (0.47 * p);
        let tone = lattice(seed ^ 0xd1, i, j);
        let stain = fractal_noise(seed ^ 0xd2, x as f32, y as f32, 0.15 * p, 3);
        let k = 0.35 + 0.65 * tone - 0.5 * stain * lattice(seed ^ 0xd3, i, j);
        let colour = if r < 0.95 {
            [0.25 * k, 0.8 * k, 0.45 * k]
        } else if r < 1.0 {
            [0.8, 0.78, 0.6]
        } else {
            [0.1, 0.3, 0.18]
        };
        let grain = 0.05 * (fractal_noise(seed ^ 0xd4, x as f32, y as f32, 2.0, 2) - 0.5);
        for c in 0..3 {
            px[c] = (colour[c] + grain).clamp(0.0, 1.0);
        }
    })
}

/// Period, in pixels, of [`tiles`] in both directions.
pub const TILE_PERIOD: usize = 32;

/// Glazed ceramic tiles: cream squares of [`TILE_PERIOD`] px with grey
/// grout and a teal ring motif, exactly periodic apart from a faint
/// non-periodic glaze noise. The regular texture of the weathering tests.
pub fn tiles(width: usize, height: usize, seed: u64) -> Image {
    let p = TILE_PERIOD as f32;
    Image::from_fn(width, height, 3, |x, y, px| {
        let (u, v) = ((x % TILE_PERIOD) as f32, (y % TILE_PERIOD) as f32);
        let glaze = 0.04 * (fractal_noise(seed, x as f32, y as f32, 4.0, 2) - 0.5);
        let grout = u < 3.0 || v < 3.0;
        let r = ((u - p / 2.0 - 1.5).powi(2) + (v - p / 2.0 - 1.5).powi(2)).sqrt();
        let ring = ((r - 8.0).abs() - 1.5).clamp(0.0, 1.0);
        let colour = if grout {
            [0.52, 0.5, 0.47]
        } else {
            let c = [0.88, 0.84, 0.74];
            let m = [0.2, 0.48, 0.52];
            [0, 1, 2].map(|i| m[i] * (1.0 - ring) + c[i] * ring)
        };
        for c in 0..3 {
            px[c] = (colour[c] + glaze).clamp(0.0, 1.0);
        }
    })
}

/// Kinds of weathering [`weather`] can inject.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weathering {
    /// Orange-brown rust blooms with their own grain.
    Rust,
    /// Dark, brownish water stains that keep the texture underneath.
    Stain,
    /// Thin dark cracks that wander and branch.
    Cracks,
    /// A network of thin dark cracks over the whole surface (crazed paint,
    /// dried mud): wobbly Voronoi cell borders about 40 px apart, so every
    /// region of the image holds some. `area` is ignored.
    CrackNetwork,
    /// Peeling paint: over `area`, the paint is gone and a pale plaster
    /// with its own grain shows, edged by a lifted paint lip (a bright rim
    /// outside the edge and a dark shadow inside it).
    Peel,
}

/// `base` with weathering of `kind` over about `area` (fraction, e.g. 0.1)
/// of it, and the mask of the weathered pixels: ground truth for tests and
/// a weathered demo input.
pub fn weather(base: &Image, kind: Weathering, area: f32, seed: u64) -> (Image, Mask) {
    let (w, h) = base.size();
    let mut out = base.clone();
    let mut mask = Mask::filled(w, h, false);
    match kind {
        Weathering::Rust | Weathering::Stain => {
            // Blobs: the top `area` fraction of a smooth noise field.
            let scale = (w.min(h) as f32 / 5.0).max(8.0);
            let field: Vec<f32> = (0..w * h).map(|i| fractal_noise(seed, (i % w) as f32, (i / w) as f32, scale, 4)).collect();
            let mut sorted = field.clone();
            sorted.sort_by(f32::total_cmp);
            let thr = sorted[((1.0 - area.clamp(0.0, 1.0)) * (w * h - 1) as f32) as usize];
            let spread = 0.02;
            for (i, &f) in field.iter().enumerate() {
                let (x, y) = (i % w, i / w);
                let a = ((f - thr) / spread + 0.5).clamp(0.0, 1.0);
                if a <= 0.0 {
                    continue;
                }
                mask.set(x, y, a >= 0.5);
                let grain = fractal_noise(seed ^ 0x7a, x as f32, y as f32, 3.0, 3);
                let p = out.pixel_mut(x, y);
                let target = match kind {
                    Weathering::Rust => [0.55 + 0.25 * grain, 0.24 + 0.12 * grain, 0.08 + 0.05 * grain],
                    _ => [p[0] * 0.4 + 0.03, p[1] * 0.36 + 0.02, p[2] * 0.3],
                };
                for c in 0..3.min(p.len()) {
                    p[c] = p[c] * (1.0 - a) + target[c] * a;
                }
            }
        }
        Weathering::Cracks => {
            // Random walks with a persistent heading, branching now and then,
            // until the cracks (2 px wide) cover `area`.
            let mut g = rng::generator(seed, &[0xc7]);
            let want = (area * (w * h) as f32) as usize;
            let mut tips: Vec<(f32, f32, f32)> = Vec::new();
            let mut steps = 0;
            while mask.count() < want && steps < 50 * want {
                steps += 1;
                if tips.is_empty() {
                    tips.push((g.gen_range(0.0..w as f32), g.gen_range(0.0..h as f32), g.gen_range(0.0..std::f32::consts::TAU)));
                }
                let k = g.gen_range(0..tips.len());
                let (x, y, a) = tips[k];
                let a = a + g.gen_range(-0.5f32..0.5);
                let (nx, ny) = (x + a.cos(), y + a.sin());
                if nx < 0.0 || ny < 0.0 || nx >= w as f32 - 1.0 || ny >= h as f32 - 1.0 {
                    tips.swap_remove(k);
                    continue;
                }
                tips[k] = (nx, ny, a);
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    mask.set(nx as usize + dx, ny as usize + dy, true);
                }
                if g.gen_range(0.0f32..1.0) < 0.01 && tips.len() < 6 {
                    tips.push((nx, ny, a + g.gen_range(-1.2f32..1.2)));
                }
            }
            for y in 0..h {
                for x in 0..w {
                    if mask.get(x, y) {
                        out.pixel_mut(x, y).iter_mut().take(3).for_each(|v| *v = *v * 0.25 + 0.02);
                    }
                }
            }
        }
        Weathering::CrackNetwork => {
            let cell = 40.0f32;
            for y in 0..h {
                for x in 0..w {
                    // Warp the cell coordinates so the borders wobble.
                    let wx = x as f32 + 6.0 * (fractal_noise(seed ^ 0xc1, x as f32, y as f32, 18.0, 2) - 0.5);
                    let wy = y as f32 + 6.0 * (fractal_noise(seed ^ 0xc2, x as f32, y as f32, 18.0, 2) - 0.5);
                    let v = voronoi(wx / cell, wy / cell, (seed ^ 0xc3, seed ^ 0xc4), 0.2);
                    let width = 0.9 + 0.9 * fractal_noise(seed ^ 0xc5, x as f32, y as f32, 12.0, 1);
                    let a = (1.0 - (v.d2 - v.d1) * cell / width).clamp(0.0, 1.0);
                    if a <= 0.0 {
                        continue;
                    }
                    mask.set(x, y, a >= 0.3);
                    let p = out.pixel_mut(x, y);
                    p.iter_mut().take(3).for_each(|c| *c = *c * (1.0 - 0.8 * a) + 0.03 * a);
                }
            }
        }
        Weathering::Peel => {
            let scale = (w.min(h) as f32 / 4.0).max(8.0);
            let field: Vec<f32> = (0..w * h).map(|i| fractal_noise(seed ^ 0x9e, (i % w) as f32, (i / w) as f32, scale, 5)).collect();
            let mut sorted = field.clone();
            sorted.sort_by(f32::total_cmp);
            let thr = sorted[((1.0 - area.clamp(0.0, 1.0)) * (w * h - 1) as f32) as usize];
            let peel = Mask::from_fn(w, h, |x, y| field[y * w + x] > thr);
            let (lip, inner) = (peel.dilate(2), peel.erode(2));
            for y in 0..h {
                for x in 0..w {
                    let p = out.pixel_mut(x, y);
                    if peel.get(x, y) {
                        let grain = fractal_noise(seed ^ 0x9f, x as f32, y as f32, 4.0, 3) - 0.5;
                        // A dark shadow under the lip along the inside of the edge.
                        let shadow = if inner.get(x, y) { 1.0 } else { 0.6 };
                        let plaster = [0.8 + 0.12 * grain, 0.77 + 0.12 * grain, 0.7 + 0.1 * grain];
                        p.iter_mut().zip(plaster).for_each(|(c, v)| *c = v * shadow);
                    } else if lip.get(x, y) {
                        // The lifted lip: lighter paint, catching the light.
                        p.iter_mut().take(3).for_each(|c| *c = (*c * 0.6 + 0.45).min(1.0));
                    }
                }
            }
            mask = lip;
        }
    }
    (out, mask)
}

/// A rusting-steel time-lapse: brushed grey steel on which rust spots
/// appear at random times and places and grow, each at its own pace, over
/// `frames` frames. The ground truth for time-varying synthesis.
pub fn rusting_timelapse(width: usize, height: usize, frames: usize, seed: u64) -> Vec<Image> {
    struct Spot {
        x: f32,
        y: f32,
        start: f32,
        grow: f32,
        radius: f32,
    }
    let mut g = rng::generator(seed, &[7]);
    let count = ((width * height) as f32 / 300.0).ceil() as usize;
    let spots: Vec<Spot> = (0..count)
        .map(|_| Spot {
            x: g.gen_range(0.0..width as f32),
            y: g.gen_range(0.0..height as f32),
            start: g.gen_range(0.0..0.7),
            grow: g.gen_range(0.15..0.5),
            radius: g.gen_range(2.5..7.0),
        })
        .collect();
    let steel = Image::from_fn(width, height, 1, |x, y, p| {
        let streak = fractal_noise(seed ^ 0x51, x as f32 * 0.08, y as f32, 6.0, 3);
        p[0] = 0.62 + 0.12 * (streak - 0.5) + 0.05 * (fractal_noise(seed ^ 0x52, x as f32, y as f32, 24.0, 3) - 0.5);
    });
    (0..frames)
        .map(|f| {
            let t = f as f32 / (frames.max(2) - 1) as f32;
            Image::from_fn(width, height, 3, |x, y, p| {
                let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
                let wobble = 0.7 + 0.6 * value_noise(seed ^ 0x53, fx / 3.0, fy / 3.0);
                let mut rust = 0.0f32;
                for s in &spots {
                    let age = ((t - s.start) / s.grow).clamp(0.0, 1.0);
                    if age <= 0.0 {
                        continue;
                    }
                    let r = s.radius * age.sqrt() * wobble;
                    let d = ((fx - s.x).powi(2) + (fy - s.y).powi(2)).sqrt();
                    rust = rust.max((1.0 - (d - r).max(0.0) / 1.5).clamp(0.0, 1.0) * (0.6 + 0.4 * age));
                }
                let v = steel.at(x, y, 0);
                let grain = value_noise(seed ^ 0x54, fx / 1.5, fy / 1.5);
                let rust_rgb = [0.42 + 0.15 * grain, 0.2 + 0.08 * grain, 0.07 + 0.04 * grain];
                for c in 0..3 {
                    let base = v * [1.0, 1.0, 1.03][c];
                    p[c] = base + rust * (rust_rgb[c] - base);
                }
            })
        })
        .collect()
}

/// `frames` under a fixed vignette: each pixel darkened by `strength` x
/// its squared distance from the centre over the corner's (the corners at
/// 1 - strength), as a lens or a flash leaves on a capture.
pub fn vignette(frames: &[Image], strength: f32) -> Vec<Image> {
    frames
        .iter()
        .map(|f| {
            let (w, h) = (f.width() as f32, f.height() as f32);
            let (cx, cy, r2) = (w / 2.0, h / 2.0, (w * w + h * h) / 4.0);
            Image::from_fn(f.width(), f.height(), f.channels(), |x, y, p| {
                let d2 = ((x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2)) / r2;
                let k = 1.0 - strength * d2;
                p.iter_mut().zip(f.pixel(x, y)).for_each(|(o, v)| *o = v * k);
            })
        })
        .collect()
}

/// Named samples, for the CLI.
pub const NAMES: [&str; 7] = ["bricks", "cobbles", "blotches", "tiles", "gravel", "planks", "stucco"];

/// A sample by name.
pub fn by_name(name: &str, width: usize, height: usize, seed: u64) -> Option<Image> {
    match name {
        "bricks" => Some(bricks(width, height, seed)),
        "cobbles" => Some(cobbles(width, height, seed)),
        "blotches" => Some(blotches(width, height, seed)),
        "tiles" => Some(tiles(width, height, seed)),
        "gravel" => Some(gravel(width, height, seed)),
        "planks" => Some(planks(width, height, seed)),
        "stucco" => Some(stucco(width, height, seed)),
        _ => None,
    }
}

/// Rough weathered stone (grey, 1 channel luminance in about [0.2, 0.8]):
/// fine fractal relief (4 octaves from 12 px), pixel grain and pitting:
/// the crumbly, pocked surface of weathered sandstone. The default sample
/// `stone` learns its roughening fractal from.
pub fn rough_stone(width: usize, height: usize, seed: u64) -> Image {
    Image::from_fn(width, height, 1, |x, y, p| {
        let (fx, fy) = (x as f32, y as f32);
        let relief = fractal_noise(seed, fx, fy, 12.0, 4) - 0.5;
        let grain = lattice(seed ^ 0x51, x as i64, y as i64) - 0.5;
        let pit = (value_noise(seed ^ 0x77, fx / 3.0, fy / 3.0) - 0.8).max(0.0);
        p[0] = (0.55 + 0.2 * relief + 0.15 * grain - 1.5 * pit).clamp(0.0, 1.0);
    })
}

/// A photographed stele (RGB) and its object mask: a round-topped granite
/// slab, lit from the top left, with rows of carved letter-like grooves and
/// fine grain, standing in front of mottled foliage. The demo's input for
/// `patina stone`.
pub fn carved_stele(width: usize, height: usize, seed: u64) -> (Image, Mask) {
    let (w, h) = (width as f32, height as f32);
    let (cx, half, top) = (w / 2.0, w * 0.3, h * 0.12);
    let inside = |x: f32, y: f32| {
        let dx = (x - cx) / half;
        (x - cx).abs() < half && y < h * 0.95 && y > top + half * (1.0 - (1.0 - dx * dx).max(0.0).sqrt()) * 0.9
    };
    let mask = Mask::from_fn(width, height, |x, y| inside(x as f32 + 0.5, y as f32 + 0.5));
    let groove = |r: f32| 0.22 * (-((r - 2.5) / 1.4).powi(2)).exp() - 0.2 * (-((r - 5.5) / 1.6).powi(2)).exp();
    let image = Image::from_fn(width, height, 3, |x, y, p| {
        let (fx, fy) = (x as f32, y as f32);
        if mask.get(x, y) {
            let grain = 0.1 * (lattice(seed ^ 0x6a, x as i64, y as i64) - 0.5);
            let mottle = 0.12 * (fractal_noise(seed ^ 0x3c, fx, fy, 24.0, 3) - 0.5);
            // Letters: a row of 14 x 18 px cells, each a random subset of
            // strokes (bars and a diagonal), in rows over the slab's middle.
            let (u, v) = (fx - (cx - half * 0.75), fy - (top + half));
            let mut carve = 0.0;
            if u >= 0.0 && v >= 0.0 && u < half * 1.5 && (v % 30.0) < 20.0 && v < h * 0.55 {
                let (cell_x, cell_y) = ((u / 16.0) as i64, (v / 30.0) as i64);
                let strokes = rng::derive(seed, &[cell_x as u64, cell_y as u64, 7]);
                let (lx, ly) = (u % 16.0, v % 30.0);
                let bars = [(strokes & 1 != 0, lx), (strokes & 2 != 0, lx - 8.0), (strokes & 4 != 0, ly), (strokes & 8 != 0, ly - 12.0)];
                for (on, r) in bars {
                    if on && lx < 12.0 && ly < 18.0 {
                        carve += groove(r + 1.0);
                    }
                }
                if strokes & 16 != 0 && lx < 12.0 && ly < 18.0 {
                    carve += groove(lx - ly * 0.66 + 1.0);
                }
            }
            let v = (0.5 + mottle + grain + carve).clamp(0.0, 1.0);
            p.copy_from_slice(&[v * 0.98, v * 0.96, v * 0.93]);
        } else {
            let m = fractal_noise(seed ^ 0x91, fx, fy, 10.0, 3);
            p.copy_from_slice(&[0.12 + 0.12 * m, 0.26 + 0.25 * m, 0.1 + 0.08 * m]);
        }
    });
    (image, mask)
}

/// A photographed painted post (RGB) and its mask: an orange cylinder lit
/// from the left, standing in the middle half of the frame over mottled
/// grey pavement. The demo's and the benchmark's input for `patina decay`.
pub fn painted_post(width: usize, height: usize, seed: u64) -> (Image, Mask) {
    let (x0, x1) = (width * 26 / 100, width * 74 / 100);
    let (y0, y1) = (height / 10, height * 95 / 100);
    let mask = Mask::from_fn(width, height, |x, y| (x0..x1).contains(&x) && (y0..y1).contains(&y));
    let image = Image::from_fn(width, height, 3, |x, y, p| {
        let grain = 0.03 * (lattice(seed ^ 0x2b, x as i64, y as i64) - 0.5);
        if mask.get(x, y) {
            let u = (x - x0) as f32 / (x1 - x0) as f32 * std::f32::consts::PI;
            let shade = 0.2 + 0.8 * (u - 0.3).sin().max(0.0);
            let c = [0.8, 0.3, 0.06].map(|a: f32| crate::image::color::linear_to_srgb(a * shade) + grain);
            p.copy_from_slice(&c);
        } else {
            p.fill(0.4 + 0.2 * fractal_noise(seed ^ 0x4d, x as f32, y as f32, 9.0, 3) + grain);
        }
    });
    (image, mask)
}
