//! Natural image decay benchmark (Hao et al. 2023): prints tables.
//!
//!     cargo run --release -p patina --example decay_bench [PHOTO MASK]
//!     cargo run --release -p patina --example decay_bench --diffusion   (table 4 only)
//!
//! 1. A 2048 x 2048 decay texture per class (procedural generator).
//! 2. Stationarity (eq. 10, fixed filter bank) at 256, 1024 and 2048: with
//!    fixed 64 x 64 crops (mean of 4 / 2 / 1 seeds) and with the paper's
//!    quarter-size crops (seed 1).
//! 3. `decay` on a 1-megapixel photo (1152 x 868: a procedural painted
//!    post, or PHOTO with MASK resized to it) with 8 frames, per class:
//!    texture, shading, Algorithm 1 (prepare), then diffusion and
//!    compositing per frame.
//! 4. Decay diffusion alone (eq. 4, a disc mask, default spread): 8 frames
//!    at 512, 1024 and 2048 px, and the 2048 / 1024 time ratio.

mod common;

use common::peak_rss_mib;
use patina::decay::{self, texture, DecayClass, DecayParams, Inputs, Substrate};
use patina::metrics::stationarity;
use std::time::Instant;

const W: usize = 1152;
const H: usize = 868;

fn diffusion_table() {
    use patina::decay::degree;
    println!("| diffusion, 8 frames | 512 | 1024 | 2048 | 2048 / 1024 |");
    println!("|---|---:|---:|---:|---:|");
    let mut secs = Vec::new();
    for side in [512usize, 1024, 2048] {
        let c = side as f32 / 2.0;
        let mask = patina::Mask::from_fn(side, side, |x, y| (x as f32 - c).powi(2) + (y as f32 - c).powi(2) < (0.45 * side as f32).powi(2));
        let (mut d, _) = degree::initial(&mask, 0.2, 0.06, None, 1).expect("initial");
        let t = Instant::now();
        let diffuser = degree::Diffuser::new(&mask, None, &decay::Diffusion::default());
        for k in 1..=8 {
            diffuser.step(&mut d, 1, k);
        }
        secs.push(t.elapsed().as_secs_f64());
    }
    println!("| seconds | {:.2} | {:.2} | {:.2} | {:.1} |\n", secs[0], secs[1], secs[2], secs[2] / secs[1]);
}

fn main() {
    if std::env::args().nth(1).as_deref() == Some("--diffusion") {
        return diffusion_table();
    }
    diffusion_table();
    println!("| class | 2048x2048 texture |");
    println!("|---|---:|");
    for class in DecayClass::ALL {
        let t = Instant::now();
        let tex = texture::generate(class, 1, 0, 0, 2048, 2048, Substrate::Paint).expect("texture");
        println!("| {} | {:.2} s |", class.name(), t.elapsed().as_secs_f64());
        drop(tex);
    }
    println!("| peak memory so far | {:.0} MiB |\n", peak_rss_mib());

    println!("| class | 256 (64 px crops) | 1024 | 2048 | max/min | 256 (1/4 crops) | 1024 | 2048 |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for class in DecayClass::ALL {
        let rgb = |n, seed| texture::generate(class, seed, 0, 0, n, n, Substrate::Paint).expect("texture").select_channels(0..3);
        let fixed: Vec<f64> = [(256, 4u64), (1024, 2), (2048, 1)]
            .iter()
            .map(|&(n, seeds)| {
                (1..=seeds).map(|s| stationarity(&rgb(n, s), Some((64, 64)), 64, 0).expect("metric").mean).sum::<f64>() / seeds as f64
            })
            .collect();
        let quarter: Vec<f64> = [256, 1024, 2048].iter().map(|&n| stationarity(&rgb(n, 1), None, 64, 0).expect("metric").mean).collect();
        let ratio = fixed.iter().cloned().fold(0.0, f64::max) / fixed.iter().cloned().fold(f64::MAX, f64::min);
        println!(
            "| {} | {:.3} | {:.3} | {:.3} | {ratio:.2} | {:.3} | {:.3} | {:.3} |",
            class.name(),
            fixed[0],
            fixed[1],
            fixed[2],
            quarter[0],
            quarter[1],
            quarter[2]
        );
    }
    println!();

    let (photo, mask, name) = common::photo_and_mask(W, H, || {
        let (p, m) = patina::samples::painted_post(W, H, 1);
        (p, m, "procedural painted post".into())
    });
    println!("| {name}, {W}x{H} ({:.2} MP), 8 frames | prepare | 8 frames | total |", (W * H) as f64 / 1e6);
    println!("|---|---:|---:|---:|");
    for class in DecayClass::ALL {
        let t = Instant::now();
        let prep =
            decay::prepare(&photo, Inputs { mask: Some(&mask), ..Default::default() }, &DecayParams::new(class), 1).expect("prepare");
        let prepare_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let frames = decay::sequence(&prep, 8, 1, None).expect("sequence");
        let frames_s = t.elapsed().as_secs_f64();
        assert_eq!(frames.len(), 8);
        println!("| {} | {prepare_s:.2} s | {frames_s:.2} s | {:.2} s |", class.name(), prepare_s + frames_s);
    }
    let t = Instant::now();
    let found = patina::image::grabcut::salient_object(&photo, None);
    let both = found.bits().iter().zip(mask.bits()).filter(|(a, b)| **a && **b).count();
    let either = found.bits().iter().zip(mask.bits()).filter(|(a, b)| **a || **b).count();
    println!(
        "| `--mask auto` (main object; IoU {:.3} with the mask) | {:.2} s | | |",
        both as f64 / either.max(1) as f64,
        t.elapsed().as_secs_f64()
    );
    println!("| peak memory | {:.0} MiB |", peak_rss_mib());
}
