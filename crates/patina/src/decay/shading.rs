//! Global shading (Hao et al. 2023, section III-C1): the object's shading
//! layer S, so the decayed surface keeps its form.
//!
//! The paper decomposes the photo with a dense-CRF intrinsic-image method.
//! patina uses Retinex-style edge-aware smoothing instead: shading is the
//! part of log luminance that an edge-preserving filter keeps. The filter
//! is the guided filter of He, Sun and Tang (2010), first with the log
//! luminance as its own guide and then twice more guided by its own result
//! (rolling guidance), restricted to the mask (box sums over object pixels
//! only, so the background cannot bleed in): within a window, variations
//! of log luminance whose variance is well under `eps` (albedo texture,
//! grain, print) are flattened, while strong, extended changes (the
//! shading across a curved body, cast shadows) are kept. Reflectance edges
//! as strong as shadow edges are kept too: the price of a filter in place
//! of a learned decomposition.

use crate::image::color::{srgb_to_linear, LUMA};
use crate::image::filter::weighted_blur;
use crate::image::summed::SummedArea;
use crate::image::{pixel_bounds, Image, Mask};

/// Parameters of the shading estimate.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ShadingParams {
    /// Window radius as a fraction of the object's longer side.
    pub radius: f32,
    /// Guided-filter regulariser: log-luminance variance below this is
    /// treated as albedo texture and smoothed away.
    pub eps: f32,
}

impl Default for ShadingParams {
    fn default() -> Self {
        ShadingParams { radius: 0.03, eps: 0.04 }
    }
}

/// The shading of `photo` (sRGB) over `mask`: a one-channel image of
/// relative linear luminance, normalised to a mean of 1 over the mask in
/// the log domain; 1 outside the mask.
pub fn estimate(photo: &Image, mask: &Mask, params: &ShadingParams) -> Image {
    let (w, h) = mask.size();
    let log_lum = log_luminance(photo);
    let set = mask.bits().iter().enumerate().filter(|(_, &m)| m).map(|(i, _)| i);
    let (bx0, by0, bx1, by1) = pixel_bounds(set, w).unwrap_or((0, 0, w - 1, h - 1));
    let side = (bx1 - bx0).max(by1 - by0) as f32 + 1.0;
    let r = ((params.radius * side).round() as usize).max(2);
    let mut shading = log_lum.clone();
    for _ in 0..PASSES {
        shading = guided_pass(&log_lum, &shading, mask, r, params.eps as f64);
    }
    for (v, &m) in shading.data_mut().iter_mut().zip(mask.bits()) {
        if !m {
            *v = f32::NAN;
        }
    }
    let inside: Vec<f64> = shading.data().iter().filter(|v| !v.is_nan()).map(|&v| v as f64).collect();
    let mean = inside.iter().sum::<f64>() / inside.len().max(1) as f64;
    for v in shading.data_mut() {
        *v = if v.is_nan() { 1.0 } else { (*v as f64 - mean).exp() as f32 };
    }
    shading
}

/// Quantile of the object's shading above which light counts as a
/// specular highlight ([`with_gloss`]).
pub const HIGHLIGHT_QUANTILE: f32 = 0.8;

/// How far above the [`HIGHLIGHT_QUANTILE`] level shading must rise to
/// count as a specular highlight ([`with_gloss`]).
pub const HIGHLIGHT_MARGIN: f32 = 1.25;

/// The natural log of the photo's linear luminance (at least 1e-3), one channel.
fn log_luminance(photo: &Image) -> Image {
    Image::from_fn(photo.width(), photo.height(), 1, |x, y, p| {
        let c = photo.pixel(x, y);
        let y_lin: f32 = (0..3).map(|k| LUMA[k] * srgb_to_linear(c[k.min(photo.channels() - 1)])).sum();
        p[0] = y_lin.max(1e-3).ln();
    })
}

/// The largest brightening residual the relief passes (log units): bright
/// specks (a carved letter's lit edge) came through dark rust and moss
/// as glitter at 0.5; grooves and recesses, the relief that matters, are
/// dark.
const RELIEF_BRIGHTEST: f32 = 0.2;

/// How much of the photo's fine relief ([`relief`]) shows through the decay.
pub const RELIEF: f32 = 0.85;

/// The photo's fine relief: what the shading estimate smoothed away (the
/// residual of log luminance over the shading, zero mean inside the
/// mask), as a linear luminance factor exp(`strength` x residual), the
/// residual held to [-1, [`RELIEF_BRIGHTEST`]]. The shading keeps only the form at the
/// window's scale, so carved letters, the curls of a statue and the bolts
/// on a hydrant vanished under the decay; a layer of rust or moss follows
/// the surface it grows on, so its luminance takes that relief too. The
/// residual also holds the photo's albedo texture (granite speckle, dark
/// marks), which then shows faintly through the decay, as stains do
/// through a thin layer. 1 outside the mask.
pub fn relief(photo: &Image, mask: &Mask, shading: &Image, strength: f32) -> Image {
    let mut residual = log_luminance(photo);
    residual.data_mut().iter_mut().zip(shading.data()).for_each(|(v, s)| *v -= s.max(1e-6).ln());
    let inside: Vec<f64> = residual.data().iter().zip(mask.bits()).filter(|(_, &m)| m).map(|(&v, _)| v as f64).collect();
    let mean = (inside.iter().sum::<f64>() / inside.len().max(1) as f64) as f32;
    let mut out = residual;
    for (v, &m) in out.data_mut().iter_mut().zip(mask.bits()) {
        *v = if m { (strength * (*v - mean).clamp(-1.0, RELIEF_BRIGHTEST)).exp() } else { 1.0 };
    }
    out
}

/// The shading as a material of the given `gloss` (0 = matte, 1 = as
/// glossy as the photo's) would show it. The edge-preserving estimate
/// keeps the photo's specular highlights as part of S, so a matte decay
/// texture composited under it would carry a glossy highlight (rust on a
/// wok). Shading above T = [`HIGHLIGHT_MARGIN`] x the object's
/// [`HIGHLIGHT_QUANTILE`] level is taken as highlight and compressed to
/// T (S / T)^gloss: flat at T for a matte material, unchanged for gloss 1.
/// A highlight stands well above the diffuse shading around it; with T at
/// the quantile itself, the lit half of a matte white statue (its curls'
/// lit tops, the shading of its cheek) was flattened to one level under
/// rust and peeling.
///
/// Simplification: the issue suggests a dichromatic or max-chromaticity
/// separation of the specular layer; on the grey and black objects it
/// names (a silver car, a wok) diffuse and specular share one
/// chromaticity and that separation has nothing to work with, so the
/// highlight is found by its brightness instead. A diffuse object lit
/// very unevenly loses the top of its shading range, a highlight under
/// 1.25 times the quantile level stays, and a highlight covering more
/// than 20% of the object is only partly removed (at the 90% quantile,
/// the broad highlight on a white statue's crown still showed through
/// rust).
pub fn with_gloss(shading: &Image, mask: &Mask, gloss: f32) -> Image {
    let mut inside: Vec<f32> = shading.data().iter().zip(mask.bits()).filter(|(_, &m)| m).map(|(v, _)| *v).collect();
    let q = match crate::image::order::quantile(&mut inside, HIGHLIGHT_QUANTILE) {
        Some(q) if gloss < 1.0 => HIGHLIGHT_MARGIN * q,
        _ => return shading.clone(),
    };
    let keep = gloss.clamp(0.0, 1.0);
    let mut out = shading.clone();
    for (v, &m) in out.data_mut().iter_mut().zip(mask.bits()) {
        if m && *v > q {
            *v = q * (*v / q).powf(keep);
        }
    }
    out
}

/// `shading` smoothed over `sigma` pixels within `mask` (a normalised
/// convolution of its log, so the ground does not bleed in at the
/// outline): the form a layer `sigma` thick lies on. The edge-aware
/// estimate keeps a carved letter's strong edges, which printed through
/// a moss cushion. Unchanged for `sigma` 0; 1 outside the mask.
pub fn under_a_layer(shading: &Image, mask: &Mask, sigma: f32) -> Image {
    if sigma <= 0.0 {
        return shading.clone();
    }
    let log = shading.map(|s| s.max(1e-4).ln());
    let (sum, held) = weighted_blur(&log, &mask.to_image(), sigma);
    let data =
        sum.data().iter().zip(held.data()).zip(mask.bits()).map(|((&v, &k), &m)| if m && k > 1e-6 { (v / k).exp() } else { 1.0 }).collect();
    Image::from_data(shading.width(), shading.height(), 1, data).expect("one value per pixel")
}

/// Guided-filter passes. The first is guided by the log luminance itself;
/// each later one by the previous result (rolling guidance, Zhang et al.
/// 2014), which removes texture the first pass only damped.
const PASSES: usize = 3;

/// One masked guided-filter pass: smooth `input` under `guide` with box
/// windows of radius `r` over mask pixels only.
fn guided_pass(input: &Image, guide: &Image, mask: &Mask, r: usize, eps: f64) -> Image {
    let (w, h) = mask.size();
    let m = |x: usize, y: usize| mask.get(x, y) as u8 as f64;
    let (p, g) = (|x: usize, y: usize| input.at(x, y, 0) as f64, |x: usize, y: usize| guide.at(x, y, 0) as f64);
    let count = SummedArea::new(w, h, m);
    let sum_g = SummedArea::new(w, h, |x, y| m(x, y) * g(x, y));
    let sum_p = SummedArea::new(w, h, |x, y| m(x, y) * p(x, y));
    let sum_gg = SummedArea::new(w, h, |x, y| m(x, y) * g(x, y) * g(x, y));
    let sum_gp = SummedArea::new(w, h, |x, y| m(x, y) * g(x, y) * p(x, y));
    let window = |x: usize, y: usize| {
        let (x0, y0) = (x.saturating_sub(r), y.saturating_sub(r));
        (x0, y0, (x + r + 1).min(w) - x0, (y + r + 1).min(h) - y0)
    };
    // Per-window linear model q = a G + b.
    let coeffs = Image::from_fn(w, h, 2, |x, y, c| {
        let (x0, y0, ww, hh) = window(x, y);
        let n = count.sum(x0, y0, ww, hh);
        if n < 1.0 {
            return;
        }
        let (mg, mp) = (sum_g.sum(x0, y0, ww, hh) / n, sum_p.sum(x0, y0, ww, hh) / n);
        let var = (sum_gg.sum(x0, y0, ww, hh) / n - mg * mg).max(0.0);
        let cov = sum_gp.sum(x0, y0, ww, hh) / n - mg * mp;
        let a = cov / (var + eps);
        c[0] = a as f32;
        c[1] = (mp - a * mg) as f32;
    });
    let sum_a = SummedArea::new(w, h, |x, y| m(x, y) * coeffs.at(x, y, 0) as f64);
    let sum_b = SummedArea::new(w, h, |x, y| m(x, y) * coeffs.at(x, y, 1) as f64);
    Image::from_fn(w, h, 1, |x, y, q| {
        let (x0, y0, ww, hh) = window(x, y);
        let n = count.sum(x0, y0, ww, hh);
        q[0] = if n < 1.0 { g(x, y) as f32 } else { ((sum_a.sum(x0, y0, ww, hh) * g(x, y) + sum_b.sum(x0, y0, ww, hh)) / n) as f32 };
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::color::linear_to_srgb;

    /// A lit cylinder (cosine falloff across x) painted with fine albedo
    /// stripes: the shading must follow the cylinder and drop the stripes.
    #[test]
    fn relief_carries_the_fine_relief_that_the_shading_smoothed_away() {
        // A flat plate lit evenly, with shallow carved grooves (a quarter
        // darker) every 12 px.
        let (w, h) = (96, 64);
        let groove = |x: usize| x % 12 < 2;
        let photo = Image::from_fn(w, h, 3, |x, _, p| p.fill(linear_to_srgb(if groove(x) { 0.34 } else { 0.45 })));
        let mask = Mask::filled(w, h, true);
        let form = estimate(&photo, &mask, &ShadingParams::default());
        let r = relief(&photo, &mask, &form, RELIEF);
        // Groove over flat brightness of the light the decay takes: the
        // photo's is 0.76; the form alone loses most of it (its filter
        // flattens variations this small), the form times the relief keeps
        // most of it (0.76^0.85 = 0.79 when all of it is relief).
        let ratio = |img: &dyn Fn(usize) -> f32| {
            let (mut inside, mut flat) = (0f32, 0f32);
            for x in 0..w {
                if groove(x) {
                    inside += img(x) / 16.0;
                } else {
                    flat += img(x) / 80.0;
                }
            }
            inside / flat
        };
        let alone = ratio(&|x| form.at(x, 32, 0));
        let with = ratio(&|x| form.at(x, 32, 0) * r.at(x, 32, 0));
        assert!(with < 0.85 && with < alone - 0.08, "groove/flat: {with} with the relief, {alone} without");
        // Outside the mask it is 1.
        let half = Mask::from_fn(w, h, |x, _| x < 48);
        let r = relief(&photo, &half, &estimate(&photo, &half, &ShadingParams::default()), RELIEF);
        assert!((48..w).all(|x| r.at(x, 10, 0) == 1.0));
    }

    #[test]
    fn shading_keeps_the_form_and_drops_the_albedo_texture() {
        let (w, h) = (96, 64);
        let shade = |x: usize| 0.15 + 0.85 * ((x as f32 / w as f32 - 0.5) * 2.6).cos().max(0.0);
        let albedo = |x: usize, y: usize| if (x / 2 + y / 3).is_multiple_of(2) { 0.5 } else { 0.62 };
        let photo = Image::from_fn(w, h, 3, |x, y, p| p.fill(linear_to_srgb(shade(x) * albedo(x, y))));
        let s = estimate(&photo, &Mask::filled(w, h, true), &ShadingParams { radius: 0.05, eps: 0.04 });
        // Relative shading between the centre and the flank matches the truth.
        let truth = shade(20).ln() - shade(48).ln();
        let found = s.at(20, 32, 0).ln() - s.at(48, 32, 0).ln();
        assert!((found - truth).abs() < 0.15 * truth.abs(), "found {found} vs {truth}");
        // The stripes (a 21% albedo step) are mostly gone from S.
        let row: Vec<f32> = (40..56).map(|x| s.at(x, 32, 0).ln()).collect();
        let wiggle = row.windows(2).map(|p| (p[1] - p[0]).abs()).fold(0.0f32, f32::max);
        assert!(wiggle < 0.05, "albedo stripes left in the shading: step {wiggle}");
    }

    /// A matte material keeps the diffuse shading of a lit side (up to
    /// 1.2 x the 80% quantile level) and flattens a specular peak (3 x).
    #[test]
    fn matte_gloss_flattens_highlights_and_keeps_a_lit_side() {
        let (w, h) = (100, 10);
        // 70% of the object at 1, a lit side at 1.2 (25%), a highlight at 3 (5%).
        let shading = Image::from_fn(w, h, 1, |x, _, p| {
            p[0] = if x < 70 {
                1.0
            } else if x < 95 {
                1.2
            } else {
                3.0
            }
        });
        let matte = with_gloss(&shading, &Mask::filled(w, h, true), 0.0);
        assert_eq!(matte.at(80, 5, 0), 1.2, "the lit side was flattened");
        assert!(matte.at(97, 5, 0) <= HIGHLIGHT_MARGIN * 1.2 + 1e-6, "the highlight stays: {}", matte.at(97, 5, 0));
        let glossy = with_gloss(&shading, &Mask::filled(w, h, true), 1.0);
        assert_eq!(glossy.at(97, 5, 0), 3.0);
    }
}
