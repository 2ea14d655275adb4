//! Screened Poisson integration of a mismatch field: the correction d that
//! minimises sum over 4-neighbour edges of (d_q - d_p - m_pq)^2 +
//! lambda sum d^2 (Pérez et al. 2003 with an anchor; Bhat et al.'s
//! "GradientShop" form). Features narrower than about 1/sqrt(lambda) px
//! follow the mismatch, wider ones stay anchored at 0. Seam blending and
//! stone's patch update use it.
//!
//! Solved by cell-centred multigrid (red-black Gauss-Seidel, 2x2
//! averaging, bilinear prolongation, operator rediscretised per level):
//! one full-multigrid pass and one more V-cycle. Deterministic: the same
//! arithmetic in the same order at any thread count.

use rayon::prelude::*;

/// Multigrid cycles: one full-multigrid pass (coarse solutions prolonged
/// level by level, one V-cycle each) and one more V-cycle.
const CYCLES: usize = 2;
/// Gauss-Seidel sweeps before and after each coarse correction.
const SWEEPS: usize = 2;

/// The correction d on a `w` x `h` grid for the horizontal (x -> x+1,
/// `mh[y w + x]`) and vertical (y -> y+1, `mv`) edge mismatches; entries
/// on the last column (`mh`) or row (`mv`) are ignored. Neumann boundaries.
pub fn integrate(mh: &[f32], mv: &[f32], w: usize, h: usize, lambda: f32) -> Vec<f32> {
    assert!(mh.len() == w * h && mv.len() == w * h, "one mismatch per pixel and direction");
    // Right-hand side: the divergence of the mismatch field.
    let mut b = vec![0f32; w * h];
    for_chunks(&mut b, w, |y, row| {
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
    let mut d = full_multigrid(&b, w, h, 1.0, lambda);
    for _ in 1..CYCLES {
        v_cycle(&mut d, &b, w, h, 1.0, lambda);
    }
    d
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

/// Half-size average of a w x h grid (cell-centred restriction).
fn restrict(r: &[f32], w: usize, h: usize) -> (Vec<f32>, usize, usize) {
    let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
    let mut rc = vec![0f32; cw * ch];
    let mut count = vec![0f32; cw * ch];
    for y in 0..h {
        for x in 0..w {
            rc[(y / 2) * cw + x / 2] += r[y * w + x];
            count[(y / 2) * cw + x / 2] += 1.0;
        }
    }
    rc.iter_mut().zip(&count).for_each(|(v, k)| *v /= k);
    (rc, cw, ch)
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

/// Full multigrid: solve the restricted problem, prolong its solution as
/// the start here, and finish with one V-cycle.
fn full_multigrid(b: &[f32], w: usize, h: usize, s: f32, lambda: f32) -> Vec<f32> {
    let mut d = vec![0f32; w * h];
    if w > 2 && h > 2 {
        let (bc, cw, ch) = restrict(b, w, h);
        let dc = full_multigrid(&bc, cw, ch, s / 4.0, lambda);
        prolong_add(&mut d, w, &dc, cw, ch);
    }
    v_cycle(&mut d, b, w, h, s, lambda);
    d
}

/// One V-cycle for (s L + lambda) d = b on a w x h grid (L the graph
/// Laplacian with Neumann boundaries, s the level's scale).
fn v_cycle(d: &mut [f32], b: &[f32], w: usize, h: usize, s: f32, lambda: f32) {
    if w <= 2 || h <= 2 {
        for _ in 0..50 {
            gauss_seidel(d, b, w, h, s, lambda);
        }
        return;
    }
    for _ in 0..SWEEPS {
        gauss_seidel(d, b, w, h, s, lambda);
    }
    let r = residual(d, b, w, h, s, lambda);
    let (rc, cw, ch) = restrict(&r, w, h);
    let mut ec = vec![0f32; cw * ch];
    v_cycle(&mut ec, &rc, cw, ch, s / 4.0, lambda);
    prolong_add(d, w, &ec, cw, ch);
    for _ in 0..SWEEPS {
        gauss_seidel(d, b, w, h, s, lambda);
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
fn gauss_seidel(d: &mut [f32], b: &[f32], w: usize, h: usize, s: f32, lambda: f32) {
    let inner = 1.0 / (4.0 * s + lambda);
    let bands = h.div_ceil(BAND);
    let mut halo = vec![0f32; 2 * bands * w];
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
                for x in (first..w).step_by(2) {
                    if interior_row && x > 0 && x + 1 < w {
                        mid[x] = (brow[x] + s * (mid[x - 1] + mid[x + 1] + up[x] + down[x])) * inner;
                    } else {
                        let (sum, n) = edge_sum([
                            (x > 0).then(|| mid[x - 1]),
                            (x + 1 < w).then(|| mid[x + 1]),
                            (y > 0).then(|| up[x]),
                            (y + 1 < h).then(|| down[x]),
                        ]);
                        mid[x] = (brow[x] + s * sum) / (s * n + lambda);
                    }
                }
            }
        };
        for_chunks(d, BAND * w, sweep);
    }
}

/// b - (s L + lambda) d.
fn residual(d: &[f32], b: &[f32], w: usize, h: usize, s: f32, lambda: f32) -> Vec<f32> {
    let mut r = vec![0f32; w * h];
    for_chunks(&mut r, w, |y, row| {
        for (x, v) in row.iter_mut().enumerate() {
            let (sum, k) = neighbours(d, w, h, x, y);
            let i = y * w + x;
            *v = b[i] - ((s * k + lambda) * d[i] - s * sum);
        }
    });
    r
}
