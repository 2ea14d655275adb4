//! Synthesis and weathering benchmark: prints a table of timings and peak
//! memory. `weather` is the whole single-image method (age map, intact
//! texture, 3 past and 3 future frames).
//!
//!     cargo run --release -p patina --example bench            # full table
//!     cargo run --release -p patina --example bench -- --quick # smaller set
//!
//! Exemplars are crops of the real photos in ../shared/data when present
//! (rust swirls, gravel), else patina's procedural samples. Each case runs
//! in a child process so its peak resident memory (VmHWM) is its own.
//! Timings are the median of 3 runs (1 run for the large cases).

mod common;

use common::peak_rss_mib;
use patina::image::resample::{resize, Filter};
use patina::synth::{OptimizeParams, QuiltParams, Synthesis};
use patina::weather;
use patina::Image;
use std::process::Command;
use std::time::Instant;

fn exemplar(name: &str, side: usize) -> (Image, &'static str) {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let (file, label) = match name {
        "rust" => ("weathered/corroded_rust_swirls.jpg", "rust_swirls"),
        "blooms" => ("weathered/rust_blooms_on_teal_paint.jpg", "rust_blooms"),
        "planks" => ("weathered/weathered_wood_planks_knots.jpg", "wood_planks"),
        _ => ("clean/skimage_gravel_gray.png", "gravel"),
    };
    match patina::image::io::load(root.join(file)) {
        Ok(img) => {
            let s = img.width().min(img.height());
            let sq = img.crop(0, 0, s, s).expect("square crop");
            (resize(&sq, side, side, Filter::Linear).expect("resize"), label)
        }
        Err(_) => (patina::samples::cobbles(side, side, 1), "cobbles (procedural)"),
    }
}

/// Child mode: run one case, print "label ms peak_mib".
fn run_case(method: &str, texture: &str, side: usize, scale: usize, runs: usize) {
    let (ex, label) = exemplar(texture, side);
    let out = side * scale;
    let mut times: Vec<f64> = (0..runs)
        .map(|i| {
            let t = Instant::now();
            let problem = Synthesis::new(&ex).size(out, out).seed(i as u64);
            match method {
                "optimize" => drop(problem.optimize(&OptimizeParams::default()).expect("optimize")),
                "quilt" => drop(problem.quilt(&QuiltParams::default()).expect("quilt")),
                "age-map" => drop(weather::age_map(&ex, &Default::default()).expect("age map")),
                // The whole method: age map, intact, 3 past and 3 future frames.
                _ => drop(weather::weather(&ex, &Default::default(), Default::default(), i as u64, &|_| {}).expect("weather")),
            }
            t.elapsed().as_secs_f64() * 1000.0
        })
        .collect();
    times.sort_by(f64::total_cmp);
    println!("{label}\t{:.0}\t{:.0}", times[times.len() / 2], peak_rss_mib());
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 7 && args[1] == "--case" {
        let n = |i: usize| args[i].parse::<usize>().expect("number");
        return run_case(&args[2], &args[3], n(4), n(5), n(6));
    }
    let quick = args.iter().any(|a| a == "--quick");
    let mut cases: Vec<(&str, &str, usize, usize, usize)> = Vec::new();
    for texture in ["rust", "gravel"] {
        for side in [128, 256] {
            for scale in [2, 4] {
                for method in ["optimize", "quilt"] {
                    cases.push((method, texture, side, scale, 3));
                }
            }
        }
    }
    for texture in ["blooms", "planks"] {
        cases.push(("age-map", texture, 512, 1, 3));
        cases.push(("weather", texture, 512, 1, if quick { 1 } else { 3 }));
    }
    if !quick {
        cases.push(("quilt", "rust", 256, 16, 1));
        cases.push(("optimize", "rust", 512, 8, 1));
        cases.push(("weather", "blooms", 1024, 1, 1));
    }
    let threads = rayon::current_num_threads();
    println!("| method | exemplar | output | time (ms) | peak RSS (MiB) |");
    println!("|---|---|---|---:|---:|");
    let me = std::env::current_exe().expect("own path");
    for (method, texture, side, scale, runs) in cases {
        let out = Command::new(&me)
            .args(["--case", method, texture, &side.to_string(), &scale.to_string(), &runs.to_string()])
            .output()
            .expect("child runs");
        let text = String::from_utf8_lossy(&out.stdout);
        let f: Vec<&str> = text.trim().split('\t').collect();
        if f.len() != 3 {
            println!("| {method} | {texture} {side} | {} | failed: {} | |", side * scale, String::from_utf8_lossy(&out.stderr).trim());
            continue;
        }
        let o = side * scale;
        println!("| {method} | {} {side}x{side} | {o}x{o} | {} | {} |", f[0], f[1], f[2]);
    }
    println!("\n{threads} threads (RAYON_NUM_THREADS to change).");
}
