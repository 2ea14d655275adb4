//! Compositing a decay texture into the photo (Hao et al. 2023, section
//! III-C3, eq. 3), in CIE Lab:
//!
//! O = w T(S) + (1 - w) I,
//!
//! in L*, a* and b*, where T(S) is the texture's colour under the
//! shading S (a ratio of linear luminance), its XYZ scaled by S.
//!
//! The paper writes O_L = (D T_L + (1 - D) I_L) S; since I already carries
//! its shading, that form darkens the photo twice and D = 0 would not give
//! the input back. Writing I_L = R_L S and applying S once, to the blend of
//! T_L and the reflectance R_L, gives the line above: the texture takes the
//! object's shading and D = 0 returns the input unchanged. The paper
//! leaves ab unshaded, which turns shadows into saturated colour (rust on
//! a dark flank read as candy red): a surface R under shading S has
//! a = 500 ((X_R S)^(1/3) - (Y_R S)^(1/3)), so ab darkens with L.
//!
//! The blend weight w is where patina adds to the paper: instead of the
//! degree D itself, w = smoothstep(onset - 0.04, onset + 0.04, D) with the
//! texture's per-texel onset (see [`super::texture`]). A half-decayed
//! region then shows half of the texels fully decayed (cracks before the
//! crazed paint between them, rust at its pits first) rather than the whole
//! texture at half opacity, which reads as a ghost of the texture. A texel
//! that has appeared then thickens from 0.6 to full opacity as D rises
//! 0.35 past its onset ([`maturity`]). w is monotone in D, 0 at D = 0 and
//! 1 at D = 1.
//!
//! Around what shows, a [`Transition`] zone stains the photo (the paper's
//! generator has none, so its decay reads as stickers): rust bleeds an
//! orange-brown glaze into the paint around it, a flake casts a thin
//! shadow, moss leaves a damp dark rim. The zone is the visible weight w
//! blurred by the zone's width (and shifted by its offset), so a big patch
//! gets a full rim and a speck a faint one; within it the photo is
//! multiplied, in linear RGB, by the zone's tint (a translucent glaze keeps
//! the photo's own detail and shading). It appears only where the decay
//! has begun (D > 0), so pixels at D = 0 stay the photo's bytes.

use super::layer::{self, Relief};
use crate::image::color::{lab_pixel_lit, lab_pixel_to_srgb, linear_pixel_to_lab, luminance, srgb_to_linear, to_linear, LUMA};
use crate::image::filter::{gaussian_blur, weighted_blur};
use crate::image::noise::smoothstep;
use crate::image::stain::StainField;
pub use crate::image::stain::Transition;
use crate::image::{Image, Mask};
use rayon::prelude::*;

/// Degree, past a texel's onset, over which it matures to full opacity.
const MATURING: f32 = 0.35;

/// How far a texel that appeared at `onset` has matured at `degree`: 0
/// when it appears, 1 once the degree is [`MATURING`] past its onset (and
/// at D = 1 for every texel). Young decay is a thinner layer (rust a
/// translucent film before it scales, moss sparse before it cushions),
/// so a texel's opacity goes from the class's young opacity
/// ([`super::DecayClass::young_opacity`]) to 1 as it matures: decayed
/// areas keep deepening after they first show, instead of arriving at
/// full strength in their first frame.
#[inline]
pub fn maturity(degree: f32, onset: f32) -> f32 {
    if onset >= 1.0 {
        return 0.0;
    }
    smoothstep(onset, (onset + MATURING).min(1.0), degree)
}

/// Gaussian (pixels) that anti-aliases the edges of decay that appears
/// whole ([`Layers::young`] 1).
const EDGE_FILTER: f32 = 0.6;

/// Half-width of the onset transition in degree units.
const ONSET_SOFTNESS: f32 = 0.04;

/// Share of the texture's own luminance contrast kept by the colour
/// transfer even when the photo is flatter (so the substrate's grain
/// stays on uniform paint). The transfer never raises the contrast: the
/// photo's luminance spread holds its shading and carving, which the
/// composite applies anyway, and scaling the texture's grain by it made
/// salt-and-pepper on a lit white statue.
const MIN_CONTRAST: f32 = 0.7;

/// The most the colour transfer scales a texture's a* or b* spread: a
/// near-neutral texture on a photo whose chroma spread is its shading's
/// colour cast (a dim white statue: b* spread 4.2) had its faint grain
/// scaled into blue specks.
const MAX_CHROMA_GAIN: f32 = 2.0;

/// The blend weight of a texel with onset `onset` at degree `degree`
/// (0 for texels that never appear).
#[inline]
pub fn weight(degree: f32, onset: f32) -> f32 {
    if degree <= 0.0 || onset >= super::texture::NEVER {
        return 0.0;
    }
    smoothstep((onset - ONSET_SOFTNESS).max(0.0), onset + ONSET_SOFTNESS, degree)
}

/// Colour transfer (Reinhard, Ashikhmin, Gooch, Shirley 2001), in Lab (the
/// paper works in l-alpha-beta; Lab is as decorrelated for this purpose):
/// per channel, move the texture's mean and standard deviation to those
/// of the photo inside the mask, the texture's measured over the texels
/// that can appear (`onset` below [`super::texture::NEVER`]). The luminance contrast is scaled by
/// 0.7 to 1 (see [`MIN_CONTRAST`]). `strength`
/// blends between the texture's own colours (0) and the full transfer (1).
pub fn transfer_colour(texture_lab: &mut Image, onset: &Image, photo_lab: &Image, mask: &Mask, strength: f32) {
    let stats = |img: &Image, keep: &dyn Fn(usize) -> bool| {
        let mut acc = [[0f64; 2]; 3];
        let mut n = 0f64;
        for (i, px) in img.data().chunks_exact(3).enumerate() {
            if keep(i) {
                n += 1.0;
                for c in 0..3 {
                    acc[c][0] += px[c] as f64;
                    acc[c][1] += (px[c] as f64).powi(2);
                }
            }
        }
        acc.map(|[s, s2]| {
            let mean = s / n.max(1.0);
            (mean as f32, ((s2 / n.max(1.0) - mean * mean).max(0.0).sqrt()) as f32)
        })
    };
    // Only texels that can appear speak for the texture (peeling's paint never does).
    let from = stats(texture_lab, &|i| onset.data()[i] < super::texture::NEVER);
    let to = stats(photo_lab, &|i| mask.bits()[i]);
    let scale: Vec<f32> = (0..3)
        .map(|c| {
            let s = to[c].1 / from[c].1.max(1e-3);
            if c == 0 {
                s.clamp(MIN_CONTRAST, 1.0)
            } else {
                s.min(MAX_CHROMA_GAIN)
            }
        })
        .collect();
    texture_lab.data_mut().par_chunks_mut(3).for_each(|px| {
        for c in 0..3 {
            let moved = (px[c] - from[c].0) * scale[c] + to[c].0;
            px[c] += strength * (moved - px[c]);
        }
        px[0] = px[0].clamp(0.0, 100.0);
    });
}

/// A texture whose colour darkens the photo's own (a photo-relative
/// class, [`super::DecayClass::photo_relative`]), in Lab: each texel's
/// linear luminance over that of `surface` (the texture's undecayed
/// surface) scales the photo's linear colour there, divided by the
/// `shading` that [`composite`] applies again.
pub fn darkened_photo(photo: &Image, texture: &Image, shading: &Image, surface: [f32; 3]) -> Image {
    let luma = |c: &[f32]| (0..3).map(|k| LUMA[k] * srgb_to_linear(c[k])).sum::<f32>();
    let reference = luma(&surface);
    let (w, h) = photo.size();
    let mut out = Image::new(w, h, 3);
    out.data_mut().par_chunks_mut(3).enumerate().for_each(|(i, o)| {
        let (p, t) = (&photo.data()[i * 3..i * 3 + 3], &texture.data()[i * texture.channels()..]);
        let f = (luma(t) / reference).min(1.0) / shading.data()[i].max(0.05);
        o.copy_from_slice(&linear_pixel_to_lab([0, 1, 2].map(|c| srgb_to_linear(p[c]) * f)));
    });
    out
}

/// Optical density of iron oxide per colour channel (linear sRGB),
/// relative: it absorbs blue most and red least, so a stain darkens
/// towards orange-brown.
const IRON_ABSORPTION: [f32; 3] = [0.35, 1.0, 1.8];
/// Optical density (times [`IRON_ABSORPTION`]) of the densest stain: it
/// passes about a third of the light (luminance), a brown.
const STAIN_DENSITY: f32 = 1.6;
/// The least density of a stained texel: the lightest of the texture's
/// rust still tints the stone.
const STAIN_FLOOR: f32 = 0.35;
/// Gaussian (pixels) that softens [`stained_photo`]'s density.
const STAIN_SOFTNESS: f32 = 2.0;
/// Wavelength (pixels) of [`stained_photo`]'s streaks across the face ...
const STREAK_WIDTH: f32 = 16.0;
/// ... and how many times longer they run down it.
const STREAK_LENGTH: f32 = 10.0;

/// Rust soaked into stone or plaster ([`super::DecayClass::stains`]), in
/// Lab: the photo's linear colour through an iron-oxide glaze (Beer-Lambert,
/// T_c = exp(-rho k a_c) with a_c [`IRON_ABSORPTION`]), divided by the
/// `shading` that [`composite`] applies again, so the stone's grain,
/// carving and lettering show through. The glaze's density rho follows
/// the rust texture's darkness: its log luminance, blurred by
/// [`STAIN_SOFTNESS`], placed between its 5th and 95th percentiles
/// (darkest 1, lightest [`STAIN_FLOOR`]).
/// Water carries the oxide down the face, so the density is streaked
/// along the image's vertical (fBm [`STREAK_LENGTH`] times longer down
/// than across, scaling it by 0.6 to 1.4; `seed` draws the streaks).
pub fn stained_photo(photo: &Image, texture: &Image, shading: &Image, seed: u64) -> Image {
    // A stain is diffuse: the crust's scale plates and pits are blurred out
    // of its density (they showed as 4-6 px orange blocks).
    let log_luminance = luminance(&to_linear(&texture.select_channels(0..3))).map(|v| v.max(1e-4).ln());
    let density = gaussian_blur(&log_luminance, STAIN_SOFTNESS);
    let mut logs = density.data().to_vec();
    let (dark, light) = {
        let lo = crate::image::order::quantile(&mut logs, 0.05).unwrap_or(0.0);
        let hi = crate::image::order::quantile(&mut logs, 0.95).unwrap_or(0.0);
        (lo, hi.max(lo + 1e-3))
    };
    let (w, h) = photo.size();
    let streaks = crate::image::noise::Layer::new(seed, 0x57a1);
    let mut out = Image::new(w, h, 3);
    out.data_mut().par_chunks_mut(3).enumerate().for_each(|(i, o)| {
        let p = &photo.data()[i * 3..i * 3 + 3];
        let rank = ((light - density.data()[i]) / (light - dark)).clamp(0.0, 1.0);
        let (x, y) = ((i % w) as f32, (i / w) as f32);
        let streak = (1.0 + 0.8 * streaks.fbm(x, y / STREAK_LENGTH, STREAK_WIDTH, 3, 0.5)).clamp(0.6, 1.4);
        let rho = (STAIN_FLOOR + (1.0 - STAIN_FLOOR) * rank) * streak;
        let s = shading.data()[i].max(0.05);
        o.copy_from_slice(&linear_pixel_to_lab(
            [0, 1, 2].map(|c| srgb_to_linear(p[c]) * (-rho * STAIN_DENSITY * IRON_ABSORPTION[c]).exp() / s),
        ));
    });
    out
}

/// The quantile of the photo's chroma and lightness that [`adapt_to_scene`]
/// takes as the scene's most saturated colour and its white.
const SCENE_QUANTILE: f32 = 0.95;
/// A texture's chroma is held to about this multiple of the scene's ...
const SCENE_CHROMA_HEADROOM: f32 = 1.25;
/// ... but never below this (a grey scene still lets rust be brown).
const MIN_CHROMA_CAP: f32 = 28.0;
/// The albedo of the brightest surfaces in a photo (its white).
const WHITE_ALBEDO: f32 = 0.8;
/// The darkest exposure [`adapt_to_scene`] assumes (a third of the texture's own light).
const MIN_EXPOSURE: f32 = 0.33;

/// The L* of the scene's white in `photo_lab`: its [`SCENE_QUANTILE`]
/// lightness (100 for an empty photo).
pub fn scene_white(photo_lab: &Image) -> f32 {
    let mut lightness: Vec<f32> = photo_lab.data().chunks_exact(3).map(|p| p[0]).collect();
    crate::image::order::quantile(&mut lightness, SCENE_QUANTILE).unwrap_or(100.0)
}

/// Adapt a decay texture's own colours (Lab, in place) to the photo's
/// light: the texture is a material seen under bright neutral light with
/// white at 1. Its exposure is scaled to the photo's (the photo's
/// 95th-percentile luminance taken as albedo 0.8, between a third and all
/// of the texture's light: rust on a dimly exposed white statue was as
/// light as the statue and read as salmon paint), and its chroma is
/// compressed softly, C' = cap tanh(C / cap), with the cap
/// at 1.25 x the photo's 95th-percentile chroma (at least 28): rust and
/// moss under a grey sky are no more saturated than the brightest things
/// in that scene, while on an orange hydrant in sunlight they keep their
/// colour. Tried: also shifting a*b* by the photo's white point (von
/// Kries); under a bluish white it turned rust pink.
pub fn adapt_to_scene(texture_lab: &mut Image, photo_lab: &Image) {
    let mut chroma: Vec<f32> = photo_lab.data().chunks_exact(3).map(|p| p[1].hypot(p[2])).collect();
    let scene = crate::image::order::quantile(&mut chroma, SCENE_QUANTILE).unwrap_or(0.0);
    let cap = (SCENE_CHROMA_HEADROOM * scene).max(MIN_CHROMA_CAP);
    // Exposure: the scene's white (its 95th-percentile luminance) is
    // taken as a surface of albedo WHITE_ALBEDO; the texture, drawn with
    // white at 1, is scaled to it in linear light: L* -> k^(1/3) (L* + 16) - 16,
    // a*b* -> k^(1/3) a*b*.
    let white = scene_white(photo_lab);
    let exposure = (((white + 16.0) / 116.0).powi(3) / WHITE_ALBEDO).clamp(MIN_EXPOSURE, 1.0).cbrt();
    texture_lab.data_mut().par_chunks_mut(3).for_each(|px| {
        px[0] = exposure * (px[0] + 16.0) - 16.0;
        let c = px[1].hypot(px[2]) * exposure;
        let scale = if c > 1e-6 { exposure * cap * (c / cap).tanh() / c } else { exposure };
        px[1] *= scale;
        px[2] *= scale;
    });
}

/// The mean Lab chroma (sqrt(a^2 + b^2)) of `lab` over `mask`: about 5 on
/// grey stone, 60 on an orange hydrant.
pub fn mean_chroma(lab: &Image, mask: &Mask) -> f32 {
    let (mut sum, mut n) = (0f64, 0usize);
    for (px, &m) in lab.data().chunks_exact(3).zip(mask.bits()) {
        if m {
            sum += (px[1] as f64).hypot(px[2] as f64);
            n += 1;
        }
    }
    (sum / n.max(1) as f64) as f32
}

/// The decay's layers as [`composite`] blends them into the photo.
pub struct Layers<'a> {
    /// The decay texture's colour in Lab.
    pub texture_lab: &'a Image,
    /// The texture's onset channel.
    pub onset: &'a Image,
    /// The object's relative shading.
    pub shading: &'a Image,
    /// The stained zone around the decay, laid out over the photo.
    pub stain: Option<&'a StainField>,
    /// Opacity of a texel that has just appeared (1: it appears whole).
    pub young: f32,
    /// The decay layer's relief and the photo's light ([`super::layer`]).
    pub relief: Relief,
    /// Towards the photo's light, in the image plane ([`super::layer::light_direction`]).
    pub light: [f32; 2],
    /// How much of each pixel the object covers ([`edge_coverage`]);
    /// `None`: all of every pixel.
    pub coverage: Option<&'a Image>,
    /// The photo's softness as a Gaussian sigma in pixels ([`focus_blur`]),
    /// which the decay's edges take too; 0 for a sharp photo.
    pub focus: f32,
}

/// Largest blur [`focus_blur`] gives a texture, in pixels.
const MAX_FOCUS_BLUR: f32 = 2.0;

/// The fineness of `lum`'s detail over the pixels `keep` selects: the
/// mean absolute forward difference over the same after a Gaussian of 1
/// px. About 2.4 for pixel-sharp noise, falling towards 1 as an image is
/// defocused (the 1 px blur then removes little).
fn fineness(lum: &Image, keep: impl Fn(usize) -> bool) -> f32 {
    let soft = gaussian_blur(lum, 1.0);
    let w = lum.width();
    let steps = |img: &Image| {
        let d = img.data();
        let mut sum = 0f64;
        for y in 0..img.height() - 1 {
            for x in 0..w - 1 {
                let i = y * w + x;
                if keep(i) {
                    sum += ((d[i + 1] - d[i]).abs() + (d[i + w] - d[i]).abs()) as f64;
                }
            }
        }
        sum
    };
    (steps(lum) / steps(&soft).max(1e-12)) as f32
}

/// The Gaussian blur (sigma, pixels, in 0.1 px steps up to 2) that brings
/// a decay texture's fineness ([`fineness`], measured on its central 256
/// x 256) down to the photo's inside the `mask` away from the silhouette
/// (whose sharp step would count as detail); 0 when the photo is as sharp.
/// A procedural texture is pixel-sharp, and on a soft or slightly
/// defocused photo its grain read as pasted on.
pub fn focus_blur(photo: &Image, mask: &Mask, texture: &Image) -> f32 {
    let deep = gaussian_blur(&mask.to_image(), 3.0);
    let deep: Vec<bool> = deep.data().iter().map(|&v| v > 0.999).collect();
    if deep.iter().filter(|&&d| d).count() < 1024 {
        return 0.0;
    }
    let target = fineness(&luminance(photo), |i| deep[i]);
    let (tw, th) = (texture.width().min(256), texture.height().min(256));
    let crop = texture.crop((texture.width() - tw) / 2, (texture.height() - th) / 2, tw, th).expect("inside the texture");
    let lum = luminance(&crop);
    // Fineness falls as the blur grows: bisect for the least step that reaches the target.
    let reaches = |k: usize| fineness(&gaussian_blur(&lum, k as f32 / 10.0), |_| true) <= target;
    let (mut lo, mut hi) = (0, (MAX_FOCUS_BLUR * 10.0) as usize);
    if reaches(lo) {
        return 0.0;
    }
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if reaches(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi as f32 / 10.0
}

/// How much of each pixel a binary object `mask` covers, for the decay's
/// opacity: 1 inside, about 0.8 on the outermost pixels of a straight
/// edge and less at corners and steps (smoothstep of the mask blurred at
/// 0.8 px, from 0.5 to 0.85), 0 outside. The photo's own silhouette is
/// anti-aliased, and a mask's is not: decay drawn at full opacity up to
/// the mask's last pixel ended in a stair-stepped edge against a soft
/// background. A stronger fade (about 0.35 on the outermost pixels) let
/// the object's own pale rim show as an outline. `None` for a mask that
/// covers the whole photo (no silhouette).
pub fn edge_coverage(mask: &Mask) -> Option<Image> {
    if mask.count() == mask.width() * mask.height() {
        return None;
    }
    let mut soft = gaussian_blur(&mask.to_image(), 0.8);
    soft.data_mut().iter_mut().zip(mask.bits()).for_each(|(v, &m)| *v = if m { smoothstep(0.5, 0.85, *v) } else { 0.0 });
    Some(soft)
}

/// Width (pixels) of the silhouette band [`matted_coverage`] mattes, and
/// the gap between the object's or the ground's reference pixels and the mask's outline.
const MATTE_BAND: usize = 2;
/// Reach (Gaussian sigma, pixels) of the local object and ground colours.
const MATTE_REACH: f32 = 3.0;
/// Least Lab distance between the object's and the ground's colour for
/// a pixel's mix of them to be read; below, the mask's geometry decides.
const MATTE_CONTRAST: f32 = 8.0;
/// Mixes below this share of object are ground (noise), above 1 minus it
/// all object.
const MATTE_SLACK: f32 = 0.05;

/// [`edge_coverage`], with each pixel within [`MATTE_BAND`] of the mask's
/// outline covered as much as its colour says: with F the object's colour
/// and B the ground's nearby (normalised convolutions over the object
/// deeper than the band and over the ground beyond it), the share of
/// object is the projection alpha = (P - B).(F - B) / |F - B|^2 (a
/// two-colour matte, as in Bayesian matting's colour line), mapped from
/// [0.05, 0.95] onto [0, 1]. A photo's silhouette is as soft as its lens
/// and anti-aliasing make it, and a binary mask is not: a geometric
/// fade left a pale rim of the object's own colour round every decayed
/// silhouette where the object is lighter than its ground (the outermost
/// mask pixel keeping half of a white statue, with the photo's mixed pixel
/// outside the mask lighter still), and decayed a mixed pixel as if it
/// were all object. Where the two colours are too alike to tell apart
/// (under [`MATTE_CONTRAST`]), the geometric coverage is kept.
///
/// `pad`: pixels by which `mask` was widened past the object's outline
/// (as [`super::AUTO_MASK_PAD`]); the geometric coverage is the narrower
/// mask's, so a widened pixel that cannot be read stays undecayed.
pub fn matted_coverage(mask: &Mask, pad: usize, photo_lab: &Image) -> Option<Image> {
    let outline = if pad > 0 { mask.erode(pad) } else { mask.clone() };
    let mut coverage = edge_coverage(&outline)?;
    let (w, h) = mask.size();
    let local = |source: &Mask| weighted_blur(photo_lab, &source.to_image(), MATTE_REACH);
    let core = outline.erode(MATTE_BAND);
    let near = outline.dilate(MATTE_BAND.max(pad + 1));
    let ground = Mask::from_fn(w, h, |x, y| !near.get(x, y));
    let ((f, fw), (b, bw)) = (local(&core), local(&ground));
    coverage.data_mut().par_iter_mut().enumerate().for_each(|(i, c)| {
        if !mask.bits()[i] || core.bits()[i] || fw.data()[i] < 0.05 || bw.data()[i] < 0.05 {
            return;
        }
        let at = |img: &Image, weight: &Image| [0, 1, 2].map(|k| img.data()[i * 3 + k] / weight.data()[i]);
        let (fc, bc, p) = (at(&f, &fw), at(&b, &bw), &photo_lab.data()[i * 3..i * 3 + 3]);
        let d = [0, 1, 2].map(|k| fc[k] - bc[k]);
        let span = d.iter().map(|v| v * v).sum::<f32>();
        if span < MATTE_CONTRAST * MATTE_CONTRAST {
            return;
        }
        let alpha = (0..3).map(|k| (p[k] - bc[k]) * d[k]).sum::<f32>() / span;
        *c = ((alpha - MATTE_SLACK) / (1.0 - 2.0 * MATTE_SLACK)).clamp(0.0, 1.0);
    });
    Some(coverage)
}

/// The object's own colour (Lab) on the pixels of its silhouette that it
/// only part covers (`coverage` in (0, 1)): the mean of the fully covered
/// pixels nearby (a normalised convolution at 1.5 px), or the pixel's own
/// colour where none is near. Elsewhere the photo's colour.
fn object_colour_at_edge(photo_lab: &Image, coverage: &Image) -> Image {
    let full = coverage.map(|c| (c >= 1.0) as u8 as f32);
    let (num, den) = weighted_blur(photo_lab, &full, 1.5);
    let mut out = photo_lab.clone();
    out.data_mut().chunks_exact_mut(3).enumerate().for_each(|(i, px)| {
        let (c, d) = (coverage.data()[i], den.data()[i]);
        if c > 0.0 && c < 1.0 && d > 1e-3 {
            px.copy_from_slice(&[0, 1, 2].map(|k| num.data()[i * 3 + k] / d));
        }
    });
    out
}

/// `values` blurred by a Gaussian of `sigma` over the object's pixels
/// only (`coverage` > 0; a normalised convolution), 0 outside: the
/// empty background does not fade the decay on the object's outermost
/// pixels (a plain blur took about half of it there, and the reviewers saw
/// a pale rim of the object's own colour round every decayed silhouette;
/// the silhouette's fade is the coverage's alone).
fn blurred_within(values: &Image, coverage: &Image, sigma: f32) -> Image {
    let inside = coverage.map(|c| (c > 0.0) as u8 as f32);
    let (num, den) = weighted_blur(values, &inside, sigma);
    Image::from_fn(values.width(), values.height(), 1, |x, y, p| {
        let i = y * values.width() + x;
        p[0] = if inside.data()[i] > 0.0 { num.data()[i] / den.data()[i].max(1e-6) } else { 0.0 };
    })
}

/// Reach (Gaussian sigma, pixels) of [`carried_past_the_edge`].
const CARRY: f32 = 2.0;

/// `weight` inside the object (`coverage` > 0) and, outside it, the mean
/// of the weight on the object nearby (a normalised convolution over the
/// object's pixels at [`CARRY`]): the layer continues past the silhouette
/// instead of stepping down to 0 there.
fn carried_past_the_edge(weight: &Image, coverage: &Image) -> Image {
    let inside = coverage.map(|c| (c > 0.0) as u8 as f32);
    let (num, den) = weighted_blur(weight, &inside, CARRY);
    let mut out = weight.clone();
    out.data_mut().iter_mut().zip(inside.data()).zip(num.data().iter().zip(den.data())).for_each(|((v, &m), (n, d))| {
        if m == 0.0 {
            *v = if *d > 1e-4 { n / d } else { 0.0 };
        }
    });
    out
}

/// Eq. 3: the photo `photo` (sRGB, its bytes kept wherever the decay is
/// invisible and has no stain) decayed to `degree` with the `layers`.
/// Pixels with degree 0 (and so everything outside the mask) are copied
/// from the photo untouched.
pub fn composite(photo: &Image, photo_lab: &Image, layers: &Layers, degree: &Image) -> Image {
    let (w, channels) = (photo.width(), photo.channels());
    let mut visible = degree.clone();
    visible.data_mut().iter_mut().zip(layers.onset.data()).for_each(|(d, &o)| *d = weight(*d, o));
    let stain = layers.stain.filter(|_| channels >= 3);
    let tint = stain.map_or([1.0; 3], |s| s.tint());
    let stain = stain.map(|s| s.weights(&visible, degree));
    // The opacity of each texel: visible, and thickening as it matures.
    let young = layers.young;
    let mut opacity = visible;
    opacity.data_mut().iter_mut().zip(degree.data()).zip(layers.onset.data()).for_each(|((v, &d), &o)| {
        *v *= young + (1.0 - young) * maturity(d, o);
    });
    // Whole flakes and open cracks switch on texel by texel: their edges
    // are anti-aliased. On a soft photo every class's edges take its blur
    // ([`focus_blur`]). Never past the decay's own extent, D > 0.
    let edge = if young >= 1.0 { EDGE_FILTER.max(layers.focus) } else { layers.focus };
    if edge > 0.0 {
        opacity = match layers.coverage {
            Some(c) => blurred_within(&opacity, c, edge),
            None => gaussian_blur(&opacity, edge),
        };
        opacity.data_mut().iter_mut().zip(degree.data()).for_each(|(v, &d)| *v = if d > 0.0 { v.min(1.0) } else { 0.0 });
    }
    // The layer's relief is read from the opacity carried on past the
    // silhouette, so the object's outline is no step in the layer (a flake
    // hole ending at the mask drew a dark wall along the silhouette).
    let relief_weight = match layers.coverage {
        Some(c) if channels >= 3 && layers.relief.height != 0.0 => Some(carried_past_the_edge(&opacity, c)),
        _ => None,
    };
    if let Some(c) = layers.coverage {
        opacity.data_mut().iter_mut().zip(c.data()).for_each(|(v, &c)| *v *= c);
    }
    let lighting =
        if channels >= 3 { layer::factor(relief_weight.as_ref().unwrap_or(&opacity), degree, &layers.relief, layers.light) } else { None };
    let body = layers.coverage.filter(|_| channels >= 3).map(|c| object_colour_at_edge(photo_lab, c));
    let mut out = photo.clone();
    out.data_mut().par_chunks_mut(w * channels).enumerate().for_each(|(y, row)| {
        for (x, px) in row.chunks_exact_mut(channels).enumerate() {
            let i = y * w + x;
            let wt = opacity.data()[i];
            // Below 1/500 the glaze changes no 8-bit level: skip its colour work.
            let cover = layers.coverage.map_or(1.0, |c| c.data()[i]);
            let b = stain.as_ref().map_or(0.0, |s| s[i]).max(0.0) * cover;
            let b = if b < 0.002 { 0.0 } else { b };
            let lit = lighting.as_ref().map_or(1.0, |f| f[i]);
            if (wt <= 0.0 && b <= 0.0 && lit == 1.0) || channels < 3 {
                continue;
            }
            // The photo under the stain: a glaze multiplying its linear colour.
            let stained;
            let p = if b > 0.0 {
                stained = linear_pixel_to_lab([0, 1, 2].map(|c| srgb_to_linear(px[c]) * (1.0 + b * (tint[c] - 1.0))));
                &stained[..]
            } else {
                &photo_lab.data()[i * 3..i * 3 + 3]
            };
            let t = &layers.texture_lab.data()[i * 3..i * 3 + 3];
            // S is a ratio of linear luminance: the texture is lit by it in
            // XYZ ([`lab_pixel_lit`]). The paper's product with L* itself
            // lit dark textures too little (rust in a shadow kept most of
            // its lightness and the object's form was lost); scaling L* + 16
            // and a*b* by S^(1/3), exact only above L* 8, crushed dark rust
            // in shadow to clipped, saturated black. The layer's own relief
            // lights texture and photo alike.
            let s = layers.shading.data()[i];
            // A part-covered silhouette pixel takes the layer's light on its object's share.
            let r = 1.0 + cover * (lit - 1.0);
            // On the silhouette's part-covered pixels the decay replaces the
            // object's share of the pixel, not a share of the pixel as a
            // whole (which left a line of the object's paint, or a pale rim
            // of white stone, along the outline): O = P + w (T s - object).
            let q = match (&body, layers.coverage) {
                (Some(body), Some(cov)) if cov.data()[i] < 1.0 => &body.data()[i * 3..i * 3 + 3],
                _ => p,
            };
            let shaded = lab_pixel_lit([t[0], t[1], t[2]], s);
            let lab = lab_pixel_lit([0, 1, 2].map(|c| p[c] + wt * (shaded[c] - q[c])), r);
            let rgb = lab_pixel_to_srgb(lab);
            for c in 0..3 {
                px[c] = rgb[c].clamp(0.0, 1.0);
            }
        }
    });
    out
}
