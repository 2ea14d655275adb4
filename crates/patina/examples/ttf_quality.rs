//! Time-lapse synthesis quality on real sequences (issue 17): each sequence
//! in ../shared/data/timelapse (and a procedural one under a vignette) is
//! enlarged 2x, and the figures of the issue are printed per setting:
//!
//! - grid: the block-grid peak of the output's gradient profile over the
//!   input's ([`patina::metrics::grid_peak`]), at the middle and last frame;
//! - repeats: near-verbatim repeated share of the middle frame;
//! - flicker: mean frame-to-frame change of the output over the input's;
//! - seams: how much worse the output's patches are on the cuts between
//!   blocks than inside them, at the first frame, 10% in and the middle
//!   (see `cut_lines`; 0 = invisible cuts);
//! - brightness: the output's mean luminance over the input frame's at the
//!   same time, at frames 1/4, 1/2, 3/4 and the last in (the mix of
//!   materials kept over time: more rust or leaves than the input's shows
//!   as a lower or higher ratio);
//! - drift: how far the output's mix of materials is from the input
//!   frame's at the same time ([`patina::metrics::material_drift`], 0 = the
//!   same mix; against the input's detail layer when the lighting was
//!   split), at the middle and the last frame: a material the quilt
//!   starves (copper's patina) or spreads shows here;
//! - time and frames.
//!
//!     cargo run --release -p patina --example ttf_quality [OUT_DIR]
//!
//! With OUT_DIR, the middle frame of every run is written there as
//! NAME_SETTING.png (for contact sheets). `TTF_FRAMES` caps the frames per
//! sequence (default 40), `TTF_ONLY` runs one sequence, `TTF_SEED` sets
//! the seed (default 1), `TTF_HEAL` adds the run with the cuts healed.

use patina::image::io::{save_png, BitDepth};
use patina::image::sequence::load_sequence;
use patina::metrics::{flicker, grid_peak, material_drift, repeated_share, seam_visibility};
use patina::synth::QuiltParams;
use patina::ttf::{input_nonstationarity, synthesize, SequenceLighting, TtfParams};
use patina::Image;
use patina::Mask;
use std::path::PathBuf;
use std::time::Instant;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/timelapse").join(name)
}

fn main() {
    let out_dir = std::env::args().nth(1).map(PathBuf::from);
    if let Some(d) = &out_dir {
        std::fs::create_dir_all(d).expect("out dir");
    }
    let cap: usize = std::env::var("TTF_FRAMES").ok().and_then(|v| v.parse().ok()).unwrap_or(40);
    let only = std::env::var("TTF_ONLY").ok();
    let seed: u64 = std::env::var("TTF_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let mut sequences: Vec<(String, Vec<Image>)> = Vec::new();
    for name in ["copper_patinating", "clay_solidifying", "growing_sprouts", "rusting_steel"] {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        if let Ok(s) = load_sequence(data(name)) {
            let n = s.frames.len();
            let step = n.div_ceil(cap).max(1);
            sequences.push((name.to_string(), s.frames.into_iter().step_by(step).collect()));
        }
    }
    if only.as_deref().is_none_or(|o| o == "vignetted_rust") {
        let f = patina::samples::rusting_timelapse(128, 128, cap, 3);
        sequences.push(("vignetted_rust".into(), patina::samples::vignette(&f, 0.6)));
    }
    let mut settings: Vec<(String, TtfParams)> = vec![("default".into(), TtfParams::default()), ("paper".into(), TtfParams::paper())];
    if std::env::var("TTF_ABLATE").is_ok() {
        let d = TtfParams::default();
        settings.push(("no-jitter".into(), TtfParams { jitter: Some(0.0), ..d.clone() }));
        settings.push(("heal".into(), TtfParams { heal: true, ..d.clone() }));
        settings.push(("no-blend".into(), TtfParams { quilt: QuiltParams { blend: false, ..d.quilt.clone() }, ..d.clone() }));
        settings.push(("keep-light".into(), TtfParams { lighting: SequenceLighting::Keep, ..d.clone() }));
        settings.push(("no-reuse".into(), TtfParams { quilt: QuiltParams { reuse: 0.0, ..d.quilt.clone() }, ..d.clone() }));
        settings.push(("no-balance".into(), TtfParams { balance: false, ..d.clone() }));
        settings.push(("families".into(), TtfParams { quilt: QuiltParams { families: 1.0, ..d.quilt.clone() }, ..d.clone() }));
    }
    // TTF_HEAL adds the default settings with the cuts healed.
    if std::env::var("TTF_HEAL").is_ok() {
        settings.push(("heal".into(), TtfParams { heal: true, ..TtfParams::default() }));
    }
    // TTF_FAM="0,4" adds default settings with those material-share weights.
    for f in std::env::var("TTF_FAM").unwrap_or_default().split(',').filter(|s| !s.is_empty()) {
        let d = TtfParams::default();
        let v: f32 = f.parse().unwrap();
        settings.push((format!("fam{f}"), TtfParams { quilt: QuiltParams { families: v, ..d.quilt.clone() }, ..d.clone() }));
    }
    // TTF_TRY="BLOCK,OVERLAP;..." adds default settings with those sizes.
    for spec in std::env::var("TTF_TRY").unwrap_or_default().split(';').filter(|s| !s.is_empty()) {
        let v: Vec<usize> = spec.split(',').map(|x| x.parse().expect("BLOCK,OVERLAP")).collect();
        let mut p = TtfParams::default();
        p.quilt.block = Some((v[0], v[0]));
        p.quilt.overlap = Some((v[1], v[1]));
        settings.push((format!("b{}o{}", v[0], v[1]), p));
    }
    println!(
        "| sequence | setting | grid mid | grid last | repeats mid | flicker ratio | seams first / f2 / 10% / mid | brightness 1/4 1/2 3/4 last | drift mid / last | lighting | time s |"
    );
    println!("|---|---|---:|---:|---:|---:|---|---|---|---|---:|");
    for (name, frames) in &sequences {
        let (w, h) = frames[0].size();
        let n = frames.len();
        let (g_mid, g_last) = (grid_peak(&frames[n / 2]), grid_peak(&frames[n - 1]));
        let f_in = flicker(frames);
        let rep_in = repeated_share(&frames[n / 2], 9, 16, 1).expect("repeats");
        println!(
            "| {name} {w}x{h}x{n} | input | 1 | 1 | {rep_in:.3} | 1 | {:.3} | 1 | 0 0 | |",
            input_nonstationarity(frames).expect("frames")
        );
        for (label, params) in &settings {
            let start = Instant::now();
            let out = synthesize(frames, (2 * w, 2 * h), params, None, seed, None).expect("synthesize");
            let secs = start.elapsed().as_secs_f64();
            let o = &out.frames;
            let rep = repeated_share(&o[n / 2], 9, 16, 1).expect("repeats");
            let (cuts, interior) = cut_lines(&out.plan.labels(), 2 * w, 2 * h);
            let seams: Vec<String> = [0, 2.min(n - 1), n / 10, n / 2]
                .iter()
                .map(|&t| {
                    let near = times_around(frames, t);
                    let on = seam_visibility(&o[t], &near, &cuts, 7, 1).expect("seams");
                    let off = seam_visibility(&o[t], &near, &interior, 7, 1).expect("seams");
                    let own = patina::metrics::self_similarity(&frames[t], 7, 1).expect("self-similarity");
                    format!("{:.2} {:.2}", (on - off) / own.max(1e-6), tone_steps(&o[t], &cuts, &interior))
                })
                .collect();
            let lum = |f: &Image| {
                let l = patina::image::color::luminance(f);
                l.data().iter().map(|&v| f64::from(v)).sum::<f64>() / l.data().len() as f64
            };
            let brightness: Vec<String> =
                [n / 4, n / 2, 3 * n / 4, n - 1].iter().map(|&t| format!("{:.2}", lum(&o[t]) / lum(&frames[t]))).collect();
            // A split output is lit flat: its mix is compared with the
            // input's detail layer, not with the frames under their light.
            let detail = out.lighting.map(|_| patina::synth::lighting::separate_sequence(frames).expect("separate").1);
            let drift = |t: usize| material_drift(&o[t], &detail.as_deref().unwrap_or(frames)[t], 1).expect("drift");
            println!(
                "| {name} | {label} | {:.2} | {:.2} | {rep:.3} | {:.2} | {} | {} | {:.3} {:.3} | {} | {secs:.1} |",
                grid_peak(&o[n / 2]) / g_mid,
                grid_peak(&o[n - 1]) / g_last,
                flicker(o) / f_in,
                seams.join(" / "),
                brightness.join(" "),
                drift(n / 2),
                drift(n - 1),
                if out.lighting.is_some() { "split" } else { "kept" },
            );
            if let Some(d) = &out_dir {
                save_png(&o[n / 2], d.join(format!("{name}_{label}.png")), BitDepth::Eight).expect("save");
                save_png(&frames[n / 2], d.join(format!("{name}_input.png")), BitDepth::Eight).expect("save");
            }
        }
    }
}

/// Tone steps along the cuts: the mean gradient of the 2 px-blurred
/// luminance on cut pixels over that inside the blocks (1 = no step; fine
/// texture is blurred away, brightness jumps between blocks are not).
fn tone_steps(img: &Image, cuts: &Mask, interior: &Mask) -> f64 {
    let l = patina::image::filter::gaussian_blur(&patina::image::color::luminance(img), 2.0);
    let (w, h) = l.size();
    let (mut on, mut non, mut off, mut noff) = (0.0f64, 0usize, 0.0f64, 0usize);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let g = f64::from((l.at(x + 1, y, 0) - l.at(x - 1, y, 0)).hypot(l.at(x, y + 1, 0) - l.at(x, y - 1, 0)));
            if cuts.get(x, y) {
                on += g;
                non += 1;
            } else if interior.get(x, y) {
                off += g;
                noff += 1;
            }
        }
    }
    (on / non.max(1) as f64) / (off / noff.max(1) as f64).max(1e-12)
}

/// The input frames within 8 of `t` (every 4th), side by side: what a
/// jittered output frame may show.
fn times_around(frames: &[Image], t: usize) -> Image {
    let picked: Vec<&Image> = (t.saturating_sub(8)..(t + 9).min(frames.len())).step_by(4).map(|u| &frames[u]).collect();
    let (w, h, c) = (frames[0].width(), frames[0].height(), frames[0].channels());
    let mut out = Image::new(w * picked.len(), h, c);
    for (k, f) in picked.iter().enumerate() {
        for y in 0..h {
            for x in 0..w {
                out.pixel_mut(k * w + x, y).copy_from_slice(f.pixel(x, y));
            }
        }
    }
    out
}

/// The output pixels on a cut between two blocks (a pixel whose right or
/// lower neighbour came from another block) and those at least 4 px from
/// any cut: the seam measure is the coherence on cuts minus that inside the
/// blocks (against the input frames within 8 of the output's), over the
/// input frame's self-similarity (0 = a seam as good as the blocks' insides).
fn cut_lines(labels: &[u32], w: usize, h: usize) -> (Mask, Mask) {
    let on = |x: usize, y: usize| {
        let l = labels[y * w + x];
        (x + 1 < w && labels[y * w + x + 1] != l) || (y + 1 < h && labels[(y + 1) * w + x] != l)
    };
    let cuts = Mask::from_fn(w, h, on);
    let near = |x: usize, y: usize| {
        (y.saturating_sub(4)..(y + 5).min(h)).any(|yy| (x.saturating_sub(4)..(x + 5).min(w)).any(|xx| cuts.get(xx, yy)))
    };
    let interior = Mask::from_fn(w, h, |x, y| !near(x, y));
    (cuts, interior)
}
