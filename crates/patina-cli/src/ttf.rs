//! `patina ttf`: time-varying texture synthesis from a time-lapse
//! (Enrique, Koudelka et al.).

use crate::output::{parse_size, save_png, side_by_side, write_sequence_from, Manifest, OutDir, Stopwatch};
use crate::progress::with_bar;
use patina::image::io::{save_gif, BitDepth};
use patina::image::sequence::{load_sequence, Sequence};
use patina::image::Image;
use patina::synth::QuiltParams;
use patina::ttf::{self, RateMap, SequenceLighting, TtfParams};
use patina::{Error, Result};
use serde_json::json;
use std::ops::Range;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// The time-lapse: a folder of frames (PNG, JPEG or EXR; ordered naturally by file name, so f2 comes before f10) or an animated GIF.
    pub input: PathBuf,
    /// Output folder: frames/NNN.png, sequence.gif, manifest.json (and compare.gif with --compare).
    #[arg(short, long)]
    pub out: PathBuf,
    /// Output size WxH [default: the rate, normal or height map's size when one is given, else twice the input's]
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Use input frames A..B only (end exclusive, counted from 0; e.g. 10..60) [default: all]
    #[arg(long, value_parser = parse_range)]
    pub frames: Option<Range<usize>>,
    /// Keep every K-th input frame (after --frames).
    #[arg(long, default_value_t = 1, value_parser = |s: &str| crate::flags::count(s, 1, 2000))]
    pub step: usize,
    /// Singular vectors compared per colour channel (the SVD rank k of section 5.2); 0 compares every frame (slow).
    #[arg(long, default_value_t = 15, value_parser = |s: &str| crate::flags::count(s, 0, 256))]
    pub rank: usize,
    /// Instead of a fixed rank, the smallest rank whose relative RMS reconstruction error is at most this (e.g. 0.05).
    #[arg(long, conflicts_with = "rank")]
    pub max_error: Option<f64>,
    /// Block size WxH; may be elongated, e.g. 320x64 for growing grass [default: a quarter of the input's smaller side, 8..64]
    #[arg(long, value_parser = parse_size)]
    pub block: Option<(usize, usize)>,
    /// Overlap between neighbouring blocks, in pixels [default: a third of the block, at least 2]
    #[arg(long, value_parser = |s: &str| crate::flags::count(s, 1, 512))]
    pub overlap: Option<usize>,
    /// Candidate blocks: those within (1 + tolerance) x the best cost.
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub tolerance: f32,
    /// Soften each seam over this many pixels on either side (0 = the paper's hard cut); for use with --no-blend, as a feathered step survives the gradient-domain blend.
    #[arg(long, default_value_t = 0, value_parser = |s: &str| crate::flags::count(s, 0, 64))]
    pub feather: usize,
    /// Time jitter E (eqs. 6-7): each block's clock drifts randomly by at most E frames (less while the whole surface changes fast), so copies of one block do not change in lockstep; frame by frame a block follows its own drift where that is invisible and falls into step with its neighbours where a change crosses its seam (dynamic programming over eq. 6's steps), changes its drift (a held or skipped frame) seldom where it moves fast and hardly ever twice within 3 frames (no freezes), gives a lead back gradually before the last frame, and never shows a frame whose block-scale colour differs visibly (over 4%) from the output time's, so a fast change of the whole surface is not shown as a patchwork of times; times are whole frames; 0 = off [default: a twelfth of the frames]
    #[arg(long, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 2000.0))]
    pub jitter: Option<f32>,
    /// Lighting (section 5.3): keep = quilt the frames as they are; flat = divide out the illumination (the frames' mean field, such as a vignette or a flash hot-spot, plus each frame's slow drift), the capture's exposure flicker, a specular streak fixed in the frame and the first frame's light (a polished plate's reflections, on a smooth first frame) where later frames still show it, quilt the detail and light the output evenly; stretch = the same, then put the input's lighting back stretched to the output; auto = flat when the input's large-scale variation is above 0.08 and its shorter side at least 96 px, else keep.
    #[arg(long, value_enum, default_value_t = LightingArg::Auto)]
    pub lighting: LightingArg,
    /// Join blocks with the paper's cut only: no gradient-domain blending of the seams.
    #[arg(long)]
    pub no_blend: bool,
    /// Heal the quilt's cuts: re-make them by texture optimization of 5x5 patches of whole time columns, shifted
    /// continuations of the blocks that meet there, one correspondence for every frame (no flicker). Softens jagged cuts
    /// through smooth frames (rusting steel); blurs fast-moving content a little (sprouts) and shows cut features whole,
    /// so repeats can rise; not with --tile or --feather [default: off]
    #[arg(long, conflicts_with_all = ["tile", "feather"])]
    pub heal: bool,
    /// Make every frame tile seamlessly (its left edge continues its right and its top its bottom): the time columns
    /// are quilted round a torus; the seams are then not blended (the blend does not wrap); not with --lighting stretch.
    #[arg(long)]
    pub tile: bool,
    /// Take the frames as they are. By default a camera that shakes is undone first: each frame is registered to
    /// the ones before it (a whole-pixel translation, by phase correlation) and all are cropped to the window they
    /// share, so that a time column follows one place on the surface instead of flickering.
    #[arg(long)]
    pub no_register: bool,
    /// Reuse penalty: a block's cost grows by this factor for every block already taken from around the same input spot (0 = off, the paper); fewer repeated features, at the price of more events per area.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub reuse: f32,
    /// Rare-feature penalty: a block holding a distinctive event or feature (no near twin elsewhere in the input) costs more for every time it was already pasted, in proportion to how distinctive it is (0 = off, the paper; off by default: on a rust test sequence it made calm steel repeat more).
    #[arg(long, default_value_t = ttf::RARITY, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub rarity: f32,
    /// Material-share control: the input's time columns are split into material families (k-means of their colour over time), and a block's cost grows with how far the materials it holds are over their share of the input in what was pasted so far, and shrinks with how far they are under it (0 = off, the paper); without it the reuse penalty starves a material that fills a small part of the input (copper's patina came out at half its share).
    #[arg(long, default_value_t = ttf::FAMILIES, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub families: f32,
    /// Sum the block cost over frames as they are (the paper's eq. 3). By default each frame is weighted by the inverse of its fine-detail contrast, so smooth early frames get seams as clean as busy late ones.
    #[arg(long)]
    pub no_balance: bool,
    /// Rate map: a greyscale image of the output's size; each pixel runs at luminance x --rate-scale times the input's speed (0 = frozen).
    #[arg(long, conflicts_with_all = ["rate_light", "rate_curvature"])]
    pub rate_map: Option<PathBuf>,
    /// Rate from a point light at X,Y,Z (output pixels, Z above the surface): (cos theta / r^2)^2, scaled to 1 at its fastest.
    #[arg(long, value_parser = parse_point, conflicts_with = "rate_curvature")]
    pub rate_light: Option<[f32; 3]>,
    /// Normal map for --rate-light (RGB, n = 2 rgb - 1; the output's size) [default: a flat surface]
    #[arg(long, requires = "rate_light")]
    pub normal_map: Option<PathBuf>,
    /// Rate from a height map's curvature (the output's size): ridges change fastest, flats at half speed, hollows slowest.
    #[arg(long)]
    pub rate_curvature: Option<PathBuf>,
    /// Multiplies the rate map (2 = twice as fast, and half as many frames).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::positive(s, 0.0, 100.0))]
    pub rate_scale: f32,
    /// Also write compare.gif: the input and the output side by side.
    #[arg(long)]
    pub compare: bool,
    /// Milliseconds per frame in the GIFs.
    #[arg(long, default_value_t = 80)]
    pub gif_delay: u32,
    /// Make only part K of N of the output frames (e.g. 3/8), numbered as in the whole output, for a render farm:
    /// every chunk computes the whole run's layout, so chunks are byte-identical to the same frames of one run
    /// and join without overlap. Merge them with `python -m patina.batch ttf ... --chunks N`, or by copying the
    /// frames/ folders together [default: all frames]
    #[arg(long, value_parser = parse_chunk)]
    pub chunk: Option<(usize, usize)>,
    /// Random seed; the same inputs and seed give identical outputs.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Replace OUT if it exists (only a folder patina wrote; it is swapped in whole when the run succeeds).
    #[arg(long)]
    pub overwrite: bool,
}

/// `--lighting` choices.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum LightingArg {
    Auto,
    Keep,
    Flat,
    Stretch,
}

impl From<LightingArg> for SequenceLighting {
    fn from(l: LightingArg) -> Self {
        match l {
            LightingArg::Auto => SequenceLighting::Auto,
            LightingArg::Keep => SequenceLighting::Keep,
            LightingArg::Flat => SequenceLighting::Flat,
            LightingArg::Stretch => SequenceLighting::Stretch,
        }
    }
}

fn parse_range(s: &str) -> std::result::Result<Range<usize>, String> {
    let bad = || format!("'{s}' is not a frame range A..B (e.g. 10..60)");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let (a, b): (usize, usize) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if a >= b {
        return Err(format!("frame range {a}..{b} is empty"));
    }
    Ok(a..b)
}

/// Parse `K/N` with 1 <= K <= N.
fn parse_chunk(s: &str) -> std::result::Result<(usize, usize), String> {
    let bad = || format!("'{s}' is not a chunk K/N (e.g. 3/8)");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n): (usize, usize) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
    if n == 0 || k == 0 || k > n || n > 10_000 {
        return Err(format!("chunk {k}/{n} must have 1 <= K <= N <= 10000"));
    }
    Ok((k, n))
}

/// The output frames of chunk K of N: N near-equal consecutive ranges.
fn chunk_range((k, n): (usize, usize), frames: usize) -> Range<usize> {
    (k - 1) * frames / n..k * frames / n
}

fn parse_point(s: &str) -> std::result::Result<[f32; 3], String> {
    let v: Vec<f32> =
        s.split(',').map(|p| p.trim().parse::<f32>()).collect::<std::result::Result<_, _>>().map_err(|_| format!("'{s}' is not X,Y,Z"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("'{s}' is not X,Y,Z (three numbers)")),
    }
}

/// The rate map the flags ask for, and the output size it implies.
fn rate_map(args: &Args, size: Option<(usize, usize)>) -> Result<Option<RateMap>> {
    let sized = |img: &Image, what: &str, path: &Path| -> Result<()> {
        match size {
            Some(s) if s != img.size() => Err(Error::invalid(format!(
                "{what} {} is {}x{} but the output is {}x{}",
                path.display(),
                img.width(),
                img.height(),
                s.0,
                s.1
            ))),
            _ => Ok(()),
        }
    };
    let map = if let Some(p) = &args.rate_map {
        let img = crate::input::load(p)?;
        sized(&img, "rate map", p)?;
        Some(RateMap::from_image(&img, 1.0)?)
    } else if let Some(light) = args.rate_light {
        let normals = args.normal_map.as_ref().map(crate::input::load).transpose()?;
        if let (Some(n), Some(p)) = (&normals, &args.normal_map) {
            sized(n, "normal map", p)?;
        }
        let (w, h) =
            size.or(normals.as_ref().map(Image::size)).ok_or_else(|| Error::invalid("--rate-light needs --size or --normal-map"))?;
        Some(RateMap::from_light(w, h, light, normals.as_ref())?)
    } else if let Some(p) = &args.rate_curvature {
        let img = crate::input::load(p)?;
        sized(&img, "height map", p)?;
        Some(RateMap::from_curvature(&img)?)
    } else {
        None
    };
    map.map(|m| m.scaled(args.rate_scale)).transpose()
}

pub fn run(args: Args) -> Result<()> {
    let mut clock = Stopwatch::start();
    let mut manifest = Manifest::new("ttf", args.seed);
    let mut seq = load_sequence(&args.input)?;
    if let Some(r) = &args.frames {
        seq = seq.subsample(r.clone(), args.step)?;
    } else if args.step > 1 {
        let n = seq.frames.len();
        seq = seq.subsample(0..n, args.step)?;
    }
    let Sequence { frames, names } = seq;
    let (frames, registration) = crate::input::registered(frames, 0..3, args.no_register)?;
    let rate = rate_map(&args, args.size)?;
    let (iw, ih) = frames[0].size();
    let size = args.size.or(rate.as_ref().map(|r| r.image().size())).unwrap_or((2 * iw, 2 * ih));
    let mut inputs: Vec<PathBuf> = vec![args.input.clone()];
    inputs.extend(names.iter().map(PathBuf::from).filter(|p| p.is_file()));
    inputs.extend([&args.rate_map, &args.normal_map, &args.rate_curvature].into_iter().flatten().cloned());
    let input_refs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    let out = OutDir::begin(&args.out, &input_refs, args.overwrite)?;
    let dir = out.path();
    manifest.timings_ms.insert("load".into(), clock.lap());

    let params = TtfParams {
        rank: args.rank,
        max_error: args.max_error,
        quilt: QuiltParams {
            block: args.block,
            overlap: args.overlap.map(|o| (o, o)),
            tolerance: args.tolerance,
            feather: args.feather,
            blend: !args.no_blend,
            reuse: args.reuse,
            rarity: args.rarity,
            families: args.families,
            ..TtfParams::default().quilt
        },
        jitter: args.jitter,
        lighting: args.lighting.into(),
        balance: !args.no_balance,
        tile: args.tile,
        heal: args.heal,
    };
    let total = ttf::output_frames(&frames, size, &params, rate.as_ref())?;
    let chunk = args.chunk.map(|c| chunk_range(c, total));
    if chunk.as_ref().is_some_and(|c| c.is_empty()) {
        let (k, n) = args.chunk.unwrap_or_default();
        return Err(Error::invalid(format!("chunk {k}/{n} holds none of the output's {total} frames; use fewer chunks")));
    }
    let result =
        with_bar("ttf", |report| ttf::synthesize_chunk(&frames, size, &params, rate.as_ref(), args.seed, chunk.clone(), Some(report)))?;
    manifest.timings_ms.insert("synthesize".into(), clock.lap());

    let first = result.first_frame;
    let timed: Vec<(f32, &Image)> = result.frames.iter().enumerate().map(|(t, f)| ((first + t) as f32, f)).collect();
    write_sequence_from(dir, first, &timed, args.gif_delay, &mut manifest)?;
    if args.compare {
        let n = frames.len();
        let pairs: Vec<Image> = (0..result.frames.len())
            .map(|i| {
                let t = first + i;
                let src = if total > 1 { (t * (n - 1) + (total - 1) / 2) / (total - 1) } else { 0 };
                side_by_side(&frames[src.min(n - 1)], &result.frames[i])
            })
            .collect();
        save_gif(&pairs.iter().collect::<Vec<_>>(), dir.join("compare.gif"), args.gif_delay)?;
        manifest.outputs.push("compare.gif".into());
    }
    if let Some(r) = &rate {
        save_png(&normalised(r.image()), dir.join("rate_map.png"), BitDepth::Eight)?;
        manifest.outputs.push("rate_map.png".into());
    }
    manifest.timings_ms.insert("save".into(), clock.lap());

    let mut p = serde_json::to_value(&params).map_err(|e| Error::Internal(e.to_string()))?;
    p["size"] = json!([size.0, size.1]);
    p["block_used"] = json!([result.plan.block.0, result.plan.block.1]);
    p["overlap_used"] = json!([result.plan.overlap.0, result.plan.overlap.1]);
    p["input_frames"] = json!(frames.len());
    p["jitter_used"] = json!(params.jitter_frames(frames.len()));
    p["lighting_used"] = json!(result.lighting.as_ref().map_or("keep", |l| l.relight));
    p["frames_range"] = json!(args.frames.as_ref().map(|r| [r.start, r.end]));
    p["step"] = json!(args.step);
    p["registered"] = json!(!args.no_register);
    p["registration"] = json!(registration);
    p["output_frames"] = json!(total);
    p["chunk"] = json!(args.chunk.map(|(k, n)| json!({ "index": k, "of": n, "frames": [first, first + result.frames.len()] })));
    p["rate"] = json!(match (&args.rate_map, args.rate_light, &args.rate_curvature) {
        (Some(f), _, _) => json!({ "map": f, "scale": args.rate_scale }),
        (_, Some(l), _) => json!({ "light": l, "normal_map": args.normal_map, "scale": args.rate_scale }),
        (_, _, Some(f)) => json!({ "curvature": f, "scale": args.rate_scale }),
        _ => serde_json::Value::Null,
    });
    manifest.params = p;
    if let Some(c) = &result.compression {
        manifest.metrics.insert("svd_rank".into(), json!(c.rank));
        manifest.metrics.insert("svd_relative_rms".into(), json!(c.relative_rms));
        manifest.metrics.insert("singular_values".into(), json!(c.singular_values.iter().take(32).collect::<Vec<_>>()));
    }
    if let Some(l) = &result.lighting {
        manifest.metrics.insert("lighting".into(), json!(l));
        manifest.metrics.insert("exposure_flicker_removed".into(), json!(result.exposure_flicker));
    }
    if let Some(h) = &result.highlight {
        manifest.metrics.insert("highlight_removed".into(), json!(h));
    }
    if let Some(s) = &result.start_light {
        manifest.metrics.insert("start_light_removed".into(), json!(s));
    }
    manifest.metrics.insert("flicker_input".into(), json!(patina::metrics::flicker(&frames)));
    manifest.metrics.insert("flicker_output".into(), json!(patina::metrics::flicker(&result.frames)));
    manifest.inputs = vec![args.input.clone()];
    manifest.inputs.extend([&args.rate_map, &args.normal_map, &args.rate_curvature].into_iter().flatten().cloned());
    manifest.write(&dir.join("manifest.json"))?;
    out.commit()?;
    crate::input::registration_note(&registration);
    crate::output::summary(format!("patina ttf: wrote {} frames of {}x{} to {}", result.frames.len(), size.0, size.1, args.out.display()));
    Ok(())
}

/// A rate map scaled to [0, 1] for viewing.
fn normalised(img: &Image) -> Image {
    let max = img.value_range().1.max(1e-12);
    img.map(|v| v / max)
}
