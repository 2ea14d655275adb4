//! How two patches are compared: a [`PatchMetric`] splits the channels into
//! groups, each with its own distance. The default is weighted SSD; other
//! modules plug their own per-texel distance in through [`TexelDistance`]
//! (the spatio-temporal BRDF's closed-form polynomial distance, say).
//!
//! Cost unit: the sum over the patch's texels of the per-texel group costs.
//! The search stops summing as soon as a cost exceeds the best one found so
//! far (`bound`), so a rejected candidate usually costs only a few rows.

use crate::image::Image;
use std::ops::Range;
use std::sync::Arc;

/// A distance between one texel's values of one channel group, in target
/// patch `a` and source patch `b`. Must be >= 0 and 0 for equal inputs.
pub trait TexelDistance: Send + Sync {
    fn cost(&self, a: &[f32], b: &[f32]) -> f32;
}

/// The distance used for one channel group.
#[derive(Clone)]
pub enum GroupDistance {
    /// sum_c w_c (a_c - b_c)^2 with one weight per channel of the group.
    WeightedSsd(Vec<f32>),
    /// `weight` x a distance supplied by the caller.
    Custom { weight: f32, distance: Arc<dyn TexelDistance> },
}

impl std::fmt::Debug for GroupDistance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GroupDistance::WeightedSsd(w) => write!(f, "WeightedSsd({w:?})"),
            GroupDistance::Custom { weight, .. } => write!(f, "Custom {{ weight: {weight} }}"),
        }
    }
}

#[derive(Clone, Debug)]
struct Group {
    channels: Range<usize>,
    distance: GroupDistance,
}

/// Widest patch the metric supports (side in pixels).
pub const MAX_PATCH: usize = 129;

/// The patch distance over all channels of an image, group by group.
#[derive(Clone, Debug)]
pub struct PatchMetric {
    channels: usize,
    groups: Vec<Group>,
    /// When every group is weighted SSD: per-channel weights repeated across
    /// a patch row, so a row is one multiply-add loop (the fast path).
    ssd_row: Option<Vec<f32>>,
}

impl PatchMetric {
    /// Weighted SSD over all channels, one weight per channel.
    pub fn ssd(weights: Vec<f32>) -> Self {
        let n = weights.len();
        PatchMetric::from_groups(n, vec![(0..n, GroupDistance::WeightedSsd(weights))])
    }

    /// SSD where every channel weighs 1 / channels (the mean over channels).
    pub fn mean_ssd(channels: usize) -> Self {
        PatchMetric::ssd(vec![1.0 / channels as f32; channels])
    }

    /// A metric from explicit groups. Groups must tile 0..channels in order;
    /// panics otherwise (a programming error, not user input).
    pub fn from_groups(channels: usize, groups: Vec<(Range<usize>, GroupDistance)>) -> Self {
        let mut next = 0;
        for (r, d) in &groups {
            assert_eq!(r.start, next, "metric groups must tile the channels in order");
            if let GroupDistance::WeightedSsd(w) = d {
                assert_eq!(w.len(), r.len(), "one SSD weight per channel");
            }
            next = r.end;
        }
        assert_eq!(next, channels, "metric groups must cover every channel");
        let groups: Vec<Group> = groups.into_iter().map(|(channels, distance)| Group { channels, distance }).collect();
        let ssd_row = groups
            .iter()
            .map(|g| match &g.distance {
                GroupDistance::WeightedSsd(w) => Some(w.clone()),
                GroupDistance::Custom { .. } => None,
            })
            .collect::<Option<Vec<Vec<f32>>>>()
            .map(|ws| ws.concat().repeat(MAX_PATCH));
        PatchMetric { channels, groups, ssd_row }
    }

    /// This metric followed by `other` over the next channels.
    pub fn then(&self, other: &PatchMetric) -> PatchMetric {
        let shift = self.channels;
        let mut groups: Vec<(Range<usize>, GroupDistance)> = self.groups.iter().map(|g| (g.channels.clone(), g.distance.clone())).collect();
        groups.extend(other.groups.iter().map(|g| (g.channels.start + shift..g.channels.end + shift, g.distance.clone())));
        PatchMetric::from_groups(self.channels + other.channels, groups)
    }

    /// The same metric with every weight multiplied by `s`.
    pub fn scaled(&self, s: f32) -> PatchMetric {
        let groups = self
            .groups
            .iter()
            .map(|g| {
                let d = match &g.distance {
                    GroupDistance::WeightedSsd(w) => GroupDistance::WeightedSsd(w.iter().map(|v| v * s).collect()),
                    GroupDistance::Custom { weight, distance } => GroupDistance::Custom { weight: weight * s, distance: distance.clone() },
                };
                (g.channels.clone(), d)
            })
            .collect();
        PatchMetric::from_groups(self.channels, groups)
    }

    /// Per-channel weights when every group is weighted SSD.
    pub fn ssd_weights(&self) -> Option<Vec<f32>> {
        self.ssd_row.as_ref().map(|row| row[..self.channels].to_vec())
    }

    /// Number of channels the metric reads.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Cost of one texel pair (all groups).
    pub fn texel_cost(&self, a: &[f32], b: &[f32]) -> f32 {
        let mut sum = 0.0;
        for g in &self.groups {
            let (ga, gb) = (&a[g.channels.clone()], &b[g.channels.clone()]);
            sum += match &g.distance {
                GroupDistance::WeightedSsd(w) => weighted_ssd(ga, gb, w),
                GroupDistance::Custom { weight, distance } => weight * distance.cost(ga, gb),
            };
        }
        sum
    }

    /// Cost between the target patch centred at (tx, ty) and the source patch
    /// centred at (sx, sy), both of radius `r`. The target patch is clipped to
    /// the target's bounds; the source patch must lie inside the source.
    /// Returns early with a value above `bound` once the sum exceeds it.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn patch_cost(&self, target: &Image, tx: usize, ty: usize, source: &Image, sx: usize, sy: usize, r: usize, bound: f32) -> f32 {
        debug_assert!(sx >= r && sy >= r && sx + r < source.width() && sy + r < source.height());
        let n = self.channels;
        let (tw, th, sw) = (target.width(), target.height(), source.width());
        let (left, right) = (r.min(tx), r.min(tw - 1 - tx));
        let (up, down) = (r.min(ty), r.min(th - 1 - ty));
        let len = (left + right + 1) * n;
        let (td, sd) = (target.data(), source.data());
        let mut acc = 0.0;
        for dy in 0..up + down + 1 {
            let trow_y = ty - up + dy;
            let srow_y = sy - up + dy;
            let t0 = (trow_y * tw + tx - left) * n;
            let s0 = (srow_y * sw + sx - left) * n;
            let (ta, sa) = (&td[t0..t0 + len], &sd[s0..s0 + len]);
            acc += match &self.ssd_row {
                Some(w) => weighted_ssd(ta, sa, &w[..len]),
                None => ta.chunks_exact(n).zip(sa.chunks_exact(n)).map(|(a, b)| self.texel_cost(a, b)).sum(),
            };
            if acc > bound {
                return acc;
            }
        }
        acc
    }
}

/// sum_i w_i (a_i - b_i)^2, in four lanes (one SSE register) so the
/// compiler vectorises it; rows whose length is a multiple of 4 (see
/// [`pad_for_search`]) have no scalar tail. The summation order is fixed,
/// so results do not depend on threads.
#[inline]
pub fn weighted_ssd(a: &[f32], b: &[f32], w: &[f32]) -> f32 {
    let mut lanes = [0f32; 4];
    let (ca, cb, cw) = (a.chunks_exact(4), b.chunks_exact(4), w.chunks_exact(4));
    let (ra, rb, rw) = (ca.remainder(), cb.remainder(), cw.remainder());
    for ((x, y), z) in ca.zip(cb).zip(cw) {
        for i in 0..4 {
            let d = x[i] - y[i];
            lanes[i] += z[i] * d * d;
        }
    }
    let mut tail = 0.0;
    for ((x, y), z) in ra.iter().zip(rb).zip(rw) {
        let d = x - y;
        tail += z * d * d;
    }
    lanes.iter().sum::<f32>() + tail
}

/// Channels to add so a pixel is a whole number of SIMD lanes.
pub fn search_padding(channels: usize) -> usize {
    (4 - channels % 4) % 4
}

/// `img` with [`search_padding`] zero channels appended, and `metric` with
/// zero-weight SSD over them: the same costs, computed faster.
pub fn pad_for_search(img: &Image, metric: &PatchMetric) -> (Image, PatchMetric) {
    let pad = search_padding(img.channels());
    if pad == 0 {
        return (img.clone(), metric.clone());
    }
    let zeros = Image::new(img.width(), img.height(), pad);
    let padded = Image::concat_channels(&[img, &zeros]).expect("same size");
    (padded, metric.then(&PatchMetric::ssd(vec![0.0; pad])))
}

#[cfg(test)]
mod tests {
    use super::*;

    struct AbsDiff;
    impl TexelDistance for AbsDiff {
        fn cost(&self, a: &[f32], b: &[f32]) -> f32 {
            a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum()
        }
    }

    fn img(seed: usize) -> Image {
        Image::from_fn(12, 10, 3, |x, y, p| {
            for (c, v) in p.iter_mut().enumerate() {
                *v = ((x * 7 + y * 11 + c * 5 + seed * 3) % 13) as f32 / 13.0;
            }
        })
    }

    fn naive(t: &Image, tx: usize, ty: usize, s: &Image, sx: usize, sy: usize, r: isize, f: impl Fn(&[f32], &[f32]) -> f32) -> f32 {
        let mut sum = 0.0;
        for dy in -r..=r {
            for dx in -r..=r {
                let (x, y) = (tx as isize + dx, ty as isize + dy);
                if x < 0 || y < 0 || x >= t.width() as isize || y >= t.height() as isize {
                    continue;
                }
                sum += f(t.pixel(x as usize, y as usize), s.pixel((sx as isize + dx) as usize, (sy as isize + dy) as usize));
            }
        }
        sum
    }

    #[test]
    fn fast_and_custom_paths_match_a_naive_sum_including_clipped_patches() {
        let (t, s) = (img(0), img(5));
        let ssd = PatchMetric::ssd(vec![0.5, 1.0, 2.0]);
        let custom = PatchMetric::from_groups(
            3,
            vec![(0..1, GroupDistance::WeightedSsd(vec![0.5])), (1..3, GroupDistance::Custom { weight: 2.0, distance: Arc::new(AbsDiff) })],
        );
        for (tx, ty) in [(0, 0), (5, 5), (11, 9), (1, 8)] {
            let want =
                naive(&t, tx, ty, &s, 4, 5, 2, |a, b| 0.5 * (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + 2.0 * (a[2] - b[2]).powi(2));
            let got = ssd.patch_cost(&t, tx, ty, &s, 4, 5, 2, f32::INFINITY);
            assert!((want - got).abs() < 1e-4, "{want} vs {got}");
            let want =
                naive(&t, tx, ty, &s, 4, 5, 2, |a, b| 0.5 * (a[0] - b[0]).powi(2) + 2.0 * ((a[1] - b[1]).abs() + (a[2] - b[2]).abs()));
            let got = custom.patch_cost(&t, tx, ty, &s, 4, 5, 2, f32::INFINITY);
            assert!((want - got).abs() < 1e-4, "{want} vs {got}");
        }
        // Early exit returns something above the bound, never below the truth.
        let full = ssd.patch_cost(&t, 5, 5, &s, 4, 5, 2, f32::INFINITY);
        let cut = ssd.patch_cost(&t, 5, 5, &s, 4, 5, 2, 0.01);
        assert!(cut > 0.01 && cut <= full);
    }
}
