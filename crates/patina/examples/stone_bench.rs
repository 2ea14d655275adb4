//! Stone weathering benchmark (Xue et al. 2011): prints a table.
//!
//!     cargo run --release -p patina --example stone_bench [PHOTO MASK]
//!
//! A 1-megapixel photo (1152 x 868: a procedural carved slab, or PHOTO
//! with MASK resized to it) at 4 time steps (0, 25, 50, 100), with every
//! stage on: the automatic mask (timed alone; the runs use MASK), tendency, segmentation, patch matching (prepare), then per
//! time Poisson updating, roughening, contrast and erosion with its fill.

mod common;

use common::peak_rss_mib;
use patina::image::{Image, Mask};
use patina::stone::{self, StoneParams};
use std::time::Instant;

const W: usize = 1152;
const H: usize = 868;

fn procedural() -> (Image, Mask) {
    let mask = Mask::from_fn(W, H, |x, y| (100..W - 100).contains(&x) && (120..H - 60).contains(&y));
    let stone = patina::samples::rough_stone(W, H, 2);
    let img = Image::from_fn(W, H, 3, |x, y, p| {
        if mask.get(x, y) {
            let carve = if (300..600).contains(&y) && (250..900).contains(&x) && (x / 40 + y / 60) % 2 == 0 { 0.15 } else { 0.0 };
            let v = 0.35 + 0.3 * stone.at(x, y, 0) + carve;
            p.copy_from_slice(&[v, v * 0.97, v * 0.93]);
        } else {
            let m = patina::samples::value_noise(3, x as f32 / 9.0, y as f32 / 9.0);
            p.copy_from_slice(&[0.2 * m, 0.4 * m + 0.1, 0.1]);
        }
    });
    (img, mask)
}

fn main() {
    let (photo, mask, name) = common::photo_and_mask(W, H, || {
        let (p, m) = procedural();
        (p, m, "procedural slab".into())
    });
    let params = StoneParams::default();
    let t = Instant::now();
    let found = stone::select::auto_mask(&photo);
    let select_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let prep = stone::prepare(&photo, Some(&mask), None, &params).expect("prepare");
    let prepare_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let frames = stone::sequence(&prep, &[0.0, 25.0, 50.0, 100.0], 1, None).expect("sequence");
    let frames_s = t.elapsed().as_secs_f64();
    println!("| {name}, {W}x{H} ({:.2} MP), 4 times | time |", (W * H) as f64 / 1e6);
    println!("|---|---:|");
    println!(
        "| `--mask auto`: clusters + GrabCut ({:.0}% of the photo) | {select_s:.2} s |",
        100.0 * found.count() as f64 / (W * H) as f64
    );
    println!("| prepare: tendency, {} patches, matching, fractal | {prepare_s:.2} s |", prep.patches.len());
    println!("| 4 frames: Poisson, roughen, contrast, erosion + fill | {frames_s:.2} s |");
    println!("| total | {:.2} s |", prepare_s + frames_s);
    println!("| eroded pixels at t = 100 | {} |", mask.count() - frames[3].mask.count());
    println!("| peak memory | {:.0} MiB |", peak_rss_mib());
}
