//! The weathering method on real photos: per photo, the figures of the
//! issue beside time and peak memory, and (with OUT) every output for a
//! contact sheet.
//!
//!     cargo run --release -p patina --example weather_photos -- DIR [SIDE] [OUT] [--growth patches]
//!
//! Each photo is scaled so its longer side is at most SIDE (default 512)
//! and runs the whole method (age map, intact, 3 past and 3 future frames)
//! in a child process, so its peak resident memory is its own. Columns:
//! - s: the whole method's time; age, intact, past, future: its stages';
//! - weathered: the fraction the automatic cut judged weathered;
//! - pacing: the largest share of the intact -> input change that one of
//!   the past steps brings ([`patina::metrics::pacing`]; even = 0.25);
//! - spread: how unevenly over the picture the t = 0.5 frame has made that
//!   change ([`patina::metrics::reveal_spread`]; 0 = every region at the
//!   same stage, 0.5 = half done and half not begun);
//! - t1->t2: the share of pixels that visibly change (colour distance over
//!   0.1) from the input to the t = 2 frame;
//! - coh t2: the t = 2 frame's patch coherence against the input over the
//!   input's own self-similarity (plausible material: at most 0.45 over
//!   1 is the bound, read as coh t2 <= 1.45);
//! - front: of the pixels that newly weather by t = 2, the share within
//!   8 px of the input's weathering (growth from the front, not stamps).
mod common;

use common::peak_rss_mib;
use patina::image::io::{load, save_png, BitDepth};
use patina::image::resample::{resize, Filter};
use patina::image::Mask;
use patina::metrics::{bidirectional, pacing, reveal_spread, self_similarity};
use patina::weather::rebuild::colour_distance;
use patina::weather::{self, Growth, Stage, WeatherParams};
use std::process::Command;
use std::time::Instant;

fn run_one(path: &str, side: usize, out: Option<&str>, growth: Growth) {
    let img = load(path).expect("photo");
    let scale = (side as f32 / img.width().max(img.height()) as f32).min(1.0);
    let (w, h) = (((img.width() as f32 * scale).round() as usize).max(16), ((img.height() as f32 * scale).round() as usize).max(16));
    let img = resize(&img.select_channels(0..img.channels().min(3)), w, h, Filter::Linear).expect("resize");
    let mut params = WeatherParams::default();
    params.sequence.growth = growth;
    // When each stage ended (the last past and last future frame end theirs).
    let ends = std::sync::Mutex::new([0f64; 4]);
    let t = Instant::now();
    let r = weather::weather(&img, &params, Default::default(), 1, &|s| {
        let stage = match s {
            Stage::AgeMap => 0,
            Stage::Intact => 1,
            Stage::Past(..) => 2,
            Stage::Future(..) => 3,
        };
        ends.lock().unwrap()[stage] = t.elapsed().as_secs_f64();
    })
    .expect("weather");
    let secs = t.elapsed().as_secs_f64();
    let stages = ends.into_inner().unwrap();
    let frames: Vec<&patina::Image> = r.frames.iter().map(|f| &f.image).collect();
    let past = &frames[..=4];
    let pace = pacing(past).expect("pacing");
    let spread = reveal_spread(past[0], past[2], past[4]).expect("spread");
    let input = frames[4];
    let last = frames[frames.len() - 1];
    let d = colour_distance(last, input).expect("distance");
    let changed = Mask::from_fn(w, h, |x, y| d[y * w + x] > 0.1);
    let ageing = changed.count() as f32 / (w * h) as f32;
    let ss = self_similarity(input, 7, 3).expect("self-similarity").max(1e-6);
    let coh = bidirectional(last, input, 7, 3).expect("coherence").coherence / ss;
    let from_intact = colour_distance(input, &r.intact).expect("distance");
    let old = Mask::from_fn(w, h, |x, y| from_intact[y * w + x] > 0.1).dilate(8);
    let new_count = changed.count().max(1);
    let near = changed.bits().iter().zip(old.bits()).filter(|(c, o)| **c && **o).count();
    let front = near as f32 / new_count as f32;
    let weathered = r.weathered.map_or(f32::NAN, |w| w.1);
    let name = std::path::Path::new(path).file_stem().unwrap().to_string_lossy().to_string();
    println!(
        "{name}\t{w}x{h}\t{secs:.1}\t{:.1}\t{:.1}\t{:.1}\t{:.1}\t{:.0}\t{weathered:.2}\t{pace:.2}\t{spread:.2}\t{ageing:.3}\t{coh:.2}\t{front:.2}",
        stages[0],
        stages[1] - stages[0],
        stages[2] - stages[1],
        stages[3] - stages[2],
        peak_rss_mib()
    );
    if let Some(dir) = out {
        let dir = std::path::Path::new(dir).join(&name);
        std::fs::create_dir_all(&dir).unwrap();
        save_png(&r.age, dir.join("a_age.png"), BitDepth::Eight).unwrap();
        for (k, f) in r.frames.iter().enumerate() {
            save_png(&f.image, dir.join(format!("f{k}_t{:.2}.png", f.t)), BitDepth::Eight).unwrap();
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let growth = if args.iter().any(|a| a == "patches") { Growth::Patches } else { Growth::Front };
    let args: Vec<&String> = args.iter().filter(|a| *a != "--growth" && *a != "patches").collect();
    if args.first().map(|a| a.as_str()) == Some("--one") {
        let side = args[2].parse().unwrap();
        run_one(args[1], side, args.get(3).map(|s| s.as_str()), growth);
        return;
    }
    let dir = args.first().map_or("../shared/data/weathered", |s| s.as_str());
    let side = args.get(1).map_or("512".to_string(), |s| s.to_string());
    let out = args.get(2);
    let mut photos: Vec<_> = std::fs::read_dir(dir).expect("photo folder").map(|e| e.unwrap().path()).collect();
    photos.sort();
    println!("photo\tsize\ts\tage\tintact\tpast\tfuture\tMiB\tweathered\tpacing\tspread\tt1->t2\tcoh t2\tfront");
    for p in photos {
        let mut cmd = Command::new(std::env::current_exe().unwrap());
        cmd.arg("--one").arg(&p).arg(&side);
        if let Some(o) = out {
            cmd.arg(o);
        }
        if growth == Growth::Patches {
            cmd.arg("patches");
        }
        let o = cmd.output().expect("child");
        print!("{}", String::from_utf8_lossy(&o.stdout));
        if !o.status.success() {
            println!(
                "{}\tfailed: {}",
                p.display(),
                String::from_utf8_lossy(&o.stderr).lines().find(|l| l.contains("panicked") || l.contains("Err")).unwrap_or("")
            );
        }
    }
}
