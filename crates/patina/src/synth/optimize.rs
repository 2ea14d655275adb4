//! Texture optimization (Kwatra, Essa, Bobick, Kwatra 2005; Wexler et al.
//! 2007), organised as in EbSynth (Jamriska et al. 2019): a coarse-to-fine
//! pyramid; at each level, alternate PatchMatch search (appearance + guide
//! cost, plus the uniformity penalty of Kaspar et al. 2015) with voting; the
//! field found at one level seeds the next, twice as fine.

use super::distance::{pad_for_search, search_padding, PatchMetric};
use super::nnf::{block_nnf, random_nnf, upsample_nnf, Match, Nnf, SourceDomain};
use super::patchmatch::PatchMatch;
use super::problem::Synthesis;
use super::quilt::QuiltParams;
use super::torus::Torus;
use super::vote::{vote, VoteWeights};
use crate::error::{Error, Result};
use crate::image::resample::{gaussian_pyramid, pyramid};
use crate::image::{Image, Mask};
use crate::rng;
use serde::{Deserialize, Serialize};

/// Parameters of texture optimization. Defaults follow EbSynth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OptimizeParams {
    /// Patch side in pixels (odd). EbSynth: 5.
    pub patch: usize,
    /// Pyramid levels; `None` picks as many as keep the coarsest level's
    /// smaller side at least [`MIN_COARSE_SIDE_QUILT`] pixels (with a quilt
    /// start) or 4 patches (otherwise) wide.
    pub levels: Option<usize>,
    /// Search + vote iterations per level. EbSynth: 6.
    pub search_vote_iters: usize,
    /// PatchMatch sweeps per search. EbSynth: 4.
    pub patchmatch_iters: usize,
    /// Weight of the uniformity penalty (0 = off). EbSynth's default 3500
    /// is in 8-bit units squared; ours are [0, 1] units: 3500 / 255^2.
    pub uniformity: f32,
    /// How votes are combined (EbSynth: mean).
    pub vote: VoteWeights,
    /// How the coarsest level starts.
    pub init: Init,
    /// EbSynth's stop threshold: after a vote, only pixels whose patch holds
    /// a value that moved by at least this much are searched again (in
    /// value units; EbSynth's 5 of 255). 0 searches every pixel every time.
    pub stop_threshold: f32,
    /// A quilt start keeps the exemplar's regular structure in phase
    /// ([`super::QuiltParams::lattice`]).
    pub lattice: bool,
    /// A quilt start copies the exemplar's rare features sparingly
    /// ([`super::QuiltParams::rarity`]; 0 = off).
    pub rarity: f32,
    /// A quilt start keeps the exemplar's mix of materials
    /// ([`super::QuiltParams::families`]; 0 = off).
    pub families: f32,
    /// A quilt start bounds how often one exemplar region is used
    /// ([`super::QuiltParams::cap`]; 0 = off).
    pub cap: f32,
    /// PatchMatch's random search looks at most this many pixels from each
    /// pixel's current match (default: the whole exemplar). Healing a
    /// layout ([`Synthesis::heal_layout`]) with a small radius only shifts
    /// and extends the layout's own blocks, so it brings in no source
    /// content the layout did not already hold.
    pub search_radius: Option<usize>,
}

/// Initial nearest-neighbour field of the coarsest level.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Init {
    /// Every pixel a random source patch (EbSynth). Votes to a grey average,
    /// from which optimization often settles on smooth, structureless minima.
    Random,
    /// Coherent random blocks of [`INIT_BLOCK`] pixels (Kwatra et al.).
    Blocks,
    /// Image quilting (texture transfer when guided) at the coarsest level:
    /// the optimization starts from quilting's intact structure and only
    /// refines it. Falls back to `Blocks` when filling a hole.
    Quilt,
    /// Quilt at full resolution and keep the quilt's correspondence; then
    /// optimize at that one level, searching only around the seams (the
    /// blocks' overlaps) at first and then wherever a vote changed the
    /// image. Block interiors stay verbatim copies, so joints, grout and
    /// grain keep their structure, while the optimization heals the seams
    /// (the "quilt-then-optimize" of DESIGN.md; mean voting over many
    /// misaligned candidates at coarse levels is what smeared structure).
    /// The uniformity penalty is not applied (the quilt's reuse penalty
    /// spreads the sources), and at most [`SEAM_ITERS`] iterations run.
    /// Falls back to `Blocks` when filling a hole.
    QuiltSeams,
}

/// Most search + vote iterations of [`Init::QuiltSeams`]: the seams settle
/// by then (on the 8 real exemplars of examples/engine_quality, 3 gave the
/// same coherence and completeness as 6, in 60% of the time).
pub const SEAM_ITERS: usize = 3;

/// Block side, in coarsest-level pixels, of [`Init::Blocks`].
pub const INIT_BLOCK: usize = 8;

impl Default for OptimizeParams {
    fn default() -> Self {
        OptimizeParams {
            patch: 5,
            levels: None,
            search_vote_iters: 6,
            patchmatch_iters: 4,
            uniformity: 3500.0 / 65025.0,
            vote: VoteWeights::Mean,
            init: Init::QuiltSeams,
            stop_threshold: 5.0 / 255.0,
            lattice: true,
            rarity: QuiltParams::default().rarity,
            families: QuiltParams::default().families,
            cap: QuiltParams::default().cap,
            search_radius: None,
        }
    }
}

/// The result of a synthesis.
#[derive(Clone, Debug)]
pub struct Synthesized {
    pub image: Image,
    /// The final nearest-neighbour field (output pixel -> exemplar patch centre).
    pub nnf: Nnf,
    /// Pyramid levels used.
    pub levels: usize,
    /// What lighting-aware synthesis separated, when asked for.
    pub lighting: Option<super::lighting::LightingReport>,
    /// The regular structure the quilt start kept in phase, if any.
    pub lattice: Option<super::Lattice>,
    /// The drifting periods the quilt start did not ([`super::Quilted::drifting`]).
    pub drifting: Vec<[f32; 2]>,
}

impl Synthesized {
    /// Inside a coherent copy (the pixel's match continues at least two of
    /// its four neighbours' matches), the pixel becomes its match's centre
    /// pixel in `exemplar` instead of the mean of the overlapping patches'
    /// votes; only pixels in `region` change. The vote averages candidates
    /// that disagree slightly into a smooth wash (grown weathering had a
    /// third of the input's pixel-scale detail); where copies meet, the
    /// vote stays and hides the seam. This is the "verbatim copy where
    /// coherent" of coherence-based synthesis (Ashikhmin 2001), applied
    /// after the optimization.
    pub fn coherent_copies(&mut self, exemplar: &Image, region: &Mask) {
        let (w, h) = self.image.size();
        let n = self.image.channels().min(exemplar.channels());
        let nnf = &self.nnf;
        let offset = |x: usize, y: usize| {
            let m = nnf.get(x, y);
            (m.x as i64 - x as i64, m.y as i64 - y as i64)
        };
        for y in 1..h.saturating_sub(1) {
            for x in 1..w.saturating_sub(1) {
                if !region.get(x, y) {
                    continue;
                }
                let o = offset(x, y);
                let agree = [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)].iter().filter(|&&(u, v)| offset(u, v) == o).count();
                if agree >= 2 {
                    let m = nnf.get(x, y);
                    self.image.pixel_mut(x, y)[..n].copy_from_slice(&exemplar.pixel(m.x as usize, m.y as usize)[..n]);
                }
            }
        }
    }
}

/// Smallest coarsest-level side when the pyramid starts from a quilt. The
/// quilt already lays out the large-scale structure; levels coarser than
/// this only blur it: on gravel (512 px exemplar), going down to 32 px left
/// flat, smeared blobs that the finer levels never recovered from, while
/// stopping at 64 px kept every stone.
pub const MIN_COARSE_SIDE_QUILT: usize = 64;

/// Pyramid levels for sides down to `floor` pixels.
fn auto_levels(min_side: usize, floor: usize) -> usize {
    let mut levels = 1;
    while (min_side >> levels) >= floor && levels < 12 {
        levels += 1;
    }
    levels
}

/// Halve a mask: a coarse pixel is set when `any` (or all) of its fine pixels are.
fn mask_down(m: &Mask, any: bool) -> Mask {
    let (w, h) = (m.width().div_ceil(2), m.height().div_ceil(2));
    Mask::from_fn(w, h, |x, y| {
        let mut vals = (0..4).filter_map(|k| {
            let (fx, fy) = (2 * x + k % 2, 2 * y + k / 2);
            (fx < m.width() && fy < m.height()).then(|| m.get(fx, fy))
        });
        if any {
            vals.any(|v| v)
        } else {
            vals.all(|v| v)
        }
    })
}

/// Pixels whose right or lower neighbour was not copied from the next
/// exemplar pixel: where two blocks meet.
fn cut_lines(positions: &[(u32, u32)], w: usize, h: usize, wrap: bool) -> Mask {
    Mask::from_fn(w, h, |x, y| {
        let p = positions[y * w + x];
        let (xr, yb) = if wrap { ((x + 1) % w, (y + 1) % h) } else { (x + 1, y + 1) };
        let right = xr < w && positions[y * w + xr] != (p.0 + 1, p.1);
        let below = yb < h && positions[yb * w + x] != (p.0, p.1 + 1);
        right || below
    })
}

/// Pixels where some channel differs by at least `threshold`.
fn changed(a: &Image, b: &Image, threshold: f32) -> Mask {
    let n = a.channels();
    let (da, db) = (a.data(), b.data());
    Mask::from_fn(a.width(), a.height(), |x, y| {
        let i = (y * a.width() + x) * n;
        (0..n).any(|c| (da[i + c] - db[i + c]).abs() >= threshold)
    })
}

/// The field copying `layout` ([`Synthesis::heal_layout`]; positions
/// outside `domain` clamped into it) and its cut lines.
fn layout_field(layout: &[(u32, u32)], (w, h): (usize, usize), domain: &SourceDomain, wrap: bool) -> (Nnf, Mask) {
    let seams = cut_lines(layout, w, h, wrap);
    let matches = layout
        .iter()
        .map(|&(x, y)| {
            let (cx, cy) = domain.clamp(x as i64, y as i64);
            Match { x: cx as u32, y: cy as u32, cost: f32::INFINITY }
        })
        .collect();
    (Nnf::from_matches(w, h, matches), seams)
}

impl Synthesis<'_> {
    /// A field copying an image quilt of `style` (guided by the guides, if
    /// any) at `size`; positions outside `domain` are clamped into it.
    /// With `seams_only`, a full-resolution quilt with blocks of a quarter
    /// of the style's side (8..=128); else blocks of a third of it.
    /// Also returns the seams: the pixels where the source position does
    /// not continue to the right or below (the cut lines, not the whole
    /// overlap bands).
    #[allow(clippy::too_many_arguments)]
    fn quilt_field(
        &self,
        style: &Image,
        sg: Option<&Image>,
        tg: Option<&Image>,
        allowed: Option<&Mask>,
        size: (usize, usize),
        domain: &SourceDomain,
        seed: u64,
        seams_only: bool,
        start: &OptimizeParams,
    ) -> Result<(Nnf, Mask, super::lattice::Steady)> {
        let (lattice, rarity, families, cap) = (start.lattice, start.rarity, start.families, start.cap);
        let mut problem = Synthesis::new(style).size(size.0, size.1).seed(seed).tileable(self.tileable);
        if let Some(m) = allowed {
            problem = problem.source_mask(m);
        }
        if let (Some(s), Some(t)) = (sg, tg) {
            problem = problem.guides(s, t, self.guide_weight);
        }
        // Quilting scores blocks by FFT, which needs a weighted SSD; a
        // custom metric starts from a mean-SSD quilt instead (only the
        // start: every search after it uses the custom metric).
        if let Some(m) = self.metric.as_ref().filter(|m| m.ssd_weights().is_some()) {
            problem = problem.metric(m.clone());
        }
        let params = if seams_only {
            // The quilting default's block (a quarter of the exemplar's
            // side), capped at 128 rather than 64: large exemplars keep more
            // structure per block, and a 512 -> 4096 quilt has a quarter as
            // many blocks to search for.
            let block = (style.width().min(style.height()) / 4).clamp(8, 128);
            QuiltParams { block: Some((block, block)), lattice, rarity, families, cap, ..QuiltParams::default() }
        } else {
            let block = (style.width().min(style.height()) / 3).max(2 * domain.radius() + 3);
            QuiltParams { block: Some((block, block)), lattice, rarity, families, cap, ..QuiltParams::default() }
        };
        let quilted = problem.quilt(&params)?;
        let plan = quilted.plan;
        let (field, seams) = layout_field(&plan.source_positions(), size, domain, self.tileable);
        Ok((field, seams, (quilted.lattice, quilted.drifting)))
    }

    /// Synthesize by texture optimization.
    pub fn optimize(&self, params: &OptimizeParams) -> Result<Synthesized> {
        self.check_tileable()?;
        self.with_lighting(|s| s.optimize_as_is(params), |r| (&mut r.image, &mut r.lighting))
    }

    fn optimize_as_is(&self, params: &OptimizeParams) -> Result<Synthesized> {
        if params.patch < 3 || params.patch.is_multiple_of(2) || params.patch > super::distance::MAX_PATCH {
            return Err(Error::invalid(format!("patch size must be odd and in 3..={}, got {}", super::distance::MAX_PATCH, params.patch)));
        }
        if params.search_vote_iters == 0 || params.patchmatch_iters == 0 {
            return Err(Error::invalid("search/vote and PatchMatch iterations must be at least 1"));
        }
        let (w, h) = self.validate(params.patch)?;
        let r = params.patch / 2;
        let src = self.source;
        let min_side = src.width().min(src.height()).min(w).min(h);
        let quilt_start =
            (self.layout.is_some() || matches!(params.init, Init::Quilt | Init::QuiltSeams)) && self.fill.is_none() && self.start.is_none();
        let seams_only = quilt_start && (params.init == Init::QuiltSeams || self.layout.is_some());
        let floor = if quilt_start { MIN_COARSE_SIDE_QUILT.max(4 * params.patch) } else { 4 * params.patch };
        let levels = if seams_only { 1 } else { params.levels.unwrap_or_else(|| auto_levels(min_side, floor)).max(1) };
        if (min_side >> (levels - 1)) < params.patch {
            return Err(Error::invalid(format!("{levels} pyramid levels shrink the smallest side ({min_side} px) below one patch")));
        }

        let style_pyr = gaussian_pyramid(src, levels);
        let sguide_pyr = self.source_guide.map(|g| gaussian_pyramid(g, levels));
        let tguide_pyr = self.target_guide.map(|g| gaussian_pyramid(g, levels));
        let allowed_pyr = self.source_mask.map(|m| pyramid(m.clone(), levels, |m| mask_down(m, false)));
        let loose_pyr = self.source_mask.map(|m| pyramid(m.clone(), levels, |m| mask_down(m, true)));
        let fill_pyr = self.fill.map(|(img, _)| gaussian_pyramid(img, levels));
        let start_pyr = self.start.map(|img| gaussian_pyramid(img, levels));
        let hole_pyr = self.fill.map(|(_, hole)| pyramid(hole.clone(), levels, |m| mask_down(m, true)));
        let mut sizes = vec![(w, h)];
        while sizes.len() < levels {
            let (a, b) = *sizes.last().expect("non-empty");
            sizes.push((a.div_ceil(2), b.div_ceil(2)));
        }

        let metric: PatchMetric = self.full_metric();
        let iterations = if seams_only { params.search_vote_iters.min(SEAM_ITERS) } else { params.search_vote_iters };
        let total: u64 = sizes.iter().map(|(a, b)| (a * b * iterations) as u64).sum();
        let mut done = 0u64;
        let mut nnf: Option<Nnf> = None;
        let mut seams: Option<Mask> = None;
        let (mut lattice, mut drifting) = (None, Vec::new());
        let mut target = Image::new(1, 1, 1);
        for level in (0..levels).rev() {
            let (tw, th) = sizes[level];
            let style = &style_pyr[level];
            let source = match &sguide_pyr {
                Some(g) => Image::concat_channels(&[style, &g[level]])?,
                None => style.clone(),
            };
            let (source, search_metric) = pad_for_search(&source, &metric);
            let pad = Image::new(tw, th, search_padding(metric.channels()).max(1));
            // A scattered mask can leave no whole patch once shrunk: coarse
            // levels then use the looser "any allowed" mask, or none (the
            // finest level always holds the mask exactly).
            let domain = SourceDomain::new(source.width(), source.height(), r, allowed_pyr.as_ref().map(|p| &p[level])).or_else(|e| {
                if level == 0 {
                    return Err(e);
                }
                SourceDomain::new(source.width(), source.height(), r, loose_pyr.as_ref().map(|p| &p[level]))
                    .or_else(|_| SourceDomain::new(source.width(), source.height(), r, None))
            })?;
            let level_seed = rng::derive(self.seed, &[level as u64]);
            let mut field = match nnf.take() {
                Some(coarse) => upsample_nnf(&coarse, tw, th, &domain, level_seed),
                None => match params.init {
                    Init::Random => random_nnf(tw, th, &domain, level_seed),
                    Init::Quilt | Init::QuiltSeams if quilt_start => {
                        let sg = sguide_pyr.as_ref().map(|p| &p[level]);
                        let tg = tguide_pyr.as_ref().map(|p| &p[level]);
                        let allowed = allowed_pyr.as_ref().map(|p| &p[level]);
                        let field = match self.layout {
                            Some(layout) => {
                                let (field, seams) = layout_field(layout, (tw, th), &domain, false);
                                Ok((field, seams, (None, Vec::new())))
                            }
                            None => self.quilt_field(style, sg, tg, allowed, (tw, th), &domain, level_seed, seams_only, params),
                        };
                        match field {
                            Ok((field, overlap, found)) => {
                                (lattice, drifting) = found;
                                seams = seams_only.then(|| match self.tileable {
                                    true => Torus::new(tw, th, 2 * r + 2).dilate(&overlap),
                                    false => overlap.dilate(2 * r + 2),
                                });
                                field
                            }
                            // A scattered source mask may leave no room for a whole block.
                            Err(_) if allowed.is_some() => block_nnf(tw, th, &domain, INIT_BLOCK, level_seed),
                            Err(e) => return Err(e),
                        }
                    }
                    _ => block_nnf(tw, th, &domain, INIT_BLOCK, level_seed),
                },
            };
            let hole = hole_pyr.as_ref().map(|p| &p[level]);
            // A healed layout is searched only around its cut lines, first
            // and last: let out to wherever a vote moved, the joins of a
            // time-lapse's layout completed features that another block
            // already shows whole (near-verbatim repeats of the tests'
            // rusting sequence 0.185 -> 0.166, seed 1).
            let search = hole.map(|m| m.dilate(r)).or_else(|| self.layout.and(seams.clone()));
            let torus = self.tileable.then(|| Torus::new(tw, th, r));
            let coarsest = level == levels - 1;
            match (&start_pyr, coarsest) {
                // Start from the given image: search before the first vote.
                (Some(p), true) => target = p[level].clone(),
                _ => {
                    target = match &fill_pyr {
                        Some(p) => p[level].clone(),
                        None => Image::new(tw, th, style.channels()),
                    };
                    vote(&field, style, r, &mut target, hole, params.vote);
                }
            }
            let pm = PatchMatch {
                radius: r,
                iterations: params.patchmatch_iters,
                metric: &search_metric,
                // Seams only: the quilt's reuse penalty already spread the
                // sources, and the verbatim interiors' occupancy would push
                // the seam band away from continuing its own blocks (on the
                // real exemplars of examples/engine_quality this doubled
                // the coherence distance).
                uniformity: if seams_only { 0.0 } else { params.uniformity },
                max_search_radius: params.search_radius,
                exclude_self: None,
            };
            let mut active: Option<Mask> = search.clone().or(seams.take());
            // On a torus, the level is worked on padded copies (see `torus`):
            // only the interior is searched and voted.
            let interior = torus.map(|t| t.interior());
            let tguide = tguide_pyr.as_ref().map(|g| match &torus {
                Some(t) => std::borrow::Cow::Owned(t.pad_image(&g[level])),
                None => std::borrow::Cow::Borrowed(&g[level]),
            });
            let pad = match &torus {
                Some(t) => t.pad_image(&pad),
                None => pad,
            };
            // The masks over the worked image: searched, voted.
            let (mut search, mut voted) = (search, hole.cloned());
            if let (Some(t), Some(inside)) = (&torus, &interior) {
                target = t.pad_image(&target);
                field = t.pad_nnf(&field);
                let inner = |m: Option<&Mask>| {
                    let padded = m.map(|m| t.pad_mask(m));
                    Mask::from_fn(inside.width(), inside.height(), |x, y| inside.get(x, y) && padded.as_ref().is_none_or(|p| p.get(x, y)))
                };
                active = Some(inner(active.as_ref()));
                search = search.map(|s| inner(Some(&s)));
                voted = Some(inner(hole));
            }
            let votes = voted.as_ref();
            for it in 0..iterations {
                let mut parts = vec![&target];
                if let Some(g) = &tguide {
                    parts.push(g);
                }
                if search_padding(metric.channels()) > 0 {
                    parts.push(&pad);
                }
                let full = Image::concat_channels(&parts)?;
                pm.improve(&full, &source, &domain, &mut field, active.as_ref(), rng::derive(level_seed, &[it as u64]));
                if let Some(t) = &torus {
                    t.refresh_nnf(&mut field);
                }
                let before = (params.stop_threshold > 0.0).then(|| target.clone());
                vote(&field, style, r, &mut target, votes, params.vote);
                if let Some(t) = &torus {
                    t.refresh_image(&mut target);
                }
                if let Some(before) = before {
                    let moved = changed(&before, &target, params.stop_threshold).dilate(r);
                    active = Some(match search.as_ref().or(interior.as_ref()) {
                        Some(s) => Mask::from_fn(s.width(), s.height(), |x, y| s.get(x, y) && moved.get(x, y)),
                        None => moved,
                    });
                }
                done += (tw * th) as u64;
                if let Some(p) = self.progress {
                    p(done, total);
                }
            }
            if let Some(t) = &torus {
                target = t.crop_image(&target);
                field = t.crop_nnf(&field);
            }
            nnf = Some(field);
        }
        let mut image = target;
        image.set_groups(src.groups().to_vec())?;
        Ok(Synthesized { image, nnf: nnf.expect("at least one level"), levels, lighting: None, lattice, drifting })
    }
}
