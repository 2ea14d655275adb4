//! Lighting-aware synthesis: a captured exemplar carries its lighting (a
//! vignette, a ramp, a flash hot-spot) as slow multiplicative variation.
//! Synthesizing it patch by patch copies that lighting piecewise, as bright
//! and dark patches. So the exemplar is split into a smooth illumination
//! field and a stationary detail layer, the detail is synthesized, and the
//! output is re-lit with the field the user chooses.
//!
//! The field is a Gaussian low-pass (sigma = 1/8 of the exemplar's smaller
//! side) of log luminance. Simplification: the issue suggests an
//! edge-aware low-pass; a plain Gaussian at this scale averages over many
//! texture features, so it follows lighting rather than structure on
//! stationary textures, and costs two separable passes.

use crate::error::{Error, Result};
use crate::image::color::luminance;
use crate::image::filter::gaussian_blur;
use crate::image::resample::{resize, Filter};
use crate::image::Image;
use rayon::prelude::*;
use serde::Serialize;

/// How a synthesized output is lit.
#[derive(Clone, Copy, Debug, Default)]
pub enum Relight<'a> {
    /// No separation: the exemplar's lighting is copied with its patches.
    #[default]
    Keep,
    /// Evenly, at the exemplar's mean luminance.
    Flat,
    /// With the exemplar's own field stretched to the output's size.
    Stretch,
    /// With this image's luminance (relative to its mean) as the field.
    Image(&'a Image),
}

impl Relight<'_> {
    /// Refuse this re-lighting for a tileable result (`what`, e.g. "output")
    /// when it cannot wrap: a stretched field of the `whose` lighting (e.g.
    /// "exemplar's") has a ramp or vignette that does not.
    pub fn check_tileable(&self, what: &str, whose: &str) -> Result<()> {
        if matches!(self, Relight::Stretch) {
            return Err(Error::invalid(format!(
                "a tileable {what} cannot take the {whose} stretched lighting, which does not wrap; use flat or keep"
            )));
        }
        Ok(())
    }
}

/// What the separation removed, for manifests.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LightingReport {
    /// The re-lighting used: "flat", "stretch" or "image".
    pub relight: &'static str,
    /// Large-scale non-stationarity ([`crate::metrics::nonstationarity`]) of the exemplar.
    pub exemplar_nonstationarity: f32,
    /// The same of the detail layer that was synthesized.
    pub detail_nonstationarity: f32,
    /// Sigma of the low-pass, in exemplar pixels.
    pub sigma: f32,
}

impl LightingReport {
    /// The report of `exemplar` split as `sep` and re-lit `how`.
    pub fn of(how: Relight, exemplar: &Image, sep: &Separation) -> Self {
        LightingReport {
            relight: how.name(),
            exemplar_nonstationarity: crate::metrics::nonstationarity(exemplar),
            detail_nonstationarity: crate::metrics::nonstationarity(&sep.detail),
            sigma: sep.sigma,
        }
    }
}

/// An exemplar split into detail and illumination.
pub struct Separation {
    /// The exemplar divided by its illumination (every channel), at the mean brightness.
    pub detail: Image,
    /// Log illumination relative to its mean (1 channel, exemplar size).
    pub log_field: Image,
    pub sigma: f32,
    /// The exemplar's mean luminance (flat re-lighting matches it).
    pub mean_luminance: f32,
}

/// Floor added to luminance before the logarithm (dark pixels).
const LOG_FLOOR: f32 = 1e-3;

/// Split `img` into detail and illumination.
pub fn separate(img: &Image) -> Separation {
    let sigma = img.width().min(img.height()) as f32 / 8.0;
    let lum = luminance(img);
    let field = log_field(&lum, sigma);
    with_field(img, &lum, field, sigma)
}

/// Degree of [`separate_smooth`]'s polynomial field.
pub const SMOOTH_DEGREE: usize = 3;
/// Its number of monomials, (d + 1) (d + 2) / 2.
const SMOOTH_TERMS: usize = (SMOOTH_DEGREE + 1) * (SMOOTH_DEGREE + 2) / 2;

/// Split `img` into detail and an illumination field that is a cubic
/// polynomial in x and y, fitted to its log luminance by least squares
/// (`sigma` is reported as 0). A vignette times a ramp is such a field
/// almost exactly, while content at any scale smaller than the image (wet
/// patches, rust fields a fifth of the sample wide) is not: the Gaussian
/// field of [`separate`] at 1/8 of the side took those for light when the
/// sample held only a few of them.
pub fn separate_smooth(img: &Image) -> Separation {
    let lum = luminance(img);
    let (w, h) = lum.size();
    let log_lum: Vec<f32> = lum.data().iter().map(|v| (v.max(0.0) + LOG_FLOOR).ln()).collect();
    // The monomials u^i v^(d-i), d = 0..=3, at a pixel (u, v in [-1, 1]).
    let terms = |x: usize, y: usize| -> [f64; SMOOTH_TERMS] {
        let (u, v) = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0, 2.0 * (y as f64 + 0.5) / h as f64 - 1.0);
        let mut t = [0.0; SMOOTH_TERMS];
        let mut k = 0;
        for total in 0..=SMOOTH_DEGREE {
            for i in 0..=total {
                t[k] = u.powi(i as i32) * v.powi((total - i) as i32);
                k += 1;
            }
        }
        t
    };
    let k = SMOOTH_TERMS;
    // Normal equations over a grid of at most 128 x 128 samples.
    let step = (w.max(h) / 128).max(1);
    let mut ata = nalgebra::DMatrix::<f64>::zeros(k, k);
    let mut atb = nalgebra::DVector::<f64>::zeros(k);
    for y in (0..h).step_by(step) {
        for x in (0..w).step_by(step) {
            let t = terms(x, y);
            let b = log_lum[y * w + x] as f64;
            for i in 0..k {
                atb[i] += t[i] * b;
                for j in 0..k {
                    ata[(i, j)] += t[i] * t[j];
                }
            }
        }
    }
    // A tiny ridge keeps images too small for a cubic solvable.
    for i in 0..k {
        ata[(i, i)] += 1e-9 * (1.0 + ata[(i, i)]);
    }
    let coef = ata.cholesky().map(|c| c.solve(&atb)).unwrap_or_else(|| nalgebra::DVector::zeros(k));
    let mut field = Image::from_fn(w, h, 1, |x, y, p| p[0] = terms(x, y).iter().zip(coef.iter()).map(|(a, b)| a * b).sum::<f64>() as f32);
    let m = mean(&field);
    field.data_mut().iter_mut().for_each(|v| *v -= m);
    with_field(img, &lum, field, 0.0)
}

/// The separation of `img` (luminance `lum`) by a log field relative to its mean.
fn with_field(img: &Image, lum: &Image, field: Image, sigma: f32) -> Separation {
    let mut sep = Separation { detail: img.clone(), log_field: field, sigma, mean_luminance: mean(lum) };
    let gain = sep.unlit_gain();
    apply_gain(&mut sep.detail, &gain);
    sep
}

impl Separation {
    /// The per-pixel gain that removes the illumination (exp(-field)),
    /// which made [`Separation::detail`].
    pub fn unlit_gain(&self) -> Vec<f32> {
        self.log_field.data().iter().map(|f| (-f).exp()).collect()
    }
}

fn mean(img: &Image) -> f32 {
    (img.data().iter().map(|&v| v as f64).sum::<f64>() / img.data().len().max(1) as f64) as f32
}

/// Re-light a synthesized detail image.
pub fn relight(detail: &Image, sep: &Separation, how: Relight) -> Result<Image> {
    let mut out = detail.clone();
    if let Some(g) = gain(detail.size(), sep, how, || mean(&luminance(detail)))? {
        apply_gain(&mut out, &g);
    }
    Ok(out)
}

/// Split a sequence under a fixed light (a vignette, a flash hot-spot)
/// that may drift slowly (a shine that fades as the surface dulls).
///
/// The fixed part is [`separate`]'s field of the frames' temporal mean. The
/// drift is each frame's own very-low-pass log luminance ([`DRIFT_SIGMA`])
/// minus its mean over all frames, averaged over [`SEQUENCE_WINDOW`] of the
/// frames on either side, those with a like drift only ([`DRIFT_EDGE`]).
/// Each frame is divided by both. One field for all frames left copper's
/// first frames, bright on one side and dark on the other, as a patchwork
/// of bright and dark blocks (the mean was dominated by the later, evenly
/// dull patina); a per-frame field at the fixed part's scale followed the
/// content instead (rust spots), and flickered at 1.3-1.5x the input's.
/// Returns the separation of the mean frame (its mean luminance and field
/// serve flat and stretched re-lighting) and the frames' detail layers.
pub fn separate_sequence(frames: &[Image]) -> Result<(Separation, Vec<Image>)> {
    let mean_frame = crate::image::sequence::temporal_mean(frames)?;
    let n = frames.len();
    let sep = separate(&mean_frame);
    let drift_sigma = mean_frame.width().min(mean_frame.height()) as f32 * DRIFT_SIGMA;
    let drifts: Vec<Vec<f32>> =
        frames.par_iter().map(|f| drift_field(&luminance(f), drift_sigma).map(Image::into_data)).collect::<Result<_>>()?;
    let mut mean_drift = vec![0f32; drifts[0].len()];
    for d in &drifts {
        mean_drift.iter_mut().zip(d).for_each(|(m, v)| *m += v / n as f32);
    }
    let half = ((n as f32 * SEQUENCE_WINDOW).round() as usize).max(1);
    let details = (0..n)
        .into_par_iter()
        .map(|t| {
            // The neighbours' drifts, each weighted by how like this
            // frame's it is (a bilateral filter in time).
            let window = &drifts[t.saturating_sub(half)..(t + half + 1).min(n)];
            let own = &drifts[t];
            let weights: Vec<f32> = window
                .iter()
                .map(|d| {
                    let ms = d.iter().zip(own).map(|(a, b)| ((a - b) as f64).powi(2)).sum::<f64>() / own.len().max(1) as f64;
                    (-ms / (2.0 * f64::from(DRIFT_EDGE).powi(2))).exp() as f32
                })
                .collect();
            let total: f32 = weights.iter().sum();
            let mut field: Vec<f32> = sep.log_field.data().iter().zip(&mean_drift).map(|(f, m)| f - m).collect();
            for (d, wt) in window.iter().zip(&weights) {
                let k = wt / total;
                field.iter_mut().zip(d).for_each(|(g, v)| *g += k * v);
            }
            field.iter_mut().for_each(|g| *g = (-*g).exp());
            let mut d = frames[t].clone();
            apply_gain(&mut d, &field);
            d
        })
        .collect();
    Ok((sep, details))
}

/// Frames on either side whose mean brightness a frame's is steadied to
/// ([`steady_exposure`]).
pub const EXPOSURE_HALF: usize = 3;

/// Take a capture's exposure flicker out of a sequence in place: each
/// frame is scaled so its mean luminance is the median of the means of
/// the frames within [`EXPOSURE_HALF`] of it (fewer near the ends, so the
/// first and last frames are left as they are). A running median keeps the
/// sequence's own slow brightening or darkening (rust darkening a plate)
/// and its steps, and drops single-frame jumps: rusting_steel's exposure
/// jumps by up to 9% for one frame every few (means 215, 209, 207, 229,
/// 211, 211, 228, ...), and blocks that time jitter showed at different
/// frames then differed by that much, a patchwork of bright and grey
/// blocks in the first frames. The drift field ([`separate_sequence`])
/// is relative to each frame's mean, so it does not see this. Returns the
/// largest correction, |gain - 1|.
pub fn steady_exposure(frames: &mut [Image]) -> f32 {
    let means: Vec<f32> = frames.par_iter().map(|f| mean(&luminance(f))).collect();
    let n = means.len();
    let gains: Vec<f32> = (0..n)
        .map(|t| {
            // A window centred on the frame (narrower at the ends), so a
            // ramp's median is the frame's own mean.
            let half = EXPOSURE_HALF.min(t).min(n - 1 - t);
            let mut near: Vec<f32> = means[t - half..=t + half].to_vec();
            near.sort_by(f32::total_cmp);
            let median = near[near.len() / 2];
            if means[t] > 0.0 {
                median / means[t]
            } else {
                1.0
            }
        })
        .collect();
    frames.par_iter_mut().zip(&gains).for_each(|(f, &g)| f.data_mut().iter_mut().for_each(|v| *v *= g));
    gains.iter().map(|g| (g - 1.0).abs()).fold(0.0, f32::max)
}

/// Share of a sequence's frames, on either side of a frame, whose lighting
/// drift is averaged into its own ([`separate_sequence`]).
pub const SEQUENCE_WINDOW: f32 = 1.0 / 24.0;

/// RMS difference of two frames' drifts (log luminance) at which the one
/// counts for the other's average with weight e^(-1/2): frames whose light
/// jumped (rusting_steel's exposure alternates by 0.04 between frame
/// pairs, copper_patinating's first frames change by 0.08-0.16) are not
/// averaged together, so no frame keeps a share of its neighbours' light,
/// which quilting scattered as a patchwork of bright and grey blocks.
/// Steady drifts differ by under 0.003 between frames.
pub const DRIFT_EDGE: f32 = 0.01;

/// Sigma of the drift's low-pass, as a share of the shorter side: a third,
/// so it follows a light that moves across the frame, not the content.
pub const DRIFT_SIGMA: f32 = 1.0 / 3.0;

/// The very-low-pass log luminance of `lum` (Gaussian of `sigma`, computed
/// at an eighth of the size and stretched back: at this scale nothing finer
/// survives), relative to its mean.
fn drift_field(lum: &Image, sigma: f32) -> Result<Image> {
    let (w, h) = lum.size();
    let (sw, sh) = ((w / 8).max(1), (h / 8).max(1));
    let small = resize(&lum.map(|v| (v.max(0.0) + LOG_FLOOR).ln()), sw, sh, Filter::Linear)?;
    let mut blurred = gaussian_blur(&small, sigma * sw as f32 / w as f32);
    let mean = blurred.data().iter().map(|&v| v as f64).sum::<f64>() as f32 / blurred.data().len().max(1) as f32;
    blurred.data_mut().iter_mut().for_each(|v| *v -= mean);
    resize(&blurred, w, h, Filter::Linear)
}

/// The mean luminance of a sequence's frames together.
pub fn sequence_luminance(frames: &[Image]) -> f32 {
    frames.iter().map(|f| mean(&luminance(f))).sum::<f32>() / frames.len().max(1) as f32
}

/// The low-passed log luminance of `lum`, relative to its mean.
fn log_field(lum: &Image, sigma: f32) -> Image {
    let log_lum = lum.map(|v| (v.max(0.0) + LOG_FLOOR).ln());
    let mut field = gaussian_blur(&log_lum, sigma);
    let mean = field.data().iter().map(|&v| v as f64).sum::<f64>() as f32 / field.data().len().max(1) as f32;
    field.data_mut().iter_mut().for_each(|v| *v -= mean);
    field
}

/// Re-light synthesized detail frames with one gain for all of them (a flat
/// re-lighting brings `detail_mean`, the mean luminance of the detail frames
/// they were made from, to the exemplar's, so the sequence's own
/// brightening or darkening is kept, and any part of the sequence gets the
/// same gain).
pub fn relight_sequence(frames: &mut [Image], sep: &Separation, how: Relight, detail_mean: impl FnOnce() -> f32) -> Result<()> {
    let Some(first) = frames.first() else { return Ok(()) };
    let size = first.size();
    if let Some(g) = gain(size, sep, how, detail_mean)? {
        frames.par_iter_mut().for_each(|f| apply_gain(f, &g));
    }
    Ok(())
}

/// The per-pixel gain that re-lights detail of `size` as `how` says;
/// `detail_mean` is the detail's mean luminance (for flat re-lighting).
/// `None` for [`Relight::Keep`]. For callers whose image is not the
/// exemplar itself (a material's coefficients, linear in the albedo).
pub fn gain(size: (usize, usize), sep: &Separation, how: Relight, detail_mean: impl FnOnce() -> f32) -> Result<Option<Vec<f32>>> {
    let (w, h) = size;
    Ok(match how {
        Relight::Keep => None,
        // Dividing by the field leaves the geometric mean brightness, darker
        // than the exemplar's under a strong vignette: scale back to its mean.
        Relight::Flat => {
            let m = detail_mean();
            Some(vec![if m > 0.0 { sep.mean_luminance / m } else { 1.0 }; w * h])
        }
        Relight::Stretch => Some(resize(&sep.log_field, w, h, Filter::Linear)?.data().iter().map(|v| v.exp()).collect()),
        Relight::Image(g) => {
            if g.size() != (w, h) {
                return Err(Error::invalid(format!("the lighting image is {}x{} but the output is {w}x{h}", g.width(), g.height())));
            }
            let l = luminance(g);
            let mean = l.data().iter().map(|&v| v as f64).sum::<f64>() as f32 / l.data().len().max(1) as f32;
            if mean <= 0.0 {
                return Err(Error::invalid("the lighting image is black"));
            }
            Some(l.data().iter().map(|v| v / mean).collect())
        }
    })
}

/// Multiply every channel of each pixel by its gain.
fn apply_gain(img: &mut Image, gain: &[f32]) {
    let n = img.channels();
    img.data_mut().par_chunks_mut(n * 1024).zip(gain.par_chunks(1024)).for_each(|(px, g)| {
        for (p, k) in px.chunks_exact_mut(n).zip(g) {
            p.iter_mut().for_each(|v| *v *= k);
        }
    });
}

impl Relight<'_> {
    /// The name recorded in manifests.
    pub fn name(&self) -> &'static str {
        match self {
            Relight::Keep => "keep",
            Relight::Flat => "flat",
            Relight::Stretch => "stretch",
            Relight::Image(_) => "image",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::nonstationarity;
    use crate::samples;
    use crate::synth::{OptimizeParams, QuiltParams, Synthesis};

    #[test]
    fn exposure_jumps_are_steadied_and_the_slow_darkening_is_kept() {
        // A texture that darkens by 30% over 30 frames, with every fifth
        // frame exposed 10% brighter.
        let base = samples::stucco(48, 48, 2);
        let mut frames: Vec<Image> = (0..30)
            .map(|t| {
                let trend = 1.0 - 0.3 * t as f32 / 29.0;
                let flash = if t % 5 == 2 { 1.1 } else { 1.0 };
                base.map(|v| v * trend * flash)
            })
            .collect();
        let base_mean = mean(&luminance(&base));
        let worst = steady_exposure(&mut frames);
        assert!((worst - (1.0 - 1.0 / 1.1)).abs() < 0.01, "largest correction {worst}");
        for (t, f) in frames.iter().enumerate() {
            let trend = base_mean * (1.0 - 0.3 * t as f32 / 29.0);
            let m = mean(&luminance(f));
            // Within 2.5% of the trend (a median of 7 frames on a ramp is
            // the middle frame's, so only the flashed frames move).
            assert!((m / trend - 1.0).abs() < 0.025, "frame {t}: mean {m}, trend {trend}");
        }
    }

    #[test]
    fn flat_relighting_removes_most_of_a_vignette_and_ramp() {
        let tex = samples::cobbles(128, 128, 4);
        let ex = samples::lit(&tex);
        let before = nonstationarity(&ex);
        for (name, out) in [
            (
                "optimize",
                Synthesis::new(&ex).size(192, 192).seed(2).relight(Relight::Flat).optimize(&OptimizeParams::default()).unwrap().image,
            ),
            ("quilt", Synthesis::new(&ex).size(192, 192).seed(2).relight(Relight::Flat).quilt(&QuiltParams::default()).unwrap().image),
        ] {
            let after = nonstationarity(&out);
            assert!(after < 0.5 * before, "{name}: {after} of {before} left");
        }
        // Flat keeps the exemplar's mean brightness, and the quilt shows no block grid.
        let flat = Synthesis::new(&ex).size(192, 192).seed(2).relight(Relight::Flat).quilt(&QuiltParams::default()).unwrap().image;
        let (g, g0) = (crate::metrics::grid_peak(&flat), crate::metrics::grid_peak(&ex));
        assert!(g <= 1.5 * g0, "grid peak {g} vs the exemplar's {g0}");
        let (a, b) = (mean(&luminance(&flat)), mean(&luminance(&ex)));
        assert!((a - b).abs() < 0.01, "flat mean {a} vs exemplar {b}");
        // Without separation, the lighting is copied piecewise. (The
        // rarity bound alone avoids the exemplar's darkest corners, which
        // the vignette makes unique: 0.45 of the variation is kept with it;
        // the material-share bound treats the dark corners as a material
        // to keep to its share: 0.47; relative overlap costs judge the
        // dim corners' overlaps against their smaller twin error and keep
        // 0.23. So the control runs without all three.)
        let plain = QuiltParams { rarity: 0.0, families: 0.0, relative: 0.0, ..QuiltParams::default() };
        let kept = Synthesis::new(&ex).size(192, 192).seed(2).quilt(&plain).unwrap().image;
        assert!(nonstationarity(&kept) > 0.5 * before, "kept {} of {before}", nonstationarity(&kept));
        // Stretch re-lights with the exemplar's own field: the ramp comes back, left dark, right bright.
        let s = Synthesis::new(&ex).size(192, 192).seed(2).relight(Relight::Stretch).quilt(&QuiltParams::default()).unwrap().image;
        let l = luminance(&s);
        let col = |x0: usize| (0..192).flat_map(|y| (x0..x0 + 32).map(move |x| (x, y))).map(|(x, y)| l.at(x, y, 0)).sum::<f32>();
        assert!(col(150) > 1.3 * col(10), "ramp {} -> {}", col(10), col(150));
    }
}
