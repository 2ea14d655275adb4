//! The light of a time-lapse's first frame, which fades as the surface
//! changes: a polished plate mirrors its surroundings (copper_patinating's
//! first frames are a bright orange third, a grey glow and a dark grey
//! third, each about 60-100 px of 256) until the patina dulls it, and
//! fresh steel shows cloudy light and dark blobs that rust covers. Neither
//! [`crate::synth::lighting::separate_sequence`]'s field of the frames'
//! temporal mean (the later, dull frames dominate it) nor its per-frame
//! drift (a third of the side wide, so that it does not follow content)
//! takes it out, and quilting scatters it as a patchwork of orange and
//! grey blocks over the first frames.
//!
//! The model: the surface is one material before it starts to change, so
//! the first frame's colour variation above a scale of [`SIGMA`] of the
//! side is light. As log colour relative to the frame's mean,
//! P(x) = G_sigma * log I_0 - mean. A pixel of frame t still carries that
//! light while it still looks as it did in the first frame: with
//! u_t(x) = exp(-|l_t(x) - l_0(x)|^2 / 2 [`UNCHANGED`]^2), l the log colour,
//! the local strength is
//! a_t(x) = G_reach * (u_t P . P) / G_reach * (P . P) (the share of the
//! light's energy within a window of [`REACH`] of the side that is still
//! unchanged, the dot product over the colour channels), times the pixel's
//! own u_t softened by 2 px, so the light goes where and when content has
//! covered it or the plate has dulled, and content that arrives keeps its
//! own colour: a matte salt crust does not mirror the room, and divided by
//! the dark reflection around it, it came out clipped white. Each frame is
//! divided by exp(a_t P) per colour channel.
//!
//! Not in the paper (its section 5.3 normalises one field for all frames).
//! Simplification: the first frame's own content above the scale is taken
//! for light too; a sequence that starts with large-scale structure that
//! persists loses it in every frame, as flat re-lighting already takes the
//! temporal mean's variation above an eighth of the side.

use crate::image::filter::gaussian_blur;
use crate::image::Image;
use rayon::prelude::*;
use serde::Serialize;

/// Sigma of the first frame's light, as a share of the shorter side (10 px
/// of 256). At 0.08 copper_patinating's grey glow, about 40 px wide, stayed
/// in the first frame.
pub const SIGMA: f32 = 0.04;

/// Sigma of the window over which a frame's strength of the first frame's
/// light is measured, as a share of the shorter side.
pub const REACH: f32 = 0.12;

/// A pixel still looks as it did in the first frame while its log colour
/// is within about this of the first frame's (a Gaussian weight of this
/// sigma). The frames' exposure flicker is out by then
/// ([`crate::synth::lighting::steady_exposure`]).
pub const UNCHANGED: f32 = 0.1;

/// Sigma (px) of the blur that softens each pixel's own u before it
/// scales the window's strength, so content's outline gets no hard step.
const OWN_SIGMA: f32 = 2.0;

/// The log colours are compared after a blur of this sigma (px), so sensor
/// noise does not count as change.
const LOOK_SIGMA: f32 = 1.0;

/// The first frame's variation above [`SIGMA`] is light in full when its
/// RMS is at least the second value times the RMS of the detail below that
/// scale, not at all under the first, and in part between. A surface's own
/// texture leaves a low pass far weaker than its detail, the fluctuation
/// of its density: growing_sprouts' seeds on soil measure 0.19 and
/// clay_solidifying's ridges 0.17 (taken for light, sprouts' seed clusters
/// came out grey and the soil between them lifted). Light on a smooth
/// surface is stronger than its detail: copper_patinating 2.4, the first
/// frame of rusting_steel 2.6 (the manifests' `start_light_removed.ratio`).
pub const LIGHT_RATIO: (f32, f32) = (0.5, 1.0);

/// Offset of the logarithm (in [0, 1] units), so black stays finite.
const LOG_FLOOR: f32 = 0.02;

/// What [`remove_start_light`] took out, for manifests.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StartLightReport {
    /// RMS of the first frame's light P over pixels and colour channels
    /// (log units), after [`LIGHT_RATIO`]'s weight.
    pub rms: f32,
    /// The first frame's large-scale variation over its fine detail (see [`LIGHT_RATIO`]).
    pub ratio: f32,
    /// Mean strength a_t over the pixels of the middle frame.
    pub strength_middle: f32,
    /// The same of the last frame.
    pub strength_last: f32,
}

/// The log colour of `frame`'s first `c` channels.
fn log_colour(frame: &Image, c: usize) -> Image {
    frame.select_channels(0..c).map(|v| (v.max(0.0) + LOG_FLOOR).ln())
}

/// `values` (`c` channels interleaved), each channel less its mean.
fn relative_to_mean(mut values: Vec<f32>, c: usize) -> Vec<f32> {
    let pixels = (values.len() / c).max(1) as f64;
    for ch in 0..c {
        let mean = values.iter().skip(ch).step_by(c).map(|&v| v as f64).sum::<f64>() / pixels;
        values.iter_mut().skip(ch).step_by(c).for_each(|v| *v -= mean as f32);
    }
    values
}

/// Root mean square of `values`.
fn rms(values: impl Iterator<Item = f32>) -> f32 {
    let (sum, n) = values.fold((0f64, 0usize), |(s, n), x| (s + (x as f64).powi(2), n + 1));
    (sum / n.max(1) as f64).sqrt() as f32
}

/// A one-channel `w` x `h` image of `values`, blurred by `sigma`.
fn blurred(values: Vec<f32>, (w, h): (usize, usize), sigma: f32) -> Image {
    gaussian_blur(&Image::from_data(w, h, 1, values).expect("one value per pixel"), sigma)
}

/// Divide the first frame's light out of every frame of `frames` in place,
/// where and while each frame still shows it (see the module's doc).
/// `None` (and the frames untouched) for fewer than two frames, or when the
/// first frame's large-scale variation is texture, not light ([`LIGHT_RATIO`]).
pub fn remove_start_light(frames: &mut [Image]) -> Option<StartLightReport> {
    let first = frames.first()?;
    if frames.len() < 2 {
        return None;
    }
    let (w, h) = first.size();
    let c = first.channels().min(3);
    let side = w.min(h) as f32;
    let (sigma, reach) = (side * SIGMA, side * REACH);
    let log = log_colour(first, c);
    let low = gaussian_blur(&log, sigma);
    // Light, or the texture's own large-scale structure? See LIGHT_RATIO.
    let fine = rms(log.data().iter().zip(low.data()).map(|(a, b)| a - b));
    let mut pattern = relative_to_mean(low.into_data(), c);
    let ratio = rms(pattern.iter().copied()) / fine.max(1e-6);
    let weight = ((ratio - LIGHT_RATIO.0) / (LIGHT_RATIO.1 - LIGHT_RATIO.0)).clamp(0.0, 1.0);
    if weight == 0.0 {
        return None;
    }
    pattern.iter_mut().for_each(|p| *p *= weight);
    // Each pixel's light weight P . P, and its sum over the window.
    let light: Vec<f32> = pattern.chunks_exact(c).map(|p| p.iter().map(|v| v * v).sum()).collect();
    let energy = blurred(light.clone(), (w, h), reach).into_data();
    // A window where the pattern is nearly flat has nothing to remove; the
    // floor keeps its strength from being noise over noise.
    let floor = 1e-3 * energy.iter().map(|&e| e as f64).sum::<f64>() as f32 / energy.len().max(1) as f32 + 1e-9;
    let start = gaussian_blur(&log, LOOK_SIGMA);
    let strengths: Vec<f32> = frames
        .par_iter_mut()
        .enumerate()
        .map(|(t, f)| {
            let strength: Vec<f32> = if t == 0 {
                vec![1.0; w * h]
            } else {
                // The light weight kept where the pixel still looks as
                // it did (u, see UNCHANGED), summed over the window; times
                // the pixel's own (softened) u: content that has arrived
                // (salt crust, a matte spot) does not mirror the plate's
                // surroundings.
                let now = gaussian_blur(&log_colour(f, c), LOOK_SIGMA);
                let unchanged: Vec<f32> = now
                    .data()
                    .chunks_exact(c)
                    .zip(start.data().chunks_exact(c))
                    .map(|(a, b)| {
                        let change: f32 = a.iter().zip(b).map(|(a, b)| (a - b).powi(2)).sum();
                        (-change / (2.0 * UNCHANGED * UNCHANGED)).exp()
                    })
                    .collect();
                let share = blurred(unchanged.iter().zip(&light).map(|(u, l)| l * u).collect(), (w, h), reach);
                let own = blurred(unchanged, (w, h), OWN_SIGMA);
                share.data().iter().zip(&energy).zip(own.data()).map(|((k, e), u)| (k / (e + floor)).min(1.0) * u).collect()
            };
            let stride = f.channels();
            for (i, px) in f.data_mut().chunks_exact_mut(stride).enumerate() {
                let a = strength[i];
                px[..c].iter_mut().zip(&pattern[i * c..i * c + c]).for_each(|(v, p)| *v *= (-a * p).exp());
            }
            (strength.iter().map(|&a| a as f64).sum::<f64>() / strength.len().max(1) as f64) as f32
        })
        .collect();
    Some(StartLightReport {
        rms: rms(pattern.iter().copied()),
        ratio,
        strength_middle: strengths[strengths.len() / 2],
        strength_last: *strengths.last().unwrap_or(&0.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    const SIDE: usize = 128;

    /// A brushed copper plate (fine noise) whose first frame is lit bright
    /// orange on the left and dull grey-blue on the right, a smooth step
    /// 8 px wide; from frame 1 a matte patina, which the light does not
    /// show on, covers rows above 8 t px; a dark spot appears on the lit
    /// side at frame 6, below the patina's reach. With the light or not.
    fn plate(n: usize, lit: bool) -> Vec<Image> {
        let mut rng = crate::rng::Generator::seed_from_u64(11);
        let grain: Vec<f32> = (0..SIDE * SIDE).map(|_| rng.gen_range(-0.03..0.03)).collect();
        (0..n)
            .map(|t| {
                Image::from_fn(SIDE, SIDE, 3, |x, y, p| {
                    let covered = y < 8 * t;
                    let spot = t >= 6 && (x as f32 - 24.0).hypot(y as f32 - 118.0) < 5.0;
                    let side = 1.0 / (1.0 + (-(x as f32 - 64.0) / 4.0).exp());
                    let light: [f32; 3] = std::array::from_fn(|c| {
                        let (left, right) = ([1.3, 1.15, 1.0][c], [0.7, 0.75, 0.85][c]);
                        if lit && !covered && !spot {
                            left + (right - left) * side
                        } else {
                            1.0
                        }
                    });
                    let body = if covered {
                        [0.3, 0.55, 0.5]
                    } else if spot {
                        [0.15, 0.1, 0.08]
                    } else {
                        [0.55, 0.4, 0.32]
                    };
                    for c in 0..3 {
                        p[c] = (body[c] + grain[y * SIDE + x]) * light[c];
                    }
                })
            })
            .collect()
    }

    /// Mean of channel `c` over the rectangle x0..x1, y0..y1.
    fn mean(img: &Image, c: usize, (x0, x1): (usize, usize), (y0, y1): (usize, usize)) -> f32 {
        let mut sum = 0.0;
        for y in y0..y1 {
            for x in x0..x1 {
                sum += img.pixel(x, y)[c];
            }
        }
        sum / ((x1 - x0) * (y1 - y0)) as f32
    }

    /// The red channel's left-over-right ratio, log, in rows y0..y1 (away
    /// from the spot).
    fn split(img: &Image, rows: (usize, usize)) -> f32 {
        (mean(img, 0, (8, 48), rows) / mean(img, 0, (80, 120), rows)).ln()
    }

    #[test]
    fn the_first_frames_light_goes_where_it_still_shows_and_content_stays() {
        let n = 12;
        let mut frames = plate(n, true);
        let clean = plate(n, false);
        let before = split(&frames[0], (0, SIDE));
        let report = remove_start_light(&mut frames).expect("a smooth plate's light is light");
        assert!(report.ratio > 1.0, "{report:?}");
        // The first frame: the split is gone.
        let after = split(&frames[0], (0, SIDE));
        assert!(after.abs() < 0.1 * before.abs(), "frame 0 split {before} -> {after}");
        // Frame 8: the uncovered rows keep the light and lose it; the
        // covered rows never had it and are not given its inverse.
        let (open, covered) = ((84, 104), (8, 56));
        let open_before = split(&plate(n, true)[8], open);
        assert!(split(&frames[8], open).abs() < 0.2 * open_before.abs(), "open rows {open_before} -> {}", split(&frames[8], open));
        assert!(split(&frames[8], covered).abs() < 0.15 * before.abs(), "covered rows {}", split(&frames[8], covered));
        // The spot that appeared keeps its own colour and its contrast to
        // the plate around it (the same ratio as without any light).
        let contrast = |f: &Image| mean(f, 1, (21, 27), (115, 121)) / mean(f, 1, (8, 16), (110, 126));
        let (got, want) = (contrast(&frames[10]), contrast(&clean[10]));
        assert!((got / want - 1.0).abs() < 0.1, "spot contrast {got} against {want}");
    }

    #[test]
    fn a_textured_first_frame_is_not_taken_for_light() {
        // Bright seeds in clumps of a few on dark soil (growing_sprouts'
        // first frame): the low pass follows where they are denser, which
        // is texture.
        let mut rng = crate::rng::Generator::seed_from_u64(5);
        let centres: Vec<(f32, f32)> = (0..200).map(|_| (rng.gen_range(0.0..SIDE as f32), rng.gen_range(0.0..SIDE as f32))).collect();
        let seeds: Vec<(f32, f32)> = (0..700)
            .map(|_| {
                let (cx, cy) = centres[rng.gen_range(0..centres.len())];
                (cx + rng.gen_range(-5.0..5.0), cy + rng.gen_range(-5.0..5.0))
            })
            .collect();
        let mut field = vec![0.08f32; SIDE * SIDE];
        for &(sx, sy) in &seeds {
            for y in (sy - 2.0).max(0.0) as usize..((sy + 2.0).max(0.0) as usize).min(SIDE) {
                for x in (sx - 2.0).max(0.0) as usize..((sx + 2.0).max(0.0) as usize).min(SIDE) {
                    field[y * SIDE + x] = 0.85;
                }
            }
        }
        let frame = Image::from_fn(SIDE, SIDE, 3, |x, y, p| p.iter_mut().for_each(|v| *v = field[y * SIDE + x]));
        let mut frames = vec![frame.clone(), frame];
        let report = remove_start_light(&mut frames);
        assert!(report.is_none(), "{report:?}");
        assert_eq!(frames[0].data(), frames[1].data());
    }
}
