//! Gradient-domain seam blending (Pérez, Gangnet, Blake 2003, applied to
//! quilting as in Kwatra et al.'s graphcut textures): a pasted composite is
//! re-integrated from a gradient field in which every gradient between two
//! pixels of one block is the composite's own, and every gradient across a
//! seam is the mean of the two blocks' gradients there (each block's
//! exemplar continued one pixel past the cut). The result keeps every
//! block's detail exactly, and the brightness step a seam had is spread
//! smoothly over the blocks instead.
//!
//! Solved per channel for the correction d = u - c: minimise
//! sum over 4-neighbour edges of (d_q - d_p - m_pq)^2 + lambda sum d^2,
//! where m is the seam mismatch (zero inside blocks), by cell-centred
//! multigrid V-cycles (red-black Gauss-Seidel, 2x2 averaging, bilinear
//! prolongation, operator rediscretised per level). Deterministic: the
//! same arithmetic in the same order at any thread count.

use crate::image::Image;
use rayon::prelude::*;

/// Anchor weight lambda: corrections fade over about 1/sqrt(lambda) = 100
/// px, longer than any block, so whole blocks can shift in brightness while
/// the image's overall level stays put.
const LAMBDA: f32 = 1e-4;
/// Multigrid cycles: one full-multigrid pass (coarse solutions prolonged
/// level by level, one V-cycle each) and one more V-cycle.
const CYCLES: usize = 2;
/// Gauss-Seidel sweeps before and after each coarse correction.
const SWEEPS: usize = 2;

/// Blend the seams of `composite`, whose pixel i was copied from exemplar
/// pixel `sources[i]` of `source` (same channels). Pixels whose right or
/// lower neighbour continues their own source position are inside one
/// block; every other neighbour pair straddles a seam. With `outlier`,
/// each seam's mismatches are clamped to that many median absolute
/// deviations around their median ([`clamp_outliers`]; a time-lapse uses
/// it so features growing across a seam do not send a changing glow
/// around them).
pub fn blend_seams(composite: &Image, source: &Image, sources: &[(u32, u32)], outlier: Option<f32>) -> Image {
    let (w, h, n) = (composite.width(), composite.height(), composite.channels());
    assert_eq!(sources.len(), w * h, "one source position per pixel");
    assert_eq!(source.channels(), n, "source and composite channels differ");
    let (sw, sh) = (source.width() as u32, source.height() as u32);
    // The seam mismatch on each horizontal (x -> x+1) and vertical (y -> y+1) edge, per channel.
    let mismatch = |horizontal: bool, c: usize| -> Vec<f32> {
        let mut m = vec![0f32; w * h];
        m.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, out) in row.iter_mut().enumerate() {
                let (qx, qy) = if horizontal { (x + 1, y) } else { (x, y + 1) };
                if qx >= w || qy >= h {
                    continue;
                }
                let (p, q) = (sources[y * w + x], sources[qy * w + qx]);
                let (dx, dy) = if horizontal { (1u32, 0u32) } else { (0, 1) };
                if q == (p.0 + dx, p.1 + dy) {
                    continue;
                }
                let at = |s: (u32, u32)| source.at(s.0 as usize, s.1 as usize, c);
                let mut g = 0f32;
                let mut k = 0f32;
                if p.0 + dx < sw && p.1 + dy < sh {
                    g += at((p.0 + dx, p.1 + dy)) - at(p);
                    k += 1.0;
                }
                if q.0 >= dx && q.1 >= dy {
                    g += at(q) - at((q.0 - dx, q.1 - dy));
                    k += 1.0;
                }
                if k > 0.0 {
                    *out = g / k - (composite.at(qx, qy, c) - composite.at(x, y, c));
                }
            }
        });
        m
    };
    let mut out = composite.clone();
    for c in 0..n {
        let (mut mh, mut mv) = (mismatch(true, c), mismatch(false, c));
        if let Some(k) = outlier {
            clamp_outliers(&mut mh, &mut mv, sources, w, k);
        }
        // Right-hand side: the divergence of the mismatch field.
        let mut b = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
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
                b[i] = v;
            }
        }
        let mut d = full_multigrid(&b, w, h, 1.0);
        for _ in 1..CYCLES {
            v_cycle(&mut d, &b, w, h, 1.0);
        }
        let data = out.data_mut();
        for (i, v) in d.iter().enumerate() {
            data[i * n + c] += v;
        }
    }
    out
}

/// Clamp each seam mismatch to within `outlier` x the median absolute
/// deviation of the mismatches along the same seam (the same pair of
/// blocks, told apart by their source offsets) from their median. Two
/// blocks whose tones differ differ by about the same amount all along
/// their seam, and that median step is kept for the blend to spread; a
/// feature cut by the seam (a spot, a crack) makes a few large mismatches,
/// which the blend would smear into a glow around it (in a time-lapse, one
/// that changes as the feature grows).
fn clamp_outliers(mh: &mut [f32], mv: &mut [f32], sources: &[(u32, u32)], w: usize, outlier: f32) {
    let offset = |i: usize| (sources[i].0 as i64 - (i % w) as i64, sources[i].1 as i64 - (i / w) as i64);
    let key = |i: usize, horizontal: bool| {
        let j = if horizontal { i + 1 } else { i + w };
        (offset(i), offset(j))
    };
    let mut seams: std::collections::BTreeMap<_, Vec<f32>> = std::collections::BTreeMap::new();
    for (m, horizontal) in [(&*mh, true), (&*mv, false)] {
        for (i, &v) in m.iter().enumerate().filter(|(_, v)| **v != 0.0) {
            seams.entry(key(i, horizontal)).or_default().push(v);
        }
    }
    let median = |v: &mut [f32]| {
        let mid = v.len() / 2;
        *v.select_nth_unstable_by(mid, f32::total_cmp).1
    };
    let bands: std::collections::BTreeMap<_, (f32, f32)> = seams
        .into_iter()
        .map(|(k, mut v)| {
            let med = median(&mut v);
            let mut dev: Vec<f32> = v.iter().map(|x| (x - med).abs()).collect();
            let spread = outlier * median(&mut dev).max(1e-3);
            (k, (med - spread, med + spread))
        })
        .collect();
    for (m, horizontal) in [(mh, true), (mv, false)] {
        for (i, v) in m.iter_mut().enumerate().filter(|(_, v)| **v != 0.0) {
            if let Some(&(lo, hi)) = bands.get(&key(i, horizontal)) {
                *v = v.clamp(lo, hi);
            }
        }
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
    d.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let fy = ((y as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (ch - 1) as f32);
        let (y0, ty) = (fy.floor() as usize, fy.fract());
        let y1 = (y0 + 1).min(ch - 1);
        for (x, v) in row.iter_mut().enumerate() {
            let fx = ((x as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (cw - 1) as f32);
            let (x0, tx) = (fx.floor() as usize, fx.fract());
            let x1 = (x0 + 1).min(cw - 1);
            let top = ec[y0 * cw + x0] * (1.0 - tx) + ec[y0 * cw + x1] * tx;
            let bottom = ec[y1 * cw + x0] * (1.0 - tx) + ec[y1 * cw + x1] * tx;
            *v += top * (1.0 - ty) + bottom * ty;
        }
    });
}

/// Full multigrid: solve the restricted problem, prolong its solution as
/// the start here, and finish with one V-cycle.
fn full_multigrid(b: &[f32], w: usize, h: usize, s: f32) -> Vec<f32> {
    let mut d = vec![0f32; w * h];
    if w > 2 && h > 2 {
        let (bc, cw, ch) = restrict(b, w, h);
        let dc = full_multigrid(&bc, cw, ch, s / 4.0);
        prolong_add(&mut d, w, &dc, cw, ch);
    }
    v_cycle(&mut d, b, w, h, s);
    d
}

/// One V-cycle for (s L + lambda) d = b on a w x h grid (L the graph
/// Laplacian with Neumann boundaries, s the level's scale).
fn v_cycle(d: &mut [f32], b: &[f32], w: usize, h: usize, s: f32) {
    if w <= 2 || h <= 2 {
        for _ in 0..50 {
            gauss_seidel(d, b, w, h, s);
        }
        return;
    }
    for _ in 0..SWEEPS {
        gauss_seidel(d, b, w, h, s);
    }
    let r = residual(d, b, w, h, s);
    let (rc, cw, ch) = restrict(&r, w, h);
    let mut ec = vec![0f32; cw * ch];
    v_cycle(&mut ec, &rc, cw, ch, s / 4.0);
    prolong_add(d, w, &ec, cw, ch);
    for _ in 0..SWEEPS {
        gauss_seidel(d, b, w, h, s);
    }
}

/// Sum of d's 4 neighbours and their count at (x, y).
#[inline]
fn neighbours(d: &[f32], w: usize, h: usize, x: usize, y: usize) -> (f32, f32) {
    let i = y * w + x;
    let (mut sum, mut k) = (0f32, 0f32);
    if x > 0 {
        sum += d[i - 1];
        k += 1.0;
    }
    if x + 1 < w {
        sum += d[i + 1];
        k += 1.0;
    }
    if y > 0 {
        sum += d[i - w];
        k += 1.0;
    }
    if y + 1 < h {
        sum += d[i + w];
        k += 1.0;
    }
    (sum, k)
}

/// Red-black Gauss-Seidel: the red pixels (x + y even) from the black ones,
/// then the black from the red; each half in parallel by rows. Interior
/// pixels take a branch-free path (four neighbours).
fn gauss_seidel(d: &mut [f32], b: &[f32], w: usize, h: usize, s: f32) {
    let inner = 1.0 / (4.0 * s + LAMBDA);
    for colour in 0..2 {
        let snapshot = d.to_vec();
        d.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            let first = (y + colour) % 2;
            if y == 0 || y + 1 == h || w < 3 {
                for x in (first..w).step_by(2) {
                    let (sum, k) = neighbours(&snapshot, w, h, x, y);
                    row[x] = (b[y * w + x] + s * sum) / (s * k + LAMBDA);
                }
                return;
            }
            let (up, mid, down) = (&snapshot[(y - 1) * w..y * w], &snapshot[y * w..(y + 1) * w], &snapshot[(y + 1) * w..(y + 2) * w]);
            let brow = &b[y * w..(y + 1) * w];
            for x in (first..w).step_by(2) {
                if x == 0 || x + 1 == w {
                    let (sum, k) = neighbours(&snapshot, w, h, x, y);
                    row[x] = (brow[x] + s * sum) / (s * k + LAMBDA);
                } else {
                    row[x] = (brow[x] + s * (mid[x - 1] + mid[x + 1] + up[x] + down[x])) * inner;
                }
            }
        });
    }
}

/// b - (s L + lambda) d.
fn residual(d: &[f32], b: &[f32], w: usize, h: usize, s: f32) -> Vec<f32> {
    let mut r = vec![0f32; w * h];
    r.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, v) in row.iter_mut().enumerate() {
            let (sum, k) = neighbours(d, w, h, x, y);
            let i = y * w + x;
            *v = b[i] - ((s * k + LAMBDA) * d[i] - s * sum);
        }
    });
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples;

    #[test]
    fn two_blocks_at_different_exposure_meet_without_a_step() {
        // Left half from the exemplar as it is, right half from a copy 25% darker:
        // the gradient across the seam comes from the exemplar, so the step goes.
        let ex = samples::cobbles(96, 64, 1);
        let dark = ex.map(|v| 0.75 * v);
        let (w, h) = (96, 64);
        let composite = Image::from_fn(w, h, 3, |x, y, p| {
            let v = if x < 48 { ex.pixel(x, y) } else { dark.pixel(x, y) };
            p.copy_from_slice(v);
        });
        // The right half came from elsewhere in the source (so the seam is a seam):
        // the source holds the dark copy to the right of the bright one.
        let source = Image::from_fn(2 * w, h, 3, |x, y, p| {
            let v = if x < w { ex.pixel(x, y) } else { dark.pixel(x - w, y) };
            p.copy_from_slice(v);
        });
        let sources: Vec<(u32, u32)> =
            (0..w * h).map(|i| ((i % w) as u32 + if i % w < 48 { 0 } else { w as u32 }, (i / w) as u32)).collect();
        let step = |img: &Image| -> f32 {
            let mean = |x0: usize| {
                (0..h).flat_map(|y| (x0..x0 + 4).map(move |x| (x, y))).map(|(x, y)| img.at(x, y, 0)).sum::<f32>() / (4 * h) as f32
            };
            (mean(48) - mean(44)).abs()
        };
        let blended = blend_seams(&composite, &source, &sources, None);
        assert!(step(&composite) > 0.04, "the composite has a step: {}", step(&composite));
        assert!(step(&blended) < 0.3 * step(&composite), "step {} -> {}", step(&composite), step(&blended));
        // Inside each block the detail (gradients) is kept.
        let gx = |img: &Image, x: usize, y: usize| img.at(x + 1, y, 0) - img.at(x, y, 0);
        let err: f32 = (0..h).map(|y| (gx(&blended, 20, y) - gx(&composite, 20, y)).abs()).sum::<f32>() / h as f32;
        assert!(err < 0.01, "interior gradients changed by {err}");
    }
}
