//! `patina decay`, `patina decay-texture`: natural image decay (Hao et al. 2023).

use crate::output::{check_outputs, manifest_path, parse_size, save, save_png, write_sequence, Manifest, OutDir, Stopwatch};
use crate::progress::with_bar;
use patina::decay::exemplar::{from_exemplar, FromExemplar};
use patina::decay::{self, degree::Diffusion, texture, DecayClass, DecayParams, Inputs, ShadingParams};
use patina::image::color::linear_to_srgb;
use patina::image::io::{self, BitDepth};
use patina::image::{Image, Mask};
use patina::{Error, Result};
use rayon::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};

/// How long each frame of sequence.gif is shown.
const GIF_DELAY_MS: u32 = 400;

/// Parse `X,Y` as two `T`s; `what` describes them in the error.
fn parse_xy<T: std::str::FromStr>(s: &str, what: &str) -> std::result::Result<(T, T), String> {
    let bad = || format!("'{s}' is not X,Y{what}");
    let (x, y) = s.split_once(',').ok_or_else(bad)?;
    Ok((x.trim().parse().map_err(|_| bad())?, y.trim().parse().map_err(|_| bad())?))
}

/// Parse `X,Y` (integers, may be negative).
fn parse_offset(s: &str) -> std::result::Result<(i64, i64), String> {
    parse_xy(s, " (e.g. 1024,0)")
}

fn parse_class(s: &str) -> std::result::Result<DecayClass, String> {
    s.parse::<DecayClass>().map_err(|e| e.to_string())
}

fn parse_substrate(s: &str) -> std::result::Result<decay::Substrate, String> {
    match s {
        "paint" => Ok(decay::Substrate::Paint),
        "stone" => Ok(decay::Substrate::Stone),
        "coated" => Ok(decay::Substrate::Coated),
        _ => Err(format!("unknown substrate '{s}' (expected paint, stone or coated)")),
    }
}

/// Make a clean object in a photo decay over time: rust, peeling paint,
/// cracks or moss spread from random seed areas (or your painted map),
/// keeping the object's shading.
///
/// Writes texture.png (the decay texture), texture_onset.png (the degree at
/// which each texel appears), shading.png (the object's estimated shading),
/// degree_NNN.png (the degree map per frame), frames/NNN.png,
/// sequence.gif and manifest.json. Pixels outside the mask (with --mask
/// auto, beyond the 2 px of the found object's soft edge), and wherever
/// the degree is 0, keep the photo's exact values.
#[derive(clap::Args)]
pub struct Args {
    /// Photo of the object (PNG, JPEG, 16-bit PNG or EXR; sRGB).
    pub photo: PathBuf,
    /// Object mask: a file (white = may decay), `auto` (the object under --point, or else the photo's main object: the largest central region unlike the picture's frame, cut out by GrabCut and written as mask_auto.png; the decay takes in 2 px more of its soft edge, whose pixels decay as much as their colour says they are object) or `none` (the whole photo).
    #[arg(long, default_value = "none")]
    pub mask: String,
    /// With --mask auto: a pixel X,Y (from the top left) on the object to decay [default: the main object].
    #[arg(long, value_parser = crate::object::parse_point)]
    pub point: Option<(usize, usize)>,
    /// Decay class: rust (a crust on paint and metal, an iron stain that runs down bare stone or plaster), peeling, cracked or mossy.
    #[arg(long, value_parser = parse_class, default_value = "rust")]
    pub class: DecayClass,
    /// Output folder.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Number of frames. Frame 0 is the clean photo and the next frames grow the initial degree map's patches from their first texels, then spread them (eqs. 4-7); a painted degree map, or a single frame, is shown whole from frame 0.
    #[arg(long, default_value_t = 8, value_parser = |s: &str| crate::flags::count(s, 1, 1000))]
    pub frames: usize,
    /// Random seed: texture, degree map and growth; the same inputs and seed give the same bytes.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Fraction of the mask the initial degree map covers (Algorithm 1; kept within +/-25%).
    #[arg(long, default_value_t = 0.25, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 1.0))]
    pub area: f32,
    /// Blob size of the initial degree map, as a fraction of the longer side (Algorithm 1's continuity).
    #[arg(long, default_value_t = 0.06, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 1.0))]
    pub continuity: f32,
    /// Painted initial degree map (grey: black = intact, white = fully decayed) instead of Algorithm 1.
    #[arg(long)]
    pub degree: Option<PathBuf>,
    /// Decay photo to synthesize the texture from (the engine), instead of the procedural generator for --class.
    #[arg(long)]
    pub exemplar: Option<PathBuf>,
    /// Spatial regularisation map: mid-grey = normal speed, white = twice as fast, black = never spreads.
    #[arg(long)]
    pub rate_map: Option<PathBuf>,
    /// Diffusion length per frame, as a fraction of the longer side (eq. 4).
    #[arg(long, default_value_t = Diffusion::default().spread, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0))]
    pub spread: f32,
    /// Self-growth per frame: Z ~ U(0, growth) added where D > 0.25 (eq. 6).
    #[arg(long, default_value_t = Diffusion::default().growth, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0))]
    pub growth: f32,
    /// Shading window radius, as a fraction of the object's longer side.
    #[arg(long, default_value_t = ShadingParams::default().radius, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 1.0))]
    pub shading_radius: f32,
    /// Shading smoothing strength: log-luminance variance below this counts as texture, not shading.
    #[arg(long, default_value_t = ShadingParams::default().eps, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 1000.0))]
    pub shading_eps: f32,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: Args) -> Result<()> {
    let mut clock = Stopwatch::start();
    let mut manifest = Manifest::new("decay", args.seed);
    let mask_file = crate::object::mask_file(&args.mask, args.point)?;
    let inputs: Vec<&Path> =
        [Some(args.photo.as_path()), mask_file.as_deref(), args.degree.as_deref(), args.exemplar.as_deref(), args.rate_map.as_deref()]
            .into_iter()
            .flatten()
            .collect();
    let degrees: Vec<String> = (0..args.frames).map(|i| format!("degree_{i:03}.png")).collect();
    let params = DecayParams {
        class: args.class,
        area: args.area,
        continuity: args.continuity,
        diffusion: Diffusion { spread: args.spread, growth: args.growth },
        shading: ShadingParams { radius: args.shading_radius, eps: args.shading_eps },
    };
    params.check()?;
    let out = OutDir::begin(&args.out, &inputs, args.overwrite)?;
    let dir = out.path();
    let photo = crate::input::load(&args.photo)?;
    let load_optional = |p: &Option<PathBuf>| p.as_ref().map(crate::input::load).transpose();
    let mask = crate::object::resolve(&args.mask, args.point, &photo)?;
    let painting = load_optional(&args.degree)?;
    let rate = load_optional(&args.rate_map)?;
    let exemplar = load_optional(&args.exemplar)?;
    manifest.timings_ms.insert("load".into(), clock.lap());

    let synthesized = match &exemplar {
        Some(ex) => Some(with_bar("texture", |report| from_exemplar(ex, photo.width(), photo.height(), args.seed, false, Some(report)))?),
        None => None,
    };
    // A found object is widened over the photo's soft silhouette, whose
    // pixels the decay mattes by colour.
    let pad = if args.mask == "auto" { decay::AUTO_MASK_PAD } else { 0 };
    let widened = mask.as_ref().map(|m| m.dilate(pad));
    let inputs_lib = Inputs {
        mask: widened.as_ref(),
        mask_pad: pad,
        texture: synthesized.as_ref().map(|s| &s.texture),
        degree: painting.as_ref(),
        rate: rate.as_ref(),
        transition: synthesized.as_ref().and_then(|s| s.transition),
    };
    let prepared = decay::prepare(&photo, inputs_lib, &params, args.seed)?;
    manifest.timings_ms.insert("prepare".into(), clock.lap());
    let frames = with_bar("decay", |report| decay::sequence(&prepared, args.frames, args.seed, Some(report)))?;
    manifest.timings_ms.insert("frames".into(), clock.lap());

    save_png(&prepared.texture.select_channels(0..3), dir.join("texture.png"), BitDepth::Eight)?;
    save_png(&prepared.texture.select_channels(3..4), dir.join("texture_onset.png"), BitDepth::Eight)?;
    save_png(&shading_preview(&prepared.shading, &prepared.mask), dir.join("shading.png"), BitDepth::Eight)?;
    manifest.outputs.extend(["texture.png".into(), "texture_onset.png".into(), "shading.png".into()]);
    frames.par_iter().zip(&degrees).try_for_each(|(f, name)| save_png(&f.degree, dir.join(name), BitDepth::Sixteen))?;
    manifest.outputs.extend(degrees.iter().map(PathBuf::from));
    let timed: Vec<(f32, &Image)> = frames.iter().enumerate().map(|(i, f)| (i as f32, &f.image)).collect();
    write_sequence(dir, &timed, GIF_DELAY_MS, &mut manifest)?;
    manifest.timings_ms.insert("save".into(), clock.lap());

    let mut p = serde_json::to_value(&params).map_err(|e| Error::Internal(e.to_string()))?;
    p["frames"] = json!(args.frames);
    p["texture_source"] = json!(if exemplar.is_some() { "exemplar" } else { "procedural" });
    if exemplar.is_none() {
        p["style"] = json!(decay::Style::draw(args.seed));
    }
    p["transition"] = json!(prepared.transition);
    p["substrate"] = json!(prepared.substrate);
    // Rust on bare stone or plaster is an iron stain seen through, not a crust.
    p["stained"] = json!(prepared.stained);
    p["transition_source"] = json!(match &synthesized {
        Some(FromExemplar { transition: Some(_), .. }) => "exemplar",
        _ => "class",
    });
    if let Some(s) = &synthesized {
        save_png(&s.age, dir.join("exemplar_age.png"), BitDepth::Eight)?;
        manifest.outputs.push("exemplar_age.png".into());
        p["lighting"] = json!(s.lighting);
    }
    p["degree_source"] = json!(if painting.is_some() { "painting" } else { "algorithm1" });
    p["mask_source"] = json!(match args.mask.as_str() {
        "auto" | "none" => args.mask.as_str(),
        _ => "file",
    });
    if args.mask == "auto" {
        p["point"] = json!(args.point.map(|(x, y)| [x, y]));
        p["mask_auto_dilated_px"] = json!(decay::AUTO_MASK_PAD);
        save_png(&mask.as_ref().expect("a found mask").to_image(), dir.join("mask_auto.png"), BitDepth::Eight)?;
        manifest.outputs.push("mask_auto.png".into());
    }
    manifest.params = p;
    let inside = prepared.mask.count().max(1) as f64;
    // Share of the object past the paper's self-growth threshold (D > 0.25).
    let decayed = |f: &decay::Frame| f.degree.data().iter().filter(|&&d| d > decay::degree::GROWTH_THRESHOLD).count() as f64 / inside;
    manifest.metrics.insert("decayed_fraction".into(), json!(frames.iter().map(decayed).collect::<Vec<_>>()));
    manifest.metrics.insert("algorithm1_draws".into(), json!(prepared.draws));
    manifest.metrics.insert("texture_focus_blur_px".into(), json!(prepared.focus));
    manifest
        .metrics
        .insert("diffusion_sigma_px".into(), json!(params.diffusion.spread * prepared.mask.width().max(prepared.mask.height()) as f32));
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.write(&dir.join("manifest.json"))?;
    out.commit()?;
    let source = if exemplar.is_some() { "the exemplar's decay" } else { args.class.name() };
    crate::output::summary(format!("patina decay: {} frames of {source} in {}", frames.len(), args.out.display()));
    Ok(())
}

/// The relative shading for viewing: S / 2 in linear light, sRGB-encoded
/// (the mean shading shows as 50% linear grey), black outside the object.
fn shading_preview(shading: &Image, mask: &Mask) -> Image {
    Image::from_fn(shading.width(), shading.height(), 1, |x, y, p| {
        p[0] = if mask.get(x, y) { linear_to_srgb((0.5 * shading.at(x, y, 0)).min(1.0)) } else { 0.0 };
    })
}

/// Generate a decay texture of any size: procedural for a class, or
/// synthesized from a decay photo. Windows of one procedural texture
/// (--offset) tile it exactly: generating in parts gives the same pixels as
/// generating at once. OUT.manifest.json is written beside OUT.
#[derive(clap::Args)]
pub struct TextureArgs {
    /// Decay class: rust, peeling, cracked or mossy.
    #[arg(long, value_parser = parse_class, default_value = "rust")]
    pub class: DecayClass,
    /// Texture size WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size, default_value = "1024x1024")]
    pub size: (usize, usize),
    /// Top-left corner X,Y of the window to generate, in the infinite procedural texture.
    #[arg(long, value_parser = parse_offset, default_value = "0,0")]
    pub offset: (i64, i64),
    /// Random seed: layout and style (palette, scale, grain direction).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Decay photo to synthesize from with the engine, instead of the procedural generator.
    #[arg(long)]
    pub exemplar: Option<PathBuf>,
    /// Also write the onset channel (the degree at which each texel appears) here.
    #[arg(long)]
    pub onset: Option<PathBuf>,
    /// What a procedural texture is for: paint (cracks craze into cells; peeling bares primed metal), stone (bare
    /// grey stone or plaster: a few long fractures that end; a weathered skin spalls off fresher stone) or coated
    /// (a grey object coated white: fractures as stone, its coat peels in chips). `patina decay` picks it from
    /// the object's colour and lightness.
    #[arg(long, value_parser = parse_substrate, default_value = "paint")]
    pub substrate: decay::Substrate,
    /// Make the texture (and its onset) tile seamlessly: its left edge continues its right and its top its bottom.
    /// A tiling procedural texture repeats at the asked size, so it takes no --offset.
    #[arg(long)]
    pub tile: bool,
    /// Output image (.png or .exr).
    #[arg(short, long)]
    pub out: PathBuf,
}

pub fn run_texture(args: TextureArgs) -> Result<()> {
    let mut clock = Stopwatch::start();
    let mut manifest = Manifest::new("decay-texture", args.seed);
    let manifest_file = manifest_path(&args.out);
    let inputs: Vec<&Path> = args.exemplar.iter().map(PathBuf::as_path).collect();
    let mut outputs = vec![args.out.as_path(), manifest_file.as_path()];
    outputs.extend(args.onset.as_deref());
    check_outputs(&outputs, &inputs)?;
    io::output_format(&args.out, 3)?;
    let (w, h) = args.size;
    let texture = match &args.exemplar {
        Some(path) => {
            if args.offset != (0, 0) {
                return Err(Error::invalid("--offset applies to procedural textures, not to --exemplar"));
            }
            let ex = crate::input::load(path)?;
            let made = with_bar("texture", |report| from_exemplar(&ex, w, h, args.seed, args.tile, Some(report)))?;
            manifest.metrics.insert("lighting".into(), json!(made.lighting));
            made.texture
        }
        None if args.tile => {
            if args.offset != (0, 0) {
                return Err(Error::invalid("--offset windows an infinite texture; a --tile texture repeats at its size"));
            }
            texture::generate_tiling(args.class, args.seed, w, h, args.substrate)?
        }
        None => texture::generate(args.class, args.seed, args.offset.0, args.offset.1, w, h, args.substrate)?,
    };
    manifest.timings_ms.insert("generate".into(), clock.lap());
    crate::embed::commit_point();
    save(&texture.select_channels(0..3), &args.out, BitDepth::Eight)?;
    if let Some(onset) = &args.onset {
        save(&texture.select_channels(3..4), onset, BitDepth::Eight)?;
        manifest.outputs.push(onset.clone());
    }
    manifest.timings_ms.insert("save".into(), clock.lap());
    manifest.params = json!({
        "class": args.class,
        "size": [w, h],
        "offset": [args.offset.0, args.offset.1],
        "source": if args.exemplar.is_some() { "exemplar" } else { "procedural" },
        "tile": args.tile,
        "substrate": args.substrate,
        "style": decay::Style::draw(args.seed),
    });
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.outputs.insert(0, args.out.clone());
    manifest.write(&manifest_file)
}
