//! Engine quality on real exemplars: each structured or stochastic photo of
//! ../shared/data cropped to 256 px (after halving the 1024 px ones) and
//! enlarged to 512 by optimization and by quilting. Prints time, peak
//! memory, coherence and completeness over the exemplar's self-similarity,
//! the block-grid peak over the exemplar's, the large-scale
//! non-stationarity, the near-verbatim repeated share, how often the
//! exemplar's rarest features are copied (`metrics::rare_feature_use`),
//! how far the mix of materials drifts (`metrics::material_drift`),
//! and coherence and completeness of the detail alone (tone removed); writes every
//! output to OUT_DIR (default /tmp/patina-engine) for looking at.
//!
//!     cargo run --release -p patina --example engine_quality [OUT_DIR] [--lit]
//!
//! `--lit` multiplies each exemplar by a vignette and a lighting ramp first,
//! `--flat` synthesizes with flat re-lighting;
//! `--levels N`, `--iters K`, `--patch P`, `--uniformity U` and `--robust`
//! (robust voting) override the optimizer's defaults, `--no-lattice`
//! turns off keeping regular structure in phase, `--rarity R` sets the
//! rare-feature reuse penalty, `--cap C` the quilt's bound on reuse
//! (`QuiltParams::cap`), `--families F` the material-share
//! penalty, `--relative G` the quilt's exponent of the twin error in its
//! overlap costs,
//! `--stagger` staggers the blocks instead of the paper's regular grid,
//! `--seed S` (default 3)
//! seeds the run, `--only NAME` runs one exemplar and `--method M`
//! (optimize or quilt) one method.

mod common;

use patina::image::resample::{resize, Filter};
use patina::metrics;
use patina::synth::{OptimizeParams, QuiltParams, Synthesis};
use patina::Image;
use std::path::Path;
use std::time::Instant;

const SET: [(&str, &str); 12] = [
    ("clean/brick_wall_old_texture.jpg", "bricks"),
    ("clean/skimage_brick_wall_gray.png", "bricks_gray"),
    ("weathered/stained_green_circle_tiles.jpg", "circle_tiles"),
    ("weathered/tile_spalling_brick_facade.png", "tile_facade"),
    ("weathered/weathered_wood_planks_knots.jpg", "planks"),
    ("weathered/lichen_on_roof_tiles.jpg", "roof_tiles"),
    ("weathered/peeling_damask_wallpaper.jpg", "damask"),
    ("weathered/cracked_paint_plaster.jpg", "cracked_paint"),
    ("clean/concrete_walls.jpg", "concrete"),
    ("clean/skimage_gravel_gray.png", "gravel"),
    ("weathered/rust_blooms_on_teal_paint.jpg", "rust_blooms"),
    ("weathered/peeling_red_paint_wood.jpg", "red_paint"),
];

fn exemplar(file: &str) -> Option<Image> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let mut img = patina::image::io::load(root.join(file)).ok()?;
    if img.width().min(img.height()) >= 1024 {
        img = resize(&img, img.width() / 2, img.height() / 2, Filter::Cubic).ok()?;
    }
    let side = img.width().min(img.height()).min(256);
    let img = img.crop((img.width() - side) / 2, (img.height() - side) / 2, side, side).ok()?;
    Some(if img.channels() > 3 { img.select_channels(0..3) } else { img })
}

/// The image minus its blur at sigma 6 px: detail without the tone, so a
/// smooth brightness offset (a gradient-domain seam blend's) is not counted
/// as a coherence defect the eye does not see.
fn detail(img: &Image) -> Image {
    let blur = patina::image::filter::gaussian_blur(img, DETAIL_SIGMA);
    Image::from_fn(img.width(), img.height(), img.channels(), |x, y, p| {
        p.iter_mut().zip(img.pixel(x, y)).zip(blur.pixel(x, y)).for_each(|((o, a), b)| *o = a - b + 0.5)
    })
}

const DETAIL_SIGMA: f32 = 6.0;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let lit_mode = args.iter().any(|a| a == "--lit");
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse::<usize>().ok());
    let mut optimize = OptimizeParams::default();
    optimize.levels = flag("--levels").or(optimize.levels);
    optimize.search_vote_iters = flag("--iters").unwrap_or(optimize.search_vote_iters);
    optimize.patch = flag("--patch").unwrap_or(optimize.patch);
    if let Some(u) = args.iter().position(|a| a == "--uniformity").and_then(|i| args.get(i + 1)).and_then(|v| v.parse::<f32>().ok()) {
        optimize.uniformity = u;
    }
    if args.iter().any(|a| a == "--robust") {
        optimize.vote = patina::synth::VoteWeights::Robust;
    }
    let seed = flag("--seed").unwrap_or(3) as u64;
    let mut quilt = QuiltParams { lattice: !args.iter().any(|a| a == "--no-lattice"), ..QuiltParams::default() };
    if let Some(r) = args.iter().position(|a| a == "--rarity").and_then(|i| args.get(i + 1)).and_then(|v| v.parse::<f32>().ok()) {
        quilt.rarity = r;
    }
    if let Some(f) = args.iter().position(|a| a == "--families").and_then(|i| args.get(i + 1)).and_then(|v| v.parse::<f32>().ok()) {
        quilt.families = f;
    }
    if let Some(r) = args.iter().position(|a| a == "--relative").and_then(|i| args.get(i + 1)).and_then(|v| v.parse::<f32>().ok()) {
        quilt.relative = r;
    }
    if let Some(c) = args.iter().position(|a| a == "--cap").and_then(|i| args.get(i + 1)).and_then(|v| v.parse::<f32>().ok()) {
        quilt.cap = c;
    }
    quilt.stagger = args.iter().any(|a| a == "--stagger");
    optimize.lattice = quilt.lattice;
    let only = args.iter().position(|a| a == "--only").and_then(|i| args.get(i + 1)).cloned();
    let only_method = args.iter().position(|a| a == "--method").and_then(|i| args.get(i + 1)).cloned();
    let out_dir = args.first().filter(|a| !a.starts_with("--")).cloned().unwrap_or_else(|| "/tmp/patina-engine".into());
    std::fs::create_dir_all(&out_dir).expect("output folder");
    println!("| exemplar | method | time (ms) | coherence / self | completeness / self | grid peak / exemplar's | non-stationarity (exemplar) | repeated share | rare use | material drift | detail coherence / completeness |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (file, name) in SET {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let Some(mut ex) = exemplar(file) else { continue };
        if lit_mode {
            ex = patina::samples::lit(&ex);
        }
        let own = metrics::self_similarity(&ex, 5, 1).expect("self-similarity");
        let own_detail = metrics::self_similarity(&detail(&ex), 5, 1).expect("self-similarity");
        let grid0 = metrics::grid_peak(&ex);
        let ns0 = metrics::nonstationarity(&ex);
        patina::image::io::save_png(&ex, Path::new(&out_dir).join(format!("{name}_exemplar.png")), patina::image::io::BitDepth::Eight)
            .unwrap();
        let size = 2 * ex.width();
        for method in ["optimize", "quilt"] {
            if only_method.as_deref().is_some_and(|m| m != method) {
                continue;
            }
            let t = Instant::now();
            let relight = if args.iter().any(|a| a == "--flat") { patina::synth::Relight::Flat } else { patina::synth::Relight::Keep };
            let problem = Synthesis::new(&ex).size(size, size).seed(seed).relight(relight);
            let out = match method {
                "optimize" => problem.optimize(&optimize).expect("optimize").image,
                _ => problem.quilt(&quilt).expect("quilt").image,
            };
            let ms = t.elapsed().as_secs_f64() * 1000.0;
            let b = metrics::bidirectional(&out, &ex, 5, 1).expect("bidirectional");
            let rep = metrics::repeated_share(&out, 9, 16, 1).expect("repeats");
            let rare = metrics::rare_feature_use(&out, &ex, 9, 16, 1).expect("rare use");
            let drift = metrics::material_drift(&out, &ex, 1).expect("material drift");
            let d = metrics::bidirectional(&detail(&out), &detail(&ex), 5, 1).expect("bidirectional");
            println!(
                "| {name} | {method} | {ms:.0} | {:.2} | {:.2} | {:.2} | {:.3} ({:.3}) | {:.3} | {rare:.2} | {drift:.3} | {:.2} / {:.2} |",
                b.coherence / own,
                b.completeness / own,
                metrics::grid_peak(&out) / grid0,
                metrics::nonstationarity(&out),
                ns0,
                rep,
                d.coherence / own_detail,
                d.completeness / own_detail
            );
            patina::image::io::save_png(&out, Path::new(&out_dir).join(format!("{name}_{method}.png")), patina::image::io::BitDepth::Eight)
                .unwrap();
        }
    }
    println!("\npeak RSS {:.0} MiB, {} threads", common::peak_rss_mib(), rayon::current_num_threads());
}
