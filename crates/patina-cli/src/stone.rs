//! `patina stone`: stone weathering in a photograph (Xue et al. 2011).

use crate::output::{save_png, write_sequence, Manifest, OutDir, Stopwatch};
use crate::progress::with_bar;
use patina::image::io::BitDepth;
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
/// fastest), segments.png (the patches, false colour), mask_auto.png (the
/// object found, with `--mask auto`), mask_tNNN.png (the object left
/// standing, when eroding), sequence.gif and manifest.json.
#[derive(clap::Args)]
pub struct Args {
    /// Photo of the stone object (PNG, JPEG, 16-bit PNG, EXR; gamma 2.2 assumed).
    pub photo: PathBuf,
    /// Object mask: a file (white = stone), `auto` (the photo's alpha if it
    /// has one, else the grey stone object found by colour and texture
    /// clustering and cut out by GrabCut, with its shadowed side (darker than
    /// the background around it, of the stone's hue), written as mask_auto.png; the
    /// weathering fades in over 2 px from its outline) or `none` (the whole image).
    #[arg(long, default_value = "auto")]
    pub mask: String,
    /// Output folder.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Times to render, comma-separated, ascending, >= 0 (the paper's scale: 100 = heavily weathered).
    #[arg(long, value_delimiter = ',', default_value = "0,25,50,100", allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 10000.0))]
    pub times: Vec<f32>,
    /// eta: tendency exponent, d = (v / v*)^eta.
    #[arg(long, default_value_t = 0.6, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 10.0))]
    pub eta: f32,
    /// m: tendency window radius r = sqrt(object pixels) / m.
    #[arg(long, default_value_t = 60.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 10000.0))]
    pub m: f32,
    /// k: smoothing speed, w = exp(-k mean d t).
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 10.0))]
    pub k: f32,
    /// n: minimum patch size = object pixels / n.
    #[arg(long, default_value_t = 3200.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 1.0e9))]
    pub n: f32,
    /// Graph-segmentation scale K (Felzenszwalb-Huttenlocher; tendency in 0..255 units).
    #[arg(long, default_value_t = 100.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 1.0e6))]
    pub seg_k: f32,
    /// w_d: how strongly patch matching prefers calm (low-tendency) source patches.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1000.0))]
    pub wd: f32,
    /// nu: roughening weight beta = d^nu.
    #[arg(long, default_value_t = 3.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub nu: f32,
    /// Photo of rough stone to learn the roughening fractal from [default: a built-in procedural sample].
    #[arg(long)]
    pub rough_sample: Option<PathBuf>,
    /// Do not roughen.
    #[arg(long)]
    pub no_roughen: bool,
    /// Do not open pits (small cavities where the stone weathers most).
    #[arg(long)]
    pub no_pits: bool,
    /// Do not erode the silhouette (erosion needs an object mask: a file, alpha or `auto`, not `none`).
    #[arg(long)]
    pub no_erosion: bool,
    /// epsilon: erosion iterations = epsilon sqrt(object pixels) t.
    #[arg(long, default_value_t = 0.0002, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0))]
    pub erosion_speed: f32,
    /// Random seed: the same inputs and seed give the same bytes.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: Args) -> Result<()> {
    let mut clock = Stopwatch::start();
    let mut manifest = Manifest::new("stone", args.seed);
    let mask_file = match args.mask.as_str() {
        "auto" | "none" => None,
        path => Some(PathBuf::from(path)),
    };
    let inputs: Vec<&Path> =
        [Some(args.photo.as_path()), mask_file.as_deref(), args.rough_sample.as_deref()].into_iter().flatten().collect();
    let masks: Vec<String> = (0..args.times.len()).map(|i| format!("mask_t{i:03}.png")).collect();
    let out = OutDir::begin(&args.out, &inputs, args.overwrite)?;
    let dir = out.path();
    let params = StoneParams {
        eta: args.eta,
        m: args.m,
        seg_k: args.seg_k,
        n: args.n,
        wd: args.wd,
        k: args.k,
        nu: args.nu,
        roughen: !args.no_roughen,
        pits: !args.no_pits,
        erosion: !args.no_erosion,
        erosion_speed: args.erosion_speed,
        ..StoneParams::default()
    };
    let photo = crate::input::load(&args.photo)?;
    let has_alpha = photo.channels() == 2 || photo.channels() == 4;
    let (mask, mask_source) = match (&mask_file, args.mask.as_str()) {
        (Some(file), _) => (Some(Mask::from_image(&patina::image::color::luminance(&crate::input::load(file)?))), "file"),
        (None, "none") => (Some(Mask::filled(photo.width(), photo.height(), true)), "none"),
        (None, _) if has_alpha => (None, "alpha"),
        (None, _) => (Some(stone::select::auto_mask(&photo)), "auto"),
    };
    let sample = args.rough_sample.as_ref().map(crate::input::load).transpose()?;
    manifest.timings_ms.insert("load".into(), clock.lap());

    // An automatic mask's outline is cut on the photo's own edges, so it
    // erodes like a hand mask; the weathering fades in over a couple of
    // pixels from it, where the cut may be a pixel off, and it is dilated
    // further than a hand mask to take in the photo's soft outline.
    let params = if mask_source == "auto" {
        StoneParams { feather: stone::select::AUTO_FEATHER, mask_dilation: stone::select::AUTO_DILATION, ..params }
    } else {
        params
    };
    let prepared = stone::prepare(&photo, mask.as_ref(), sample.as_ref(), &params)?;
    manifest.timings_ms.insert("prepare".into(), clock.lap());
    let frames = with_bar("stone", |report| stone::sequence(&prepared, &args.times, args.seed, Some(report)))?;
    manifest.timings_ms.insert("frames".into(), clock.lap());

    if let (Some(found), "auto") = (&mask, mask_source) {
        // The object as found; runs dilate it by mask_dilation, as any mask.
        save_png(&found.to_image(), dir.join("mask_auto.png"), BitDepth::Eight)?;
        manifest.outputs.push("mask_auto.png".into());
    }
    save_png(&prepared.tendency, dir.join("tendency.png"), BitDepth::Eight)?;
    save_png(&segment::false_colour(&prepared.patches, prepared.mask.size()), dir.join("segments.png"), BitDepth::Eight)?;
    manifest.outputs.extend(["tendency.png".into(), "segments.png".into()]);
    let eroding = frames.iter().any(|f| f.mask != prepared.mask);
    if eroding {
        for (f, name) in frames.iter().zip(&masks) {
            save_png(&f.mask.to_image(), dir.join(name), BitDepth::Eight)?;
            manifest.outputs.push(name.into());
        }
    }
    let timed: Vec<(f32, &Image)> = frames.iter().map(|f| (f.t, &f.image)).collect();
    write_sequence(dir, &timed, GIF_DELAY_MS, &mut manifest)?;
    manifest.timings_ms.insert("save".into(), clock.lap());

    let mut p = serde_json::to_value(&params).map_err(|e| Error::Internal(e.to_string()))?;
    p["times"] = json!(args.times);
    p["window_radius"] = json!(stone::tendency::window_radius(prepared.mask.count(), params.m));
    p["patches"] = json!(prepared.patches.len());
    p["fractal_amplitudes"] = json!(prepared.fractal.amplitudes);
    p["masked"] = json!(prepared.masked);
    p["mask_source"] = json!(mask_source);
    // Plants over the stone, left unweathered (stone::select::plants).
    p["plant_pixels"] = json!(prepared.plants.data().iter().filter(|&&v| v >= 0.5).count());
    manifest.params = p;
    manifest.metrics.insert("object_pixels".into(), json!(frames.iter().map(|f| f.mask.count()).collect::<Vec<_>>()));
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.write(&dir.join("manifest.json"))?;
    out.commit()?;
    crate::output::summary(format!("patina stone: {} frames in {}", frames.len(), args.out.display()));
    Ok(())
}
