//! `patina stone`: stone weathering in a photograph (Xue et al. 2011).

use crate::output::{mkdir, refuse_overwrite, sequence_outputs, write_sequence, Manifest, Stopwatch};
use crate::progress::with_bar;
use patina::image::io::{self, save_png, BitDepth};
use patina::image::{Image, Mask};
use patina::stone::{self, segment, StoneParams};
use patina::{Error, Result};
use serde_json::json;
use std::path::{Path, PathBuf};

/// How long each frame of sequence.gif is shown.
const GIF_DELAY_MS: u32 = 600;

/// Weather the stone in a photo: carved detail wears smooth, rough spots
/// appear where the stone is busiest, and the silhouette erodes from the top.
///
/// Writes frames/NNN.png (one per time), tendency.png (white = weathers
/// fastest), segments.png (the patches, false colour), mask_tNNN.png (the
/// object left standing, when eroding), sequence.gif and manifest.json.
#[derive(clap::Args)]
pub struct Args {
    /// Photo of the stone object (PNG, JPEG, 16-bit PNG, EXR; gamma 2.2 assumed).
    pub photo: PathBuf,
    /// Object mask, white = stone [default: the photo's alpha, or the whole image].
    #[arg(long)]
    pub mask: Option<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Times to render, comma-separated, ascending, >= 0 (the paper's scale: 100 = heavily weathered).
    #[arg(long, value_delimiter = ',', default_value = "0,25,50,100")]
    pub times: Vec<f32>,
    /// eta: tendency exponent, d = (v / v*)^eta.
    #[arg(long, default_value_t = 0.6)]
    pub eta: f32,
    /// m: tendency window radius r = sqrt(object pixels) / m.
    #[arg(long, default_value_t = 60.0)]
    pub m: f32,
    /// k: smoothing speed, w = exp(-k mean d t).
    #[arg(long, default_value_t = 0.01)]
    pub k: f32,
    /// n: minimum patch size = object pixels / n.
    #[arg(long, default_value_t = 3200.0)]
    pub n: f32,
    /// Graph-segmentation scale K (Felzenszwalb-Huttenlocher; tendency in 0..255 units).
    #[arg(long, default_value_t = 100.0)]
    pub seg_k: f32,
    /// w_d: how strongly patch matching prefers calm (low-tendency) source patches.
    #[arg(long, default_value_t = 1.0)]
    pub wd: f32,
    /// nu: roughening weight beta = d^nu.
    #[arg(long, default_value_t = 3.0)]
    pub nu: f32,
    /// Photo of rough stone to learn the roughening fractal from [default: a built-in procedural sample].
    #[arg(long)]
    pub rough_sample: Option<PathBuf>,
    /// Do not roughen.
    #[arg(long)]
    pub no_roughen: bool,
    /// Do not erode the silhouette (erosion needs a mask or alpha anyway).
    #[arg(long)]
    pub no_erosion: bool,
    /// epsilon: erosion iterations = epsilon sqrt(object pixels) t.
    #[arg(long, default_value_t = 0.0002)]
    pub erosion_speed: f32,
    /// Random seed: the same inputs and seed give the same bytes.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

pub fn run(args: Args) -> Result<()> {
    let mut clock = Stopwatch::start();
    let mut manifest = Manifest::new("stone", args.seed);
    let inputs: Vec<&Path> =
        [Some(args.photo.as_path()), args.mask.as_deref(), args.rough_sample.as_deref()].into_iter().flatten().collect();
    let masks: Vec<String> = (0..args.times.len()).map(|i| format!("mask_t{i:03}.png")).collect();
    let mut extra = vec!["tendency.png", "segments.png"];
    extra.extend(masks.iter().map(String::as_str));
    refuse_overwrite(&sequence_outputs(&args.out, args.times.len(), &extra), &inputs)?;
    let params = StoneParams {
        eta: args.eta,
        m: args.m,
        seg_k: args.seg_k,
        n: args.n,
        wd: args.wd,
        k: args.k,
        nu: args.nu,
        roughen: !args.no_roughen,
        erosion: !args.no_erosion,
        erosion_speed: args.erosion_speed,
        ..StoneParams::default()
    };
    let photo = io::load(&args.photo)?;
    let mask = args.mask.as_ref().map(|m| io::load(m).map(|img| Mask::from_image(&patina::image::color::luminance(&img)))).transpose()?;
    let sample = args.rough_sample.as_ref().map(io::load).transpose()?;
    manifest.timings_ms.insert("load".into(), clock.lap());

    let prepared = stone::prepare(&photo, mask.as_ref(), sample.as_ref(), &params)?;
    manifest.timings_ms.insert("prepare".into(), clock.lap());
    let frames = with_bar("stone", |report| stone::sequence(&prepared, &args.times, args.seed, Some(report)))?;
    manifest.timings_ms.insert("frames".into(), clock.lap());

    mkdir(&args.out)?;
    save_png(&prepared.tendency, args.out.join("tendency.png"), BitDepth::Eight)?;
    save_png(&segment::false_colour(&prepared.patches, prepared.mask.size()), args.out.join("segments.png"), BitDepth::Eight)?;
    manifest.outputs.extend(["tendency.png".into(), "segments.png".into()]);
    let eroding = frames.iter().any(|f| f.mask != prepared.mask);
    if eroding {
        for (f, name) in frames.iter().zip(&masks) {
            save_png(&f.mask.to_image(), args.out.join(name), BitDepth::Eight)?;
            manifest.outputs.push(name.into());
        }
    }
    let timed: Vec<(f32, &Image)> = frames.iter().map(|f| (f.t, &f.image)).collect();
    write_sequence(&args.out, &timed, GIF_DELAY_MS, &mut manifest)?;
    manifest.timings_ms.insert("save".into(), clock.lap());

    let mut p = serde_json::to_value(&params).map_err(|e| Error::Internal(e.to_string()))?;
    p["times"] = json!(args.times);
    p["window_radius"] = json!(stone::tendency::window_radius(prepared.mask.count(), params.m));
    p["patches"] = json!(prepared.patches.len());
    p["fractal_amplitudes"] = json!(prepared.fractal.amplitudes);
    p["masked"] = json!(prepared.masked);
    manifest.params = p;
    manifest.metrics.insert("object_pixels".into(), json!(frames.iter().map(|f| f.mask.count()).collect::<Vec<_>>()));
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.write(&args.out.join("manifest.json"))?;
    println!("patina stone: {} frames in {}", frames.len(), args.out.display());
    Ok(())
}
