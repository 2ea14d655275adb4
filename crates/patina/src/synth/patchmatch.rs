//! PatchMatch (Barnes, Shechtman, Finkelstein, Goldman 2009): improve a
//! nearest-neighbour field by propagation from scan-order neighbours and
//! random search at exponentially shrinking radii.
//!
//! Deterministic in parallel: the target is cut into bands of [`BAND_ROWS`]
//! rows. Even bands run in parallel, then odd bands; inside a band the scan
//! propagates through its own fresh results, across band edges it reads the
//! field as it stood at the start of the phase. Each band draws from its own
//! generator (seed, iteration, band), so the result is the same at any
//! thread count.
//!
//! Uniformity (Kaspar et al. 2015, EbSynth's `-uniformity`): a candidate's
//! cost is raised by `uniformity` x its normalised occupancy, the number of
//! target patch texels already copied from the pixels it covers, divided by
//! the count a perfectly even use of the source would give. The occupancy is
//! recomputed from the field before every iteration (not updated inside an
//! iteration: that would depend on scheduling).

use super::distance::PatchMetric;
use super::nnf::{random_nnf, Match, Nnf, SourceDomain};
use crate::error::Result;
use crate::image::{Image, Mask};
use crate::rng;
use rayon::prelude::*;

/// Rows per band of parallel work (fixed: results must not depend on threads).
pub const BAND_ROWS: usize = 16;

/// Settings for one PatchMatch run.
#[derive(Clone, Debug)]
pub struct PatchMatch<'a> {
    /// Patch radius (patch side = 2 radius + 1).
    pub radius: usize,
    /// Propagation + random search sweeps.
    pub iterations: usize,
    pub metric: &'a PatchMetric,
    /// Weight of the occupancy penalty; 0 turns it off.
    pub uniformity: f32,
    /// Largest random-search radius (default: the source's larger side).
    pub max_search_radius: Option<usize>,
    /// For matching an image against itself: source centres within this
    /// Chebyshev distance of the target pixel are not allowed.
    pub exclude_self: Option<usize>,
}

/// Normalised occupancy of each source centre (see the module docs).
struct Occupancy {
    width: usize,
    occ: Vec<f32>,
    /// A pixel's own contribution to the occupancy of its current match.
    own: f32,
}

impl Occupancy {
    fn new(nnf: &Nnf, domain: &SourceDomain) -> Self {
        let (w, h, r) = (domain.width(), domain.height(), domain.radius() as isize);
        let mut hist = vec![0f32; w * h];
        for m in nnf.matches() {
            hist[m.y as usize * w + m.x as usize] += 1.0;
        }
        // Patch-overlap weights (P - |d|) for |d| <= 2r, applied separably:
        // occ(c) = sum_v hist(v) * overlap(patch(c), patch(v)).
        let p = 2 * r + 1;
        let tri: Vec<f32> = (-2 * r..=2 * r).map(|d| (p - d.abs()) as f32).collect();
        let filt = |src: &[f32], horizontal: bool| -> Vec<f32> {
            let mut out = vec![0f32; w * h];
            out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                for (x, o) in row.iter_mut().enumerate() {
                    let mut s = 0.0;
                    for (k, t) in tri.iter().enumerate() {
                        let d = k as isize - 2 * r;
                        let (xx, yy) = if horizontal { (x as isize + d, y as isize) } else { (x as isize, y as isize + d) };
                        if xx >= 0 && yy >= 0 && (xx as usize) < w && (yy as usize) < h {
                            s += t * src[yy as usize * w + xx as usize];
                        }
                    }
                    *o = s;
                }
            });
            out
        };
        let mut occ = filt(&filt(&hist, true), false);
        let per_centre = nnf.matches().len() as f32 / domain.len() as f32;
        let p2 = (p * p) as f32;
        let even = per_centre * p2 * p2;
        occ.iter_mut().for_each(|v| *v /= even);
        Occupancy { width: w, occ, own: p2 / even }
    }
    #[inline]
    fn at(&self, x: u32, y: u32) -> f32 {
        self.occ[y as usize * self.width + x as usize]
    }
}

/// Everything a band's scan reads.
struct Scan<'a> {
    pm: &'a PatchMatch<'a>,
    target: &'a Image,
    source: &'a Image,
    domain: &'a SourceDomain,
    search: Option<&'a Mask>,
    occupancy: Option<Occupancy>,
    seed: u64,
    iteration: usize,
    radius_max: usize,
}

impl Scan<'_> {
    #[inline]
    fn penalty(&self, x: u32, y: u32) -> f32 {
        self.occupancy.as_ref().map_or(0.0, |o| self.pm.uniformity * o.at(x, y))
    }

    #[inline]
    fn allowed(&self, tx: usize, ty: usize, cx: i64, cy: i64) -> bool {
        if !self.domain.contains(cx, cy) {
            return false;
        }
        match self.pm.exclude_self {
            Some(e) => (cx - tx as i64).abs() > e as i64 || (cy - ty as i64).abs() > e as i64,
            None => true,
        }
    }

    /// Try centre (cx, cy) for target (tx, ty); keep it if its total is lower.
    #[inline]
    fn try_candidate(&self, tx: usize, ty: usize, cx: i64, cy: i64, best: &mut Match, best_total: &mut f32) {
        if (cx as u32 == best.x && cy as u32 == best.y) || !self.allowed(tx, ty, cx, cy) {
            return;
        }
        let (cx, cy) = (cx as u32, cy as u32);
        let pen = self.penalty(cx, cy);
        let bound = *best_total - pen;
        if bound <= 0.0 {
            return;
        }
        let r = self.pm.radius;
        let cost = self.pm.metric.patch_cost(self.target, tx, ty, self.source, cx as usize, cy as usize, r, bound);
        if cost < bound {
            *best = Match { x: cx, y: cy, cost };
            *best_total = cost + pen;
        }
    }

    fn band(&self, band: usize, rows: &mut [Match], snapshot: &[Match]) {
        let w = self.target.width();
        let h = self.target.height();
        let y0 = band * BAND_ROWS;
        let nrows = rows.len() / w;
        let forward = self.iteration.is_multiple_of(2);
        let mut g = rng::generator(self.seed, &[self.iteration as u64, band as u64]);
        let own = self.occupancy.as_ref().map_or(0.0, |o| self.pm.uniformity * o.own);
        let step: i64 = if forward { -1 } else { 1 };
        for yi in 0..nrows {
            let yi = if forward { yi } else { nrows - 1 - yi };
            let y = y0 + yi;
            for xi in 0..w {
                let x = if forward { xi } else { w - 1 - xi };
                if self.search.is_some_and(|m| !m.get(x, y)) {
                    continue;
                }
                let mut best = rows[yi * w + x];
                let mut best_total = if self.allowed(x, y, best.x as i64, best.y as i64) {
                    best.cost + self.penalty(best.x, best.y) - own
                } else {
                    f32::INFINITY
                };
                // Propagation from the neighbours already visited in this scan.
                let nx = x as i64 + step;
                if nx >= 0 && (nx as usize) < w {
                    let m = rows[yi * w + nx as usize];
                    self.try_candidate(x, y, m.x as i64 - step, m.y as i64, &mut best, &mut best_total);
                }
                let ny = y as i64 + step;
                if ny >= 0 && (ny as usize) < h {
                    let ny = ny as usize;
                    let m = if ny >= y0 && ny < y0 + nrows { rows[(ny - y0) * w + x] } else { snapshot[ny * w + x] };
                    self.try_candidate(x, y, m.x as i64, m.y as i64 - step, &mut best, &mut best_total);
                }
                // Random search around the best match, radius halving each time.
                let mut rad = self.radius_max as i64;
                while rad >= 1 {
                    let cx = best.x as i64 + rng::offset(&mut g, rad);
                    let cy = best.y as i64 + rng::offset(&mut g, rad);
                    let (cx, cy) = self.domain.clamp(cx, cy);
                    self.try_candidate(x, y, cx, cy, &mut best, &mut best_total);
                    rad /= 2;
                }
                if best_total.is_infinite() {
                    // Nothing allowed was found: draw a random allowed centre.
                    for _ in 0..64 {
                        let (cx, cy) = self.domain.random(&mut g);
                        if self.allowed(x, y, cx as i64, cy as i64) {
                            let r = self.pm.radius;
                            let cost =
                                self.pm.metric.patch_cost(self.target, x, y, self.source, cx as usize, cy as usize, r, f32::INFINITY);
                            best = Match { x: cx, y: cy, cost };
                            break;
                        }
                    }
                }
                rows[yi * w + x] = best;
            }
        }
    }
}

impl PatchMatch<'_> {
    /// The nearest `to` patch of every interior patch of `from` (whole
    /// images, patches of this run's radius), from a random field seeded
    /// by `init_seed` improved with `search_seed`; also the mask of
    /// `from`'s interior pixels, the only ones matched.
    pub fn nearest(&self, from: &Image, to: &Image, init_seed: u64, search_seed: u64) -> Result<(Nnf, Mask)> {
        let r = self.radius;
        let domain = SourceDomain::new(to.width(), to.height(), r, None)?;
        let interior = SourceDomain::new(from.width(), from.height(), r, None)?;
        let inside = Mask::from_fn(from.width(), from.height(), |x, y| interior.contains(x as i64, y as i64));
        let mut nnf = random_nnf(from.width(), from.height(), &domain, init_seed);
        self.improve(from, to, &domain, &mut nnf, Some(&inside), search_seed);
        Ok((nnf, inside))
    }

    /// Improve `nnf` (target -> source) in place. Only pixels set in
    /// `search` are updated (all when `None`). `seed` names this run.
    pub fn improve(&self, target: &Image, source: &Image, domain: &SourceDomain, nnf: &mut Nnf, search: Option<&Mask>, seed: u64) {
        assert_eq!((nnf.width(), nnf.height()), target.size(), "field and target sizes differ");
        assert_eq!(target.channels(), self.metric.channels(), "metric and target channels differ");
        assert_eq!(source.channels(), self.metric.channels(), "metric and source channels differ");
        let w = target.width();
        let r = self.radius;
        // Costs of the current matches against the current target.
        nnf.matches_mut().par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            let mut g = rng::generator(seed, &[u64::MAX, y as u64]);
            for (x, m) in row.iter_mut().enumerate() {
                if search.is_some_and(|s| !s.get(x, y)) {
                    continue;
                }
                if !domain.contains(m.x as i64, m.y as i64) {
                    let (sx, sy) = domain.random(&mut g);
                    (m.x, m.y) = (sx, sy);
                }
                m.cost = self.metric.patch_cost(target, x, y, source, m.x as usize, m.y as usize, r, f32::INFINITY);
            }
        });
        let radius_max = self.max_search_radius.unwrap_or(source.width().max(source.height())).max(1);
        for iteration in 0..self.iterations {
            let occupancy = (self.uniformity > 0.0).then(|| Occupancy::new(nnf, domain));
            let scan = Scan { pm: self, target, source, domain, search, occupancy, seed, iteration, radius_max };
            for parity in 0..2 {
                let snapshot = nnf.matches().to_vec();
                nnf.matches_mut()
                    .par_chunks_mut(BAND_ROWS * w)
                    .enumerate()
                    .filter(|(b, _)| b % 2 == parity)
                    .for_each(|(b, rows)| scan.band(b, rows, &snapshot));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::nnf::random_nnf;
    use super::*;

    fn texture(w: usize, h: usize) -> Image {
        Image::from_fn(w, h, 3, |x, y, p| {
            let v = ((x * 37 + y * 101) ^ (x * y + 7)) % 97;
            p.copy_from_slice(&[v as f32 / 97.0, ((v * 31) % 97) as f32 / 97.0, (x % 5) as f32 / 5.0]);
        })
    }

    #[test]
    fn finds_exact_copies_of_a_shifted_crop() {
        let source = texture(64, 48);
        let target = source.crop(10, 7, 40, 30).unwrap();
        let metric = PatchMetric::mean_ssd(3);
        let domain = SourceDomain::new(64, 48, 2, None).unwrap();
        let mut nnf = random_nnf(40, 30, &domain, 1);
        let pm = PatchMatch { radius: 2, iterations: 5, metric: &metric, uniformity: 0.0, max_search_radius: None, exclude_self: None };
        pm.improve(&target, &source, &domain, &mut nnf, None, 9);
        let mut exact = 0;
        for y in 2..28 {
            for x in 2..38 {
                let m = nnf.get(x, y);
                exact += (m.x as usize == x + 10 && m.y as usize == y + 7) as usize;
            }
        }
        assert!(exact as f32 > 0.99 * (26 * 36) as f32, "only {exact} exact matches");
    }

    #[test]
    fn respects_source_mask_and_self_exclusion() {
        let source = texture(48, 48);
        let allowed = Mask::from_fn(48, 48, |x, _| x < 24);
        let metric = PatchMetric::mean_ssd(3);
        let domain = SourceDomain::new(48, 48, 2, Some(&allowed)).unwrap();
        let mut nnf = random_nnf(48, 48, &domain, 3);
        let pm = PatchMatch { radius: 2, iterations: 3, metric: &metric, uniformity: 0.0, max_search_radius: None, exclude_self: Some(4) };
        pm.improve(&source, &source, &domain, &mut nnf, None, 4);
        for y in 0..48 {
            for x in 0..48 {
                let m = nnf.get(x, y);
                assert!(m.x as usize + 2 < 24, "patch at {} reaches the masked half", m.x);
                assert!((m.x as i64 - x as i64).abs() > 4 || (m.y as i64 - y as i64).abs() > 4);
            }
        }
    }
}
