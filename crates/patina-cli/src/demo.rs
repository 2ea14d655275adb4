//! `patina demo`: the whole pipeline on samples patina makes itself.

use crate::output::{mkdir, save_png, Manifest, OutDir, Stopwatch};
use crate::progress::with_bar;
use clap::Parser;
use patina::image::io::BitDepth;
use patina::synth::{OptimizeParams, QuiltParams, Synthesis};
use patina::{metrics, samples, Error, Result};
use serde_json::json;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Folder for the demo's outputs (created if missing; a previous demo's folder is replaced, any other non-empty folder is refused).
    #[arg(short, long, default_value = "patina-demo")]
    pub out: PathBuf,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

pub fn run(args: Args) -> Result<()> {
    let out = OutDir::begin(&args.out, &[], true)?;
    let dir = out.path();
    let mut clock = Stopwatch::start();
    let mut manifest = Manifest::new("demo", args.seed);
    let exemplar = samples::bricks(128, 128, args.seed);
    let (w, h) = (256, 256);
    manifest.timings_ms.insert("make_exemplar".into(), clock.lap());

    let mut optimize = OptimizeParams::default();
    let optimized =
        with_bar("optimize", |report| Synthesis::new(&exemplar).size(w, h).seed(args.seed).progress(report).optimize(&optimize))?;
    optimize.levels = Some(optimized.levels);
    manifest.timings_ms.insert("optimize".into(), clock.lap());

    let mut quilt = QuiltParams::default();
    let quilted = with_bar("quilt", |report| Synthesis::new(&exemplar).size(w, h).seed(args.seed).progress(report).quilt(&quilt))?;
    (quilt.block, quilt.overlap) = (Some(quilted.plan.block), Some(quilted.plan.overlap));
    manifest.timings_ms.insert("quilt".into(), clock.lap());

    let own = metrics::self_similarity(&exemplar, 5, args.seed)?;
    manifest.metrics.insert("exemplar_self_similarity".into(), json!(own));
    for (name, img) in [("optimize", &optimized.image), ("quilt", &quilted.image)] {
        let b = metrics::bidirectional(img, &exemplar, 5, args.seed)?;
        manifest.metrics.insert(format!("{name}_coherence"), json!(b.coherence));
        manifest.metrics.insert(format!("{name}_completeness"), json!(b.completeness));
    }
    manifest.timings_ms.insert("metrics".into(), clock.lap());

    let files = [("exemplar.png", &exemplar), ("optimize.png", &optimized.image), ("quilt.png", &quilted.image)];
    for (name, img) in files {
        save_png(img, dir.join(name), BitDepth::Eight)?;
        manifest.outputs.push(name.into());
    }
    manifest.timings_ms.insert("save".into(), clock.lap());
    manifest.params = json!({
        "exemplar": { "sample": "bricks", "size": [128, 128] },
        "size": [w, h],
        "optimize": optimize,
        "quilt": quilt,
    });
    manifest.write(&dir.join("manifest.json"))?;
    let samples = dir.join("samples");
    mkdir(&samples)?;
    weather_demo(dir, args.seed)?;
    ttf_demo(dir, args.seed)?;
    stbrdf_demo(dir, args.seed)?;
    stone_demo(dir, args.seed)?;
    decay_demo(dir, args.seed)?;
    out.commit()?;
    eprintln!(
        "patina demo: wrote every output to {} (the generated inputs are in {})",
        args.out.display(),
        args.out.join("samples").display()
    );
    eprintln!(
        "patina demo: browse them with, e.g., patina view {} (or {}, {})",
        args.out.join("weather").display(),
        args.out.join("stbrdf").join("enlarged").display(),
        args.out.join("stone").display()
    );
    Ok(())
}

/// A procedural painted post (256 x 320) and its mask, rusting over 8
/// frames into OUT/decay/ like `patina decay`.
fn decay_demo(dir: &Path, seed: u64) -> Result<()> {
    photo_demo(dir, seed, "decay", samples::painted_post(256, 320, seed), &["--class", "rust"])
}

/// A procedural carved stele (256 x 320) and its mask, weathered into
/// OUT/stone/ like `patina stone`.
fn stone_demo(dir: &Path, seed: u64) -> Result<()> {
    photo_demo(dir, seed, "stone", samples::carved_stele(256, 320, seed), &["--times", "0,50,100,200"])
}

/// Write a procedural photo and its mask as OUT/samples/COMMAND.png and
/// COMMAND_mask.png and run `patina COMMAND PHOTO --mask MASK --out
/// OUT/COMMAND --seed S` with `extra` flags.
fn photo_demo(dir: &Path, seed: u64, command: &str, (photo, mask): (patina::Image, patina::Mask), extra: &[&str]) -> Result<()> {
    let out = dir.join(command);
    let photo_path = dir.join("samples").join(format!("{command}.png"));
    let mask_path = dir.join("samples").join(format!("{command}_mask.png"));
    save_png(&photo, &photo_path, BitDepth::Eight)?;
    save_png(&mask.to_image(), &mask_path, BitDepth::Eight)?;
    let seed = seed.to_string();
    let mut argv: Vec<&OsStr> = vec![command.as_ref(), photo_path.as_os_str(), "--mask".as_ref(), mask_path.as_os_str()];
    argv.extend(["--out".as_ref(), out.as_os_str(), "--seed".as_ref(), seed.as_ref()]);
    argv.extend(extra.iter().map(OsStr::new));
    run_command(&argv)
}

/// A procedural drying-wood material (64 x 64, 11 time steps) fitted with
/// cubics, enlarged to 128 x 128 and rendered at 6 times into OUT/stbrdf/.
fn stbrdf_demo(dir: &Path, seed: u64) -> Result<()> {
    use patina::stbrdf::{enlarge, fit, procedural};
    let dir = dir.join("stbrdf");
    let (steps, times) = procedural::drying_wood(64, 64, 11, seed);
    let fitted = fit::fit(&steps, &times, 3, procedural::drying_wood_params())?;
    fitted.material.save(&dir.join("material"))?;
    let big = enlarge::enlarge(&fitted.material, (128, 128), &enlarge::EnlargeParams::default(), None, seed, None)?;
    let big_dir = dir.join("enlarged");
    big.save(&big_dir)?;
    let renders = dir.join("renders");
    run_command(&[
        "stbrdf".as_ref(),
        "render".as_ref(),
        big_dir.as_os_str(),
        "--out".as_ref(),
        renders.as_os_str(),
        "--frames".as_ref(),
        "6".as_ref(),
    ])
}

/// Run a subcommand parsed exactly as from the command line (so the demo
/// runs with the flags' defaults).
fn run_command(argv: &[&OsStr]) -> Result<()> {
    let cli = crate::Cli::try_parse_from(std::iter::once(OsStr::new("patina")).chain(argv.iter().copied()))
        .map_err(|e| Error::Internal(format!("demo arguments: {e}")))?;
    // The subcommand writes into the demo's staging folder: its own
    // summary would name that, not where the output ends up. Summaries come
    // back when the run ends, also when it unwinds (an embedded cancel).
    struct Quiet;
    impl Drop for Quiet {
        fn drop(&mut self) {
            crate::output::QUIET.store(false, std::sync::atomic::Ordering::Relaxed);
        }
    }
    crate::output::QUIET.store(true, std::sync::atomic::Ordering::Relaxed);
    let _quiet = Quiet;
    crate::dispatch(cli.command)
}

/// A procedural rusting-steel time-lapse (96 x 96, 40 frames) enlarged to
/// 192 x 192 with time jitter, written to OUT/ttf/ like `patina ttf`.
fn ttf_demo(dir: &Path, seed: u64) -> Result<()> {
    let input_dir = dir.join("samples").join("ttf");
    mkdir(&input_dir)?;
    for (i, frame) in samples::rusting_timelapse(96, 96, 40, seed).iter().enumerate() {
        save_png(frame, input_dir.join(format!("{i:03}.png")), BitDepth::Eight)?;
    }
    let out = dir.join("ttf");
    let seed = seed.to_string();
    run_command(&[
        "ttf".as_ref(),
        input_dir.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--size".as_ref(),
        "192x192".as_ref(),
        "--jitter".as_ref(),
        "2".as_ref(),
        "--compare".as_ref(),
        "--seed".as_ref(),
        seed.as_ref(),
    ])
}

/// The flagship: glazed tiles with rust stains, aged back to intact and
/// forward to more rust, written to OUT/weather/ like `patina weather`.
fn weather_demo(dir: &Path, seed: u64) -> Result<()> {
    let clean = samples::tiles(192, 192, seed);
    let (input, _) = samples::weather(&clean, samples::Weathering::Rust, 0.1, seed ^ 0x5eed);
    let input_path = dir.join("samples").join("weather.png");
    save_png(&input, &input_path, BitDepth::Eight)?;
    let out = dir.join("weather");
    let seed = seed.to_string();
    run_command(&["weather".as_ref(), input_path.as_os_str(), "--out".as_ref(), out.as_os_str(), "--seed".as_ref(), seed.as_ref()])
}
