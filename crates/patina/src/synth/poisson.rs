//! Screened Poisson integration of a mismatch field: the correction d that
//! minimises sum over 4-neighbour edges of (d_q - d_p - m_pq)^2 +
//! lambda sum d^2 (Pérez et al. 2003 with an anchor; Bhat et al.'s
//! "GradientShop" form). Features narrower than about 1/sqrt(lambda) px
//! follow the mismatch, wider ones stay anchored at 0. Seam blending and
//! stone's patch update use it.
//!
//! Solved by cell-centred multigrid (red-black Gauss-Seidel, 2x2
//! averaging, bilinear prolongation, operator rediscretised per level):
//! one full-multigrid pass. Deterministic: the same
//! arithmetic in the same order at any thread count.

use rayon::prelude::*;

/// Gauss-Seidel sweeps before and after each coarse correction.
const SWEEPS: usize = 2;

/// The multigrid's working grids for one size, kept between solves: a
/// caller integrating several channels (a seam blend, stone's patch
/// update) allocates them once. Fresh multi-megabyte buffers on every
/// level and sweep cost a third of a 1024 px RGB seam blend in page faults.
pub struct Solver {
    /// Level 0 is the `w` x `h` grid; each next one is half the size.
    levels: Vec<Level>,
    /// The rows each Gauss-Seidel band reads from outside itself, sized
    /// for level 0 (the coarser levels need less).
    halo: Vec<f32>,
}

/// One level's right-hand side `b`, solution `d` and residual `r`.
struct Level {
    w: usize,
    h: usize,
    b: Vec<f32>,
    d: Vec<f32>,
    r: Vec<f32>,
}

impl Solver {
    /// Working grids for a `w` x `h` problem.
    pub fn new(w: usize, h: usize) -> Self {
        let mut levels = Vec::new();
        let (mut lw, mut lh) = (w, h);
        loop {
            let n = lw * lh;
            levels.push(Level { w: lw, h: lh, b: vec![0.0; n], d: vec![0.0; n], r: vec![0.0; n] });
            if lw <= 2 || lh <= 2 {
                break;
            }
            (lw, lh) = (lw.div_ceil(2), lh.div_ceil(2));
        }
        Solver { levels, halo: vec![0.0; 2 * h.div_ceil(BAND) * w] }
    }

    /// The correction d on this solver's `w` x `h` grid for the horizontal
    /// (x -> x+1, `mh[y w + x]`) and vertical (y -> y+1, `mv`) edge
    /// mismatches; entries on the last column (`mh`) or row (`mv`) are
    /// ignored. Neumann boundaries. The correction stays valid until the
    /// next solve.
    pub fn integrate(&mut self, mh: &[f32], mv: &[f32], lambda: f32) -> &[f32] {
        let (w, h) = (self.levels[0].w, self.levels[0].h);
        assert!(mh.len() == w * h && mv.len() == w * h, "one mismatch per pixel and direction");
        // Right-hand side: the divergence of the mismatch field.
        for_chunks(&mut self.levels[0].b, w, |y, row| {
            for (x, out) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let mut v = 0.0;
                if x + 1 < w {
                    v -= mh[i];
                }
                if x > 0 {
                    v += mh[i - 1];
                }
                if y + 1 < h {
                    v -= mv[i];
                }
                if y > 0 {
                    v += mv[i - w];
                }
                *out = v;
            }
        });
        // One full-multigrid pass (coarse solutions prolonged level by
        // level, one V-cycle each). A further V-cycle changed no output by
        // more than 2 levels of 255 (quilt seam blends of 12 real exemplars;
        // stone on the front Buddha at t = 100 and 200: at most 1) and cost
        // a fifth of a 1024 px RGB seam blend.
        full_multigrid(&mut self.levels, &mut self.halo, 1.0, lambda);
        &self.levels[0].d
    }
}

/// Grids smaller than this many pixels are swept on one thread: on the
/// coarse levels rayon's hand-offs cost more than the sweeps (they were
/// about a third of a 1 MP solve's time).
const PARALLEL_FROM: usize = 1 << 16;

/// Run `f(k, chunk)` over the `len`-long chunks of `data`, in parallel on
/// grids of at least [`PARALLEL_FROM`] pixels. Each chunk's arithmetic is
/// the same either way, so the result does not depend on it.
fn for_chunks(data: &mut [f32], len: usize, f: impl Fn(usize, &mut [f32]) + Sync) {
    if data.len() >= PARALLEL_FROM {
        data.par_chunks_mut(len).enumerate().for_each(|(k, chunk)| f(k, chunk));
    } else {
        data.chunks_mut(len).enumerate().for_each(|(k, chunk)| f(k, chunk));
    }
}

/// Half-size average of a w x h grid into `rc` (cell-centred restriction).
fn restrict(r: &[f32], w: usize, h: usize, rc: &mut [f32]) {
    let cw = w.div_ceil(2);
    // How many fine cells each coarse one averages: 4, or 2 or 1 on an odd edge.
    let count = |k: usize, n: usize| if 2 * k + 1 < n { 2.0f32 } else { 1.0 };
    // Each coarse row sums its (one or two) fine rows in raster order.
    for_chunks(rc, cw, |cy, row| {
        row.iter_mut().for_each(|v| *v = 0.0);
        for y in 2 * cy..(2 * cy + 2).min(h) {
            for (x, v) in r[y * w..(y + 1) * w].iter().enumerate() {
                row[x / 2] += v;
            }
        }
        row.iter_mut().enumerate().for_each(|(cx, v)| *v /= count(cx, w) * count(cy, h));
    });
}

/// Add the bilinear (cell-centred) prolongation of the coarse `ec` to `d`.
fn prolong_add(d: &mut [f32], w: usize, ec: &[f32], cw: usize, ch: usize) {
    // Each column's two coarse columns and weight, found once.
    let columns: Vec<(usize, usize, f32)> = (0..w)
        .map(|x| {
            let fx = ((x as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (cw - 1) as f32);
            let (x0, tx) = (fx.floor() as usize, fx.fract());
            (x0, (x0 + 1).min(cw - 1), tx)
        })
        .collect();
    for_chunks(d, w, |y, row| {
        let fy = ((y as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (ch - 1) as f32);
        let (y0, ty) = (fy.floor() as usize, fy.fract());
        let y1 = (y0 + 1).min(ch - 1);
        for (v, &(x0, x1, tx)) in row.iter_mut().zip(&columns) {
            let top = ec[y0 * cw + x0] * (1.0 - tx) + ec[y0 * cw + x1] * tx;
            let bottom = ec[y1 * cw + x0] * (1.0 - tx) + ec[y1 * cw + x1] * tx;
            *v += top * (1.0 - ty) + bottom * ty;
        }
    });
}

/// Full multigrid on `levels[0]`: solve the restricted problem, prolong its
/// solution as the start here, and finish with one V-cycle.
fn full_multigrid(levels: &mut [Level], halo: &mut [f32], s: f32, lambda: f32) {
    let (fine, coarser) = levels.split_first_mut().expect("at least one level");
    fine.d.iter_mut().for_each(|v| *v = 0.0);
    if let Some(coarse) = coarser.first_mut() {
        restrict(&fine.b, fine.w, fine.h, &mut coarse.b);
        full_multigrid(coarser, halo, s / 4.0, lambda);
        let coarse = &coarser[0];
        prolong_add(&mut fine.d, fine.w, &coarse.d, coarse.w, coarse.h);
    }
    v_cycle(levels, halo, s, lambda);
}

/// One V-cycle for (s L + lambda) d = b on `levels[0]` (L the graph
/// Laplacian with Neumann boundaries, s the level's scale).
fn v_cycle(levels: &mut [Level], halo: &mut [f32], s: f32, lambda: f32) {
    let (fine, coarser) = levels.split_first_mut().expect("at least one level");
    let Some(coarse) = coarser.first_mut() else {
        for _ in 0..50 {
            gauss_seidel(fine, halo, s, lambda);
        }
        return;
    };
    for _ in 0..SWEEPS {
        gauss_seidel(fine, halo, s, lambda);
    }
    residual(fine, s, lambda);
    restrict(&fine.r, fine.w, fine.h, &mut coarse.b);
    coarse.d.iter_mut().for_each(|v| *v = 0.0);
    v_cycle(coarser, halo, s / 4.0, lambda);
    let coarse = &coarser[0];
    prolong_add(&mut fine.d, fine.w, &coarse.d, coarse.w, coarse.h);
    for _ in 0..SWEEPS {
        gauss_seidel(fine, halo, s, lambda);
    }
}

/// Sum of d's 4 neighbours and their count at (x, y).
#[inline]
fn neighbours(d: &[f32], w: usize, h: usize, x: usize, y: usize) -> (f32, f32) {
    let i = y * w + x;
    edge_sum([(x > 0).then(|| d[i - 1]), (x + 1 < w).then(|| d[i + 1]), (y > 0).then(|| d[i - w]), (y + 1 < h).then(|| d[i + w])])
}

/// Sum and count of the neighbours that exist (left, right, up, down), added
/// in that order so every caller rounds alike.
#[inline]
fn edge_sum(values: [Option<f32>; 4]) -> (f32, f32) {
    let (mut sum, mut k) = (0f32, 0f32);
    for v in values.into_iter().flatten() {
        sum += v;
        k += 1.0;
    }
    (sum, k)
}

/// Rows per band of a Gauss-Seidel half-sweep (see [`gauss_seidel`]).
const BAND: usize = 16;

/// Red-black Gauss-Seidel: the red pixels (x + y even) from the black ones,
/// then the black from the red. A half-sweep reads only the other colour,
/// which it does not change, so it updates in place: bands of [`BAND`]
/// rows in parallel, each reading the rows just outside it from a copy of
/// them taken before the half-sweep (the same values it would read in
/// place). Interior pixels take a branch-free path (four neighbours).
fn gauss_seidel(level: &mut Level, halo: &mut [f32], s: f32, lambda: f32) {
    let Level { w, h, ref b, ref mut d, .. } = *level;
    let inner = 1.0 / (4.0 * s + lambda);
    let bands = h.div_ceil(BAND);
    for colour in 0..2 {
        for k in 0..bands {
            let (y0, y1) = (k * BAND, ((k + 1) * BAND).min(h));
            if y0 > 0 {
                halo[2 * k * w..(2 * k + 1) * w].copy_from_slice(&d[(y0 - 1) * w..y0 * w]);
            }
            if y1 < h {
                halo[(2 * k + 1) * w..(2 * k + 2) * w].copy_from_slice(&d[y1 * w..(y1 + 1) * w]);
            }
        }
        let sweep = |k: usize, band: &mut [f32]| {
            let y0 = k * BAND;
            let rows = band.len() / w;
            let (above, below) = (&halo[2 * k * w..(2 * k + 1) * w], &halo[(2 * k + 1) * w..(2 * k + 2) * w]);
            for r in 0..rows {
                let y = y0 + r;
                let first = (y + colour) % 2;
                let brow = &b[y * w..(y + 1) * w];
                let (before, rest) = band.split_at_mut(r * w);
                let (mid, after) = rest.split_at_mut(w);
                let up = if r > 0 { &before[(r - 1) * w..] } else { above };
                let down = if r + 1 < rows { &after[..w] } else { below };
                let interior_row = y > 0 && y + 1 < h && w >= 3;
                // Each pixel of this colour reads only the other colour,
                // so the order within the row does not matter: inside a
                // row without bounds tests, the ends (and the first and
                // last rows) with them.
                let edge = |x: usize, mid: &mut [f32]| {
                    let (sum, n) = edge_sum([
                        (x > 0).then(|| mid[x - 1]),
                        (x + 1 < w).then(|| mid[x + 1]),
                        (y > 0).then(|| up[x]),
                        (y + 1 < h).then(|| down[x]),
                    ]);
                    mid[x] = (brow[x] + s * sum) / (s * n + lambda);
                };
                if interior_row {
                    for x in (2 - first..w - 1).step_by(2) {
                        mid[x] = (brow[x] + s * (mid[x - 1] + mid[x + 1] + up[x] + down[x])) * inner;
                    }
                    if first == 0 {
                        edge(0, mid);
                    }
                    if (w - 1) % 2 == first {
                        edge(w - 1, mid);
                    }
                } else {
                    for x in (first..w).step_by(2) {
                        edge(x, mid);
                    }
                }
            }
        };
        for_chunks(d, BAND * w, sweep);
    }
}

/// The level's residual r = b - (s L + lambda) d.
fn residual(level: &mut Level, s: f32, lambda: f32) {
    let Level { w, h, ref b, ref d, ref mut r } = *level;
    for_chunks(r, w, |y, row| {
        let interior_row = y > 0 && y + 1 < h;
        for (x, v) in row.iter_mut().enumerate() {
            let i = y * w + x;
            // Inside, the four neighbours in `neighbours`' order (the same
            // sums, without its bounds tests).
            let (sum, k) = if interior_row && x > 0 && x + 1 < w {
                (0f32 + d[i - 1] + d[i + 1] + d[i - w] + d[i + w], 4.0)
            } else {
                neighbours(d, w, h, x, y)
            };
            *v = b[i] - ((s * k + lambda) * d[i] - s * sum);
        }
    });
}
