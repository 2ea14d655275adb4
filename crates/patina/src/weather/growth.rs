//! Growth of weathering past the input (t > 1) by front propagation: the
//! alternative the issue proposes to the paper's eq. 2 patch blending
//! (see [`super::sequence::future`]), and the default because it grows
//! from the existing damage instead of stamping patches.
//!
//! 1. Arrival times: a weighted distance (Dijkstra over the 8-neighbour
//!    grid) from the weathered pixels (age above the cut) and from a few
//!    nucleation sites, through a speed field. The speed follows the
//!    input's own age (weathering advances first into material that is
//!    already a little aged: the halo around rust, the fine cracks that
//!    lead away from a peel) and a fractal noise, so fronts are ragged,
//!    not round.
//! 2. Per future frame, the front advances to the arrival time that makes
//!    the weathered area reach its target: the clean surface shrinks by
//!    [`GROWTH_RATE`] of itself per unit of t. The evolved age is the
//!    input's age where it is higher, else the typical weathered age,
//!    ramped over a few pixels behind the front.
//! 3. The band the front crossed since the previous frame is filled
//!    ([`Synthesis::fill`]) from weathered input material only (the pixels
//!    above the age cut), guided by age (source: the input's age, target:
//!    the evolved age), so new damage is made of the input's own damage and
//!    continues it across the front; the fill is then rebuilt from whole
//!    weathered patches (its vote dulls large holes drawn from a small
//!    source set) and taken whole. Every other pixel keeps the previous
//!    frame exactly. (Guided re-synthesis of the whole frame
//!    started from the previous one barely changed anything on the photos
//!    of ../shared/data: the previous frame's clean content out-voted the
//!    age guide.)

use super::rebuild::{rebuild, Engine};
use super::sequence::{Frame, SequenceParams};
use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use crate::rng::{self, Rng};
use crate::samples::fractal_noise;
use crate::synth::{OptimizeParams, Synthesis};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Share of the still-clean surface that weathers per unit of t.
pub const GROWTH_RATE: f32 = 0.2;
/// Nucleation sites per 64 x 64 px of clean surface.
pub const NUCLEATION_DENSITY: f32 = 0.25;
/// Width, in pixels of arrival distance, of the ramp behind the front.
const RAMP: f32 = 3.0;
/// Weight of the age guide channel against the appearance features.
const AGE_GUIDE: f32 = 3.0;

/// Arrival time of the weathering at every pixel (0 on weathered pixels).
pub fn arrival_times(age: &Image, weathered: &Mask, seed: u64) -> Vec<f32> {
    let (w, h) = age.size();
    let mut g = rng::generator(seed, &[0x9a0]);
    let noise_seed = rng::derive(seed, &[0x9a1]);
    // Speed: faster through already-aged material and along a ragged noise.
    let speed: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let n = fractal_noise(noise_seed, x, y, 10.0, 4);
            // Ragged fronts (a noise over a factor of about 5) that still
            // advance a few pixels per frame everywhere.
            0.3 + 1.6 * n * n + age.data()[i]
        })
        .collect();
    let mut time = vec![f32::INFINITY; w * h];
    let mut heap: BinaryHeap<Reverse<(u32, u32)>> = BinaryHeap::new();
    let key = |t: f32| (t * 1024.0) as u32;
    for (i, t) in time.iter_mut().enumerate() {
        if weathered.bits()[i] {
            *t = 0.0;
            heap.push(Reverse((0, i as u32)));
        }
    }
    // Nucleation: new sites on clean pixels, drawn in proportion to their
    // age (slightly aged spots start first), each starting a little late.
    let clean = (w * h) - weathered.count();
    let sites = ((clean as f32 / 4096.0) * NUCLEATION_DENSITY).round() as usize;
    let weights: Vec<f32> = (0..w * h).map(|i| if weathered.bits()[i] { 0.0 } else { age.data()[i] * age.data()[i] }).collect();
    let total: f32 = weights.iter().sum();
    if total > 0.0 {
        for _ in 0..sites {
            let mut pick = g.gen_range(0.0..total);
            let i = weights.iter().position(|&wt| {
                pick -= wt;
                pick <= 0.0
            });
            if let Some(i) = i {
                let start = g.gen_range(5.0f32..25.0);
                if start < time[i] {
                    time[i] = start;
                    heap.push(Reverse((key(start), i as u32)));
                }
            }
        }
    }
    while let Some(Reverse((k, i))) = heap.pop() {
        let i = i as usize;
        if k > key(time[i]) {
            continue;
        }
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        for (dx, dy, len) in
            [(1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0), (1, 1, 1.414), (1, -1, 1.414), (-1, 1, 1.414), (-1, -1, 1.414)]
        {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                continue;
            }
            let j = ny as usize * w + nx as usize;
            let t = time[i] + len * 2.0 / (speed[i] + speed[j]);
            if t < time[j] {
                time[j] = t;
                heap.push(Reverse((key(t), j as u32)));
            }
        }
    }
    time
}

/// Frames for t > 1 grown by front propagation (see the module docs).
pub fn future(input: &Image, age: &Image, cut: f32, params: &SequenceParams, seed: u64, progress: &dyn Fn(usize)) -> Result<Vec<Frame>> {
    let (w, h) = input.size();
    if age.size() != input.size() {
        return Err(Error::invalid("the input and its age map must have one size"));
    }
    if params.future_span.is_nan() || params.future_span <= 0.0 {
        return Err(Error::invalid("future frames need a positive span"));
    }
    let weathered = Mask::from_fn(w, h, |x, y| age.at(x, y, 0) >= cut);
    let arrival = arrival_times(age, &weathered, seed);
    // Arrival times of the clean pixels, sorted: the quantiles set the front.
    let mut clean_times: Vec<f32> = arrival.iter().zip(weathered.bits()).filter(|(_, &b)| !b).map(|(t, _)| *t).collect();
    clean_times.sort_by(f32::total_cmp);
    // The typical weathered age, which new weathering takes on.
    let mut aged: Vec<f32> = age.data().iter().copied().filter(|&a| a >= cut).collect();
    aged.sort_by(f32::total_cmp);
    let typical = if aged.is_empty() { 1.0 } else { aged[aged.len() / 2] };
    // Weathered input material the new damage is made of: whole patches
    // above the cut (the most aged tenth when too little is left).
    let patch = params.rebuild.patch;
    let r = patch / 2;
    let mut sources = weathered.erode(r).dilate(r);
    if sources.count() < patch * patch * 4 {
        let mut sorted = age.data().to_vec();
        sorted.sort_by(f32::total_cmp);
        let top = sorted[sorted.len() * 9 / 10];
        sources = Mask::from_fn(w, h, |x, y| age.at(x, y, 0) >= top).erode(r).dilate(r);
    }
    if sources.count() == 0 {
        sources = Mask::filled(w, h, true);
    }
    let source_guide = age.map(|v| v * AGE_GUIDE);
    let mut previous = input.clone();
    let mut previous_age = age.clone();
    let mut reached = weathered.clone();
    let mut frames = Vec::with_capacity(params.future);
    for k in 1..=params.future {
        let t = 1.0 + params.future_span * k as f32 / params.future as f32;
        // The clean share that has weathered by t.
        let share = 1.0 - (1.0 - GROWTH_RATE).powf(t - 1.0);
        let front = if clean_times.is_empty() {
            0.0
        } else {
            clean_times[((share * clean_times.len() as f32) as usize).min(clean_times.len() - 1)]
        };
        let evolved = Image::from_fn(w, h, 1, |x, y, p| {
            let i = y * w + x;
            let ramp = ((front - arrival[i]) / RAMP).clamp(0.0, 1.0);
            p[0] = age.data()[i].max(typical * ramp).max(previous_age.data()[i]);
        });
        // Newly reached pixels (the front passed them):
        // filled from weathered material.
        let reached_now = Mask::from_fn(w, h, |x, y| reached.get(x, y) || front >= arrival[y * w + x]);
        let moved = Mask::from_fn(w, h, |x, y| reached_now.get(x, y) && !reached.get(x, y));
        reached = reached_now;
        let current = if moved.count() == 0 {
            previous.clone()
        } else {
            // Fill this frame's band, in the previous frame.
            let target_guide = evolved.map(|v| v * AGE_GUIDE);
            // A rough fill is enough: the rebuild below makes it real material.
            let op = OptimizeParams { patch, levels: Some(2), search_vote_iters: 3, ..OptimizeParams::default() };
            let filled = Synthesis::new(input)
                .fill(&previous, &moved)
                .source_mask(&sources)
                .guides(&source_guide, &target_guide, params.rebuild.guide_weight)
                .seed(rng::derive(seed, &[0xf2, k as u64]))
                .optimize(&op)?
                .image;
            // The fill's vote dulls large holes drawn from a small source
            // set: rebuild it from whole weathered patches, guided by it.
            let filled = rebuild(input, &filled, Some(&sources), Engine::Optimize, &params.rebuild, rng::derive(seed, &[0xf3, k as u64]))?;
            // Taken whole: new damage need not lie farther from the intact
            // colour than the material it replaces (grey bare stone under
            // yellow lichen), and keeping only the pixels that do left
            // just the fill's rims: contour lines.
            blend_where(&previous, &filled, &moved.to_image())
        };
        previous_age = evolved;
        previous = current;
        frames.push(Frame { t, image: previous.clone() });
        progress(k);
    }
    Ok(frames)
}

/// `a` blended towards `b` by `weight` (one channel in [0, 1]). The fill
/// already joins its hole's border, so the band is taken with a hard edge:
/// a feathered one would change the pixels around it a second time.
fn blend_where(a: &Image, b: &Image, weight: &Image) -> Image {
    Image::from_fn(a.width(), a.height(), a.channels(), |x, y, p| {
        let wt = weight.at(x, y, 0);
        for (c, v) in p.iter_mut().enumerate() {
            *v = a.at(x, y, c) * (1.0 - wt) + b.at(x, y, c) * wt;
        }
    })
}
