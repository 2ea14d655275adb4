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
//! Seam-aligned jitter ([`seam_aligned`], not in the paper): a block whose
//! time is shifted shows a different stage of any change that spans its
//! seam, a colour jump against its neighbours. So each block's warp is
//! chosen frame by frame, by dynamic programming over the eq. 6-7 steps,
//! to follow its own random warp wherever that is invisible and to fall
//! into step with its neighbours wherever a change crosses its seam.
//! Copies of one block still get different warps, and events inside a
//! block (a spot that does not reach the seam) still happen at different
//! times. Each change of a block's offset holds or skips one of its
//! frames, so changes are kept apart: a run of them is a freeze or a
//! jump, and a block ahead of time gives its lead back before the last
//! frame instead of stopping on it.

use crate::image::Image;
use crate::rng::{self, Rng};
use crate::synth::QuiltPlan;
use rayon::prelude::*;

/// One pixel of a block's overlap: its source pixel, the earlier block
/// shown there and that block's source pixel.
type OverlapPixel = ((usize, usize), usize, (usize, usize));

/// Side of the cells whose mean colours [`seam_aligned`] compares: a
/// colour jump between blocks is a difference of local means, while the
/// blocks' different textures mostly average out in them.
const CELL: usize = 4;
/// A mean colour difference per channel at which a time offset's mismatch
/// costs as much as the largest departure from the block's own random warp
/// (a just-noticeable step is 1-2% of the range; cell means of two
/// different textures differ by a few percent at any offset). At 0.02
/// clay_solidifying's copies fell into lockstep (near-verbatim repeated
/// share 0.086 in the middle frame, against 0.045 at 0.04); at 0.08
/// rusting_steel's early blocks kept colour jumps.
const VISIBLE_STEP: f32 = 0.04;
/// Cost per frame of showing the same frame as an earlier copy of the
/// block's source (weighted by the share of the source they have in
/// common): copies of one block get different event times (issue 17,
/// item 3). On a vignetted rust sequence (96 -> 192 px, 24 frames, seeds
/// 3-6) the middle frame's near-verbatim repeated share was 0.043-0.110
/// without it and 0.050-0.073 at 1.
const COPY_COST: f32 = 1.0;
/// Cost of each change of a block's offset: each is a held or a doubled
/// frame, so frequent changes make blocks stutter (regions frozen for a
/// frame while others move). On growing_sprouts (frames 30-60) the share
/// of output pixels frozen between frames was 5.3% without it, 4.8% at 1,
/// 3.4% at 2 and 1.4% at 10; but from 3 up a block no longer falls into
/// step with a neighbour for a 5-frame colour change (the unit test), and
/// at 2 the vignetted test's large-scale variation went just over its bound.
const CHANGE_COST: f32 = 1.0;
/// Added to [`CHANGE_COST`], times the block's own change over one frame
/// where the change happens (the mean colours of its overlap cells, in
/// the seam mismatch's units): a held or doubled frame shows as a stutter
/// as large as that change. With the seam mismatch alone, a block of
/// growing_sprouts (2x, seed 1) changed its offset, holding or skipping a
/// frame, at 60% of frames (held 0.32, skipped 0.28 of the output's area
/// per frame) while leaves grew across every seam, and a reviewer saw the
/// leaves move "in jerky chunks" that took turns; at 4 it is 0.13 / 0.09
/// (rusting_steel 0.16 / 0.15 -> 0.09 / 0.09, copper 0.08 / 0.05 -> 0.06 /
/// 0.04), and the output's frame-to-frame change is 0.95x the input's
/// instead of 0.77x (examples/ttf_quality, 34 frames). At 16 (0.06 /
/// 0.03) copies fell into lockstep: the vignetted test's near-verbatim
/// share rose to 0.107 (bound 0.08).
const HOLD_COST: f32 = 4.0;
/// Near either end of the sequence a block's offset is at most one frame
/// per this many frames from the end: a block ahead of the output's time
/// gives its lead back before the last frame, and one behind falls back
/// from frame 0, one held frame at a time this far apart. Bounded only by
/// the sequence, a block up to E frames ahead had to hold a frame at every
/// one of the last E frames, a freeze at the end (clay_solidifying and
/// copper_patinating, 2x, seed 1: 55-63% of blocks had a run of 3 or more
/// held frames, up to 9-11; 7-13% of 32 px tiles were frozen from frame to
/// frame in the last 10 frames, against 0.3-2% in the middle), and its
/// random warp, clamped to the last frame, asked for it. Each block's
/// ramp steps at its own phase: stepping together, the blocks near their
/// bound held a frame together every fourth frame, a hitch over up to 27%
/// of the frame that a blind review saw at the ends of clay and copper.
const END_RAMP: usize = 4;
/// A change of a block's offset within this many frames of its last one
/// costs [`SPACING_COST`] more: two held frames in a row are a freeze, a
/// hold and a skip a jerk.
const SPACING: usize = 3;
/// See [`SPACING`].
const SPACING_COST: f32 = 8.0;

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

    /// The frame shown at output frame t (f(t) rounded, within the warp).
    fn shown(&self, t: usize) -> usize {
        self.at(t as f32).round() as usize
    }

    /// The warp t + d(t) over `n` frames with whole offsets |d| <= `band`,
    /// d(0) = 0 and steps of d in {-1, 0, 1}, minimising the sum over t of
    /// `cost(t, d(t) + band)`, plus `change(t, d(t) + band)` at every t
    /// where d changes, plus [`SPACING_COST`] for a change less than
    /// [`SPACING`] frames after the one before (dynamic programming over
    /// the offsets and the frames since the last change, capped at
    /// SPACING).
    fn viterbi(n: usize, band: usize, cost: impl Fn(usize, usize) -> f32, change: impl Fn(usize, usize) -> f32) -> TimeWarp {
        let offsets = 2 * band + 1;
        let memory = SPACING + 1;
        let states = offsets * memory;
        let at = |s: usize, r: usize| s * memory + r;
        let mut total = vec![f32::INFINITY; states];
        total[at(band, SPACING)] = cost(0, band);
        let mut from = vec![0u16; n * states];
        let mut next = vec![f32::INFINITY; states];
        for t in 1..n {
            for s in 0..offsets {
                let c = cost(t, s);
                // Kept: one frame longer since the last change.
                for r in 1..memory {
                    let (mut best, mut arg) = (total[at(s, r - 1)], at(s, r - 1));
                    if r == SPACING && total[at(s, r)] < best {
                        (best, arg) = (total[at(s, r)], at(s, r));
                    }
                    next[at(s, r)] = best + c;
                    from[t * states + at(s, r)] = arg as u16;
                }
                // Changed, from a neighbouring offset.
                let (mut best, mut arg) = (f32::INFINITY, at(s, 0));
                for q in s.saturating_sub(1)..(s + 2).min(offsets) {
                    if q == s {
                        continue;
                    }
                    for r in 0..memory {
                        let v = total[at(q, r)] + if r < SPACING { SPACING_COST } else { 0.0 };
                        if v < best {
                            (best, arg) = (v, at(q, r));
                        }
                    }
                }
                next[at(s, 0)] = best + change(t, s) + c;
                from[t * states + at(s, 0)] = arg as u16;
            }
            std::mem::swap(&mut total, &mut next);
        }
        let mut k = (0..states)
            .min_by(|&a, &b| total[a].total_cmp(&total[b]).then((a / memory).abs_diff(band).cmp(&(b / memory).abs_diff(band))))
            .unwrap_or(at(band, SPACING));
        let mut f = vec![0f32; n];
        for t in (0..n).rev() {
            f[t] = (t as f32 + (k / memory) as f32 - band as f32).max(0.0);
            k = from[t * states + k] as usize;
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

/// Which time offsets keep a block's colour: entry t * (2 band + 1) + d +
/// band says whether frame t + d exists and showing it at output frame t
/// changes the frames' block-sized cell means by at most [`VISIBLE_STEP`]
/// (the mean over cells of their RMS change over channels). Where the
/// whole surface changes colour fast (copper_patinating's first frames),
/// a block drawn a few frames off shows another colour than its
/// neighbours, a patchwork of times; the seam alignment alone let blocks
/// sit the full E frames off there, since its colour cost is relative to
/// the best offset at each frame and neighbours can lag together. Events
/// smaller than a block (a spot appearing) barely move a cell's mean, so
/// their times stay free.
/// Tried first: eq. 7's band on the pace clock, which also tied the times
/// of a sequence whose few events are its only change.
fn colour_keeping_offsets(frames: &[Image], (bw, bh): (usize, usize), band: usize) -> Vec<bool> {
    let n = frames.len();
    let (w, h) = frames[0].size();
    let c = frames[0].channels();
    let (cw, ch) = (w.div_ceil(bw), h.div_ceil(bh));
    let means: Vec<Vec<f32>> = frames
        .par_iter()
        .map(|f| {
            let mut m = vec![0f32; cw * ch * c];
            let mut k = vec![0f32; cw * ch];
            for y in 0..h {
                for x in 0..w {
                    let i = (y / bh) * cw + x / bw;
                    k[i] += 1.0;
                    m[i * c..][..c].iter_mut().zip(f.pixel(x, y)).for_each(|(s, v)| *s += v);
                }
            }
            m.chunks_exact_mut(c).zip(&k).for_each(|(m, k)| m.iter_mut().for_each(|v| *v /= k));
            m
        })
        .collect();
    let states = 2 * band + 1;
    (0..n * states)
        .into_par_iter()
        .map(|i| {
            let (t, u) = (i / states, (i / states + i % states) as isize - band as isize);
            let Some(other) = usize::try_from(u).ok().and_then(|u| means.get(u)) else { return false };
            let step: f32 = means[t]
                .chunks_exact(c)
                .zip(other.chunks_exact(c))
                .map(|(a, b)| (a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f32>() / c as f32).sqrt())
                .sum();
            step / (cw * ch) as f32 <= VISIBLE_STEP
        })
        .collect()
}

/// One warp per placement of `plan` (in plan order), within `jitter`
/// frames of the identity over the `frames`' time.
///
/// Each block draws a random warp (eqs. 6-7) on the clock `pace`
/// ([`TimeWarp::through`]; the identity clock `0..n` gives the paper's
/// warps). Its actual warp f(t) = t + d(t) keeps eq. 6's steps (d changes
/// by -1, 0 or +1 per frame, so f never decreases and steps are 0-2
/// frames), eq. 7's band |d| <= E, and f(0) = 0, and minimises over all
/// frames, by dynamic programming,
///
///   sum_t  ||m(t + d(t)) - n(t)||^2 / (cells VISIBLE_STEP^2) + |d(t) - d*(t)| / E,
///
/// plus [`COPY_COST`] for showing the same frame as an earlier copy of the
/// same source and [`CHANGE_COST`] + [`HOLD_COST`] x the block's own
/// change over one frame there per change of d ([`SPACING_COST`] more
/// within [`SPACING`] frames of the last change; near either end |d| is
/// at most one per [`END_RAMP`] frames to it), where m and n are the
/// mean colours, per [`CELL`]-pixel cell of the block's rectangle where
/// earlier blocks show (on both sides of the cut),
/// of this block and of what those blocks show there at their own warped
/// times, taken relative to the best offset at t; and d* is the random
/// warp's offset. Where nothing changes across the seam every offset
/// matches and the block keeps its own timing; where a spot grows across
/// it, the block falls into step. Offsets that would change the colour of
/// the whole frame visibly (block-sized cell means moving by over
/// VISIBLE_STEP, 4%, on average) are not allowed at all. Offsets are whole
/// frames, as rendering rounds jittered times (so the choice is made on
/// what is shown).
pub fn seam_aligned(plan: &QuiltPlan, frames: &[Image], jitter: f32, pace: &[f32], seed: u64) -> Vec<TimeWarp> {
    let n = frames.len();
    let band = jitter.round() as usize;
    if band == 0 || n < 2 {
        return vec![TimeWarp::identity(n); plan.placements.len()];
    }
    let (w, h) = (plan.width, plan.height);
    let (bw, bh) = plan.block;
    let c = frames[0].channels();
    let domain = pace.last().map_or(n, |&p| p.ceil() as usize + 1);
    let states = 2 * band + 1;
    let keeps_colour = colour_keeping_offsets(frames, (bw, bh), band);
    let mut owner = vec![u32::MAX; w * h];
    let mut warps: Vec<TimeWarp> = Vec::with_capacity(plan.placements.len());
    for (i, p) in plan.placements.iter().enumerate() {
        let target = TimeWarp::jittered(domain, jitter, rng::derive(seed, &[i as u64])).through(pace);
        // Where the block's end ramp steps (see END_RAMP): its own phase,
        // so blocks do not hold their frames on the same beat.
        let phase = (rng::derive(seed, &[i as u64, 1]) % END_RAMP as u64) as usize;
        // Per cell of the overlap, the mean colour of this block at every
        // frame and of the earlier blocks as they are shown at every frame.
        let (cw, ch) = (bw.min(w.saturating_sub(p.x)), bh.min(h.saturating_sub(p.y)));
        let cells: Vec<Vec<OverlapPixel>> = (0..ch.div_ceil(CELL) * cw.div_ceil(CELL))
            .map(|k| {
                let (cx, cy) = (k % cw.div_ceil(CELL) * CELL, k / cw.div_ceil(CELL) * CELL);
                let mut pixels = Vec::new();
                for y in cy..(cy + CELL).min(ch) {
                    for x in cx..(cx + CELL).min(cw) {
                        let j = owner[(p.y + y) * w + p.x + x];
                        if j != u32::MAX {
                            let q = &plan.placements[j as usize];
                            pixels.push((
                                (p.source_x + x, p.source_y + y),
                                j as usize,
                                (q.source_x + p.x + x - q.x, q.source_y + p.y + y - q.y),
                            ));
                        }
                    }
                }
                pixels
            })
            .filter(|px| !px.is_empty())
            .collect();
        // The cost of offset d (state s = d + band) at t for leaving the
        // block's own random warp; offsets that change the colour are out.
        let own = |t: usize, s: usize| {
            let d = s as isize - band as isize;
            if keeps_colour[t * states + s] && -d <= ((t + phase) / END_RAMP) as isize && d <= ((n - 1 - t + phase) / END_RAMP) as isize {
                (d as f32 - (target.at(t as f32) - t as f32)).abs() / band as f32
            } else {
                f32::INFINITY
            }
        };
        let warp = if cells.is_empty() {
            // Nothing to keep step with: the block's own warp (made, like
            // every block's, with the change cost).
            TimeWarp::viterbi(n, band, own, |_, _| CHANGE_COST)
        } else {
            let means = |theirs: bool| -> Vec<f32> {
                // [cell][frame][channel]
                let mut out = vec![0f32; cells.len() * n * c];
                out.par_chunks_mut(n * c).zip(&cells).for_each(|(out, px)| {
                    let k = 1.0 / px.len() as f32;
                    for (t, sum) in out.chunks_exact_mut(c).enumerate() {
                        for &(mine, j, other) in px {
                            let v =
                                if theirs { frames[warps[j].shown(t)].pixel(other.0, other.1) } else { frames[t].pixel(mine.0, mine.1) };
                            sum.iter_mut().zip(v).for_each(|(s, v)| *s += k * v);
                        }
                    }
                });
                out
            };
            let (mine, theirs) = (means(false), means(true));
            let norm = 1.0 / (cells.len() as f32 * c as f32 * VISIBLE_STEP * VISIBLE_STEP);
            // Mismatch of offset d (state d + band) at frame t, relative to
            // the best offset at t.
            let mut mismatch = vec![0f32; n * states];
            mismatch.par_chunks_mut(states).enumerate().for_each(|(t, costs)| {
                for (s, e) in costs.iter_mut().enumerate() {
                    let tau = t as isize + s as isize - band as isize;
                    *e = if tau < 0 || tau >= n as isize {
                        f32::INFINITY
                    } else {
                        let mut e = 0f32;
                        for cell in 0..cells.len() {
                            let a = &mine[(cell * n + tau as usize) * c..][..c];
                            let b = &theirs[(cell * n + t) * c..][..c];
                            e += a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f32>();
                        }
                        e * norm
                    };
                }
                let best = costs.iter().copied().fold(f32::INFINITY, f32::min);
                costs.iter_mut().for_each(|e| *e -= best);
            });
            // Earlier copies of (much of) this block's source, with the share
            // of it they hold: showing the same frame as one of them makes a
            // near-verbatim repeat.
            let copies: Vec<(usize, f32)> = plan.placements[..i]
                .iter()
                .enumerate()
                .filter_map(|(j, q)| {
                    let ox = (bw as isize - (q.source_x as isize - p.source_x as isize).abs()).max(0) as f32;
                    let oy = (bh as isize - (q.source_y as isize - p.source_y as isize).abs()).max(0) as f32;
                    let share = ox * oy / (bw * bh) as f32;
                    (share > 0.25).then_some((j, share))
                })
                .collect();
            let unary = |t: usize, s: usize| {
                let shown = t as isize + s as isize - band as isize;
                let same: f32 = copies.iter().filter(|(j, _)| warps[*j].shown(t) as isize == shown).map(|(_, share)| share).sum();
                mismatch[t * states + s] + own(t, s) + COPY_COST * same
            };
            // A change of offset holds or skips a frame of the block: as
            // visible as the block's own change over one frame there.
            let motion: Vec<f32> = (0..n)
                .map(|u| {
                    let v = u.max(1);
                    let mut e = 0f32;
                    for cell in 0..cells.len() {
                        let a = &mine[(cell * n + v) * c..][..c];
                        let b = &mine[(cell * n + v - 1) * c..][..c];
                        e += a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f32>();
                    }
                    e * norm
                })
                .collect();
            let change = |t: usize, s: usize| {
                let shown = (t + s).saturating_sub(band).min(n - 1);
                CHANGE_COST + HOLD_COST * motion[shown]
            };
            TimeWarp::viterbi(n, band, unary, change)
        };
        warps.push(warp);
        for y in 0..ch {
            for x in 0..cw {
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
    fn a_block_keeps_step_with_its_neighbour_only_while_a_change_crosses_their_seam() {
        // A static texture whose colour shifts from 0.3 to 0.7 over frames
        // 25-30, and two copies of one source block side by side.
        let n = 60;
        let level = |t: usize| 0.3 + 0.4 * ((t as f32 - 25.0) / 5.0).clamp(0.0, 1.0);
        let frames: Vec<Image> = (0..n)
            .map(|t| {
                let mut f = Image::new(32, 32, 3);
                for (k, v) in f.data_mut().iter_mut().enumerate() {
                    *v = level(t) + 0.05 * ((k * 7919 % 97) as f32 / 97.0);
                }
                f
            })
            .collect();
        let keep: Vec<f32> = (0..32 * 32).map(|k| if k % 32 < 8 { 0.0 } else { 1.0 }).collect();
        let plan = QuiltPlan {
            width: 48,
            height: 32,
            source_size: (32, 32),
            block: (32, 32),
            overlap: (16, 32),
            placements: vec![
                crate::synth::Placement { x: 0, y: 0, source_x: 0, source_y: 0, keep: vec![1.0; 32 * 32] },
                crate::synth::Placement { x: 16, y: 0, source_x: 0, source_y: 0, keep },
            ],
            wrap: false,
        };
        let clock: Vec<f32> = (0..n).map(|t| t as f32).collect();
        for seed in 1..4 {
            let w = seam_aligned(&plan, &frames, 6.0, &clock, seed);
            let (a, b) = (&w[0], &w[1]);
            for warp in [a, b] {
                let f = warp.samples();
                assert_eq!(f[0], 0.0);
                assert!(f.windows(2).all(|p| p[1] >= p[0] && p[1] - p[0] <= 2.0), "eq. 6 steps: {f:?}");
                assert!(f.iter().enumerate().all(|(t, v)| (v - t as f32).abs() <= 6.0), "eq. 7 band");
            }
            // No colour jump at the seam at any frame...
            for t in 0..n {
                let (fa, fb) = (a.shown(t), b.shown(t));
                assert!((level(fa) - level(fb)).abs() <= 0.03, "seed {seed}, frame {t}: shows {fa} beside {fb}");
            }
            // ...and outside the change the copies are not in lockstep.
            let apart = (0..n).filter(|&t| a.shown(t) != b.shown(t)).count();
            assert!(apart >= n / 3, "seed {seed}: the copies differ at only {apart} of {n} frames");
        }
    }

    #[test]
    fn no_block_freezes_for_two_frames_in_a_row_not_even_at_the_ends() {
        // One block over a sequence that changes every frame, with the
        // whole band to drift in: its lead or lag is given back one held
        // frame at a time, never in a run.
        let n = 60;
        let frames: Vec<Image> = (0..n).map(|t| Image::from_fn(16, 16, 3, |x, y, p| p.fill(((x + y + t) % 7) as f32 / 7.0))).collect();
        let plan = QuiltPlan {
            width: 16,
            height: 16,
            source_size: (16, 16),
            block: (16, 16),
            overlap: (0, 0),
            placements: vec![crate::synth::Placement { x: 0, y: 0, source_x: 0, source_y: 0, keep: vec![1.0; 256] }],
            wrap: false,
        };
        let clock: Vec<f32> = (0..n).map(|t| t as f32).collect();
        let (mut runs, mut ahead_late) = (0, 0);
        for seed in 0..40 {
            let w = &seam_aligned(&plan, &frames, 6.0, &clock, seed)[0];
            let shown: Vec<usize> = (0..n).map(|t| w.shown(t)).collect();
            assert!(shown.windows(2).all(|p| p[1] >= p[0]) && shown[n - 1] <= n - 1);
            runs += shown.windows(3).filter(|p| p[0] == p[2]).count();
            ahead_late += usize::from(shown[n - 8] > n - 8);
        }
        assert_eq!(runs, 0, "frames shown three times in a row");
        assert!(ahead_late > 0, "no block was ahead of time near the end: the test proves nothing");
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
