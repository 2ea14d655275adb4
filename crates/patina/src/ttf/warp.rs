//! Time jitter (Enrique et al., eqs. 6 and 7): each pasted block reads its
//! source frames through its own monotone time warp, so copies of one source
//! block show their events at different times.
//!
//! f(0) = 0, f(t + 1) = f(t) + 1 + delta with delta uniform in [-1, 1];
//! delta is set to 0 wherever the step would leave the band
//! |f(t + 1) - (t + 1)| <= E. Steps are 1 + delta >= 0, so f never decreases.
//! f is also kept within the sequence (<= n - 1). Between the integer times
//! f is interpolated linearly, and a fractional source time blends its two
//! neighbouring frames.
//!
//! Seam-matched jitter ([`seam_matched`], not in the paper): a block whose
//! time is shifted shows a different stage of any change that spans its
//! seam, a colour jump against its neighbours. So each block draws several
//! warps and keeps the one whose overlap with the blocks already placed
//! differs least over time; copies of one block still get different warps,
//! and events inside a block (a spot that does not reach the seam) still
//! happen at different times.

use crate::image::Image;
use crate::rng::{self, Rng};
use crate::synth::QuiltPlan;
use rayon::prelude::*;

/// Warps drawn per block for [`seam_matched`].
const CANDIDATES: usize = 8;
/// Frames (evenly spaced) on which candidate warps are compared.
const PROBE_FRAMES: usize = 12;

/// One block's time warp: source time f(t) at the integer times 0..n.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeWarp(Vec<f32>);

impl TimeWarp {
    /// The identity warp over `n` frames.
    pub fn identity(n: usize) -> Self {
        TimeWarp((0..n).map(|t| t as f32).collect())
    }

    /// A random warp over `n` frames within `jitter` frames (E) of the
    /// identity, drawn from `seed`.
    pub fn jittered(n: usize, jitter: f32, seed: u64) -> Self {
        if jitter <= 0.0 || n == 0 {
            return TimeWarp::identity(n);
        }
        let mut g = rng::generator(seed, &[]);
        let last = (n - 1) as f32;
        let mut f = Vec::with_capacity(n);
        f.push(0.0f32);
        for t in 1..n {
            let prev = f[t - 1];
            let delta: f32 = g.gen_range(-1.0..=1.0);
            let mut next = prev + 1.0 + delta;
            if (next - t as f32).abs() > jitter {
                next = prev + 1.0;
            }
            f.push(next.min(last));
        }
        TimeWarp(f)
    }

    /// This warp applied in another clock: `pace[t]` is frame t's time on
    /// that clock (increasing from 0, within this warp's domain), and the
    /// result maps t to the frame whose clock time is f(pace[t]). Monotone
    /// and 0 at 0; where the clock runs at least one unit per frame, it
    /// stays as close to the identity as this warp does.
    pub fn through(&self, pace: &[f32]) -> TimeWarp {
        let last = pace.len().saturating_sub(1);
        let inverse = |v: f32| -> f32 {
            // The first frame whose clock time reaches v, interpolated.
            let i = pace.partition_point(|&p| p < v).min(last);
            if i == 0 {
                return 0.0;
            }
            let (a, b) = (pace[i - 1], pace[i]);
            (i - 1) as f32 + if b > a { ((v - a) / (b - a)).clamp(0.0, 1.0) } else { 1.0 }
        };
        TimeWarp(pace.iter().map(|&p| inverse(self.at(p))).collect())
    }

    /// f at the integer times.
    pub fn samples(&self) -> &[f32] {
        &self.0
    }

    /// f(s) for a real s in [0, n - 1] (clamped), interpolated linearly.
    pub fn at(&self, s: f32) -> f32 {
        let last = self.0.len() - 1;
        let s = s.clamp(0.0, last as f32);
        let i = (s as usize).min(last);
        let j = (i + 1).min(last);
        let w = s - i as f32;
        self.0[i] + w * (self.0[j] - self.0[i])
    }
}

/// One warp per placement of `plan` (in plan order) within `jitter` frames
/// of the identity on the clock `pace` ([`TimeWarp::through`]; the
/// identity clock `0..n` gives the paper's warps) over the `frames`' time: of [`CANDIDATES`] random
/// warps, the one whose pixels in the overlap with the blocks placed before
/// it (its whole rectangle where they show, on both sides of the cut) are
/// closest (squared difference summed over [`PROBE_FRAMES`] frames)
/// to what those blocks show there at their own warped times.
pub fn seam_matched(plan: &QuiltPlan, frames: &[Image], jitter: f32, pace: &[f32], seed: u64) -> Vec<TimeWarp> {
    let n = frames.len();
    if jitter <= 0.0 || n < 2 {
        return vec![TimeWarp::identity(n); plan.placements.len()];
    }
    let (w, h) = (plan.width, plan.height);
    let (bw, bh) = plan.block;
    let c = frames[0].channels();
    let domain = pace.last().map_or(n, |&p| p.ceil() as usize + 1);
    let probes: Vec<f32> = (0..PROBE_FRAMES).map(|k| (k * (n - 1)) as f32 / (PROBE_FRAMES - 1) as f32).collect();
    let mut owner = vec![u32::MAX; w * h];
    let mut warps: Vec<TimeWarp> = Vec::with_capacity(plan.placements.len());
    let mut mine = Vec::new();
    let mut theirs = Vec::new();
    let mut value = vec![0f32; c];
    for (i, p) in plan.placements.iter().enumerate() {
        // The overlap: this block's source pixel and what the earlier
        // blocks show there at every probe time.
        mine.clear();
        theirs.clear();
        for y in 0..bh.min(h.saturating_sub(p.y)) {
            for x in 0..bw.min(w.saturating_sub(p.x)) {
                let j = owner[(p.y + y) * w + p.x + x];
                if j == u32::MAX {
                    continue;
                }
                let q = &plan.placements[j as usize];
                let (qx, qy) = (q.source_x + p.x + x - q.x, q.source_y + p.y + y - q.y);
                mine.push((p.source_x + x, p.source_y + y));
                for &t in &probes {
                    super::sample(frames, qx, qy, warps[j as usize].at(t), &mut value);
                    theirs.extend_from_slice(&value);
                }
            }
        }
        let candidate = |k: usize| TimeWarp::jittered(domain, jitter, rng::derive(seed, &[i as u64, k as u64])).through(pace);
        let best = if mine.is_empty() {
            0
        } else {
            let costs: Vec<f64> = (0..CANDIDATES)
                .into_par_iter()
                .map(|k| {
                    let warp = candidate(k);
                    let times: Vec<f32> = probes.iter().map(|&t| warp.at(t)).collect();
                    let mut v = vec![0f32; c];
                    let mut cost = 0f64;
                    for (&(sx, sy), want) in mine.iter().zip(theirs.chunks_exact(c * probes.len())) {
                        for (&tau, want) in times.iter().zip(want.chunks_exact(c)) {
                            super::sample(frames, sx, sy, tau, &mut v);
                            cost += v.iter().zip(want).map(|(a, b)| f64::from(a - b).powi(2)).sum::<f64>();
                        }
                    }
                    cost
                })
                .collect();
            (0..CANDIDATES).min_by(|&a, &b| costs[a].total_cmp(&costs[b]).then(a.cmp(&b))).unwrap_or(0)
        };
        warps.push(candidate(best));
        for y in 0..bh.min(h.saturating_sub(p.y)) {
            for x in 0..bw.min(w.saturating_sub(p.x)) {
                if p.keep[y * bw + x] >= 0.5 {
                    owner[(p.y + y) * w + p.x + x] = i as u32;
                }
            }
        }
    }
    warps
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warp_is_monotone_stays_in_its_band_and_moves() {
        for (seed, e) in [(1u64, 3.0f32), (2, 0.5), (3, 8.0)] {
            let w = TimeWarp::jittered(80, e, seed);
            let f = w.samples();
            assert_eq!(f[0], 0.0);
            assert!(f.windows(2).all(|p| p[1] >= p[0]), "monotone");
            assert!(f.iter().enumerate().all(|(t, v)| (v - t as f32).abs() <= e + 1e-5), "band");
            assert!(f.iter().all(|&v| v <= 79.0));
            assert!(f.iter().enumerate().any(|(t, v)| (v - t as f32).abs() > 0.05 * e), "jitter {e} did nothing");
        }
        assert_eq!(TimeWarp::jittered(10, 0.0, 4), TimeWarp::identity(10));
    }

    #[test]
    fn a_warp_through_a_clock_keeps_fast_stretches_nearly_in_step() {
        let w = TimeWarp::jittered(200, 6.0, 5);
        let identity: Vec<f32> = (0..80).map(|t| t as f32).collect();
        // On the identity clock the warp is itself (clamped to the last frame).
        let same: Vec<f32> = w.samples()[..80].iter().map(|v| v.min(79.0)).collect();
        assert_eq!(w.through(&identity).samples(), same.as_slice());
        // The steps into frames 40, 41 and 42 change 30x faster than the rest,
        // so frames 40 and 41, inside that stretch, barely move.
        let mut clock = vec![0f32; 80];
        for t in 1..80 {
            clock[t] = clock[t - 1] + if (40..43).contains(&t) { 30.0 } else { 1.0 };
        }
        let f = w.through(&clock);
        let s = f.samples();
        assert!(s.windows(2).all(|p| p[1] >= p[0]), "monotone");
        assert!(s.iter().enumerate().all(|(t, v)| (v - t as f32).abs() <= 6.0 + 1e-4), "band in frames");
        for (t, v) in s.iter().enumerate().take(42).skip(40) {
            assert!((v - t as f32).abs() <= 6.0 / 30.0 + 1e-3, "frame {t} moved to {v}");
        }
    }
}
