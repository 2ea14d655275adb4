//! `patina weather`, `patina age-map`, `patina intact` and
//! `patina weather-transfer`: texture weathering from a single image
//! (Bellini et al. 2016).

use crate::output::{check_outputs, manifest_path, save_png, write_sequence, Manifest, OutDir, Stopwatch};
use crate::progress::with_bar;
use patina::image::io::{self, BitDepth};
use patina::image::{Image, Mask};
use patina::weather::{self, age_map, intact, transfer, Overrides, Stage, Until, WeatherParams};
use patina::{Error, Result};
use serde_json::json;
use std::path::{Path, PathBuf};

/// How long each frame of sequence.gif is shown.
const GIF_DELAY_MS: u32 = 400;

/// A weathering sequence as (t, frame) pairs for [`write_sequence`].
fn timed(frames: &[weather::Frame]) -> Vec<(f32, &Image)> {
    frames.iter().map(|f| (f.t, &f.image)).collect()
}

/// `--growth` choices.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum GrowthArg {
    Front,
    Patches,
}

impl From<GrowthArg> for weather::Growth {
    fn from(g: GrowthArg) -> Self {
        match g {
            GrowthArg::Front => weather::Growth::Front,
            GrowthArg::Patches => weather::Growth::Patches,
        }
    }
}

/// Which part of the image weathers, and which material is the weathering:
/// flags of `weather`, `age-map` and `intact`.
#[derive(clap::Args, Clone)]
pub struct SurfaceArgs {
    /// The surface to weather: a mask file (white = weathers), `auto` (the object under --point, or else the photo's main object: the largest central region unlike the picture's frame, cut out by GrabCut and written as mask_auto.png beside the outputs) or `none` (the whole image). Pixels outside keep the input and play no part in the age map (no match, region or source comes from them); their age is 0.
    #[arg(long, default_value = "none")]
    pub mask: String,
    /// With --mask auto: a pixel X,Y (from the top left) on the object to weather [default: the main object].
    #[arg(long, value_parser = crate::object::parse_point)]
    pub point: Option<(usize, usize)>,
    /// A pixel X,Y (from the top left) on weathering. The age map calls the commoner material intact, which is wrong when the weathering covers most of the surface (more rust than paint, stone under lichen); if it judged this pixel intact, it is turned over [default: the age map as found].
    #[arg(long, value_parser = crate::object::parse_point)]
    pub weathered_at: Option<(usize, usize)>,
}

impl SurfaceArgs {
    /// The mask file named, if any (an input of the run).
    fn file(&self) -> Result<Option<PathBuf>> {
        crate::object::mask_file(&self.mask, self.point)
    }

    /// The mask asked for on `input`.
    fn resolve(&self, input: &Image) -> Result<Option<Mask>> {
        crate::object::resolve(&self.mask, self.point, input)
    }

    /// Records in `p` where the mask came from and whether the age map was
    /// turned over, and writes a found mask to `mask_file` (listed in the
    /// manifest's outputs).
    fn record(
        &self,
        p: &mut serde_json::Value,
        mask: Option<&Mask>,
        flipped: bool,
        mask_file: &Path,
        manifest: &mut Manifest,
    ) -> Result<()> {
        p["mask_source"] = json!(match self.mask.as_str() {
            "auto" | "none" => self.mask.clone(),
            _ => "file".into(),
        });
        if let Some(found) = mask {
            p["mask_share"] = json!(found.count() as f32 / (found.width() * found.height()) as f32);
            if self.mask == "auto" {
                save_png(&found.to_image(), mask_file, BitDepth::Eight)?;
                manifest.outputs.push(mask_file.file_name().map_or_else(|| mask_file.to_path_buf(), PathBuf::from));
            }
        }
        p["age_flipped"] = json!(flipped);
        Ok(())
    }
}

/// Flags of the age map and the intact texture, shared by the subcommands.
#[derive(clap::Args, Clone)]
pub struct MethodArgs {
    /// Age map grid: N x N source patches (paper: 20; lowered so patches keep at least 8 px).
    #[arg(long, default_value_t = 20, value_parser = |s: &str| crate::flags::count(s, 2, 64))]
    pub grid: usize,
    /// Share of the other grid cells averaged into a patch's age (K = share x (N^2 - 1)); 0 uses the paper's K = 10.
    #[arg(long, default_value_t = 0.4, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0))]
    pub k_fraction: f32,
    /// Compare luminance only, as the paper does (default: CIE Lab colour).
    #[arg(long)]
    pub luminance_only: bool,
    /// Weight of the per-pixel detail term of the age map, which finds thin cracks (0 = paper's grid age only).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub detail: f32,
    /// Do not raise whole regions whose colour belongs to the weathered material (the plain interior of a wide peel) in the age map; the paper's prevalence age alone.
    #[arg(long)]
    pub no_colour_regions: bool,
    /// Treat a fixed share of the most-aged pixels as weathered (the paper: 0.2) [default: automatic, Otsu's cut of the age map].
    #[arg(long, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 0.94))]
    pub discard: Option<f32>,
    /// Largest share of the surface the automatic cut may call weathered (raise it for a photo that is mostly rust).
    #[arg(long, default_value_t = 0.6, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 0.94))]
    pub weathered_max: f32,
    /// Do not look for a tile grid: treat the texture as stochastic.
    #[arg(long)]
    pub no_tiles: bool,
    /// Colour layers aged separately (k-means in Lab; 0 or 1 = one layer).
    #[arg(long, default_value_t = 0, value_parser = |s: &str| crate::flags::count(s, 0, 16))]
    pub layers: usize,
    /// Label image for the layers (one grey level per layer; overrides --layers).
    #[arg(long)]
    pub labels: Option<PathBuf>,
    /// Random seed: the same inputs and seed give the same bytes.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

impl MethodArgs {
    fn params(&self) -> WeatherParams {
        let mut p = WeatherParams::default();
        p.age.grid = self.grid;
        p.age.k_fraction = (self.k_fraction > 0.0).then_some(self.k_fraction);
        p.age.colour = !self.luminance_only;
        p.age.detail = self.detail;
        p.age.regions = !self.no_colour_regions;
        p.intact.discard = self.discard;
        p.intact.weathered_max = self.weathered_max;
        p.intact.detect_tiles = !self.no_tiles;
        p.layers = self.layers;
        p
    }
}

#[derive(clap::Args)]
pub struct Args {
    /// The weathered texture: PNG, JPEG or EXR.
    pub input: PathBuf,
    /// Output folder (created if missing): age_map.png, intact.png, frames/NNN.png, sequence.gif, manifest.json.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Frames between the intact texture (t = 0) and the input (t = 1).
    #[arg(long, default_value_t = 3, value_parser = |s: &str| crate::flags::count(s, 0, 256))]
    pub past: usize,
    /// Frames after the input, evenly spaced up to t = 1 + --span.
    #[arg(long, default_value_t = 3, value_parser = |s: &str| crate::flags::count(s, 0, 256))]
    pub future: usize,
    /// Time of the last future frame minus 1.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 100.0))]
    pub span: f32,
    /// How future frames grow: front (from the existing damage, along the age map, with a few new sites) or patches (the paper's eq. 2 patch blends).
    #[arg(long, value_enum, default_value_t = GrowthArg::Front)]
    pub growth: GrowthArg,
    /// Patch blends per future frame, with --growth patches [default: half the age map's grid cells, N^2 / 2].
    #[arg(long, value_parser = |s: &str| crate::flags::count(s, 1, 4096))]
    pub steps: Option<usize>,
    /// A user age map (grey, white = weathered) replacing the automatic one.
    #[arg(long)]
    pub age_map: Option<PathBuf>,
    /// A user intact texture replacing the automatic one.
    #[arg(long)]
    pub intact: Option<PathBuf>,
    #[command(flatten)]
    pub surface: SurfaceArgs,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
    #[command(flatten)]
    pub method: MethodArgs,
}

#[derive(clap::Args)]
pub struct SingleArgs {
    /// The weathered texture: PNG, JPEG or EXR.
    pub input: PathBuf,
    /// Output image (.png); OUT.manifest.json is written beside it.
    #[arg(short, long)]
    pub out: PathBuf,
    /// A user age map to use instead of the automatic one (intact only).
    #[arg(long)]
    pub age_map: Option<PathBuf>,
    #[command(flatten)]
    pub surface: SurfaceArgs,
    #[command(flatten)]
    pub method: MethodArgs,
}

#[derive(clap::Args)]
pub struct TransferArgs {
    /// The weathered texture whose weathering is carried over.
    #[arg(long)]
    pub source: PathBuf,
    /// The clean texture that takes it on (its size is the output size).
    #[arg(long)]
    pub target: PathBuf,
    /// Output folder: frames/NNN.png, sequence.gif, manifest.json.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Frames, at t = k / frames for k = 1..frames (t = 1: all of the source's weathering).
    #[arg(long, default_value_t = 4, value_parser = |s: &str| crate::flags::count(s, 1, 256))]
    pub frames: usize,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
    #[command(flatten)]
    pub method: MethodArgs,
}

fn load_labels(method: &MethodArgs) -> Result<Option<Image>> {
    method.labels.as_ref().map(crate::input::load).transpose()
}

pub fn run(args: Args) -> Result<()> {
    let mut clock = Stopwatch::start();
    let m = &args.method;
    let mut manifest = Manifest::new("weather", m.seed);
    let mask_file = args.surface.file()?;
    let mut inputs: Vec<&Path> = vec![&args.input];
    inputs.extend(args.age_map.as_deref());
    inputs.extend(args.intact.as_deref());
    inputs.extend(m.labels.as_deref());
    inputs.extend(mask_file.as_deref());
    let out = OutDir::begin(&args.out, &inputs, args.overwrite)?;
    let input = crate::input::load(&args.input)?;
    let mask = args.surface.resolve(&input)?;
    let user_age = args.age_map.as_ref().map(crate::input::load).transpose()?;
    let user_intact = args.intact.as_ref().map(crate::input::load).transpose()?;
    let labels = load_labels(m)?;
    manifest.timings_ms.insert("load".into(), clock.lap());

    let mut params = m.params();
    params.sequence.past = args.past;
    params.sequence.future = args.future;
    params.sequence.future_span = args.span;
    params.sequence.steps = args.steps;
    params.sequence.growth = args.growth.into();
    let overrides = Overrides {
        age: user_age.as_ref(),
        intact: user_intact.as_ref(),
        labels: labels.as_ref(),
        mask: mask.as_ref(),
        weathered_at: args.surface.weathered_at,
    };
    let total = (2 + args.past + args.future) as u64;
    let result = with_bar("weather", |report| {
        weather::weather(&input, &params, overrides, m.seed, &|stage| {
            let done = match stage {
                Stage::AgeMap => 1,
                Stage::Intact => 2,
                Stage::Past(k, _) => 2 + k,
                Stage::Future(k, _) => 2 + args.past + k,
            };
            report(done as u64, total);
        })
    })?;
    manifest.timings_ms.insert("weather".into(), clock.lap());

    let dir = out.path();
    save_png(&result.age, dir.join("age_map.png"), BitDepth::Eight)?;
    save_png(&result.intact, dir.join("intact.png"), BitDepth::Eight)?;
    manifest.outputs.extend(["age_map.png".into(), "intact.png".into()]);
    if let Some(l) = &result.layers {
        save_png(&l.to_image(), dir.join("layers.png"), BitDepth::Eight)?;
        manifest.outputs.push("layers.png".into());
    }
    write_sequence(dir, &timed(&result.frames), GIF_DELAY_MS, &mut manifest)?;
    manifest.timings_ms.insert("save".into(), clock.lap());

    let mut p = serde_json::to_value(&params).map_err(|e| Error::Internal(e.to_string()))?;
    if let Some((n, patch, k)) = result.age_grid {
        p["age"]["grid_used"] = json!(n);
        p["age"]["patch_used"] = json!([patch.0, patch.1]);
        p["age"]["k_used"] = json!(k);
    }
    p["tiles"] = json!(result.lattice);
    if let Some((cut, fraction)) = result.weathered {
        p["intact"]["age_cut_used"] = json!(cut);
        p["intact"]["weathered_fraction"] = json!(fraction);
    }
    p["layers_used"] = json!(result.layers.as_ref().map(|l| l.count));
    args.surface.record(&mut p, mask.as_ref(), result.flipped, &dir.join("mask_auto.png"), &mut manifest)?;
    manifest.params = p;
    manifest.metrics.insert("weathered_area".into(), json!(weathered_areas(&result.frames, &result.intact)?));
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.write(&dir.join("manifest.json"))?;
    out.commit()?;
    crate::output::summary(format!("patina weather: wrote {} frames to {}", result.frames.len(), args.out.display()));
    Ok(())
}

/// Per frame, the share of pixels whose colour differs from the intact
/// texture by more than 0.1.
fn weathered_areas(frames: &[weather::Frame], intact: &Image) -> Result<Vec<f32>> {
    frames
        .iter()
        .map(|f| {
            let d = weather::rebuild::colour_distance(&f.image, intact)?;
            Ok(d.iter().filter(|&&v| v > 0.1).count() as f32 / d.len() as f32)
        })
        .collect()
}

/// The age map or the intact texture alone (`until`), written to OUT with
/// OUT.manifest.json beside it (and, with `--mask auto`, the mask found
/// as OUT's name with `.mask_auto.png`).
fn run_single(args: SingleArgs, command: &str, until: Until) -> Result<()> {
    let mut clock = Stopwatch::start();
    let manifest_file = manifest_path(&args.out);
    let mask_out = args.out.with_extension("mask_auto.png");
    let mask_file = args.surface.file()?;
    let mut inputs: Vec<&Path> = vec![&args.input];
    inputs.extend(args.age_map.as_deref());
    inputs.extend(args.method.labels.as_deref());
    inputs.extend(mask_file.as_deref());
    let mut outputs: Vec<&Path> = vec![&args.out, &manifest_file];
    if args.surface.mask == "auto" {
        outputs.push(&mask_out);
    }
    check_outputs(&outputs, &inputs)?;
    io::output_format(&args.out, 3)?;
    let input = crate::input::load(&args.input)?;
    let labels = load_labels(&args.method)?;
    let user_age = args.age_map.as_ref().map(crate::input::load).transpose()?;
    let mask = args.surface.resolve(&input)?;
    let mut manifest = Manifest::new(command, args.method.seed);
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.outputs = vec![args.out.clone()];
    let params = args.method.params();
    let overrides = Overrides {
        age: user_age.as_ref(),
        labels: labels.as_ref(),
        mask: mask.as_ref(),
        weathered_at: args.surface.weathered_at,
        ..Default::default()
    };
    let result = with_bar(command, |_| weather::weather_until(&input, &params, overrides, args.method.seed, &|_| {}, until))?;
    manifest.timings_ms.insert(command.replace('-', "_"), clock.lap());
    crate::embed::commit_point();
    let mut p = match until {
        Until::AgeMap => {
            save_png(&result.age, &args.out, BitDepth::Eight)?;
            serde_json::to_value(&params.age).map_err(|e| Error::Internal(e.to_string()))?
        }
        _ => {
            save_png(&result.intact, &args.out, BitDepth::Eight)?;
            let mut p = serde_json::to_value(&params.intact).map_err(|e| Error::Internal(e.to_string()))?;
            p["age"] = serde_json::to_value(&params.age).map_err(|e| Error::Internal(e.to_string()))?;
            p["tiles"] = json!(result.lattice);
            if let Some((cut, fraction)) = result.weathered {
                p["age_cut_used"] = json!(cut);
                p["weathered_fraction"] = json!(fraction);
            }
            p
        }
    };
    if let Some((n, patch, k)) = result.age_grid {
        p["grid_used"] = json!(n);
        p["patch_used"] = json!([patch.0, patch.1]);
        p["k_used"] = json!(k);
    }
    p["layers_used"] = json!(result.layers.as_ref().map(|l| l.count));
    args.surface.record(&mut p, mask.as_ref(), result.flipped, &mask_out, &mut manifest)?;
    manifest.params = p;
    manifest.write(&manifest_file)
}

/// `patina age-map`.
pub fn run_age_map(args: SingleArgs) -> Result<()> {
    if args.age_map.is_some() {
        return Err(Error::invalid("--age-map is an input of 'patina intact', not of 'patina age-map'"));
    }
    run_single(args, "age-map", Until::AgeMap)
}

/// `patina intact`.
pub fn run_intact(args: SingleArgs) -> Result<()> {
    run_single(args, "intact", Until::Intact)
}

/// `patina weather-transfer`.
pub fn run_transfer(args: TransferArgs) -> Result<()> {
    let mut clock = Stopwatch::start();
    let m = &args.method;
    let mut manifest = Manifest::new("weather-transfer", m.seed);
    let inputs: Vec<&Path> = vec![&args.source, &args.target];
    let out = OutDir::begin(&args.out, &inputs, args.overwrite)?;
    let source = crate::input::load(&args.source)?;
    let target = crate::input::load(&args.target)?;
    if source.channels() != target.channels() {
        return Err(Error::invalid(format!(
            "{} has {} channels but {} has {}",
            args.source.display(),
            source.channels(),
            args.target.display(),
            target.channels()
        )));
    }
    manifest.timings_ms.insert("load".into(), clock.lap());
    let params = m.params();
    let times: Vec<f32> = (1..=args.frames).map(|k| k as f32 / args.frames as f32).collect();
    let frames = with_bar("transfer", |report| -> Result<_> {
        let total = (args.frames + 2) as u64;
        let a = age_map(&source, &params.age)?;
        report(1, total);
        let i = intact(&source, &a.map, None, &params.intact, None, m.seed)?;
        report(2, total);
        transfer::transfer(
            &transfer::Source { image: &source, age: &a.map, intact: &i.image },
            &target,
            &times,
            &params.intact.rebuild,
            m.seed,
            &|k| report(2 + k as u64, total),
        )
    })?;
    manifest.timings_ms.insert("transfer".into(), clock.lap());
    let mut all = vec![weather::Frame { t: 0.0, image: target.clone() }];
    all.extend(frames);
    write_sequence(out.path(), &timed(&all), GIF_DELAY_MS, &mut manifest)?;
    manifest.params = json!({ "frames": args.frames, "age": params.age, "intact": params.intact });
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.write(&out.path().join("manifest.json"))?;
    out.commit()?;
    crate::output::summary(format!("patina weather-transfer: wrote {} frames to {}", all.len(), args.out.display()));
    Ok(())
}
