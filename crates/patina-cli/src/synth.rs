//! `patina synth`: texture synthesis from an exemplar.

use crate::output::{check_outputs, manifest_path, parse_size, Manifest, Stopwatch};
use crate::progress::with_bar;
use clap::ValueEnum;
use patina::image::io::{self, BitDepth};
use patina::image::Image;
use patina::synth::{Init, Lattice, OptimizeParams, QuiltParams, Relight, Synthesis, VoteWeights};
use patina::Result;
use serde_json::json;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Quilt a plain enlargement; optimize when the output must tile or follows guides. (Two blind reviews of
    /// 7 structured photos preferred the quilt's whole tiles and straight courses to optimize's healed seams,
    /// and its detail coherence was as good or better on 8 of 10 real exemplars; a tileable quilt keeps its
    /// cuts unblended, and guided quilting does not blend its seams.)
    Auto,
    /// Texture optimization: PatchMatch search + voting over a pyramid (EbSynth-like).
    Optimize,
    /// Image quilting: blocks joined along minimum-error cuts (Efros-Freeman).
    Quilt,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum InitArg {
    /// Each pixel a random exemplar patch (EbSynth).
    Random,
    /// Coherent random blocks (Kwatra et al.).
    Blocks,
    /// A coarse image quilt: keeps structure such as brick courses.
    Quilt,
    /// A full-resolution quilt whose block interiors are kept; the optimization heals only the seams.
    QuiltSeams,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum VoteArg {
    /// Plain mean of the overlapping patches (EbSynth).
    Mean,
    /// Kwatra's robust weights: well-matching patches dominate.
    Robust,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RelightArg {
    /// Copy the exemplar's lighting with its patches.
    Keep,
    /// Remove the exemplar's smooth illumination (vignette, ramp) and light the output evenly at its mean.
    Flat,
    /// Re-light with the exemplar's illumination stretched to the output.
    Stretch,
}

impl RelightArg {
    fn relight(self) -> Relight<'static> {
        match self {
            RelightArg::Keep => Relight::Keep,
            RelightArg::Flat => Relight::Flat,
            RelightArg::Stretch => Relight::Stretch,
        }
    }
}

/// Parse `N` (square) or `WxH`.
fn parse_block(s: &str) -> std::result::Result<(usize, usize), String> {
    match s.parse::<usize>() {
        Ok(0) => Err("block size must be at least 1".into()),
        Ok(n) => Ok((n, n)),
        Err(_) => parse_size(s),
    }
}

fn parse_bits(s: &str) -> std::result::Result<u8, String> {
    match s {
        "8" => Ok(8),
        "16" => Ok(16),
        _ => Err(format!("'{s}' is not 8 or 16")),
    }
}

#[derive(clap::Args)]
pub struct Args {
    /// Exemplar image: PNG or JPEG (8/16-bit, gray/RGB, with or without alpha) or OpenEXR.
    pub exemplar: PathBuf,
    /// Output image, .png or .exr. OUT.manifest.json is written beside it.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Output size WIDTHxHEIGHT [default: the target guide's size, else twice the exemplar's].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Synthesis method.
    #[arg(long, value_enum, default_value_t = Method::Auto)]
    pub method: Method,
    /// Random seed: the same inputs and seed give the same bytes.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Patch side in pixels, odd (optimize).
    #[arg(long, default_value_t = 5, value_parser = |s: &str| crate::flags::count(s, 3, 63).and_then(|v| if v % 2 == 1 { Ok(v) } else { Err(format!("patch {v} must be odd")) }))]
    pub patch: usize,
    /// Search + vote iterations per pyramid level (optimize).
    #[arg(long, default_value_t = 6, value_parser = |s: &str| crate::flags::count(s, 1, 100))]
    pub iters: usize,
    /// PatchMatch sweeps per search (optimize).
    #[arg(long, default_value_t = 4, value_parser = |s: &str| crate::flags::count(s, 1, 64))]
    pub pm_iters: usize,
    /// Pyramid levels (optimize) [default: as many as keep the coarsest level 4 patches wide].
    #[arg(long, value_parser = |s: &str| crate::flags::count(s, 1, 16))]
    pub levels: Option<usize>,
    /// Uniformity weight: penalises reusing the same exemplar patches (optimize; 0 = off; EbSynth's 3500 in 8-bit units; not used by --init quilt-seams, whose quilt spreads its sources with --reuse).
    #[arg(long, default_value_t = 3500.0 / 65025.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0e6))]
    pub uniformity: f32,
    /// How overlapping patches are combined (optimize).
    #[arg(long, value_enum, default_value_t = VoteArg::Mean)]
    pub vote: VoteArg,
    /// How the coarsest level starts (optimize).
    #[arg(long, value_enum, default_value_t = InitArg::QuiltSeams)]
    pub init: InitArg,
    /// Stop threshold: re-search only pixels whose patch changed by at least this much after a vote (optimize; 0 = always; EbSynth's 5 of 255).
    #[arg(long, default_value_t = 5.0 / 255.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0))]
    pub stop_threshold: f32,
    /// Block size, N or WxH (quilt) [default: a quarter of the exemplar's smaller side, within 8..64].
    #[arg(long, value_parser = parse_block)]
    pub block: Option<(usize, usize)>,
    /// Overlap, N or WxH (quilt) [default: block / 6].
    #[arg(long, value_parser = parse_block)]
    pub overlap: Option<(usize, usize)>,
    /// Candidate blocks are those within (1 + tolerance) x the best overlap error (quilt).
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub tolerance: f32,
    /// Never choose among fewer candidate blocks than this (quilt; prevents verbatim copying).
    #[arg(long, default_value_t = 3, value_parser = |s: &str| crate::flags::count(s, 1, 1000))]
    pub min_candidates: usize,
    /// Reuse penalty: a candidate block's cost grows by this factor per block already taken from around the same exemplar spot (quilt; 0 = off, as in the paper).
    #[arg(long, default_value_t = QuiltParams::default().reuse, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub reuse: f32,
    /// Rare-feature penalty: a candidate block holding a distinctive feature (one with no near twin elsewhere in the exemplar, like a knot or a chip) costs more for every time that feature was already pasted, in proportion to how distinctive it is, so it is not stamped across the output (quilt, and optimize's quilt start; 0 = off).
    #[arg(long, default_value_t = QuiltParams::default().rarity, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub rarity: f32,
    /// Material-share penalty: the exemplar's colours are grouped into a few materials, and a candidate block of a
    /// material the output already holds more of than the exemplar does costs more, in proportion to the excess, so a
    /// material in one corner of the exemplar does not spread over the output (quilt, and optimize's quilt start;
    /// 0 = off, the default: try 1 for such exemplars; it can break structured ones and thin out rare features).
    #[arg(long, default_value_t = QuiltParams::default().families, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub families: f32,
    /// Relative overlap costs: a candidate block's overlap error is divided by (twin error + 0.25)^this, where the twin
    /// error is how far the exemplar's material there is from its nearest twin elsewhere (over the median), so busy
    /// material (peels, rust) competes fairly with plain paint instead of being left to the output's edges (quilt;
    /// 0 = plain errors, as in the paper).
    #[arg(long, default_value_t = QuiltParams::default().relative, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 4.0))]
    pub relative: f32,
    /// Reuse bound: a candidate block holding an exemplar region already covered by this many times its fair share of
    /// blocks is left out while another costs at most twice the --min-candidates-th cheapest, so one bloom is not pasted
    /// a dozen times while its twins go unused (quilt, and optimize's quilt start; 0 = off, the default: try 1 when one
    /// feature of a plain region repeats; it can break structure and copy rare features such as knots more often).
    #[arg(long, default_value_t = QuiltParams::default().cap, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 100.0))]
    pub cap: f32,
    /// Lay the blocks out in rows of random height, each row with its own random spacing, so block outlines do not line
    /// up into a grid (quilt; off by default: the paper's regular grid).
    #[arg(long)]
    pub stagger: bool,
    /// Blend blocks linearly across the overlap instead of cutting along the minimum-error seam (quilt).
    #[arg(long)]
    pub no_cut: bool,
    /// Keep the cut seams as they are instead of blending them in the gradient domain (quilt).
    #[arg(long)]
    pub no_blend: bool,
    /// Do not keep a regular structure in phase. By default, when the exemplar repeats regularly (a tile
    /// grid, brick courses, boards; found by autocorrelation, recorded in the manifest), each block is taken
    /// only where it continues its neighbours' grid (quilt, and optimize's quilt start).
    #[arg(long)]
    pub no_lattice: bool,
    /// Soften each minimum-error seam over this many pixels on either side (quilt; 0 = a hard cut).
    #[arg(long, default_value_t = 0, value_parser = |s: &str| crate::flags::count(s, 0, 64))]
    pub feather: usize,
    /// Texture-transfer passes with guides, each with blocks a third smaller (quilt).
    #[arg(long, default_value_t = 3, value_parser = |s: &str| crate::flags::count(s, 1, 10))]
    pub transfer_passes: usize,
    #[command(flatten)]
    pub guide: GuideArgs,
    /// Make the output tile seamlessly: its left edge continues its right and its top its bottom (wrap-around
    /// synthesis; with --method quilt the cuts are not blended; not with --relight stretch).
    #[arg(long)]
    pub tile: bool,
    /// How the output is lit (lighting-aware synthesis).
    #[arg(long, value_enum, default_value_t = RelightArg::Keep)]
    pub relight: RelightArg,
    /// Bits per channel of a PNG output (8 or 16).
    #[arg(long, default_value_t = 8, value_parser = parse_bits)]
    pub bits: u8,
}

impl Args {
    fn optimize_params(&self) -> OptimizeParams {
        OptimizeParams {
            patch: self.patch,
            levels: self.levels,
            search_vote_iters: self.iters,
            patchmatch_iters: self.pm_iters,
            uniformity: self.uniformity,
            vote: match self.vote {
                VoteArg::Mean => VoteWeights::Mean,
                VoteArg::Robust => VoteWeights::Robust,
            },
            init: match self.init {
                InitArg::Random => Init::Random,
                InitArg::QuiltSeams => Init::QuiltSeams,
                InitArg::Blocks => Init::Blocks,
                InitArg::Quilt => Init::Quilt,
            },
            stop_threshold: self.stop_threshold,
            lattice: !self.no_lattice,
            rarity: self.rarity,
            families: self.families,
            cap: self.cap,
            search_radius: None,
        }
    }

    fn quilt_params(&self) -> QuiltParams {
        QuiltParams {
            block: self.block,
            overlap: self.overlap,
            tolerance: self.tolerance,
            min_candidates: self.min_candidates,
            boundary_cut: !self.no_cut,
            feather: self.feather,
            transfer_passes: self.transfer_passes,
            reuse: self.reuse,
            rarity: self.rarity,
            families: self.families,
            blend: !self.no_blend,
            lattice: !self.no_lattice,
            stagger: self.stagger,
            relative: self.relative,
            cap: self.cap,
        }
    }
}

/// A pair of guide images and their weight, shared by every command that
/// synthesizes under guides.
#[derive(clap::Args)]
pub struct GuideArgs {
    /// Guide image for the exemplar or material (same size as it); needs --target-guide.
    #[arg(long, requires = "target_guide")]
    pub source_guide: Option<PathBuf>,
    /// Guide image for the output (its size is the output size); needs --source-guide.
    #[arg(long, requires = "source_guide")]
    pub target_guide: Option<PathBuf>,
    /// Weight of the guide term against appearance.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = |s: &str| crate::flags::number(s, 0.0, 1.0e6))]
    pub guide_weight: f32,
}

impl GuideArgs {
    /// The guide files given (none or both).
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.source_guide.as_deref().into_iter().chain(self.target_guide.as_deref())
    }

    /// Load the (source, target) guides, if given.
    pub fn load(&self) -> Result<Option<(Image, Image)>> {
        match (&self.source_guide, &self.target_guide) {
            (Some(s), Some(t)) => Ok(Some((crate::input::load(s)?, crate::input::load(t)?))),
            _ => Ok(None),
        }
    }
}

/// Period vectors as "(x, y) px and (x, y) px".
fn periods_text(periods: &[[f32; 2]]) -> String {
    periods.iter().map(|p| format!("({:.1}, {:.1}) px", p[0], p[1])).collect::<Vec<_>>().join(" and ")
}

/// A tileable output of a regular texture closes its grid across the
/// edges only when its size is a whole number of periods: say which size
/// nearest the asked one would (the manifest holds the lattice).
fn tile_fit_note(lattice: &Lattice, size: (usize, usize)) {
    let fit = lattice.tile_fit(size, 8);
    if fit != size {
        crate::output::summary(format!(
            "note: the exemplar repeats every {}; a {}x{} tile breaks that grid at its edges, {}x{} would close it",
            periods_text(&lattice.periods),
            size.0,
            size.1,
            fit.0,
            fit.1
        ));
    }
}

pub fn run(args: Args) -> Result<()> {
    let mut clock = Stopwatch::start();
    let mut manifest = Manifest::new("synth", args.seed);
    let manifest_file = manifest_path(&args.out);
    let mut inputs: Vec<&Path> = vec![&args.exemplar];
    inputs.extend(args.guide.paths());
    check_outputs(&[&args.out, &manifest_file], &inputs)?;

    let exemplar = crate::input::load(&args.exemplar)?;
    io::output_format(&args.out, exemplar.channels())?;
    let depth = if args.bits == 16 { BitDepth::Sixteen } else { BitDepth::Eight };
    let guides = args.guide.load()?;
    let size = args.size.or(guides.as_ref().map(|(_, t)| t.size())).unwrap_or((2 * exemplar.width(), 2 * exemplar.height()));
    manifest.timings_ms.insert("load".into(), clock.lap());

    let (image, mut params, lattice, drifting) = with_bar("synth", |report| -> Result<_> {
        let mut problem = Synthesis::new(&exemplar)
            .size(size.0, size.1)
            .seed(args.seed)
            .progress(report)
            .relight(args.relight.relight())
            .tileable(args.tile);
        if let Some((s, t)) = &guides {
            problem = problem.guides(s, t, args.guide.guide_weight);
        }
        let quilt = match args.method {
            Method::Quilt => true,
            Method::Optimize => false,
            Method::Auto => !args.tile && guides.is_none(),
        };
        Ok(if quilt {
            let mut p = args.quilt_params();
            let out = problem.quilt(&p)?;
            (p.block, p.overlap) = (Some(out.plan.block), Some(out.plan.overlap));
            manifest.metrics.insert("blocks".into(), json!(out.plan.placements.len()));
            manifest.metrics.insert("lighting".into(), json!(out.lighting));
            manifest.metrics.insert("lattice".into(), json!(out.lattice));
            (out.image, json!({ "method": "quilt", "quilt": p }), out.lattice, out.drifting)
        } else {
            let mut p = args.optimize_params();
            let out = problem.optimize(&p)?;
            p.levels = Some(out.levels);
            let texels = (p.patch * p.patch) as f32;
            manifest.metrics.insert("mean_patch_rms".into(), json!((out.nnf.mean_cost(None) / texels).sqrt()));
            manifest.metrics.insert("lighting".into(), json!(out.lighting));
            manifest.metrics.insert("lattice".into(), json!(out.lattice));
            (out.image, json!({ "method": "optimize", "optimize": p }), out.lattice, out.drifting)
        })
    })?;
    manifest.timings_ms.insert("synthesize".into(), clock.lap());
    if let Some(l) = lattice.as_ref().filter(|_| args.tile) {
        tile_fit_note(l, size);
    }
    if !drifting.is_empty() {
        manifest.metrics.insert("drifting_periods".into(), json!(drifting));
        crate::output::summary(format!(
            "note: the exemplar repeats about every {}, but that period changes across it by more than {:.0}% \
             (perspective?), so blocks are not kept in phase with it; a photo taken square-on keeps rows and columns whole",
            periods_text(&drifting),
            100.0 * patina::synth::lattice::DRIFT
        ));
    }
    crate::embed::commit_point();
    crate::output::save(&image, &args.out, depth)?;
    manifest.timings_ms.insert("save".into(), clock.lap());
    params["size"] = json!([size.0, size.1]);
    params["guide_weight"] = json!(args.guide.guide_weight);
    params["bits"] = json!(args.bits);
    params["relight"] = json!(args.relight.relight().name());
    params["tile"] = json!(args.tile);
    manifest.params = params;
    manifest.inputs = inputs.iter().map(|p| p.to_path_buf()).collect();
    manifest.outputs = vec![args.out.clone()];
    manifest.write(&manifest_file)
}
