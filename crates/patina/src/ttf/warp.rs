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

use crate::rng::{self, Rng};

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
}
