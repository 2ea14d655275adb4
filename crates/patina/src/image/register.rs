//! Registration of a time-lapse whose camera shakes: each frame's
//! whole-pixel translation against the frames before it, by phase
//! correlation (Kuglin and Hines 1975), and the window every frame covers.
//!
//! Time-lapses cut from video often move by a few pixels between frames
//! (the rusting-steel capture of `../shared/data` jumps 12 px after its
//! first frame and shakes by 1-4 px in 54 of its 98 steps). A per-texel fit
//! in time then follows one texel through several places: spots smear into
//! their neighbours and a texel sees a passing flake as its own history.
//!
//! - Each frame is registered against a running reference, the mean of the
//!   last [`REFERENCE_FRAMES`] frames already aligned, so appearance that
//!   changes over the sequence (rust growing) stays comparable, and one
//!   noisy frame does not carry its error on.
//! - Luminance (the mean of the chosen channels) under a Hann window, mean
//!   removed; the normalised cross-power spectrum's inverse peaks at the
//!   shift, searched within [`MAX_SHIFT`] of each side around the previous
//!   frame's (a camera may pan).
//! - The peak is refined by the normalised correlation itself within
//!   [`REFINE`] px: where the content changed between a frame and its
//!   reference, the phase-only peak can sit a pixel off.
//! - A frame keeps the previous frame's offset unless the new one raises
//!   its normalised correlation with the reference by [`MIN_GAIN`] to at
//!   least [`MIN_MATCH`]: content that moves without the camera (sprouts
//!   growing) does not make the sequence shift, and a frame that matches
//!   nowhere is not moved by a chance peak.
//! - Shifts are whole pixels (simplification): frames are cropped, never
//!   resampled, so they keep their sharpness; what is left is under half
//!   a pixel.

use super::fourier::{Fft2, FftDirection, C64};
use super::Image;
use crate::error::{Error, Result};
use rayon::prelude::*;
use serde::Serialize;
use std::ops::Range;

/// Aligned frames averaged into the reference a frame is registered
/// against.
pub const REFERENCE_FRAMES: usize = 4;
/// Largest translation searched between a frame and the one before it, as
/// a share of each side.
pub const MAX_SHIFT: f32 = 0.25;
/// How much a new offset must raise a frame's normalised correlation with
/// its reference over the previous frame's offset to be taken.
pub const MIN_GAIN: f64 = 0.02;
/// Pixels around the phase correlation's peak searched by direct
/// correlation.
pub const REFINE: i32 = 2;
/// Smallest normalised correlation with its reference at which a frame is
/// moved: a frame that matches nowhere (a cut, or a move beyond
/// [`MAX_SHIFT`]) keeps the previous frame's offset instead of taking a
/// chance peak, and so does a steady frame whose content changed a lot
/// since the last (a 5-frame rusting sequence correlates 0.26 with its
/// first frame, and 0.31 shifted by 7 x 3 px). The rusting-steel capture's
/// moves correlate 0.72 or more.
pub const MIN_MATCH: f64 = 0.5;
/// Smallest share of each side the window common to all frames may keep.
pub const MIN_KEPT: f32 = 0.5;

/// Where each frame of a sequence lies against its first.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Registration {
    /// Per frame, where frame 0's content lies in it, (dx, dy) px: frame
    /// i's pixel (x + dx, y + dy) shows what frame 0's (x, y) does.
    pub offsets: Vec<[i32; 2]>,
    /// The window every frame covers, in frame 0's coordinates:
    /// [x, y, width, height].
    pub window: [usize; 4],
}

impl Registration {
    /// Registers `frames` (all of one size) on the mean of `channels`.
    /// Fails when the frames move so far that their common window would
    /// keep less than [`MIN_KEPT`] of a side.
    pub fn of(frames: &[Image], channels: Range<usize>) -> Result<Registration> {
        let Some(first) = frames.first() else {
            return Err(Error::invalid("registration needs at least one frame"));
        };
        let (w, h) = first.size();
        if let Some(i) = frames.iter().position(|f| f.size() != (w, h)) {
            let (fw, fh) = frames[i].size();
            return Err(Error::invalid(format!("frame {i} is {fw}x{fh}, frame 0 {w}x{h}: registration needs frames of one size")));
        }
        // Luminance is made per frame as it is registered, and only the
        // reference's frames are kept: a 500-frame 256 x 256 sequence holds
        // 5 of them, not 500.
        let luminance = |f: &Image| -> Vec<f64> {
            let c = channels.end.min(f.channels());
            let k = channels.start.min(c - 1)..c;
            let n = k.len() as f64;
            f.data().chunks_exact(f.channels()).map(|p| p[k.clone()].iter().map(|&v| v as f64).sum::<f64>() / n).collect()
        };
        let hann = |n: usize| -> Vec<f64> {
            (0..n).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * (i as f64 + 0.5) / n as f64).cos()).collect()
        };
        let (wx, wy) = (hann(w), hann(h));
        let (forward, inverse) = (Fft2::new(w, h, FftDirection::Forward), Fft2::new(w, h, FftDirection::Inverse));
        let spectrum = |values: &[f64]| -> Vec<C64> {
            let mean = values.iter().sum::<f64>() / values.len() as f64;
            let mut data: Vec<C64> = values.iter().enumerate().map(|(i, v)| C64::new((v - mean) * wx[i % w] * wy[i / w], 0.0)).collect();
            forward.process(&mut data);
            data
        };
        let reach = ((w as f32 * MAX_SHIFT) as i32, (h as f32 * MAX_SHIFT) as i32);
        let mut offsets = vec![[0i32; 2]];
        let mut recent: std::collections::VecDeque<Vec<f64>> = std::collections::VecDeque::from([luminance(first)]);
        for frame in &frames[1..] {
            let lum = &luminance(frame);
            let reference: Vec<f64> = (0..w * h).map(|i| recent.iter().map(|a| a[i]).sum::<f64>() / recent.len() as f64).collect();
            let (f, r) = (spectrum(lum), spectrum(&reference));
            let mut cross: Vec<C64> = f
                .iter()
                .zip(&r)
                .map(|(a, b)| {
                    let c = a * b.conj();
                    c / (c.norm() + 1e-12)
                })
                .collect();
            inverse.process(&mut cross);
            // The peak's shift is found modulo the frame's size: it is read
            // as the one nearest the previous frame's offset, within reach.
            let previous = *offsets.last().expect("frame 0's offset");
            let nearest = |v: i32, n: usize, around: i32| v - n as i32 * ((v - around) as f32 / n as f32).round() as i32;
            let mut best = ([0i32; 2], f64::NEG_INFINITY);
            for (i, c) in cross.iter().enumerate() {
                let d = [nearest((i % w) as i32, w, previous[0]), nearest((i / w) as i32, h, previous[1])];
                if (d[0] - previous[0]).abs() <= reach.0 && (d[1] - previous[1]).abs() <= reach.1 && c.re > best.1 {
                    best = (d, c.re);
                }
            }
            // The peak of a frame whose content changed can sit a pixel
            // off: the shift is refined by direct correlation around it.
            let score = |d: [i32; 2]| correlation(lum, &reference, d, (w, h));
            let around: Vec<[i32; 2]> =
                (-REFINE..=REFINE).flat_map(|dy| (-REFINE..=REFINE).map(move |dx| [best.0[0] + dx, best.0[1] + dy])).collect();
            let scores: Vec<f64> = around.par_iter().map(|&d| score(d)).collect();
            let refined = around.into_iter().zip(scores).fold(([0; 2], f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
            let moved = refined.0 != previous && refined.1 >= MIN_MATCH && refined.1 >= score(previous) + MIN_GAIN;
            let offset = if moved { refined.0 } else { previous };
            if recent.len() == REFERENCE_FRAMES {
                recent.pop_front();
            }
            recent.push_back((0..w * h).map(|i| sample(lum, (w, h), (i % w) as i32 + offset[0], (i / w) as i32 + offset[1])).collect());
            offsets.push(offset);
        }
        let span = |k: usize| {
            let (lo, hi) = offsets.iter().fold((0, 0), |(lo, hi), o| (o[k].min(lo), o[k].max(hi)));
            ((-lo) as usize, (hi - lo) as usize)
        };
        let ((x0, sx), (y0, sy)) = (span(0), span(1));
        let (ww, wh) = (w.saturating_sub(sx), h.saturating_sub(sy));
        if (ww as f32) < MIN_KEPT * w as f32 || (wh as f32) < MIN_KEPT * h as f32 {
            return Err(Error::invalid(format!(
                "the frames move by up to {sx} x {sy} px against each other, which leaves a common window of {ww}x{wh} of their {w}x{h}; \
                 steady the sequence first or do not register it"
            )));
        }
        Ok(Registration { offsets, window: [x0, y0, ww, wh] })
    }

    /// No frame moves against the first.
    pub fn is_steady(&self) -> bool {
        self.offsets.iter().all(|o| *o == [0, 0])
    }

    /// The largest motion of a frame against the first, (x, y) px.
    pub fn largest_motion(&self) -> [i32; 2] {
        let largest = |k: usize| self.offsets.iter().map(|o| o[k].abs()).max().unwrap_or(0);
        [largest(0), largest(1)]
    }

    /// `frames` aligned on the first and cropped to [`Registration::window`]
    /// (every channel).
    pub fn apply(&self, frames: &[Image]) -> Vec<Image> {
        let [x0, y0, ww, wh] = self.window;
        frames
            .iter()
            .zip(&self.offsets)
            .map(|(f, o)| {
                let (sx, sy) = ((x0 as i32 + o[0]) as usize, (y0 as i32 + o[1]) as usize);
                Image::from_fn(ww, wh, f.channels(), |x, y, p| p.copy_from_slice(f.pixel(sx + x, sy + y)))
            })
            .collect()
    }
}

/// `values` (w x h) at (x, y), clamped to its edges.
fn sample(values: &[f64], (w, h): (usize, usize), x: i32, y: i32) -> f64 {
    values[y.clamp(0, h as i32 - 1) as usize * w + x.clamp(0, w as i32 - 1) as usize]
}

/// Normalised correlation of `frame` read at offset `d` with `reference`,
/// over the pixels where both lie inside the frame.
fn correlation(frame: &[f64], reference: &[f64], d: [i32; 2], (w, h): (usize, usize)) -> f64 {
    let xs = (-d[0]).max(0)..(w as i32 - d[0]).min(w as i32);
    let ys = (-d[1]).max(0)..(h as i32 - d[1]).min(h as i32);
    // The overlap's pixel pairs (reference, frame), row by row.
    let rows = || {
        ys.clone().flat_map(|y| {
            let (r, f) = (y as usize * w, (y + d[1]) as usize * w);
            let xs = xs.start as usize..xs.end.max(xs.start) as usize;
            let shift = d[0] as isize;
            reference[r + xs.start..r + xs.end]
                .iter()
                .zip(&frame[(f + xs.start).wrapping_add_signed(shift)..(f + xs.end).wrapping_add_signed(shift)])
        })
    };
    let (mut n, mut ma, mut mb) = (0usize, 0.0, 0.0);
    for (a, b) in rows() {
        n += 1;
        ma += a;
        mb += b;
    }
    let n = n.max(1) as f64;
    let (ma, mb) = (ma / n, mb / n);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (a, b) in rows() {
        let (a, b) = (a - ma, b - mb);
        ab += a * b;
        aa += a * a;
        bb += b * b;
    }
    ab / (aa * bb).sqrt().max(1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::noise::Layer;

    /// A 160 x 160 canvas of fBm grain with dark spots that grow over
    /// time `t`, seen through a 96 x 96 window at (`x`, `y`).
    fn view(t: f32, (x, y): (i32, i32)) -> Image {
        let grain = Layer::new(5, 1);
        let spots = Layer::new(5, 2);
        Image::from_fn(96, 96, 3, |i, j, p| {
            let (u, v) = ((i as i32 + 32 + x) as f32, (j as i32 + 32 + y) as f32);
            let g = 0.6 + 0.25 * grain.fbm(u, v, 6.0, 3, 0.5);
            let rust = (spots.fbm(u, v, 14.0, 2, 0.5) + 0.6 * t - 0.3).clamp(0.0, 0.1) * 10.0;
            p.copy_from_slice(&[g * (1.0 - 0.7 * rust), g * (1.0 - 0.8 * rust), g * (1.0 - 0.9 * rust)]);
        })
    }

    #[test]
    fn a_shaking_sequence_is_registered_to_the_pixel_and_cropped_to_what_all_frames_show() {
        let moves = [(0, 0), (12, 1), (11, -3), (13, -4), (9, -2), (14, 2), (12, 0), (10, -5)];
        let frames: Vec<Image> = moves.iter().enumerate().map(|(i, &m)| view(i as f32 / 7.0, m)).collect();
        let reg = Registration::of(&frames, 0..3).unwrap();
        // Frame i shows frame 0's pixel (x, y) at (x - move, y - move).
        let want: Vec<[i32; 2]> = moves.iter().map(|&(x, y)| [-x, -y]).collect();
        assert_eq!(reg.offsets, want);
        // The camera moves over x 0..=14 and y -5..=2.
        assert_eq!(reg.window, [14, 2, 96 - 14, 96 - 7]);
        assert_eq!(reg.largest_motion(), [14, 5]);
        let aligned = reg.apply(&frames);
        // The last frame, aligned, shows the first's place: where its spots
        // have not spread, its grain is the first frame's to the bit; read
        // at the first frame's window without its offset, nowhere is.
        let (a, b) = (&aligned[0], &aligned[7]);
        assert_eq!(a.size(), (82, 89));
        let unaligned = Image::from_fn(82, 89, 3, |x, y, p| p.copy_from_slice(frames[7].pixel(14 + x, 2 + y)));
        let same = |b: &Image| (0..82 * 89).filter(|i| a.pixel(i % 82, i / 82)[0] == b.pixel(i % 82, i / 82)[0]).count();
        assert!(same(b) > 82 * 89 / 20, "only {} pixels unchanged after alignment", same(b));
        assert!(same(&unaligned) < 82 * 89 / 200, "{} pixels unchanged without it", same(&unaligned));
    }

    #[test]
    fn a_steady_sequence_is_left_as_it_is() {
        let frames: Vec<Image> = (0..6).map(|i| view(i as f32 / 5.0, (0, 0))).collect();
        let reg = Registration::of(&frames, 0..3).unwrap();
        assert!(reg.is_steady());
        assert_eq!(reg.window, [0, 0, 96, 96]);
        assert_eq!(reg.apply(&frames), frames);
    }

    #[test]
    fn a_steady_time_lapse_whose_spots_grow_is_not_moved() {
        for (w, h, n, seed) in [(48, 40, 5, 1), (64, 64, 21, 5), (96, 96, 40, 2)] {
            let frames = crate::samples::rusting_timelapse(w, h, n, seed);
            let reg = Registration::of(&frames, 0..3).unwrap();
            assert!(reg.is_steady(), "{w}x{h}, {n} frames: {:?}", reg.offsets);
        }
    }

    #[test]
    fn frames_that_match_nowhere_are_not_moved() {
        // Views 30 px apart (beyond the 24 px searched) of white noise: no
        // offset correlates, and a chance peak must not move them.
        let noise = Layer::new(9, 3);
        let view = |dx: usize| Image::from_fn(96, 96, 1, |x, y, p| p[0] = noise.white((x + dx) as i32, y as i32));
        let frames: Vec<Image> = (0..4).map(|i| view(30 * i)).collect();
        assert!(Registration::of(&frames, 0..1).unwrap().is_steady());
    }

    #[test]
    fn frames_that_share_too_little_are_refused() {
        let err = Registration::of(&[view(0.0, (0, 0)), Image::new(90, 96, 3)], 0..3).unwrap_err().to_string();
        assert!(err.contains("frame 1 is 90x96"), "{err}");
        // A pan of 15-20 px per frame is followed, but the frames share 41 px.
        let frames = vec![view(0.0, (0, 0)), view(0.0, (20, 0)), view(0.0, (40, 0)), view(0.0, (55, 0))];
        let err = Registration::of(&frames, 0..3).unwrap_err().to_string();
        assert!(err.contains("common window of 41x96"), "{err}");
    }
}
