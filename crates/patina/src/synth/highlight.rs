//! Fixed highlights in a time-lapse: a specular streak or hot-spot that
//! stays where the camera and the light put it while the surface under it
//! changes (copper_patinating's vertical reflection runs the whole height
//! of the plate in every frame). Quilting copies it with every block that
//! holds a piece of it (six streaks in a 2x enlargement), and the
//! illumination field of [`crate::synth::lighting`] cannot take it out:
//! it is a twentieth of the side wide, far under the field's scale.
//!
//! The dichromatic model (Shafer 1985) writes a pixel as a body colour
//! plus an illuminant-coloured specular term, I = D + s (1, 1, 1) for a
//! white-balanced capture, so the specular term lifts the smallest channel
//! by s. Per frame t the lift over the surroundings is the band-pass
//! e_t = G_fine * min(I_t) - G_wide * min(I_t) (fine = side / 128, wide =
//! side / 10, the surroundings a median that leaves the highlight out). A
//! highlight lifts its pixels in *every* frame, while content (a rust
//! spot's bright rim, steel between spots) comes and goes, so the
//! candidates are where S = max(0, min_t e_t) > [`THRESHOLD`]. Only a
//! long, thin structure is lighting: a piece (joined across gaps where
//! content darkened it for a while) that spans at least [`MIN_EXTENT`] of
//! the frame and is on average at most [`MAX_WIDTH`] wide. A field of
//! small glints (wet clay's ridges) is texture and stays. On that support
//! each frame loses its own positive lift e_t from every colour channel, so
//! a shine that dulls over time or changes its shape goes frame by frame;
//! where the lift was large (it clipped the body colour) the pixel takes
//! its surroundings' chromaticity.
//!
//! Simplifications: the separation works on the encoded values, where the
//! model is additive only approximately, and takes the illuminant as
//! white. Bright content under the streak loses its lift with it.

use crate::image::filter::gaussian_blur;
use crate::image::order::median;
use crate::image::region::components;
use crate::image::{Image, Mask};
use rayon::prelude::*;
use serde::Serialize;

/// Smallest lift (in [0, 1] units) in every frame that counts as highlight.
pub const THRESHOLD: f32 = 0.03;

/// A kept highlight piece spans at least this share of the shorter side:
/// half, so it is lighting across the frame. At a quarter (the default
/// block of time-lapse synthesis), a cluster of bright seeds at
/// growing_sprouts' left edge and a bright strip along clay_solidifying's
/// top edge were taken for highlights.
pub const MIN_EXTENT: f32 = 0.5;

/// A lift this large (in [0, 1] units) has clipped the body colour: the
/// pixel takes its surroundings' chromaticity.
pub const CLIP_LIFT: f32 = 0.1;

/// A streak's joined piece is on average at most this share of the
/// shorter side wide (a fifth). copper_patinating's streak and its glow
/// measure about a sixth; the joined glints of clay_solidifying two thirds.
pub const MAX_WIDTH: f32 = 1.0 / 5.0;

/// What [`remove_fixed_highlight`] took out, for manifests.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HighlightReport {
    /// Share of the pixels under the highlight.
    pub share: f32,
    /// The mean lift taken out under it (in [0, 1] units) in the first frame.
    pub lift_first: f32,
    /// The same in the last frame.
    pub lift_last: f32,
}

/// The per-frame lift of the smallest channel over its surroundings.
fn lift(frame: &Image, fine: f32, wide: f32, exclude: Option<&[f32]>) -> Vec<f32> {
    let c = frame.channels().min(3);
    let (w, h) = frame.size();
    let low = Image::from_fn(w, h, 1, |x, y, p| p[0] = frame.pixel(x, y)[..c].iter().copied().fold(f32::INFINITY, f32::min));
    let near = gaussian_blur(&low, fine);
    let far = surroundings(&low, wide, exclude);
    near.data().iter().zip(&far).map(|(a, b)| a - b).collect()
}

/// The diffuse level around each pixel of `low`: the median of cell means
/// (cells of a third of `wide`) within about `wide`, bilinear between cell
/// centres. A median, because dark content that appears next to a
/// highlight (spots, patina) would pull a mean down and make the highlight
/// look brighter than it is; cells mostly under `exclude` (the highlight
/// found so far) are left out, so a wide highlight does not lift its own
/// surroundings.
fn surroundings(low: &Image, wide: f32, exclude: Option<&[f32]>) -> Vec<f32> {
    let (w, h) = low.size();
    let f = (wide / 3.0).floor().max(1.0) as usize;
    let (cw, ch) = (w.div_ceil(f), h.div_ceil(f));
    let mut cell = vec![(0f32, 0f32, 0usize); cw * ch];
    for y in 0..h {
        for x in 0..w {
            let c = &mut cell[(y / f) * cw + x / f];
            c.0 += low.at(x, y, 0);
            c.1 += exclude.map_or(0.0, |e| e[y * w + x]);
            c.2 += 1;
        }
    }
    let means: Vec<(f32, bool)> = cell.iter().map(|&(s, e, k)| (s / k as f32, e / (k as f32) < 0.5)).collect();
    const R: usize = 3;
    let medians: Vec<f32> = (0..cw * ch)
        .into_par_iter()
        .map_init(Vec::new, |buf: &mut Vec<f32>, i| {
            let (cx, cy) = (i % cw, i / cw);
            let window = |keep_all: bool, buf: &mut Vec<f32>| {
                buf.clear();
                for y in cy.saturating_sub(R)..(cy + R + 1).min(ch) {
                    for x in cx.saturating_sub(R)..(cx + R + 1).min(cw) {
                        let (m, open) = means[y * cw + x];
                        if open || keep_all {
                            buf.push(m);
                        }
                    }
                }
            };
            window(false, buf);
            if buf.len() < 5 {
                window(true, buf);
            }
            median(buf).unwrap_or(0.0)
        })
        .collect();
    let at = |u: f32, n: usize| {
        let u = u.clamp(0.0, (n - 1) as f32);
        let i = (u.floor() as usize).min(n.saturating_sub(2));
        (i, (u - i as f32).min(1.0))
    };
    let mut out = vec![0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let (j, v) = if ch > 1 { at((y as f32 + 0.5) / f as f32 - 0.5, ch) } else { (0, 0.0) };
        let j1 = (j + 1).min(ch - 1);
        for (x, o) in row.iter_mut().enumerate() {
            let (i, u) = if cw > 1 { at((x as f32 + 0.5) / f as f32 - 0.5, cw) } else { (0, 0.0) };
            let i1 = (i + 1).min(cw - 1);
            let top = medians[j * cw + i] * (1.0 - u) + medians[j * cw + i1] * u;
            let bottom = medians[j1 * cw + i] * (1.0 - u) + medians[j1 * cw + i1] * u;
            *o = top * (1.0 - v) + bottom * v;
        }
    });
    out
}

/// The colour around each pixel, leaving out the highlight (`support`):
/// a normalized Gaussian convolution of sigma `wide` / 2, RGB per pixel.
fn surrounding_colour(frame: &Image, support: &[f32], wide: f32) -> Vec<f32> {
    let (w, h) = frame.size();
    let weighted = Image::from_fn(w, h, 4, |x, y, p| {
        let k = 1.0 - support[y * w + x];
        let px = frame.pixel(x, y);
        for c in 0..3 {
            p[c] = k * px[c];
        }
        p[3] = k;
    });
    let blurred = gaussian_blur(&weighted, wide / 2.0);
    blurred
        .data()
        .chunks_exact(4)
        .flat_map(|p| {
            let k = p[3].max(1e-4);
            [p[0] / k, p[1] / k, p[2] / k]
        })
        .collect()
}

/// The highlight's support (a weight in [0, 1], soft at the rim): the
/// streaks among the pieces of S = max(0, min over frames of the lift) >
/// [`THRESHOLD`]; `None` when there is no streak.
fn support(frames: &[Image], fine: f32, wide: f32, exclude: Option<&[f32]>) -> Option<Vec<f32>> {
    let (w, h) = frames.first()?.size();
    let mut layer =
        frames.par_iter().map(|f| lift(f, fine, wide, exclude)).reduce_with(|a, b| a.iter().zip(&b).map(|(x, y)| x.min(*y)).collect())?;
    layer.iter_mut().for_each(|v| *v = v.max(0.0));
    // Pieces broken by content that darkens part of the highlight in some
    // frame are joined for the count (a dilation of a 32nd of the side);
    // a joined piece is a streak when it is long and thin: its extent at
    // least MIN_EXTENT of the side, its area no more than extent x
    // MAX_WIDTH of the side. A field of small glints (wet clay) joins into
    // a piece that is long but wide, and stays as texture.
    let side = w.min(h) as f32;
    let bright = Mask::from_fn(w, h, |x, y| layer[y * w + x] > THRESHOLD);
    let joined = bright.dilate((side / 32.0).round().max(1.0) as usize);
    let (label, count) = components(joined.bits(), w, h);
    let mut bounds = vec![(usize::MAX, usize::MAX, 0usize, 0usize, 0usize); count];
    for (i, &l) in label.iter().enumerate() {
        if l != u32::MAX {
            let b = &mut bounds[l as usize];
            let (x, y) = (i % w, i / w);
            *b = (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y), b.4 + 1);
        }
    }
    let large: Vec<bool> = bounds
        .iter()
        .map(|b| {
            let extent = (b.2 + 1 - b.0).max(b.3 + 1 - b.1) as f32;
            extent >= side * MIN_EXTENT && (b.4 as f32) <= extent * side * MAX_WIDTH
        })
        .collect();
    if !large.iter().any(|&k| k) {
        return None;
    }
    // A soft rim, so the subtraction leaves no step where the layer
    // crosses the threshold.
    let kept = Image::from_fn(w, h, 1, |x, y, p| {
        let l = label[y * w + x];
        p[0] = if l != u32::MAX && large[l as usize] { 1.0 } else { 0.0 }
    });
    Some(gaussian_blur(&kept, fine).data().iter().map(|k| k.min(1.0)).collect())
}

/// Find a highlight fixed in the frame of `frames` and subtract it from
/// every frame in place. `None` (and the frames untouched) when there is
/// none larger than [`MIN_EXTENT`].
pub fn remove_fixed_highlight(frames: &mut [Image]) -> Option<HighlightReport> {
    let (w, h) = frames.first()?.size();
    let side = w.min(h) as f32;
    let (fine, wide) = ((side / 128.0).max(1.0), side / 10.0);
    // Found once, then again with the first find left out of its own
    // surroundings (a wide highlight lifts its background).
    let first = support(frames, fine, wide, None)?;
    let support = support(frames, fine, wide, Some(&first))?;
    let area: f64 = support.iter().map(|&k| k as f64).sum();
    // Each frame's lift is computed again rather than kept from the second
    // pass: keeping every frame's would hold another float per input
    // sample (131 MB for 500 frames of 256 x 256).
    let removed: Vec<f32> = frames
        .par_iter_mut()
        .map(|f| {
            let e = lift(f, fine, wide, Some(&support));
            let tint = (f.channels() >= 3).then(|| surrounding_colour(f, &support, wide));
            let stride = f.channels();
            let c = stride.min(3);
            let mut total = 0f64;
            for (i, px) in f.data_mut().chunks_exact_mut(stride).enumerate() {
                let r = support[i] * e[i].max(0.0);
                total += r as f64;
                px[..c].iter_mut().for_each(|v| *v = (*v - r).max(0.0));
                // Where the highlight lifted much, it clipped the body
                // colour too: take the surroundings' chromaticity at the
                // pixel's own brightness.
                if let Some(tint) = &tint {
                    let k = support[i] * (r / CLIP_LIFT).min(1.0);
                    let t = &tint[3 * i..3 * i + 3];
                    let (lp, lt) = (px[..3].iter().sum::<f32>(), t.iter().sum::<f32>());
                    if k > 0.0 && lt > 1e-4 {
                        for ch in 0..3 {
                            px[ch] += k * (lp * t[ch] / lt - px[ch]);
                        }
                    }
                }
            }
            (total / area) as f32
        })
        .collect();
    Some(HighlightReport { share: (area / (w * h) as f64) as f32, lift_first: removed[0], lift_last: *removed.last().unwrap_or(&0.0) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A textured grey surface with dark spots that appear at random times,
    /// under a fixed vertical streak (lift 0.3 dulling to 0.15) when
    /// `streak`; with the streak's profile per column.
    fn sequence(n: usize, streak: bool) -> (Vec<Image>, Vec<f32>) {
        let (w, h) = (128, 128);
        let mut rng = crate::rng::Generator::seed_from_u64(7);
        let base: Vec<f32> = (0..w * h).map(|_| rng.gen_range(0.0..0.15)).collect();
        let spots: Vec<(f32, f32, usize)> =
            (0..30).map(|_| (rng.gen_range(0.0..w as f32), rng.gen_range(0.0..h as f32), rng.gen_range(0..n))).collect();
        let streak_at = |x: usize| if streak { 0.3 * (-((x as f32 - 50.0) / 3.0).powi(2)).exp() } else { 0.0 };
        let frames = (0..n)
            .map(|t| {
                let dull = 1.0 - 0.5 * t as f32 / n as f32;
                Image::from_fn(w, h, 3, |x, y, p| {
                    let spot = spots.iter().any(|&(sx, sy, on)| on <= t && (x as f32 - sx).hypot(y as f32 - sy) < 6.0);
                    let body = if spot { [0.45, 0.25, 0.1] } else { [0.5, 0.5, 0.52] };
                    for c in 0..3 {
                        p[c] = body[c] + base[y * w + x] + dull * streak_at(x);
                    }
                })
            })
            .collect();
        (frames, (0..w).map(streak_at).collect())
    }

    #[test]
    fn a_streak_fixed_in_the_frame_is_removed_and_the_rest_stays() {
        let n = 24;
        let (mut frames, streak) = sequence(n, true);
        let (clean, _) = sequence(n, false);
        let report = remove_fixed_highlight(&mut frames).expect("the streak is found");
        assert!(report.share > 0.03 && report.share < 0.25, "{report:?}");
        assert!(report.lift_first > 1.25 * report.lift_last, "it dulls: {report:?}");
        // Mean absolute error against the streak-free frames on the
        // streak's core (where it lifts over 0.15 at frame 0) and away from
        // it, in the green channel.
        for t in [0, n / 2, n - 1] {
            let (f, c) = (&frames[t], &clean[t]);
            let err = |cols: &dyn Fn(usize) -> bool| {
                let (mut s, mut k) = (0.0f64, 0usize);
                for y in 0..128 {
                    for x in (0..128).filter(|&x| cols(x)) {
                        s += (f.at(x, y, 1) - c.at(x, y, 1)).abs() as f64;
                        k += 1;
                    }
                }
                s / k as f64
            };
            let core = err(&|x| streak[x] > 0.15);
            let left = (1.0 - 0.5 * t as f64 / n as f64) * 0.24;
            // Dark spots that grow over the streak keep its lift (their
            // own lift is negative), so about a quarter of the core keeps
            // it by the last frame.
            assert!(core < 0.5 * left, "frame {t}: {core:.3} left of a streak of about {left:.3}");
            assert!(err(&|x| x.abs_diff(50) > 20) < 1e-3, "frame {t}: away from the streak the frame changed");
        }
    }

    #[test]
    fn content_that_comes_and_goes_is_not_a_highlight() {
        let (mut frames, _) = sequence(24, false);
        let before = frames.clone();
        assert!(remove_fixed_highlight(&mut frames).is_none());
        assert_eq!(frames, before);
    }
}
