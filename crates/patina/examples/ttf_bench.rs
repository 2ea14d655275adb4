//! Time-lapse synthesis benchmark (Enrique et al.): prints three tables.
//!
//!     cargo run --release -p patina --example ttf_bench
//!
//! 1. SVD on the real time-lapses in ../shared/data/timelapse: time, the
//!    relative RMS error at rank 15, and the rank that reaches 5% and 2%.
//! 2. Block search: quilting a 256 x 256 output from a 100-frame sequence,
//!    comparing blocks on the rank-15 SVD coefficients vs on every frame.
//! 3. Whole runs with the defaults (SVD, quilting, seam-aligned jitter,
//!    lighting, seam blending, rendering every frame), each input enlarged
//!    2x (128 -> 256 and 256 -> 512, 100 frames), and 500 frames of 256 x
//!    256 -> 512 x 512, with peak memory.
//!
//! Each case of table 3 runs in a child process so its peak resident memory
//! (VmHWM) is its own. Timings are medians of 3 runs (5 for the block
//! search, 1 for the large case).

mod common;

use common::peak_rss_mib;
use patina::image::sequence::load_sequence;
use patina::synth::{PatchMetric, QuiltParams, Synthesis};
use patina::ttf::{synthesize, TemporalBasis, TtfParams};
use patina::Image;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

const SEQUENCES: [&str; 4] = ["rusting_steel", "copper_patinating", "clay_solidifying", "growing_sprouts"];

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/timelapse").join(name)
}

/// A real sequence, or the procedural one when the data is absent.
fn sequence(name: &str, frames: usize) -> (Vec<Image>, String) {
    match load_sequence(data(name)) {
        Ok(s) => {
            let f: Vec<Image> = s.frames.into_iter().take(frames).collect();
            let label = format!("{name} {}x{}x{}", f[0].width(), f[0].height(), f.len());
            (f, label)
        }
        Err(_) => {
            let f = patina::samples::rusting_timelapse(128, 128, frames, 1);
            (f, format!("procedural rust 128x128x{frames}"))
        }
    }
}

fn median_ms(runs: usize, mut f: impl FnMut(usize)) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|i| {
            let s = Instant::now();
            f(i);
            s.elapsed().as_secs_f64() * 1000.0
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn svd_table() {
    println!("| sequence | SVD ms | rel. RMS at k=15 | k for 5% | k for 2% |");
    println!("|---|---:|---:|---:|---:|");
    for name in SEQUENCES {
        let Ok(seq) = load_sequence(data(name)) else {
            println!("| {name} | (missing) | | | |");
            continue;
        };
        let f = &seq.frames;
        let mut basis = None;
        let ms = median_ms(3, |_| basis = Some(TemporalBasis::new(f).expect("svd")));
        let b = basis.expect("ran");
        let label = format!("{name} {}x{}x{}", f[0].width(), f[0].height(), f.len());
        println!("| {label} | {ms:.0} | {:.2}% | {} | {} |", 100.0 * b.relative_rms(15), b.rank_for(0.05), b.rank_for(0.02));
    }
}

fn search_table() {
    println!("\n| sequence | block search on all frames (ms) | on rank-15 coefficients (ms) | speed-up |");
    println!("|---|---:|---:|---:|");
    for name in ["rusting_steel", "growing_sprouts", "clay_solidifying"] {
        let (frames, label) = sequence(name, 100);
        let n = frames.len();
        let basis = TemporalBasis::new(&frames).expect("svd");
        let coef = basis.coefficients(&frames, 15).expect("coefficients");
        let full = patina::ttf::stack(&frames, &vec![1.0; n]).expect("stack");
        let time = |features: &Image| {
            median_ms(5, |i| {
                let metric = PatchMetric::ssd(vec![1.0 / n as f32; features.channels()]);
                let q = Synthesis::new(features).size(256, 256).metric(metric).seed(i as u64).quilt(&QuiltParams::default());
                drop(q.expect("quilt"));
            })
        };
        let (a, b) = (time(&full), time(&coef));
        println!("| {label} | {a:.0} | {b:.0} | {:.1}x |", a / b);
    }
}

/// Child mode: one whole run; prints "label ms peak_mib".
fn run_case(case: &str) {
    let (frames, label, size, runs) = match case {
        "500" => {
            // 500 frames of 256 x 256: clay_solidifying played forwards and
            // backwards (or the procedural sequence when the data is absent).
            let (base, label) = match load_sequence(data("clay_solidifying")) {
                Ok(s) => (s.frames, "clay_solidifying ping-pong 256x256x500".to_string()),
                Err(_) => (patina::samples::rusting_timelapse(256, 256, 100, 2), "procedural rust 256x256x500".to_string()),
            };
            let n = base.len();
            let frames: Vec<Image> = (0..500).map(|t| base[if (t / n) % 2 == 0 { t % n } else { n - 1 - t % n }].clone()).collect();
            (frames, label, (512, 512), 1)
        }
        name => {
            let (f, label) = sequence(name, 100);
            let size = (2 * f[0].width(), 2 * f[0].height());
            (f, label, size, 3)
        }
    };
    let ms = median_ms(runs, |i| drop(synthesize(&frames, size, &TtfParams::default(), None, i as u64, None).expect("ttf")));
    println!("{label} -> {}x{}x{}\t{ms:.0}\t{:.0}", size.0, size.1, frames.len(), peak_rss_mib());
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 3 && args[1] == "--case" {
        return run_case(&args[2]);
    }
    svd_table();
    search_table();
    println!("\n| whole run (rank 15) | ms | peak MiB |");
    println!("|---|---:|---:|");
    let exe = std::env::current_exe().expect("own path");
    for case in ["rusting_steel", "growing_sprouts", "copper_patinating", "500"] {
        let out = Command::new(&exe).args(["--case", case]).output().expect("child runs");
        let line = String::from_utf8_lossy(&out.stdout);
        let parts: Vec<&str> = line.trim().split('\t').collect();
        match parts.as_slice() {
            [label, ms, mib] => println!("| {label} | {ms} | {mib} |"),
            _ => println!("| {case} | failed: {} | |", String::from_utf8_lossy(&out.stderr).trim()),
        }
    }
}
