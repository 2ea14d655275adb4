//! `patina stbrdf fit|enlarge|transfer|render`: spatio-temporal BRDF
//! materials (Meister et al. 2021).

use crate::output::{parse_size, save_png, side_by_side, Manifest, OutDir, Stopwatch};
use crate::progress::with_bar;
use crate::synth::GuideArgs;
use patina::image::io::{self, save_gif, BitDepth};
use patina::image::sequence::{load_sequence, natural_cmp, MAX_FRAMES};
use patina::image::Image;
use patina::stbrdf::{enlarge, fit, render, shader, transfer, Encoding, Material, Param};
use patina::synth::OptimizeParams;
use patina::{Error, Result};
use serde_json::json;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(clap::Subcommand)]
pub enum Command {
    /// Fit polynomials in time to parameter maps sampled at N times.
    ///
    /// FOLDER holds one subfolder per time step (in natural order), each with one image per parameter named
    /// Diffuse, Specular, Roughness, Normal, Height or anything else (.exr or .png; single-valued maps may be grey).
    /// A folder of plain RGB frames (a time-lapse) is fitted as an albedo-only material (Diffuse).
    /// Times are evenly spaced over [0, 1] unless --times gives them.
    Fit(FitArgs),
    /// Enlarge a material by texture optimization on its coefficients (closed-form time-integrated distance).
    Enlarge(EnlargeArgs),
    /// Carry a material's time behaviour onto a static texture, equal to it at --t0.
    Transfer(TransferArgs),
    /// Evaluate a material at several times: parameter maps, shaded plane and sphere, GIF, and shaders that evaluate it on the GPU
    /// (WGSL, GLSL, HLSL, and a Unity ShaderLab surface shader).
    Render(RenderArgs),
}

#[derive(clap::Args)]
pub struct FitArgs {
    /// Folder of time steps (see above).
    pub input: PathBuf,
    /// Output material folder ({Name}-{i}.exr and material.json).
    #[arg(short, long)]
    pub out: PathBuf,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
    /// Polynomial degree d (1..6).
    #[arg(long, default_value_t = 3, value_parser = |s: &str| crate::flags::count(s, 1, 6))]
    pub degree: usize,
    /// Times of the steps, comma-separated in [0, 1] [default: evenly spaced]
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0))]
    pub times: Option<Vec<f32>>,
    /// The Specular maps are STAF-style (coupled with a Gaussian lobe of width Roughness): decouple them first (eq. 9).
    #[arg(long)]
    pub staf: bool,
    /// How the colour maps (Diffuse, Specular) are encoded, recorded in material.json for previews and transfer.
    /// auto: sRGB when they are 8- or 16-bit images (PNG, JPEG, GIF), linear when they are EXR.
    #[arg(long, value_enum, default_value_t = EncodingArg::Auto)]
    pub encoding: EncodingArg,
    /// Fit the time steps as they are. By default a camera that shakes is undone first: each step is registered
    /// to the ones before it (a whole-pixel translation, by phase correlation on the Diffuse maps) and all are
    /// cropped to the window they share, so that each texel's polynomial follows one place on the surface.
    #[arg(long)]
    pub no_register: bool,
}

/// `--encoding`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum EncodingArg {
    /// From the files (fit) or the material (render).
    Auto,
    Srgb,
    Linear,
}

impl EncodingArg {
    fn or(self, auto: Encoding) -> Encoding {
        match self {
            EncodingArg::Auto => auto,
            EncodingArg::Srgb => Encoding::Srgb,
            EncodingArg::Linear => Encoding::Linear,
        }
    }
}

#[derive(clap::Args)]
pub struct EnlargeArgs {
    /// Material folder (ours or meistdan/tsvbrdf's layout).
    pub material: PathBuf,
    /// Output material folder.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
    /// Scale factor for both sides (ignored with --size).
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 64.0))]
    pub scale: f32,
    /// Output size WxH instead of --scale.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Weight per parameter, comma-separated in the material's order [default: 1 each]
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0e6))]
    pub weights: Option<Vec<f32>>,
    #[command(flatten)]
    pub guide: GuideArgs,
    /// The capture's lighting (a vignette, a light ramp), found as a smooth cubic field in the time-averaged Diffuse:
    /// flat removes it and lights the result evenly; stretch removes it and stretches it over the result;
    /// keep copies it with the patches (the paper); auto is flat for materials fitted to photos (sRGB) and keep for linear ones.
    #[arg(long, value_enum, default_value_t = IlluminationArg::Auto)]
    pub illumination: IlluminationArg,
    /// Do not blend the seams between copied regions in the gradient domain (blending is exact on coefficients).
    #[arg(long)]
    pub no_seam_blend: bool,
    /// Make the material tile seamlessly: its left edge continues its right and its top its bottom (wrap-around
    /// synthesis; skips the seam blend, which does not wrap; not with --illumination stretch).
    #[arg(long)]
    pub tile: bool,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// `--illumination`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum IlluminationArg {
    Auto,
    Flat,
    Stretch,
    Keep,
}

#[derive(clap::Args)]
pub struct TransferArgs {
    /// Material folder whose time behaviour is carried over.
    pub material: PathBuf,
    /// The static RGB texture that takes it on (its size is the output's).
    #[arg(long)]
    pub target: PathBuf,
    /// The time at which the result equals the target exactly.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0))]
    pub t0: f32,
    /// Output material folder.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
    /// Weight of the guides. grow with --mask: the material's density of change against where water stands on the object (its bottom, and its rims less), so the densest rust gathers there [default: 0.1]; grow without a mask is unguided. ratio, offset, auto: the material's equalised luminance at t0 against the target's [default: 2].
    #[arg(long, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0e6))]
    pub guide_weight: Option<f32>,
    /// How the material's change lands on the target. grow: the material covers the target texel by texel in its own
    /// spatial pattern, up to --coverage of the source's share (see --tempo), spots growing from their
    /// middle out and starting in the target's crevices and chips. ratio: the change scaled by target / material
    /// at t0 (eq. 16; wetting, dulling). offset: the change added unscaled. auto: ratio for changes small against the
    /// material at t0, offset for large ones.
    #[arg(long, value_enum, default_value_t = ModeArg::Grow)]
    pub mode: ModeArg,
    /// Only the object changes: a mask image of the target's size (white = changes, black = stays exactly the target;
    /// grey blends). Its alpha channel is used if it has one, else its luminance.
    #[arg(long)]
    pub mask: Option<PathBuf>,
    /// Soften the mask's edge inwards over this many pixels (a Gaussian of this sigma, never reaching outside it).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub feather: f32,
    /// grow: width (Gaussian sigma, px) of the glaze the material bleeds into the target around what has arrived
    /// (rust staining the paint around its spots, in the material's own hue); 0 for no glaze and no runoff.
    #[arg(long, default_value_t = transfer::HALO, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1000.0))]
    pub halo: f32,
    /// grow: how far (px) the glaze runs down the image below what has arrived, in streaks (rust's runoff); 0 for none.
    #[arg(long, default_value_t = transfer::RUNOFF, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100000.0))]
    pub runoff: f32,
    /// grow: how the covered share grows over time. even: the texels arrive in the source's order, their arrivals
    /// spread evenly over time, so the covered share grows linearly to the source's final share. source: at the source
    /// material's own pace (the share covered at each time is the source's; a time-lapse's pace is often its camera's).
    #[arg(long, value_enum, default_value_t = TempoArg::Even)]
    pub tempo: TempoArg,
    /// grow: how strongly the material gathers in patches over the object (areas where the coat failed first take
    /// most of it, others stay nearly clean), in units of a texel's own strength; 0 spreads it evenly but for where
    /// water stands and the target's chips.
    #[arg(long, default_value_t = transfer::CLUSTERING, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub clustering: f32,
    /// grow: the share of the source material's final visible cover the target takes on, in (0, 1]. Below 1 the
    /// spots the target favours least (its dry, sheltered, patch-free parts) stay clean [default: 0.6 with --mask, a
    /// coated object rusting where its coat fails; 1 without].
    #[arg(long, value_parser = |s: &str| crate::flags::positive(s, 0.0, 1.0))]
    pub coverage: Option<f32>,
    /// The material's size on the target: 0.5 draws its features (spots, grain) at half the size they have in the
    /// material, 2 at twice (its coefficients resampled, exact at every time)
    /// [default: grow with --mask, the object spans 2.5 times the material's side (within 1..4); else 1]
    #[arg(long, value_parser = |s: &str| crate::flags::number(s, 0.05, 8.0))]
    pub scale: Option<f32>,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

#[derive(clap::Args)]
pub struct RenderArgs {
    /// Material folder.
    pub material: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
    /// Times to render, comma-separated in [0, 1] (overrides --frames).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0))]
    pub times: Option<Vec<f32>>,
    /// Number of evenly spaced times over [0, 1].
    #[arg(long, default_value_t = 11, value_parser = |s: &str| crate::flags::count(s, 1, 1000))]
    pub frames: usize,
    /// Side of the sphere preview in pixels.
    #[arg(long, default_value_t = 256, value_parser = |s: &str| crate::flags::count(s, 8, 4096))]
    pub sphere: usize,
    /// Milliseconds per frame in sequence.gif.
    #[arg(long, default_value_t = 150)]
    pub gif_delay: u32,
    /// The light: sun (one directional light from the upper right, plus a little ambient) or sky (a procedural sky and ground).
    #[arg(long, value_enum, default_value_t = LightArg::Sun)]
    pub light: LightArg,
    /// Exposure in stops, applied to radiance before the tone curve (Khronos PBR Neutral).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, -10.0, 10.0))]
    pub exposure: f32,
    /// How the colour maps are encoded: auto takes material.json's (sRGB for materials fitted to 8-bit images, linear otherwise).
    #[arg(long, value_enum, default_value_t = EncodingArg::Auto)]
    pub encoding: EncodingArg,
}

/// `--mode` of transfer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    Grow,
    Ratio,
    Offset,
    Auto,
}

/// `--tempo` of transfer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TempoArg {
    Source,
    Even,
}

/// `--light`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LightArg {
    Sun,
    Sky,
}

pub fn run(args: Args) -> Result<()> {
    match args.command {
        Command::Fit(a) => run_fit(a),
        Command::Enlarge(a) => run_enlarge(a),
        Command::Transfer(a) => run_transfer(a),
        Command::Render(a) => run_render(a),
    }
}

/// The parameter a file stem names, with its canonical spelling.
fn param_name(stem: &str) -> String {
    let lower = stem.to_lowercase();
    for name in ["Diffuse", "Specular", "Roughness", "Normal", "Height"] {
        if lower == name.to_lowercase() || (name == "Diffuse" && (lower == "albedo" || lower == "basecolor" || lower == "kd")) {
            return name.to_string();
        }
    }
    stem.to_string()
}

/// Parameter maps per time step from a folder of subfolders, or an
/// albedo-only material from a folder of frames. A folder holding both is
/// ambiguous and refused, naming both.
fn load_steps(dir: &Path) -> Result<(Vec<Image>, Vec<Param>, Encoding)> {
    let entries = std::fs::read_dir(dir).map_err(|source| Error::Read { path: dir.into(), source })?;
    let paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    let mut subdirs: Vec<PathBuf> = paths.iter().filter(|p| p.is_dir()).cloned().collect();
    subdirs.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    let image_file = |p: &&PathBuf| {
        p.is_file()
            && p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| ["png", "jpg", "jpeg", "exr", "gif"].contains(&e.to_lowercase().as_str()))
    };
    if let (Some(sub), Some(file)) = (subdirs.first(), paths.iter().find(image_file)) {
        return Err(Error::invalid(format!(
            "{} holds both image files ({}) and subfolders ({}): give a folder of frames or a folder of time-step subfolders",
            dir.display(),
            file.display(),
            sub.display()
        )));
    }
    if subdirs.len() > MAX_FRAMES {
        return Err(Error::invalid(format!("{} holds {} time steps; patina reads at most {MAX_FRAMES}", dir.display(), subdirs.len())));
    }
    if subdirs.is_empty() {
        let seq = load_sequence(dir)?;
        let frames = seq.frames.iter().cloned().map(|f| if f.channels() >= 3 { f.select_channels(0..3) } else { f }).collect::<Vec<_>>();
        let c = frames[0].channels();
        let exr = seq.names.iter().any(|n| n.to_lowercase().ends_with(".exr"));
        return Ok((frames, vec![Param { name: "Diffuse".into(), channels: c }], if exr { Encoding::Linear } else { Encoding::Srgb }));
    }
    let mut params: Vec<Param> = Vec::new();
    let mut encoding = Encoding::Linear;
    let mut files_of_first: Vec<String> = Vec::new();
    let mut steps = Vec::new();
    for (i, sub) in subdirs.iter().enumerate() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(sub)
            .map_err(|source| Error::Read { path: sub.clone(), source })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| ["exr", "png"].contains(&e.to_lowercase().as_str())))
            .collect();
        files.sort_by_key(|p| {
            let n = param_name(&p.file_stem().unwrap_or_default().to_string_lossy());
            (["Diffuse", "Specular", "Roughness", "Normal", "Height"].iter().position(|c| *c == n).unwrap_or(5), n)
        });
        let stems: Vec<String> = files.iter().map(|p| param_name(&p.file_stem().unwrap_or_default().to_string_lossy())).collect();
        if i == 0 {
            if files.is_empty() {
                return Err(Error::invalid(format!("{} holds no .exr or .png parameter maps", sub.display())));
            }
            files_of_first = stems.clone();
        } else if stems != files_of_first {
            return Err(Error::invalid(format!(
                "{} holds parameters {:?} but the first step holds {:?}",
                sub.display(),
                stems,
                files_of_first
            )));
        }
        let maps = files.iter().map(crate::input::load).collect::<Result<Vec<_>>>()?;
        if i == 0 {
            let colour_png = files.iter().zip(&stems).any(|(f, n)| {
                matches!(n.as_str(), "Diffuse" | "Specular") && !f.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
            });
            if colour_png {
                encoding = Encoding::Srgb;
            }
            params = stems
                .iter()
                .zip(&maps)
                .map(|(n, img)| {
                    let single = matches!(n.as_str(), "Roughness" | "Height") || img.channels() < 3;
                    Param { name: n.clone(), channels: if single { 1 } else { 3 } }
                })
                .collect();
        }
        let parts: Vec<Image> = params.iter().zip(&maps).map(|(p, img)| img.select_channels(0..p.channels.min(img.channels()))).collect();
        let refs: Vec<&Image> = parts.iter().collect();
        let step = Image::concat_channels(&refs).map_err(|e| Error::invalid(format!("{}: {e}", sub.display())))?;
        steps.push(step);
    }
    Ok((steps, params, encoding))
}

fn run_fit(args: FitArgs) -> Result<()> {
    let mut clock = Stopwatch::start();
    let out = OutDir::begin(&args.out, &[&args.input], args.overwrite)?;
    let (mut steps, params, found) = load_steps(&args.input)?;
    let encoding = args.encoding.or(found);
    if args.staf {
        fit::decouple_frames(&mut steps, &params)?;
    }
    let channels = patina::stbrdf::material::param_range(&params, "diffuse").unwrap_or(0..params[0].channels);
    let (steps, registration) = crate::input::registered(steps, channels, args.no_register)?;
    let n = steps.len();
    let times = match &args.times {
        Some(t) if t.len() != n => return Err(Error::invalid(format!("--times lists {} times for {n} time steps", t.len()))),
        Some(t) if t.iter().any(|v| !(0.0..=1.0).contains(v)) => return Err(Error::invalid("--times must lie in [0, 1]")),
        Some(t) => t.clone(),
        None => (0..n).map(|i| if n > 1 { i as f32 / (n - 1) as f32 } else { 0.0 }).collect(),
    };
    let mut fitted = fit::fit(&steps, &times, args.degree, params)?;
    fitted.material.encoding = encoding;
    let mut manifest = Manifest::new("stbrdf fit", 0);
    manifest.timings_ms.insert("fit".into(), clock.lap());
    fitted.material.save(out.path())?;
    manifest.timings_ms.insert("save".into(), clock.lap());
    let mut channel = 0;
    let mut rms = serde_json::Map::new();
    for p in &fitted.material.params {
        rms.insert(p.name.clone(), json!(fitted.rms[channel..channel + p.channels]));
        channel += p.channels;
    }
    manifest.metrics.insert("rms".into(), serde_json::Value::Object(rms));
    manifest.params = json!({ "degree": args.degree, "times": times, "staf_decoupled": args.staf, "encoding": encoding, "params": fitted.material.params.iter().map(|p| json!({"name": p.name, "channels": p.channels})).collect::<Vec<_>>(), "registered": !args.no_register, "registration": registration });
    manifest.inputs = vec![args.input.clone()];
    manifest.write(&out.path().join("manifest.json"))?;
    out.commit()?;
    crate::input::registration_note(&registration);
    crate::output::summary(format!("patina stbrdf fit: {} time steps -> degree-{} material in {}", n, args.degree, args.out.display()));
    Ok(())
}

fn run_enlarge(args: EnlargeArgs) -> Result<()> {
    let mut clock = Stopwatch::start();
    let inputs: Vec<&Path> = std::iter::once(args.material.as_path()).chain(args.guide.paths()).collect();
    let out = OutDir::begin(&args.out, &inputs, args.overwrite)?;
    let material = Material::load(&args.material)?;
    let (w, h) = material.size();
    let size = args.size.unwrap_or((((w as f32 * args.scale).round() as usize).max(1), ((h as f32 * args.scale).round() as usize).max(1)));
    let guides = args.guide.load()?;
    let params = enlarge::EnlargeParams {
        weights: args.weights.clone(),
        illumination: match args.illumination {
            IlluminationArg::Auto => enlarge::Illumination::Auto,
            IlluminationArg::Flat => enlarge::Illumination::Flat,
            IlluminationArg::Stretch => enlarge::Illumination::Stretch,
            IlluminationArg::Keep => enlarge::Illumination::Keep,
        },
        blend_seams: !args.no_seam_blend,
        tileable: args.tile,
        verbatim: false,
        optimize: OptimizeParams::default(),
    };
    let enlarged = with_bar("enlarge", |report| {
        enlarge::enlarge(&material, size, &params, guides.as_ref().map(|(s, t)| (s, t, args.guide.guide_weight)), args.seed, Some(report))
    })?;
    let mut manifest = Manifest::new("stbrdf enlarge", args.seed);
    manifest.timings_ms.insert("enlarge".into(), clock.lap());
    enlarged.save(out.path())?;
    manifest.params = json!({ "size": [size.0, size.1], "guide_weight": args.guide.guide_weight, "enlarge": params });
    manifest.inputs = std::iter::once(args.material.as_path()).chain(args.guide.paths()).map(Path::to_path_buf).collect();
    manifest.write(&out.path().join("manifest.json"))?;
    out.commit()?;
    crate::output::summary(format!("patina stbrdf enlarge: {}x{} -> {}x{} in {}", w, h, size.0, size.1, args.out.display()));
    Ok(())
}

fn run_transfer(args: TransferArgs) -> Result<()> {
    let mut clock = Stopwatch::start();
    let inputs: Vec<&Path> =
        [Some(args.material.as_path()), Some(args.target.as_path()), args.mask.as_deref()].into_iter().flatten().collect();
    let out = OutDir::begin(&args.out, &inputs, args.overwrite)?;
    let material = Material::load(&args.material)?;
    let mut target = crate::input::load(&args.target)?;
    // The target's values join the material's: an image file is sRGB-encoded
    // unless it is an EXR.
    let target_is_exr = args.target.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if material.encoding == Encoding::Linear && !target_is_exr {
        target = patina::image::color::to_linear(&target);
    } else if material.encoding == Encoding::Srgb && target_is_exr {
        target = patina::image::color::to_srgb(&target.map(|v| v.clamp(0.0, 1.0)));
    }
    let mask = match &args.mask {
        Some(path) => {
            let img = crate::input::load(path)?;
            let m = match img.group("alpha") {
                Some(a) => img.select_channels(a),
                None => patina::image::color::luminance(&img),
            };
            if m.size() != target.size() {
                return Err(Error::invalid(format!(
                    "the mask {} is {}x{} but the target is {}x{}",
                    path.display(),
                    m.width(),
                    m.height(),
                    target.width(),
                    target.height()
                )));
            }
            // Feathered inwards: min(mask, blurred mask) is 0 wherever the mask is.
            let soft = patina::image::filter::gaussian_blur(&m, args.feather);
            let data = m.data().iter().zip(soft.data()).map(|(a, b)| if args.feather > 0.0 { a.min(*b) } else { *a }).collect();
            Some(Image::from_data(m.width(), m.height(), 1, data)?)
        }
        None => None,
    };
    let mode = match args.mode {
        ModeArg::Grow => transfer::Mode::Grow,
        ModeArg::Ratio => transfer::Mode::Ratio,
        ModeArg::Offset => transfer::Mode::Offset,
        ModeArg::Auto => transfer::Mode::Auto,
    };
    let params = transfer::TransferParams {
        t0: args.t0,
        guide_weight: args.guide_weight,
        mode,
        halo: args.halo,
        runoff: args.runoff,
        tempo: match args.tempo {
            TempoArg::Source => transfer::Tempo::Source,
            TempoArg::Even => transfer::Tempo::Even,
        },
        clustering: args.clustering,
        coverage: args.coverage,
        scale: args.scale,
        ..Default::default()
    };
    let moved = with_bar("transfer", |report| transfer::transfer(&material, &target, mask.as_ref(), &params, args.seed, Some(report)))?;
    let mut manifest = Manifest::new("stbrdf transfer", args.seed);
    manifest.timings_ms.insert("transfer".into(), clock.lap());
    moved.material.save(out.path())?;
    manifest.params = serde_json::to_value(&params).map_err(|e| Error::Internal(e.to_string()))?;
    manifest.params["mode_used"] = json!(moved.mode);
    manifest.params["scale_used"] = json!(moved.scale);
    manifest.params["masked"] = json!(mask.is_some());
    manifest.params["feather"] = json!(args.feather);
    manifest.params["guide_weight_used"] = json!(params.weight());
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.write(&out.path().join("manifest.json"))?;
    out.commit()?;
    crate::output::summary(format!("patina stbrdf transfer: wrote {}", args.out.display()));
    Ok(())
}

fn run_render(args: RenderArgs) -> Result<()> {
    let mut clock = Stopwatch::start();
    let out = OutDir::begin(&args.out, &[&args.material], args.overwrite)?;
    let dir = out.path();
    let mut material = Material::load(&args.material)?;
    material.encoding = args.encoding.or(material.encoding);
    let times: Vec<f32> = match &args.times {
        Some(t) if t.is_empty() || t.len() > 1000 => return Err(Error::invalid("--times must list 1 to 1000 times")),
        Some(t) => t.clone(),
        None => (0..args.frames).map(|i| if args.frames > 1 { i as f32 / (args.frames - 1) as f32 } else { 0.0 }).collect(),
    };
    crate::output::mkdir(&dir.join("frames"))?;
    let mut manifest = Manifest::new("stbrdf render", 0);
    let lighting = render::Lighting {
        environment: match args.light {
            LightArg::Sun => render::Environment::Sun,
            LightArg::Sky => render::Environment::Sky,
        },
        exposure: args.exposure.exp2(),
        ..render::Lighting::default()
    };
    let mut previews = Vec::new();
    for (i, &t) in times.iter().enumerate() {
        let frame = material.evaluate(t);
        for p in &material.params {
            let r = material.param(&p.name).expect("own parameter");
            let name = match p.name.as_str() {
                "Diffuse" => "basecolor".to_string(),
                other => other.to_lowercase(),
            };
            let rel = PathBuf::from("frames").join(format!("{i:03}_{name}.png"));
            let mut map = frame.select_channels(r);
            // Colour maps are shown sRGB-encoded, as an image viewer expects.
            if material.encoding == Encoding::Linear && matches!(p.name.as_str(), "Diffuse" | "Specular") {
                map = patina::image::color::to_srgb(&map.map(|v| v.clamp(0.0, 1.0)));
            }
            save_png(&map, dir.join(&rel), BitDepth::Eight)?;
            manifest.outputs.push(rel);
        }
        let plane = render::plane(&material, t, &lighting);
        let sphere = render::sphere(&material, t, args.sphere, &lighting);
        for (kind, img) in [("plane", &plane), ("sphere", &sphere)] {
            let rel = PathBuf::from("frames").join(format!("{i:03}_{kind}.png"));
            save_png(img, dir.join(&rel), BitDepth::Eight)?;
            manifest.frames.push(crate::output::FrameEntry { t, path: rel });
        }
        previews.push(side_by_side(&plane, &sphere));
    }
    save_gif(&previews.iter().collect::<Vec<_>>(), dir.join("sequence.gif"), args.gif_delay)?;
    let shaders = [
        ("material.wgsl", shader::wgsl(&material)),
        ("material.glsl", shader::glsl(&material)),
        ("material.hlsl", shader::hlsl(&material)),
        ("material.shader", shader::shaderlab(&material)),
    ];
    for (name, text) in &shaders {
        io::write_atomic(&dir.join(name), |b| {
            b.extend_from_slice(text.as_bytes());
            Ok(())
        })?;
        manifest.outputs.push(name.into());
    }
    manifest.outputs.push("sequence.gif".into());
    manifest.timings_ms.insert("render".into(), clock.lap());
    manifest.params = json!({ "times": times, "sphere": args.sphere, "lighting": lighting, "exposure_stops": args.exposure, "encoding": material.encoding, "tone_map": "khronos-pbr-neutral" });
    manifest.inputs = vec![args.material.clone()];
    manifest.write(&dir.join("manifest.json"))?;
    out.commit()?;
    crate::output::summary(format!("patina stbrdf render: {} times to {}", times.len(), args.out.display()));
    Ok(())
}
