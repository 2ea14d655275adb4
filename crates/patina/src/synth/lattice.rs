//! Translational symmetry of an exemplar: the shifts that map its regular
//! structure onto itself (a tile grid, brick courses, board widths,
//! louvres), so that synthesis can keep that structure whole.
//!
//! Found on the normalised autocorrelation of the exemplar's high-passed
//! channels (weighted as the synthesis weights them; the overlap of each
//! shift divided out, 1 at zero shift), at most 512 px on a side:
//! 1. **Continuous direction.** A direction along which the correlation
//!    stays high all the way out (mean over the ray >= [`RIDGE`]) is a
//!    structure that runs along it: courses, boards, grooves. Their period
//!    is the first strong peak ([`PEAK`]) of the profile across that
//!    direction (the correlation averaged along lines parallel to it).
//! 2. **Otherwise a grid.** Peaks of the correlation at least [`MIN_PERIOD`]
//!    long and [`PEAK`] high; the shortest of the strongest is the first
//!    period, the shortest of the strongest peaks at least 30 degrees away
//!    the second (none: repeats in one direction only).
//!
//! A repeat must stand out from the correlation half-way back to zero shift
//! by [`CONTRAST`]; the slope of the central peak, or a texture's smooth
//! grain, does not. A period is kept only if the structure is regular:
//! it repeats at twice the period nearly as well ([`REGULAR`]), checked
//! when twice the period fits in [`FAR`] of the side (else the repeat
//! must be [`STRONG`]). Periods are refined to sub-pixel by a parabola
//! through the peak and then measured again at the farthest multiple that
//! fits, because a block copied k periods away from its neighbour's
//! source drifts by k times the period's error.
//!
//! [`Lattice::detect_steady`] also drops a period that changes across the
//! exemplar (a structure seen in perspective): no one shift keeps blocks
//! copied from different parts of it in phase ([`DRIFT`]).
//!
//! Stochastic textures (gravel, cracked paint, rust) have none, and
//! synthesis runs unchanged on them.

use super::correlate::autocorrelation;
use crate::image::filter::gaussian_blur;
use crate::image::resample::pyr_down;
use crate::image::Image;
use serde::Serialize;

/// Mean correlation along a ray that makes it a continuous direction.
pub const RIDGE: f32 = 0.25;
/// Correlation a repeat needs.
pub const PEAK: f32 = 0.2;
/// How far a repeat's correlation must stand above the correlation half-way back.
pub const CONTRAST: f32 = 0.15;
/// Shortest period, in analysed pixels.
pub const MIN_PERIOD: usize = 8;
/// Largest side analysed; larger exemplars are halved until they fit.
const MAX_SIDE: usize = 512;
/// A regular structure repeats at twice its period nearly as well as at
/// once (the correlation keeps this share); columns of bricks whose widths
/// vary have a period on average only, and keeping them in phase with it
/// breaks them (the grey brick wall of ../shared/data falls to 0.46, its
/// circle tiles keep 0.90-0.98, boards 0.71, roof tiles 0.73).
pub const REGULAR: f32 = 0.6;
/// Correlation a repeat needs when its regularity cannot be checked (twice
/// the period does not fit): the damask wallpaper's 0.44 and 0.55.
pub const STRONG: f32 = 0.4;
/// Farthest shift, as a share of the smaller side, at which a repeat is
/// checked.
pub const FAR: f32 = 0.7;
/// Largest spread of a period measured in three bands of the exemplar, as
/// a share of its mean, for it to count as one period ([`drifts`]): twice
/// [`Lattice::tolerance`]'s 3%.
pub const DRIFT: f32 = 0.06;
/// Periods a band must hold along a period for its local period to be
/// measured.
const BAND_REPEATS: f32 = 3.0;

/// What [`Lattice::detect_steady`] finds: the lattice kept, if any, and
/// the periods left out as drifting.
pub type Steady = (Option<Lattice>, Vec<[f32; 2]>);

/// The periods of a texture's regular structure: one vector (repeats in one
/// direction, e.g. across boards) or two (a grid), in exemplar pixels.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Lattice {
    pub periods: Vec<[f32; 2]>,
}

/// The normalised autocorrelation of an analysed exemplar.
struct Correlation {
    values: Vec<f32>,
    fw: usize,
    fh: usize,
    w: usize,
    h: usize,
    /// The high-passed exemplar, its channels weighted into one.
    detail: Image,
}

impl Correlation {
    fn new(img: &Image, weights: &[f32]) -> Option<Self> {
        let sigma = (img.width().min(img.height()) as f32 / 40.0).max(2.0);
        let low = gaussian_blur(img, sigma);
        let detail =
            Image::from_data(img.width(), img.height(), img.channels(), img.data().iter().zip(low.data()).map(|(a, b)| a - b).collect())
                .expect("same size");
        let (mut values, fw, fh) = autocorrelation(&detail, weights);
        let detail = Image::from_fn(img.width(), img.height(), 1, |x, y, p| {
            p[0] = detail.pixel(x, y).iter().zip(weights).map(|(v, w)| v * w.sqrt()).sum::<f32>()
        });
        let (w, h) = img.size();
        let zero = values[0] / (w * h) as f32;
        if zero <= 1e-12 {
            return None; // flat: no structure
        }
        for dy in 0..fh {
            for dx in 0..fw {
                let (ax, ay) = (dx.min(fw - dx), dy.min(fh - dy));
                let overlap = (w.saturating_sub(ax) * h.saturating_sub(ay)).max(1) as f32;
                values[dy * fw + dx] /= overlap * zero;
            }
        }
        Some(Correlation { values, fw, fh, w, h, detail })
    }

    /// At an integer shift (|dx| < w, |dy| < h).
    fn at(&self, dx: i64, dy: i64) -> f32 {
        let x = dx.rem_euclid(self.fw as i64) as usize;
        let y = dy.rem_euclid(self.fh as i64) as usize;
        self.values[y * self.fw + x]
    }

    /// Bilinear, at a sub-pixel shift.
    fn sample(&self, dx: f32, dy: f32) -> f32 {
        let (x0, y0) = (dx.floor(), dy.floor());
        let (fx, fy) = (dx - x0, dy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        (1.0 - fy) * ((1.0 - fx) * self.at(x0, y0) + fx * self.at(x0 + 1, y0))
            + fy * ((1.0 - fx) * self.at(x0, y0 + 1) + fx * self.at(x0 + 1, y0 + 1))
    }

    /// Reach of the analysis: repeats must fit twice in the exemplar.
    fn reach(&self) -> usize {
        self.w.min(self.h) / 2
    }
}

/// Vertex offset of the parabola through three equally spaced samples
/// (in -0.5..=0.5): a peak's sub-sample position.
fn parabola(a: f32, b: f32, c: f32) -> f32 {
    let d = a - 2.0 * b + c;
    if d.abs() > 1e-12 {
        (0.5 * (a - c) / d).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

impl Lattice {
    /// Detect the regular structure of `img` (channels weighted by
    /// `weights`, as the synthesis compares them); `None` = stochastic.
    pub fn detect(img: &Image, weights: &[f32]) -> Option<Lattice> {
        Self::of(found(img, weights, false).into_iter().map(|(v, _)| v).collect())
    }

    /// [`Lattice::detect`] without the periods that drift across the
    /// exemplar ([`DRIFT`]): only what one shift keeps in phase
    /// everywhere, which is what quilting aligns its blocks on; and the
    /// drifting periods it left out (a regular structure photographed at
    /// an angle). (The weathering's tile template takes the drifting
    /// periods too: its median over tiles in perspective is checked for
    /// sharpness there.)
    pub fn detect_steady(img: &Image, weights: &[f32]) -> Steady {
        let (drifting, steady): (Vec<_>, Vec<_>) = found(img, weights, true).into_iter().partition(|&(_, d)| d);
        (Self::of(steady.into_iter().map(|(v, _)| v).collect()), drifting.into_iter().map(|(v, _)| v).collect())
    }

    fn of(periods: Vec<[f32; 2]>) -> Option<Lattice> {
        (!periods.is_empty()).then_some(Lattice { periods })
    }

    /// How far, in pixels, the shift `d` is from the nearest shift that maps
    /// the structure onto itself (for one period, measured across it only).
    pub fn misalignment(&self, d: [f32; 2]) -> f32 {
        match self.periods[..] {
            [p] => {
                let len2 = p[0] * p[0] + p[1] * p[1];
                let c = (d[0] * p[0] + d[1] * p[1]) / len2;
                (c - c.round()).abs() * len2.sqrt()
            }
            [a, b] => {
                let det = a[0] * b[1] - a[1] * b[0];
                let i = (d[0] * b[1] - d[1] * b[0]) / det;
                let j = (a[0] * d[1] - a[1] * d[0]) / det;
                let mut best = f32::INFINITY;
                for ii in [i.floor(), i.ceil()] {
                    for jj in [j.floor(), j.ceil()] {
                        let r = [d[0] - ii * a[0] - jj * b[0], d[1] - ii * a[1] - jj * b[1]];
                        best = best.min((r[0] * r[0] + r[1] * r[1]).sqrt());
                    }
                }
                best
            }
            _ => 0.0,
        }
    }

    /// Only the periods longer than `length`; `None` if none is.
    pub fn longer_than(&self, length: f32) -> Option<Lattice> {
        let periods: Vec<[f32; 2]> = self.periods.iter().copied().filter(|p| (p[0] * p[0] + p[1] * p[1]).sqrt() > length).collect();
        Self::of(periods)
    }

    /// The tile size nearest `(w, h)` whose edges wrap in phase: the
    /// nearest sides, within one period (longest vector) of the asked ones
    /// and at least `min_side`, for which the shifts (w', 0) and (0, h')
    /// are within half a pixel of the lattice (else the best there is), so
    /// that a grid closes across a tileable output's edges.
    pub fn tile_fit(&self, (w, h): (usize, usize), min_side: usize) -> (usize, usize) {
        let longest = self.periods.iter().map(|p| (p[0] * p[0] + p[1] * p[1]).sqrt()).fold(0.0f32, f32::max).ceil() as usize;
        let fit = |side: usize, shift: &dyn Fn(f32) -> [f32; 2]| {
            let sizes = || (0..=longest).flat_map(|k| [side.checked_sub(k), Some(side + k)]).flatten().filter(|&s| s >= min_side);
            let off = |s: usize| self.misalignment(shift(s as f32));
            sizes().find(|&s| off(s) <= 0.5).or_else(|| sizes().min_by(|&a, &b| off(a).total_cmp(&off(b)))).unwrap_or(side)
        };
        (fit(w, &|s| [s, 0.0]), fit(h, &|s| [0.0, s]))
    }

    /// The misalignment still counted as aligned: 5% of the shortest
    /// period, at least 1.5 px (real structure is never exactly periodic).
    pub fn tolerance(&self) -> f32 {
        let shortest = self.periods.iter().map(|p| (p[0] * p[0] + p[1] * p[1]).sqrt()).fold(f32::INFINITY, f32::min);
        (0.03 * shortest).max(1.5)
    }
}

/// Every period of `img`'s regular structure (see the module docs), in
/// its pixels, each with whether it drifts across the image ([`drifts`];
/// only judged when `judge_drift`).
fn found(img: &Image, weights: &[f32], judge_drift: bool) -> Vec<([f32; 2], bool)> {
    let mut analysed = img.clone();
    let mut scale = 1.0f32;
    while analysed.width().max(analysed.height()) > MAX_SIDE {
        analysed = pyr_down(&analysed);
        scale *= 2.0;
    }
    if analysed.width().min(analysed.height()) < 4 * MIN_PERIOD {
        return Vec::new();
    }
    let Some(corr) = Correlation::new(&analysed, weights) else { return Vec::new() };
    let periods: Vec<[f32; 2]> = match continuous_direction(&corr) {
        Some(along) => stripe_period(&corr, along).into_iter().collect(),
        None => grid_periods(&corr).unwrap_or_default().into_iter().filter(|&v| regular(|x, y| corr.sample(x, y), v, &corr)).collect(),
    };
    periods.into_iter().map(|v| ([v[0] * scale, v[1] * scale], judge_drift && drifts(&corr, v))).collect()
}

/// The direction (unit vector) along which the correlation stays high, if any.
fn continuous_direction(corr: &Correlation) -> Option<[f32; 2]> {
    let reach = corr.reach();
    let (mut best, mut along) = (f32::MIN, [1.0, 0.0]);
    for deg in 0..180 {
        let t = (deg as f32).to_radians();
        let u = [t.cos(), t.sin()];
        let mean = (MIN_PERIOD..reach).map(|r| corr.sample(r as f32 * u[0], r as f32 * u[1])).sum::<f32>() / (reach - MIN_PERIOD) as f32;
        if mean > best {
            (best, along) = (mean, u);
        }
    }
    (best >= RIDGE).then_some(along)
}

/// The period across a structure continuous `along` a direction: the
/// fundamental peak of the correlation profile across it, refined.
fn stripe_period(corr: &Correlation, along: [f32; 2]) -> Option<[f32; 2]> {
    let reach = corr.reach();
    let far = (FAR * corr.w.min(corr.h) as f32) as usize;
    let across = [-along[1], along[0]];
    let half = (reach / 2) as i64;
    let profile: Vec<f32> = (0..far + 2)
        .map(|s| {
            let n = (half + 1) as f32;
            (-half..=half)
                .step_by(2)
                .map(|t| {
                    let (s, t) = (s as f32, t as f32);
                    corr.sample(s * across[0] + t * along[0], s * across[1] + t * along[1])
                })
                .sum::<f32>()
                / n
        })
        .collect();
    let at = |s: f32| {
        let i = (s.floor() as usize).min(profile.len() - 2);
        let f = s - i as f32;
        (1.0 - f) * profile[i] + f * profile[i + 1]
    };
    let is_peak = |s: usize| s >= 1 && s + 1 < reach && profile[s] >= profile[s - 1] && profile[s] >= profile[s + 1];
    let peaks: Vec<usize> =
        (MIN_PERIOD..reach).filter(|&s| is_peak(s) && profile[s] >= PEAK && profile[s] - at(s as f32 / 2.0) >= CONTRAST).collect();
    let top = peaks.iter().map(|&s| profile[s]).fold(f32::MIN, f32::max);
    let s = *peaks.iter().find(|&&s| profile[s] >= 0.8 * top)?;
    let mut period = s as f32 + parabola(profile[s - 1], profile[s], profile[s + 1]);
    // Measured again at the farthest multiple that fits.
    let m = (reach - 2) as f32 / period;
    if m >= 2.0 {
        let m = m.floor();
        let guess = (m * period).round() as usize;
        let lo = guess.saturating_sub(m as usize).max(1);
        let hi = (guess + m as usize).min(reach - 2);
        if let Some(k) = (lo..=hi).filter(|&k| is_peak(k) && profile[k] >= PEAK).max_by(|&a, &b| profile[a].total_cmp(&profile[b])) {
            period = (k as f32 + parabola(profile[k - 1], profile[k], profile[k + 1])) / m;
        }
    }
    let v = [period * across[0], period * across[1]];
    regular(|x, y| at(x * across[0] + y * across[1]), v, corr).then_some(v)
}

/// Whether the period `v` changes across the exemplar, as a structure
/// seen in perspective does: the exemplar is cut into three bands across
/// each axis, and in every band holding at least [`BAND_REPEATS`] periods
/// along `v` the local period is the shift along `v` (0.8..1.25 times its
/// length, in quarter pixels) that best correlates the band's detail with
/// itself. A spread of the three local periods above [`DRIFT`] of their
/// mean is a drift: blocks copied from different bands are out of phase
/// however they are aligned on the one mean period (the roof tiles of
/// ../shared/data are 21.4, 23.4 and 24.7 px wide from top to bottom, a
/// 14% spread; the circle tiles' spread is 1.3%, the old brick wall's
/// courses 1.8%).
fn drifts(corr: &Correlation, v: [f32; 2]) -> bool {
    let d = &corr.detail;
    let (w, h) = d.size();
    let len = (v[0] * v[0] + v[1] * v[1]).sqrt();
    let u = [v[0] / len, v[1] / len];
    let at = |x: f32, y: f32| {
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        (1.0 - fy) * ((1.0 - fx) * d.at(x0, y0, 0) + fx * d.at(x1, y0, 0)) + fy * ((1.0 - fx) * d.at(x0, y1, 0) + fx * d.at(x1, y1, 0))
    };
    // Normalised correlation of a band with itself shifted by k along u.
    let similarity = |(x0, y0, bw, bh): (usize, usize, usize, usize), k: f32| {
        let (sx, sy) = (k * u[0], k * u[1]);
        let (mut ab, mut aa, mut bb) = (0.0f64, 0.0f64, 0.0f64);
        for y in y0..y0 + bh {
            for x in x0..x0 + bw {
                let (tx, ty) = (x as f32 + sx, y as f32 + sy);
                if tx < 0.0 || ty < 0.0 || tx > (w - 1) as f32 || ty > (h - 1) as f32 {
                    continue;
                }
                let (a, b) = (f64::from(d.at(x, y, 0)), f64::from(at(tx, ty)));
                (ab, aa, bb) = (ab + a * b, aa + a * a, bb + b * b);
            }
        }
        ab / (aa * bb).sqrt().max(1e-12)
    };
    let local_period = |band| {
        let steps = ((1.25 - 0.8) * len * 4.0) as usize;
        (0..=steps)
            .map(|i| 0.8 * len + i as f32 * 0.25)
            .map(|k| (k, similarity(band, k)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(len, |b| b.0)
    };
    let (tw, th) = (w / 3, h / 3);
    let families =
        [[(0, 0, w, th), (0, th, w, th), (0, 2 * th, w, h - 2 * th)], [(0, 0, tw, h), (tw, 0, tw, h), (2 * tw, 0, w - 2 * tw, h)]];
    families.iter().any(|bands| {
        let (_, _, bw, bh) = bands[0];
        let reach = u[0].abs() * bw as f32 + u[1].abs() * bh as f32;
        if reach < BAND_REPEATS * len {
            return false;
        }
        let periods: Vec<f32> = bands.iter().map(|&b| local_period(b)).collect();
        let (lo, hi) = periods.iter().fold((f32::MAX, f32::MIN), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        (hi - lo) > DRIFT * periods.iter().sum::<f32>() / 3.0
    })
}

/// Whether the structure repeats at twice `v` nearly as well as at `v`
/// ([`REGULAR`]), by `value` at a shift; when 2 v does not fit in [`FAR`]
/// of the side, whether the repeat at `v` is [`STRONG`].
fn regular(value: impl Fn(f32, f32) -> f32, v: [f32; 2], corr: &Correlation) -> bool {
    let len = (v[0] * v[0] + v[1] * v[1]).sqrt();
    // The highest value within k px of k v (a real period's error grows with k).
    let near = |k: f32| {
        let mut best = f32::MIN;
        for j in -2..=2 {
            for i in -2..=2 {
                let (ox, oy) = (i as f32 * k / 2.0, j as f32 * k / 2.0);
                best = best.max(value(k * v[0] + ox, k * v[1] + oy));
            }
        }
        best
    };
    if 2.0 * len > FAR * corr.w.min(corr.h) as f32 {
        return near(1.0) >= STRONG;
    }
    near(2.0) >= REGULAR * near(1.0)
}

/// One or two grid periods from the correlation's peaks.
fn grid_periods(corr: &Correlation) -> Option<Vec<[f32; 2]>> {
    let reach = corr.reach() as i64;
    let mut peaks: Vec<(f32, [i64; 2])> = Vec::new();
    for dy in 0..reach {
        for dx in -reach + 1..reach {
            if (dy == 0 && dx <= 0) || dx * dx + dy * dy < (MIN_PERIOD * MIN_PERIOD) as i64 {
                continue;
            }
            let v = corr.at(dx, dy);
            if v < PEAK {
                continue;
            }
            let highest = (-2..=2).all(|j| (-2..=2).all(|i| (i == 0 && j == 0) || corr.at(dx + i, dy + j) <= v));
            if highest && v - corr.sample(dx as f32 / 2.0, dy as f32 / 2.0) >= CONTRAST {
                peaks.push((v, [dx, dy]));
            }
        }
    }
    let len2 = |p: [i64; 2]| p[0] * p[0] + p[1] * p[1];
    // The shortest of the peaks within 80% of the strongest.
    let shortest_strong = |set: &[(f32, [i64; 2])]| -> Option<[i64; 2]> {
        let top = set.iter().map(|p| p.0).fold(f32::MIN, f32::max);
        set.iter().filter(|p| p.0 >= 0.8 * top).map(|p| p.1).min_by_key(|&p| (len2(p), p))
    };
    let a = shortest_strong(&peaks)?;
    let apart: Vec<(f32, [i64; 2])> = peaks
        .iter()
        .copied()
        .filter(|(_, p)| {
            let cross = (a[0] * p[1] - a[1] * p[0]) as f32;
            cross.abs() >= 0.5 * (len2(a) as f32).sqrt() * (len2(*p) as f32).sqrt()
        })
        .collect();
    let refine = |p: [i64; 2]| -> [f32; 2] {
        let ox = parabola(corr.at(p[0] - 1, p[1]), corr.at(p[0], p[1]), corr.at(p[0] + 1, p[1]));
        let oy = parabola(corr.at(p[0], p[1] - 1), corr.at(p[0], p[1]), corr.at(p[0], p[1] + 1));
        [p[0] as f32 + ox, p[1] as f32 + oy]
    };
    let mut periods = vec![refine(a)];
    if let Some(b) = shortest_strong(&apart) {
        periods.push(refine(b));
    }
    Some(periods)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{self, Rng};

    #[test]
    fn a_disc_grid_has_its_two_periods_and_noise_has_none() {
        let img = crate::samples::disc_grid(200, 200, 27, 1);
        let l = Lattice::detect(&img, &[1.0 / 3.0; 3]).expect("a grid");
        assert_eq!(l.periods.len(), 2, "{l:?}");
        let mut periods = l.periods.clone();
        periods.sort_by(|p, q| q[0].abs().total_cmp(&p[0].abs()));
        let (a, b) = (periods[0], periods[1]);
        assert!((a[0].abs() - 27.0).abs() < 0.3 && a[1].abs() < 0.3, "{l:?}");
        assert!(b[0].abs() < 0.3 && (b[1].abs() - 27.0).abs() < 0.3, "{l:?}");
        assert!(l.misalignment([54.0, -27.0]) < 1.0);
        assert!(l.misalignment([13.0, 0.0]) > 8.0);
        assert!(l.misalignment([0.0, 14.0]) > 8.0);

        let mut g = rng::generator(2, &[]);
        let noise = Image::from_fn(200, 200, 1, |_, _, p| p[0] = g.gen_range(0.0..1.0));
        assert_eq!(Lattice::detect(&crate::image::filter::gaussian_blur(&noise, 1.5), &[1.0]), None);
    }

    #[test]
    fn boards_repeat_across_only() {
        let img = crate::samples::planks(256, 256, 3);
        let l = Lattice::detect(&img, &[1.0 / 3.0; 3]).expect("boards");
        assert_eq!(l.periods.len(), 1, "{l:?}");
        let p = l.periods[0];
        // Boards 26 px apart, running horizontally.
        assert!(p[0].abs() < 1.0 && (p[1].abs() - 26.0).abs() < 0.5, "{l:?}");
        assert!(l.misalignment([17.0, 52.0]) < 1.0, "along the boards is free");
        assert!(l.misalignment([0.0, 13.0]) > 10.0);
    }

    #[test]
    fn the_nearest_tile_that_closes_the_grid() {
        let l = Lattice { periods: vec![[0.0, 26.0]] };
        // Boards across y: any width wraps, the height must be whole boards.
        assert_eq!(l.tile_fit((100, 100), 8), (100, 104));
        let grid = Lattice { periods: vec![[30.0, 0.0], [15.0, 20.0]] };
        // Widths: multiples of 30; heights: multiples of 40 (two rows).
        assert_eq!(grid.tile_fit((100, 100), 8), (90, 80));
    }

    #[test]
    fn boards_widening_across_the_image_are_not_regular() {
        // Boards 18 px wide on the left, 40 on the right (a receding
        // wall): a mean period, but no regular one.
        let mut g = rng::generator(6, &[]);
        let mut edges = vec![0usize];
        while *edges.last().unwrap() < 400 {
            let e = *edges.last().unwrap();
            edges.push(e + 18 + 22 * e.min(384) / 384);
        }
        let tones: Vec<f32> = edges.iter().map(|_| g.gen_range(0.4..0.6)).collect();
        let grain: Vec<f32> = (0..384 * 384).map(|_| g.gen_range(0.0..0.05)).collect();
        let img = Image::from_fn(384, 384, 1, |x, y, p| {
            let board = edges.iter().filter(|&&e| e <= x).count();
            let gap = edges.iter().any(|&e| x >= e && x < e + 2);
            p[0] = if gap { 0.1 } else { tones[board] } + grain[y * 384 + x];
        });
        assert_eq!(Lattice::detect(&img, &[1.0]), None);
    }

    #[test]
    fn boards_receding_in_perspective_keep_no_period() {
        // A fence seen from below: every row has a period, but not the
        // same one.
        let boards = |top: f32, bottom: f32| crate::samples::receding_boards(240, 240, top, bottom, 8);
        let (upright, none) = Lattice::detect_steady(&boards(23.0, 23.0), &[1.0]);
        let upright = upright.expect("boards of one width");
        assert!((upright.periods[0][0].abs() - 23.0).abs() < 0.5, "{upright:?}");
        assert!(none.is_empty(), "{none:?}");
        // 11% wider at the bottom: each 2 x period repeat still correlates
        // (the regularity check passes), but the period is not one.
        let receding = boards(22.0, 24.5);
        assert!(Lattice::detect(&receding, &[1.0]).is_some(), "a mean period");
        let (steady, drifting) = Lattice::detect_steady(&receding, &[1.0]);
        assert_eq!(steady, None, "boards widening 22 -> 24.5 px down the image");
        assert_eq!(drifting.len(), 1);
    }

    #[test]
    fn stochastic_samples_have_no_lattice() {
        for img in [crate::samples::cobbles(256, 256, 4), crate::samples::stucco(256, 256, 5)] {
            let w = vec![1.0 / img.channels() as f32; img.channels()];
            assert_eq!(Lattice::detect(&img, &w), None);
        }
    }
}
