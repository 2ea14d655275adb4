//! [`Synthesis`]: the description of one synthesis problem (exemplar,
//! output size, guides, masks, metric, seed), shared by texture
//! optimization and quilting. Built builder-style:
//!
//! ```no_run
//! # use patina::{Image, synth::{Synthesis, OptimizeParams}};
//! # let exemplar = Image::new(64, 64, 3);
//! let out = Synthesis::new(&exemplar).size(256, 256).seed(7).optimize(&OptimizeParams::default())?;
//! # Ok::<(), patina::Error>(())
//! ```

use super::distance::PatchMetric;
use crate::error::{Error, Result};
use crate::image::{Image, Mask};

/// Progress callback: (units done, units in all). Called from worker threads.
pub type Progress<'a> = &'a (dyn Fn(u64, u64) + Sync);

/// One synthesis problem. See the module docs.
#[derive(Clone)]
pub struct Synthesis<'a> {
    pub(crate) source: &'a Image,
    pub(crate) size: Option<(usize, usize)>,
    pub(crate) source_guide: Option<&'a Image>,
    pub(crate) target_guide: Option<&'a Image>,
    pub(crate) guide_weight: f32,
    pub(crate) source_mask: Option<&'a Mask>,
    pub(crate) fill: Option<(&'a Image, &'a Mask)>,
    pub(crate) start: Option<&'a Image>,
    pub(crate) metric: Option<PatchMetric>,
    pub(crate) seed: u64,
    pub(crate) progress: Option<Progress<'a>>,
    pub(crate) relight: super::lighting::Relight<'a>,
    pub(crate) tileable: bool,
    pub(crate) materials: Option<&'a Image>,
    pub(crate) layout: Option<&'a [(u32, u32)]>,
}

impl<'a> Synthesis<'a> {
    /// Synthesize from `source` (the exemplar; any number of channels).
    pub fn new(source: &'a Image) -> Self {
        Synthesis {
            source,
            size: None,
            source_guide: None,
            target_guide: None,
            guide_weight: 1.0,
            source_mask: None,
            fill: None,
            start: None,
            metric: None,
            seed: 0,
            progress: None,
            relight: super::lighting::Relight::Keep,
            tileable: false,
            materials: None,
            layout: None,
        }
    }
    /// Lighting-aware synthesis ([`super::lighting`]): separate the
    /// exemplar's smooth illumination, synthesize its detail, and light the
    /// output as `relight` says. `Keep` (the default) copies the lighting
    /// with the patches.
    pub fn relight(mut self, relight: super::lighting::Relight<'a>) -> Self {
        self.relight = relight;
        self
    }

    /// Run `synthesize` on the exemplar's detail layer when re-lighting is
    /// asked for, and re-light its image; else run it as it is.
    pub(crate) fn with_lighting<T>(
        &self,
        synthesize: impl FnOnce(&Synthesis) -> Result<T>,
        image: impl FnOnce(&mut T) -> (&mut Image, &mut Option<super::lighting::LightingReport>),
    ) -> Result<T> {
        use super::lighting::{relight, separate, LightingReport, Relight};
        if matches!(self.relight, Relight::Keep) {
            return synthesize(self);
        }
        let sep = separate(self.source);
        let mut inner = self.clone();
        inner.source = &sep.detail;
        inner.relight = Relight::Keep;
        let mut result = synthesize(&inner)?;
        let (img, report) = image(&mut result);
        let groups = img.groups().to_vec();
        *img = relight(img, &sep, self.relight)?;
        img.set_groups(groups)?;
        *report = Some(LightingReport::of(self.relight, self.source, &sep));
        Ok(result)
    }
    /// Make the output tile: synthesize it on a torus ([`super::torus`]), so
    /// its left edge continues its right edge and its top its bottom.
    /// Texture optimization only; not with hole filling or a start image,
    /// whose fixed content does not wrap, nor re-lit with the exemplar's
    /// stretched lighting, which does not.
    pub fn tileable(mut self, tileable: bool) -> Self {
        self.tileable = tileable;
        self
    }
    /// The image quilting's material families ([`super::QuiltParams::families`])
    /// are clustered on, the source's size, its first three channels
    /// weighed equally (default: the source, as the metric weighs it).
    /// Time-lapse quilting compares time columns whose first channels are
    /// one colour's temporal coefficients; their materials are those of
    /// the frames' temporal mean colour.
    pub fn materials(mut self, image: &'a Image) -> Self {
        self.materials = Some(image);
        self
    }
    /// Heal the seams of a layout made elsewhere: output pixel i copies
    /// source pixel `layout[i]` (as [`super::QuiltPlan::source_positions`]
    /// gives it, row by row). Texture optimization then starts from this
    /// correspondence instead of quilting its own, and works as
    /// [`super::Init::QuiltSeams`] does whatever the init asked: one level,
    /// searching around the layout's cut lines first, so block interiors
    /// stay verbatim copies. The returned field is the healed
    /// correspondence; a caller that renders other images through the
    /// same layout (a time-lapse's frames) renders them through it.
    pub fn heal_layout(mut self, layout: &'a [(u32, u32)]) -> Self {
        self.layout = Some(layout);
        self
    }
    /// Output size (default: the target guide's, the filled image's, or the source's).
    pub fn size(mut self, width: usize, height: usize) -> Self {
        self.size = Some((width, height));
        self
    }
    /// Guided synthesis (image analogies): the output at a pixel should look
    /// like the source where `source_guide` resembles `target_guide` there.
    /// `weight` scales the guide term against the appearance term.
    pub fn guides(mut self, source_guide: &'a Image, target_guide: &'a Image, weight: f32) -> Self {
        self.source_guide = Some(source_guide);
        self.target_guide = Some(target_guide);
        self.guide_weight = weight;
        self
    }
    /// Source pixels patches may use (others are never copied).
    pub fn source_mask(mut self, allowed: &'a Mask) -> Self {
        self.source_mask = Some(allowed);
        self
    }
    /// Fill (inpaint) the pixels of `hole` in `image`, keeping the rest.
    pub fn fill(mut self, image: &'a Image, hole: &'a Mask) -> Self {
        self.fill = Some((image, hole));
        self
    }
    /// Texture optimization starts from this image (the output's size and
    /// the source's channels) instead of random or quilted patches: the
    /// result is the image remade from source patches (Wexler et al.).
    pub fn start_from(mut self, image: &'a Image) -> Self {
        self.start = Some(image);
        self
    }
    /// Appearance metric over the source's channels (default: mean SSD).
    pub fn metric(mut self, metric: PatchMetric) -> Self {
        self.metric = Some(metric);
        self
    }
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }
    pub fn progress(mut self, progress: Progress<'a>) -> Self {
        self.progress = Some(progress);
        self
    }

    /// The output size after checking every input against the others.
    pub(crate) fn validate(&self, patch: usize) -> Result<(usize, usize)> {
        let src = self.source;
        if src.width() < patch || src.height() < patch {
            return Err(Error::invalid(format!(
                "the exemplar ({}x{}) is smaller than one {patch}x{patch} patch",
                src.width(),
                src.height()
            )));
        }
        let size = self.size.or(self.target_guide.map(Image::size)).or(self.fill.map(|(i, _)| i.size())).unwrap_or(src.size());
        let (w, h) = size;
        if w == 0 || h == 0 {
            return Err(Error::invalid(format!("output size {w}x{h} is empty")));
        }
        if w > crate::image::MAX_SIDE || h > crate::image::MAX_SIDE {
            return Err(Error::invalid(format!("output size {w}x{h} exceeds {} pixels per side", crate::image::MAX_SIDE)));
        }
        if let (Some(sg), Some(tg)) = (self.source_guide, self.target_guide) {
            if sg.size() != src.size() {
                return Err(Error::invalid(format!(
                    "source guide is {}x{} but the exemplar is {}x{}",
                    sg.width(),
                    sg.height(),
                    src.width(),
                    src.height()
                )));
            }
            if tg.size() != size {
                return Err(Error::invalid(format!("target guide is {}x{} but the output is {w}x{h}", tg.width(), tg.height())));
            }
            if sg.channels() != tg.channels() {
                return Err(Error::invalid(format!("source guide has {} channels but target guide has {}", sg.channels(), tg.channels())));
            }
        }
        if let Some(m) = self.source_mask {
            if m.size() != src.size() {
                return Err(Error::invalid("source mask and exemplar sizes differ"));
            }
        }
        if let Some((img, hole)) = self.fill {
            if img.size() != size || hole.size() != size {
                return Err(Error::invalid("the image to fill, its hole mask and the output size differ"));
            }
            if img.channels() != src.channels() {
                return Err(Error::invalid("the image to fill and the exemplar have different channel counts"));
            }
        }
        if let Some(img) = self.start {
            if img.size() != size || img.channels() != src.channels() {
                return Err(Error::invalid(format!(
                    "the starting image is {}x{} with {} channels; the output is {w}x{h} with {}",
                    img.width(),
                    img.height(),
                    img.channels(),
                    src.channels()
                )));
            }
        }
        if let Some(m) = &self.metric {
            if m.channels() != src.channels() {
                return Err(Error::invalid(format!("metric reads {} channels, the exemplar has {}", m.channels(), src.channels())));
            }
        }
        if let Some(l) = self.layout {
            if l.len() != w * h {
                return Err(Error::invalid(format!("the layout to heal has {} positions for a {w}x{h} output", l.len())));
            }
            if self.fill.is_some() || self.start.is_some() || self.tileable {
                return Err(Error::invalid("a layout to heal cannot be combined with a hole to fill, a start image or a tileable output"));
            }
            if l.iter().any(|&(x, y)| x as usize >= src.width() || y as usize >= src.height()) {
                return Err(Error::invalid(format!("the layout to heal points outside the {}x{} exemplar", src.width(), src.height())));
            }
        }
        let guide_c = self.target_guide.map_or(0, Image::channels);
        crate::image::budget::check_working_set("the output", w, h, src.channels() + guide_c)?;
        Ok(size)
    }

    /// Refuse a tileable problem whose given content or lighting cannot wrap
    /// (checked where users ask for a tile, before the engine's own
    /// tileable steps, which fill holes on the torus).
    pub(crate) fn check_tileable(&self) -> Result<()> {
        if self.tileable {
            if self.fill.is_some() || self.start.is_some() {
                return Err(Error::invalid(
                    "a tileable output cannot fill a hole or start from an image: their fixed content does not wrap",
                ));
            }
            self.relight.check_tileable("output", "exemplar's")?;
        }
        Ok(())
    }

    /// The appearance metric (style channels) followed by the guide metric.
    pub(crate) fn full_metric(&self) -> PatchMetric {
        let style = self.metric.clone().unwrap_or_else(|| PatchMetric::mean_ssd(self.source.channels()));
        match self.source_guide {
            Some(g) => style.then(&PatchMetric::mean_ssd(g.channels()).scaled(self.guide_weight)),
            None => style,
        }
    }
}
