//! Spatio-temporal BRDF benchmark (Meister et al. 2021): prints a table.
//!
//!     cargo run --release -p patina --example stbrdf_bench
//!
//! - Distance: the closed-form b^T H b (eq. 14) against 50-sample
//!   summation (eq. 15), per 7-parameter degree-3 texel pair.
//! - Fit: 512 x 512 x 50 time steps x 7 channels, degree 3.
//! - Registration (before fitting a capture whose camera shakes): 100
//!   frames of 256 x 256 cut from a rusting time-lapse at offsets of up to
//!   16 px, and whether every offset is found exactly.
//! - Enlarge: a 128 x 128 degree-3 drying-wood material to 512 x 512.
//! - Transfer (grow mode): a 128 x 128 rusting time-lapse, fitted at degree
//!   3, onto a 512 x 512 texture.

mod common;

use common::peak_rss_mib;
use patina::image::register::Registration;
use patina::stbrdf::poly::{sampled_distance, PolyDistance};
use patina::stbrdf::procedural::{drying_wood, drying_wood_at, drying_wood_params};
use patina::stbrdf::transfer::{transfer, TransferParams};
use patina::stbrdf::{enlarge::enlarge, fit::fit, Param};
use patina::synth::TexelDistance;
use std::hint::black_box;
use std::time::Instant;

fn main() {
    // Distances between 100 000 pseudo-random texel pairs.
    let pairs: Vec<([f32; 28], [f32; 28])> = (0..100_000u32)
        .map(|i| {
            let v = |k: u32| ((i.wrapping_mul(2654435761).wrapping_add(k * 40503)) % 1000) as f32 / 1000.0 - 0.5;
            (std::array::from_fn(|k| v(k as u32)), std::array::from_fn(|k| v(k as u32 + 77)))
        })
        .collect();
    let closed = PolyDistance::new(3);
    let t = Instant::now();
    let a: f32 = pairs.iter().map(|(p, q)| closed.cost(black_box(p), black_box(q))).sum();
    let closed_ns = t.elapsed().as_secs_f64() * 1e9 / pairs.len() as f64;
    let t = Instant::now();
    let b: f32 = pairs.iter().map(|(p, q)| sampled_distance(black_box(p), black_box(q), 3, 50)).sum();
    let sampled_ns = t.elapsed().as_secs_f64() * 1e9 / pairs.len() as f64;
    println!("| case | time | note |");
    println!("|---|---:|---|");
    println!("| distance, closed form (eq. 14) | {closed_ns:.1} ns/texel pair | 7 parameters, degree 3 |");
    println!(
        "| distance, 50 samples (eq. 15) | {sampled_ns:.1} ns/texel pair | {:.1}x slower; sums agree to {:.2}% |",
        sampled_ns / closed_ns,
        100.0 * (a - b).abs() / a
    );

    let times: Vec<f32> = (0..50).map(|i| i as f32 / 49.0).collect();
    let frames: Vec<_> = times.iter().map(|&t| drying_wood_at(512, 512, t, 1)).collect();
    let t = Instant::now();
    let fitted = fit(&frames, &times, 3, drying_wood_params()).expect("fit");
    println!(
        "| fit 512x512 x 50 steps x 7 channels, d = 3 | {:.0} ms | max channel RMS {:.4} |",
        t.elapsed().as_secs_f64() * 1000.0,
        fitted.rms.iter().copied().fold(0.0f32, f32::max)
    );
    drop(frames);

    // A shaking camera: frame i is the rusting sequence's frame i seen
    // through a 256 x 256 window at a pseudo-random place within 16 px.
    let canvas = patina::samples::rusting_timelapse(272, 272, 100, 7);
    let moves: Vec<[i32; 2]> = (0..100).map(|i: i32| [(i * 7919) % 17, (i * 104_729) % 17]).collect();
    let shaking: Vec<_> = canvas
        .iter()
        .zip(&moves)
        .map(|(f, m)| patina::Image::from_fn(256, 256, 3, |x, y, p| p.copy_from_slice(&f.pixel(x + m[0] as usize, y + m[1] as usize)[..3])))
        .collect();
    drop(canvas);
    let t = Instant::now();
    let registration = Registration::of(&shaking, 0..3).expect("registration");
    let exact = registration.offsets.iter().zip(&moves).filter(|(o, m)| **o == [moves[0][0] - m[0], moves[0][1] - m[1]]).count();
    println!(
        "| register 100 frames of 256x256 (moves up to 16 px) | {:.0} ms | {exact} of 100 offsets exact; window {}x{} |",
        t.elapsed().as_secs_f64() * 1000.0,
        registration.window[2],
        registration.window[3]
    );
    drop(shaking);

    let (small, small_times) = drying_wood(128, 128, 11, 3);
    let wood = fit(&small, &small_times, 3, drying_wood_params()).expect("fit").material;
    let t = Instant::now();
    let big = enlarge(&wood, (512, 512), &Default::default(), None, 1, None).expect("enlarge");
    println!(
        "| enlarge 128x128 -> 512x512, d = 3 (28 channels) | {:.0} ms | {}x{} |",
        t.elapsed().as_secs_f64() * 1000.0,
        big.size().0,
        big.size().1
    );

    let frames = patina::samples::rusting_timelapse(128, 128, 21, 5);
    let steps: Vec<f32> = (0..21).map(|i| i as f32 / 20.0).collect();
    let rust = fit(&frames, &steps, 3, vec![Param { name: "Diffuse".into(), channels: 3 }]).expect("fit").material;
    let target = patina::samples::cobbles(512, 512, 2);
    let t = Instant::now();
    let grown = transfer(&rust, &target, None, &TransferParams::default(), 1, None).expect("transfer");
    println!(
        "| transfer, grow mode, 128x128 rust -> 512x512 | {:.0} ms | degree {} result |",
        t.elapsed().as_secs_f64() * 1000.0,
        grown.material.degree
    );
    println!("\npeak memory: {:.0} MiB", peak_rss_mib());
}
