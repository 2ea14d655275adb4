//! Tile detection (Bellini et al. 2016, section 5): is the texture a
//! regular grid of tiles, and with which period?
//!
//! 1. Distance map of a central patch about a third of the image wide
//!    against every placement in the image (FFT, [`SpectralSource`]).
//! 2. Candidate tile positions: local minima among the lowest
//!    [`CANDIDATE_QUANTILE`] of the map.
//! 3. Verification by re-matching: a candidate stays when its distance is
//!    well below the map's median ([`MATCH_RATIO`]) and when its own patch,
//!    matched back against the image, finds the central patch again (a
//!    minimum within 1 px of the centre, also below the ratio). Stochastic
//!    textures have no such pairs.
//! 4. Offsets between every pair of verified positions vote (within 1 px);
//!    the two most frequent non-collinear offsets are the lattice basis,
//!    refined to sub-pixel precision by least squares over all positions.
//!
//! [`median_tile`] then builds the template of section 5: at each pixel,
//! the per-channel median over every tile at the same offset.

use super::features::Features;
use crate::image::{Image, Mask};
use crate::synth::correlate::SpectralSource;
use crate::synth::lattice::parabola;
use rayon::prelude::*;
use serde::Serialize;

/// Fraction of the distance map's lowest values that become candidates. Paper: 0.5%.
pub const CANDIDATE_QUANTILE: f32 = 0.005;
/// A repetition's distance must be below this fraction of the median distance.
/// 0.7 finds the stained green circle tiles of ../shared/data (0.5 did
/// not: each tile is stained differently) and still no lattice on any
/// stochastic photo or sample.
pub const MATCH_RATIO: f32 = 0.7;
/// Fewest verified repetitions (besides the centre) that make a grid.
pub const MIN_REPEATS: usize = 3;
/// Shortest period, in pixels, a grid or stripes may have.
pub const MIN_PERIOD: usize = 6;
/// A repeat's distance times this must stay below the distance half-way
/// back to the centre.
const RIDGE: f32 = 1.5;
/// Most candidate repeats verified and voted on.
const MAX_CANDIDATES: usize = 96;

/// The lattice of a tiled texture: tile (i, j) starts at origin + i a + j b.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Lattice {
    pub a: [f32; 2],
    pub b: [f32; 2],
    pub origin: [f32; 2],
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

/// Detect how the texture repeats, by the steps of the module docs; a
/// single direction whose repeats are verified but that has no second,
/// non-collinear one is [`Periodicity::Stripes`]. `None` = stochastic.
/// Appearance first; then, for boards and siding whose tone changes from
/// board to board while their grooves repeat, the edges alone (the
/// gradient-direction features).
pub fn periods(img: &Image) -> Option<Periodicity> {
    let (w, h) = img.size();
    let (pw, ph) = ((w / 3).max(4), (h / 3).max(4));
    if w < 2 * pw || h < 2 * ph {
        return None;
    }
    let f = Features::new(img, true).ok()?;
    let stacked = f.stacked();
    match periods_of(&stacked, &f.weights(1.0, 4.0)) {
        Some(Periodicity::Grid(l)) if repeats(&f.appearance, &[l.a, l.b]) => Some(Periodicity::Grid(l)),
        Some(Periodicity::Stripes(v)) if repeats(&f.appearance, &[v]) => Some(Periodicity::Stripes(v)),
        _ => axis_stripes(&f.appearance),
    }
}

/// Whether the image is explained by its median repeat over `vectors`
/// ([`explained_by`]). A few chance matches in a stochastic texture (grain
/// that lines up) make a lattice that fails this.
fn repeats(appearance: &Image, vectors: &[[f32; 2]]) -> bool {
    explained_by(appearance, &median_translates(appearance, vectors, None), None)
}

/// Whether `template` explains `img` over the `allowed` pixels (all when
/// `None`): their mean colour distance to it (first three channels) is
/// below half their mean distance to their own mean colour.
pub fn explained_by(img: &Image, template: &Image, allowed: Option<&Mask>) -> bool {
    let (c, n) = (img.channels(), img.channels().min(3));
    let pick = |i: usize| allowed.is_none_or(|m| m.bits()[i]);
    let pixels = || img.data().chunks_exact(c).zip(template.data().chunks_exact(c)).enumerate().filter(|(i, _)| pick(*i)).map(|(_, pq)| pq);
    let count = pixels().count().max(1) as f64;
    let mut mean = vec![0f64; n];
    for (p, _) in pixels() {
        mean.iter_mut().zip(p).for_each(|(m, v)| *m += *v as f64 / count);
    }
    let (mut residual, mut spread) = (0f64, 0f64);
    for (p, q) in pixels() {
        residual += (0..n).map(|k| ((p[k] - q[k]) as f64).powi(2)).sum::<f64>().sqrt();
        spread += (0..n).map(|k| (p[k] as f64 - mean[k]).powi(2)).sum::<f64>().sqrt();
    }
    residual < 0.5 * spread
}

/// Boards, siding and grooves seen square-on, whose tone changes from
/// board to board so that whole patches do not repeat: the edges across
/// the boards do. Per axis, the profile of the edge energy across it (the
/// mean |dL| along each row, or column) and its autocorrelation; a
/// period is the first autocorrelation peak of at least
/// [`PROFILE_PEAK`] of the zero-lag value, from [`MIN_PERIOD`] to a third
/// of the side, confirmed by a peak at twice the lag. Stripes only when
/// exactly one axis has a period (both: a grid, which [`periods_of`] owns).
fn axis_stripes(appearance: &Image) -> Option<Periodicity> {
    let (w, h) = appearance.size();
    let mut rows = vec![0f32; h];
    let mut cols = vec![0f32; w];
    for (y, row) in rows.iter_mut().enumerate().skip(1) {
        for (x, col) in cols.iter_mut().enumerate().skip(1) {
            let l = appearance.at(x, y, 0);
            *row += (l - appearance.at(x, y - 1, 0)).abs() / w as f32;
            *col += (l - appearance.at(x - 1, y, 0)).abs() / h as f32;
        }
    }
    match (profile_period(&rows[1..]), profile_period(&cols[1..])) {
        (Some((p, _)), None) => Some(Periodicity::Stripes([0.0, p])),
        (None, Some((p, _))) => Some(Periodicity::Stripes([p, 0.0])),
        // Both: stripes along the clearly stronger one (board ends make a
        // weak, irregular period along the boards).
        (Some((p, a)), Some((_, b))) if a > DOMINANT * b => Some(Periodicity::Stripes([0.0, p])),
        (Some((_, a)), Some((p, b))) if b > DOMINANT * a => Some(Periodicity::Stripes([p, 0.0])),
        _ => None,
    }
}

/// How much stronger (peak over zero lag) one axis's period must be than
/// the other's for stripes.
const DOMINANT: f32 = 1.5;

/// Share of the zero-lag autocorrelation a profile's period peak needs.
pub const PROFILE_PEAK: f32 = 0.3;

/// The period of a 1-D profile (see [`axis_stripes`]), refined to a
/// sub-sample lag by a parabola through the peak, and the peak's share of
/// the zero-lag value.
fn profile_period(profile: &[f32]) -> Option<(f32, f32)> {
    let n = profile.len();
    // Smooth over a couple of samples: a groove's two edges become one bump.
    let kernel = [0.06f32, 0.24, 0.4, 0.24, 0.06];
    let smooth: Vec<f32> =
        (0..n).map(|i| kernel.iter().enumerate().map(|(k, w)| w * profile[(i + k).saturating_sub(2).min(n - 1)]).sum()).collect();
    let mean = smooth.iter().sum::<f32>() / n.max(1) as f32;
    let v: Vec<f32> = smooth.iter().map(|p| p - mean).collect();
    let ac = |lag: usize| -> f32 { v.iter().zip(&v[lag..]).map(|(a, b)| a * b).sum::<f32>() / (n - lag) as f32 };
    let zero = ac(0);
    if zero <= 0.0 || n < 3 * MIN_PERIOD {
        return None;
    }
    let max_lag = n / 3;
    let values: Vec<f32> = (0..=max_lag + 1).map(ac).collect();
    let peak = |lag: usize| lag >= 1 && lag < values.len() - 1 && values[lag] >= values[lag - 1] && values[lag] >= values[lag + 1];
    // The fundamental: the shortest peak nearly as high as the highest.
    let top = (MIN_PERIOD..=max_lag).filter(|&l| peak(l)).map(|l| values[l]).fold(f32::MIN, f32::max);
    let lag = (MIN_PERIOD..=max_lag).find(|&l| peak(l) && values[l] >= PROFILE_PEAK * zero && values[l] >= 0.85 * top)?;
    // Confirmed by a peak near twice the lag (when it fits).
    if 2 * lag + 1 < n {
        let twice = (2 * lag - 1..=2 * lag + 1).map(ac).fold(f32::MIN, f32::max);
        if twice < PROFILE_PEAK * zero {
            return None;
        }
    }
    let (a, b, c) = (values[lag - 1], values[lag], values[lag + 1]);
    Some((lag as f32 + parabola(a, b, c), b / zero))
}

/// [`periods`] on one feature image with per-channel weights.
fn periods_of(stacked: &Image, weights: &[f32]) -> Option<Periodicity> {
    let (w, h) = stacked.size();
    let (pw, ph) = ((w / 3).max(4), (h / 3).max(4));
    let spectral = SpectralSource::new(stacked, weights);
    let (vw, vh) = (w - pw + 1, h - ph + 1);
    let distances = |x: usize, y: usize| -> Vec<f32> {
        let t = stacked.crop(x, y, pw, ph).expect("placement inside the image").into_data();
        let mut q = spectral.query(pw, ph);
        spectral.add_box_term(&mut q, &t, 1.0);
        spectral.finish(q)
    };
    let centre = ((w - pw) / 2, (h - ph) / 2);
    let map = distances(centre.0, centre.1);
    let mut sorted = map.clone();
    sorted.sort_by(f32::total_cmp);
    let median = sorted[sorted.len() / 2];
    if median <= 0.0 {
        return None; // a flat image: no structure to repeat
    }
    let cut = sorted[((sorted.len() as f32 * CANDIDATE_QUANTILE) as usize).min(sorted.len() - 1)];
    let min_at = |m: &[f32], x: usize, y: usize| {
        let v = m[y * vw + x];
        (y.saturating_sub(1)..=(y + 1).min(vh - 1)).all(|yy| (x.saturating_sub(1)..=(x + 1).min(vw - 1)).all(|xx| m[yy * vw + xx] >= v))
    };
    // An offset is a repeat, not the slope of the centre's own valley (a
    // smooth grain matches itself a few pixels along), when it is at least
    // MIN_PERIOD long, lands on a low distance and has a ridge half-way
    // back to the centre.
    let is_repeat = |o: [i32; 2]| -> bool {
        let at = |dx: i32, dy: i32| -> Option<f32> {
            let (x, y) = (centre.0 as i64 + dx as i64, centre.1 as i64 + dy as i64);
            ((0..vw as i64).contains(&x) && (0..vh as i64).contains(&y)).then(|| map[y as usize * vw + x as usize])
        };
        let long = o[0] * o[0] + o[1] * o[1] >= (MIN_PERIOD * MIN_PERIOD) as i32;
        // The highest distance a quarter, half and three quarters of the way
        // (a multiple of the period has ridges between its repeats too).
        let ridge = |s: i32| -> Option<f32> {
            [1, 2, 3].iter().map(|&k| at(s * o[0] * k / 4, s * o[1] * k / 4)).try_fold(f32::MIN, |m, v| v.map(|v| m.max(v)))
        };
        let side = |s: i32| match (at(s * o[0], s * o[1]), ridge(s)) {
            (Some(v), Some(mid)) => Some(long && v < MATCH_RATIO * median && mid > RIDGE * v),
            _ => None,
        };
        // Beyond the map on one side: judge by the other.
        side(1).or_else(|| side(-1)).unwrap_or(false)
    };
    let mut candidates: Vec<(usize, usize)> = (0..vw * vh)
        .map(|i| (i % vw, i / vw))
        .filter(|&(x, y)| (x, y) != centre && map[y * vw + x] <= cut && map[y * vw + x] < MATCH_RATIO * median && min_at(&map, x, y))
        .filter(|&(x, y)| is_repeat([x as i32 - centre.0 as i32, y as i32 - centre.1 as i32]))
        .collect();
    // The closest matches only: re-matching and the basis vote grow with
    // the square and the fourth power of the count (an outlier pixel can
    // make every flat spot a candidate).
    candidates.sort_by(|p, q| map[p.1 * vw + p.0].total_cmp(&map[q.1 * vw + q.0]).then(p.cmp(q)));
    candidates.truncate(MAX_CANDIDATES);
    // Re-match each candidate's own patch and look for the centre.
    let verified: Vec<(usize, usize)> = candidates
        .par_iter()
        .filter(|&&(x, y)| {
            let back = distances(x, y);
            let mut s = back.clone();
            s.sort_by(f32::total_cmp);
            let med = s[s.len() / 2];
            let near = (centre.1.saturating_sub(1)..=(centre.1 + 1).min(vh - 1))
                .flat_map(|yy| (centre.0.saturating_sub(1)..=(centre.0 + 1).min(vw - 1)).map(move |xx| (xx, yy)))
                .map(|(xx, yy)| back[yy * vw + xx])
                .fold(f32::INFINITY, f32::min);
            near < MATCH_RATIO * med
        })
        .copied()
        .collect();
    if verified.len() < MIN_REPEATS {
        return None;
    }
    let mut points: Vec<[f32; 2]> = verified.iter().map(|&(x, y)| [x as f32, y as f32]).collect();
    points.push([centre.0 as f32, centre.1 as f32]);
    let (a, b) = match basis(&points, &is_repeat)? {
        (a, Some(b)) => (a, b),
        (a, None) => return stripes(&points, a),
    };
    let lattice = reduce(refine(&points, a, b, [centre.0 as f32, centre.1 as f32]));
    // Express the origin as the lattice point nearest the image's top-left.
    let o = lattice.origin;
    let inv = invert(lattice.a, lattice.b)?;
    let (i, j) = (inv[0][0] * o[0] + inv[0][1] * o[1], inv[1][0] * o[0] + inv[1][1] * o[1]);
    let (i, j) = (i.floor(), j.floor());
    let origin = [o[0] - i * lattice.a[0] - j * lattice.b[0], o[1] - i * lattice.a[1] - j * lattice.b[1]];
    Some(Periodicity::Grid(Lattice { origin, ..lattice }))
}

/// One period direction: `a` refined as the mean of the verified offsets
/// that are whole multiples of it (least squares through the origin),
/// when at least [`MIN_REPEATS`] of them line up.
fn stripes(points: &[[f32; 2]], a: [f32; 2]) -> Option<Periodicity> {
    let len2 = a[0] * a[0] + a[1] * a[1];
    let centre = points.last()?;
    let (mut num, mut den, mut count) = ([0f32; 2], 0f32, 0usize);
    for p in &points[..points.len() - 1] {
        let d = [p[0] - centre[0], p[1] - centre[1]];
        let k = ((d[0] * a[0] + d[1] * a[1]) / len2).round();
        if k == 0.0 || (d[0] - k * a[0]).abs() > 1.5 || (d[1] - k * a[1]).abs() > 1.5 {
            continue;
        }
        num = [num[0] + k * d[0], num[1] + k * d[1]];
        den += k * k;
        count += 1;
    }
    (count >= MIN_REPEATS).then(|| Periodicity::Stripes([num[0] / den, num[1] / den]))
}

/// The two most frequent non-collinear pairwise offsets (each counted with
/// the offsets within 1 px of it), shortest first; the second is `None`
/// when every frequent offset lies along the first.
fn basis(points: &[[f32; 2]], is_repeat: &dyn Fn([i32; 2]) -> bool) -> Option<([f32; 2], Option<[f32; 2]>)> {
    let mut offsets: Vec<[i32; 2]> = Vec::new();
    for (i, p) in points.iter().enumerate() {
        for q in &points[i + 1..] {
            let (mut dx, mut dy) = ((q[0] - p[0]) as i32, (q[1] - p[1]) as i32);
            // One sign per direction: dx > 0, or dx == 0 and dy > 0.
            if dx < 0 || (dx == 0 && dy < 0) {
                (dx, dy) = (-dx, -dy);
            }
            offsets.push([dx, dy]);
        }
    }
    let votes = |o: [i32; 2]| offsets.iter().filter(|v| (v[0] - o[0]).abs() <= 1 && (v[1] - o[1]).abs() <= 1).count();
    let mut ranked: Vec<([i32; 2], usize)> = offsets.iter().filter(|&&o| is_repeat(o)).map(|&o| (o, votes(o))).collect();
    let len2 = |o: [i32; 2]| o[0] * o[0] + o[1] * o[1];
    ranked.sort_by(|x, y| y.1.cmp(&x.1).then(len2(x.0).cmp(&len2(y.0))).then(x.0.cmp(&y.0)));
    let a = ranked.first()?.0;
    let b = ranked.iter().find(|(o, n)| {
        let cross = (a[0] * o[1] - a[1] * o[0]).abs() as f32;
        *n >= 2 && cross > 0.5 * (len2(a) as f32).sqrt() * (len2(*o) as f32).sqrt()
    });
    let f = |o: [i32; 2]| [o[0] as f32, o[1] as f32];
    Some((f(a), b.map(|b| f(b.0))))
}

/// Gauss (Lagrange) reduction: the same lattice with its shortest basis.
fn reduce(mut l: Lattice) -> Lattice {
    let dot = |u: [f32; 2], v: [f32; 2]| u[0] * v[0] + u[1] * v[1];
    for _ in 0..32 {
        if dot(l.a, l.a) > dot(l.b, l.b) {
            std::mem::swap(&mut l.a, &mut l.b);
        }
        let m = (dot(l.a, l.b) / dot(l.a, l.a)).round();
        if m == 0.0 {
            break;
        }
        l.b = [l.b[0] - m * l.a[0], l.b[1] - m * l.a[1]];
    }
    l
}

/// Inverse of the 2x2 matrix with columns a and b.
fn invert(a: [f32; 2], b: [f32; 2]) -> Option<[[f32; 2]; 2]> {
    let det = a[0] * b[1] - b[0] * a[1];
    (det.abs() > 1e-6).then(|| [[b[1] / det, -b[0] / det], [-a[1] / det, a[0] / det]])
}

/// Least-squares lattice through `points`: each gets integer coordinates
/// (i, j) under the integer basis, then origin, a, b minimise
/// sum |p - origin - i a - j b|^2.
fn refine(points: &[[f32; 2]], a: [f32; 2], b: [f32; 2], origin: [f32; 2]) -> Lattice {
    let Some(inv) = invert(a, b) else { return Lattice { a, b, origin } };
    let coords: Vec<[f32; 3]> = points
        .iter()
        .map(|p| {
            let d = [p[0] - origin[0], p[1] - origin[1]];
            [1.0, (inv[0][0] * d[0] + inv[0][1] * d[1]).round(), (inv[1][0] * d[0] + inv[1][1] * d[1]).round()]
        })
        .collect();
    // Normal equations (3 x 3, shared by the x and y coordinates).
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    let mut rhs = nalgebra::Matrix3x2::<f64>::zeros();
    for (c, p) in coords.iter().zip(points) {
        for r in 0..3 {
            for s in 0..3 {
                m[(r, s)] += (c[r] * c[s]) as f64;
            }
            rhs[(r, 0)] += (c[r] * p[0]) as f64;
            rhs[(r, 1)] += (c[r] * p[1]) as f64;
        }
    }
    match m.try_inverse() {
        Some(mi) => {
            let sol = mi * rhs;
            let g = |r: usize| [sol[(r, 0)] as f32, sol[(r, 1)] as f32];
            Lattice { origin: g(0), a: g(1), b: g(2) }
        }
        None => Lattice { a, b, origin },
    }
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
                row[x * n + c] = if v.is_empty() {
                    img.at(x, y, c)
                } else {
                    let mid = v.len() / 2;
                    *v.select_nth_unstable_by(mid, f32::total_cmp).1
                };
            }
        }
    });
    let mut out = Image::from_data(w, h, n, data).expect("sizes match");
    out.set_groups(img.groups().to_vec()).expect("same channels");
    out
}
