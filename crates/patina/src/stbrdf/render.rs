//! Shaded previews of a material at time t (Meister et al., eqs. 6-7):
//! Lambert diffuse plus a GGX microfacet specular lobe with Smith
//! shadowing-masking and Schlick's Fresnel, on a flat plane (one texel per
//! pixel) and on a sphere (the material mapped azimuthally about the point facing
//! the viewer, [`sphere_point`]).
//!
//! A linear workflow, as a renderer would do it:
//! - the colour parameters (Diffuse, Specular) are decoded from the
//!   material's [`Encoding`] (sRGB for materials fitted to 8-bit photos,
//!   whose values are sRGB-encoded; linear for EXR materials);
//! - shading is in linear light, under one directional light ([`Environment::Sun`])
//!   or a procedural sky ([`Environment::Sky`]);
//! - radiance is scaled by the exposure, tone-mapped with the Khronos PBR
//!   Neutral curve and encoded as sRGB. Neutral is linear up to 0.76 and
//!   only rolls off highlights, so an albedo shows at its own level and
//!   contrast; ACES (tried first) darkened snow to grey and flattened bare
//!   steel into a milky card.
//!
//! The sphere is supersampled (3 x 3 per pixel, which also smooths its
//! outline) and each sample reads a mip-mapped frame at the level its
//! footprint asks for (trilinear), so texels are filtered, not skipped,
//! where the sphere minifies them towards the limb; where it magnifies
//! them (a small capture), the finest level is read bicubically.
//!
//! Conventions: alpha = roughness^2; Ks is the Fresnel reflectance at
//! normal incidence (F0); a `Normal` parameter is a tangent-space map
//! (n = 2 rgb - 1). The sun has radiance pi, so a white Lambert surface
//! facing it reflects 1.

use super::material::{Encoding, Material};
use super::poly::evaluate;
use crate::image::color::{linear_to_srgb, srgb_to_linear};
use crate::image::resample::{pyr_down, Filter};
use crate::image::Image;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;
use std::ops::Range;

/// What lights the preview.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Environment {
    /// One directional light plus a fill from the procedural sky (its
    /// share is `Lighting::ambient`), so shadowed sides keep their detail.
    #[default]
    Sun,
    /// A procedural sky: a bluish zenith fading to a bright horizon over a
    /// dark ground (a hemisphere light), no sun.
    Sky,
}

/// Light and view directions (towards the light / the viewer, unit length
/// after normalisation), the share of sky fill under the sun, the environment and the
/// exposure (a factor on radiance before tone-mapping).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lighting {
    pub light: [f32; 3],
    pub view: [f32; 3],
    pub ambient: f32,
    pub environment: Environment,
    pub exposure: f32,
}

impl Default for Lighting {
    fn default() -> Self {
        Lighting { light: [0.45, 0.55, 0.70], view: [0.0, 0.0, 1.0], ambient: 0.25, environment: Environment::Sun, exposure: 1.0 }
    }
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
    [v[0] / l, v[1] / l, v[2] / l]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The sky's radiance at the zenith, at the horizon and from the ground
/// (linear RGB), nearly neutral: a bluer zenith gave white materials a
/// visible cyan cast (review). Its irradiance on a surface facing the horizon is about pi
/// times the mean of sky and ground, so a white wall under it reflects
/// about 0.9 (the same as under the sun, so the two previews show a material at about the same level).
const SKY_ZENITH: [f32; 3] = [1.25, 1.35, 1.55];
const SKY_HORIZON: [f32; 3] = [2.05, 2.0, 1.95];
const SKY_GROUND: [f32; 3] = [0.55, 0.5, 0.45];
/// Screen up, the sky's zenith.
const UP: [f32; 3] = [0.0, 1.0, 0.0];

/// The sky's radiance in direction `d`: the ground below, fading into the
/// horizon over a few degrees (a hard horizon drew a line across glossy
/// spheres), then towards the zenith.
fn sky_radiance(d: [f32; 3]) -> [f32; 3] {
    let u = dot(d, UP);
    let ground = ((0.08 - u) / 0.16).clamp(0.0, 1.0);
    let ground = ground * ground * (3.0 - 2.0 * ground);
    let up = u.max(0.0).sqrt();
    std::array::from_fn(|c| {
        let sky = SKY_HORIZON[c] + (SKY_ZENITH[c] - SKY_HORIZON[c]) * up;
        sky + (SKY_GROUND[c] - sky) * ground
    })
}

/// Irradiance over pi from the sky on a surface with normal `n`: the
/// hemisphere-light approximation, mixing sky and ground by the share of
/// each the surface sees ((1 + cos) / 2), with the sky's mean over its
/// upper half.
fn sky_irradiance(n: [f32; 3]) -> [f32; 3] {
    let see_sky = 0.5 * (1.0 + dot(n, UP));
    std::array::from_fn(|c| {
        let sky = SKY_HORIZON[c] + (SKY_ZENITH[c] - SKY_HORIZON[c]) * (2.0 / 3.0);
        see_sky * sky + (1.0 - see_sky) * SKY_GROUND[c]
    })
}

/// Outgoing radiance (linear RGB) of one texel with linear parameters:
/// eq. (6) with the GGX lobe of eq. (7) under the sun; under the sky,
/// Lambert times the hemisphere irradiance plus the sky seen in the mirror
/// direction (blurred towards the irradiance as roughness grows) times
/// Karis's analytic fit of the split-sum environment BRDF.
pub fn shade(kd: [f32; 3], ks: [f32; 3], roughness: f32, n: [f32; 3], lighting: &Lighting) -> [f32; 3] {
    let v = normalize(lighting.view);
    let nv = dot(n, v).max(1e-4);
    if lighting.environment == Environment::Sky {
        let r = normalize(std::array::from_fn(|c| 2.0 * nv * n[c] - v[c]));
        let (e, mirror) = (sky_irradiance(n), sky_radiance(r));
        // Karis, "Physically based shading on mobile" (2014).
        let c0 = [-1.0, -0.0275, -0.572, 0.022];
        let c1 = [1.0, 0.0425, 1.04, -0.04];
        let rough: [f32; 4] = std::array::from_fn(|i| roughness * c0[i] + c1[i]);
        let a004 = (rough[0] * rough[0]).min((-9.28 * nv).exp2()) * rough[0] + rough[1];
        let (scale, bias) = (a004 * -1.04 + rough[2], a004 * 1.04 + rough[3]);
        let blur = roughness.clamp(0.0, 1.0);
        return std::array::from_fn(|c| {
            let spec = (1.0 - blur) * mirror[c] + blur * e[c];
            kd[c] * e[c] + (ks[c] * scale + bias) * spec
        });
    }
    let l = normalize(lighting.light);
    let h = normalize([l[0] + v[0], l[1] + v[1], l[2] + v[2]]);
    let (nl, nh, vh) = (dot(n, l), dot(n, h).max(0.0), dot(v, h).max(0.0));
    let mut out = [0.0f32; 3];
    let fill = sky_irradiance(n);
    for c in 0..3 {
        out[c] = lighting.ambient * kd[c] * fill[c];
    }
    if nl <= 0.0 {
        return out;
    }
    let alpha = (roughness * roughness).clamp(1e-4, 1.0);
    let a2 = alpha * alpha;
    let d = a2 / (PI * ((nh * nh) * (a2 - 1.0) + 1.0).powi(2));
    let g1 = |x: f32| 2.0 * x / (x + (a2 + (1.0 - a2) * x * x).sqrt());
    let g = g1(nl) * g1(nv);
    let schlick = (1.0 - vh).powi(5);
    for c in 0..3 {
        let f = ks[c] + (1.0 - ks[c]) * schlick;
        let spec = d * g * f / (4.0 * nl * nv);
        out[c] += PI * (kd[c] / PI + spec) * nl;
    }
    out
}

/// Whether `material`'s normal map is DirectX-style (green pointing down
/// the image), as the previews read it: from its Height when it has one,
/// else OpenGL-style. `false` without a 3-channel Normal.
pub fn normal_green_down(material: &Material) -> bool {
    Layout::of(material).green_down
}

/// The Khronos PBR Neutral tone mapper (Khronos 3D Commerce, 2024):
/// linear radiance to [0, 1], preserving hue and the base colour's level up
/// to 0.76, then compressing highlights towards white. Simplification:
/// without Neutral's toe, which subtracts the 4% Fresnel reflection an
/// image-lit scene adds everywhere; a sun-lit diffuse surface has none, and
/// the toe crushed dark rust (a 0.25 sRGB albedo showed at 0.15).
pub fn pbr_neutral(rgb: [f32; 3]) -> [f32; 3] {
    const START: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let mut c = rgb;
    let peak = c[0].max(c[1]).max(c[2]);
    if peak < START {
        return c.map(|v| v.clamp(0.0, 1.0));
    }
    let d = 1.0 - START;
    let new_peak = 1.0 - d * d / (peak + d - START);
    c = c.map(|v| v * new_peak / peak);
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.map(|v| (v + (new_peak - v) * g).clamp(0.0, 1.0))
}

/// Linear radiance to a displayed sRGB value: exposure, PBR Neutral, sRGB.
fn display(radiance: [f32; 3], exposure: f32, px: &mut [f32]) {
    for (o, v) in px.iter_mut().zip(pbr_neutral(radiance.map(|v| (exposure * v).max(0.0)))) {
        *o = linear_to_srgb(v);
    }
}

/// The material at time t with its colour parameters decoded to linear,
/// as mip levels (finest first) for filtered lookups.
struct ShadingFrame {
    mips: Vec<Image>,
}

impl ShadingFrame {
    fn new(material: &Material, t: f32, layout: &Layout, levels: usize) -> Self {
        let mut frame = material.evaluate(t);
        if material.encoding == Encoding::Srgb {
            let n = frame.channels();
            let colour: Vec<usize> = layout.kd.iter().chain(layout.ks.iter()).flat_map(|r| r.clone()).collect();
            frame.data_mut().par_chunks_mut(n).for_each(|px| {
                for &c in &colour {
                    px[c] = srgb_to_linear(px[c].clamp(0.0, 1.0));
                }
            });
        }
        let mut mips = vec![frame];
        while mips.len() < levels && mips.last().is_some_and(|m| m.width().min(m.height()) > 1) {
            let next = pyr_down(mips.last().expect("non-empty"));
            mips.push(next);
        }
        ShadingFrame { mips }
    }

    /// Lookup at texel coordinates of the finest level (texel centres at
    /// +0.5, clamped at the edges) for a sample whose footprint spans
    /// `footprint` finest texels: trilinear between the mip levels around
    /// log2(footprint) when minified, Catmull-Rom on the finest level when
    /// magnified (bilinear magnification showed a small capture's spots as
    /// soft blobs on the sphere, review).
    fn sample(&self, fx: f32, fy: f32, footprint: f32, out: &mut [f32], tmp: &mut [f32]) {
        if footprint < 1.0 {
            return catmull_rom(&self.mips[0], fx, fy, out);
        }
        let top = (self.mips.len() - 1) as f32;
        let lod = footprint.log2().clamp(0.0, top);
        let l0 = lod.floor() as usize;
        let a = lod - l0 as f32;
        bilinear(&self.mips[l0], fx, fy, self.mips[0].size(), out);
        if a > 0.0 && l0 + 1 < self.mips.len() {
            bilinear(&self.mips[l0 + 1], fx, fy, self.mips[0].size(), tmp);
            out.iter_mut().zip(tmp.iter()).for_each(|(o, v)| *o += a * (v - *o));
        }
    }
}

/// Bilinear lookup in `level` at finest-level texel coordinates (`finest`
/// is the finest level's size), clamped at the edges.
fn bilinear(level: &Image, fx: f32, fy: f32, finest: (usize, usize), out: &mut [f32]) {
    let (w, h) = level.size();
    let x = (fx * w as f32 / finest.0 as f32 - 0.5).clamp(0.0, (w - 1) as f32);
    let y = (fy * h as f32 / finest.1 as f32 - 0.5).clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor(), y.floor());
    let (ax, ay) = (x - x0, y - y0);
    let (xa, ya) = (x0 as usize, y0 as usize);
    let (xb, yb) = ((xa + 1).min(w - 1), (ya + 1).min(h - 1));
    let (p00, p10, p01, p11) = (level.pixel(xa, ya), level.pixel(xb, ya), level.pixel(xa, yb), level.pixel(xb, yb));
    for (c, o) in out.iter_mut().enumerate() {
        *o = (1.0 - ay) * ((1.0 - ax) * p00[c] + ax * p10[c]) + ay * ((1.0 - ax) * p01[c] + ax * p11[c]);
    }
}

/// Catmull-Rom (bicubic, a = -0.5) lookup in `img` at texel coordinates
/// (centres at +0.5, clamped at the edges), each channel held within the
/// range of the 2 x 2 texels around the point so edges do not ring.
fn catmull_rom(img: &Image, fx: f32, fy: f32, out: &mut [f32]) {
    let (w, h) = img.size();
    let (x, y) = ((fx - 0.5).clamp(0.0, (w - 1) as f32), (fy - 0.5).clamp(0.0, (h - 1) as f32));
    let (x0, y0) = (x.floor(), y.floor());
    let weights = |t: f32| [1.0 + t, t, 1.0 - t, 2.0 - t].map(|d| Filter::Cubic.weight(d));
    let (wx, wy) = (weights(x - x0), weights(y - y0));
    let at = |base: f32, k: usize, n: usize| (base as isize + k as isize - 1).clamp(0, n as isize - 1) as usize;
    out.iter_mut().for_each(|o| *o = 0.0);
    for (j, wyj) in wy.iter().enumerate() {
        let row = at(y0, j, h);
        for (i, wxi) in wx.iter().enumerate() {
            let p = img.pixel(at(x0, i, w), row);
            out.iter_mut().zip(p).for_each(|(o, v)| *o += wyj * wxi * v);
        }
    }
    let (xa, ya) = (x0 as usize, y0 as usize);
    let (xb, yb) = ((xa + 1).min(w - 1), (ya + 1).min(h - 1));
    let corners = [img.pixel(xa, ya), img.pixel(xb, ya), img.pixel(xa, yb), img.pixel(xb, yb)];
    for (c, o) in out.iter_mut().enumerate() {
        let (lo, hi) = corners.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| (lo.min(p[c]), hi.max(p[c])));
        *o = o.clamp(lo, hi);
    }
}

/// Where the shading parameters sit in an evaluated frame, looked up once
/// per render rather than per pixel.
struct Layout {
    kd: Option<Range<usize>>,
    ks: Option<Range<usize>>,
    roughness: Option<usize>,
    normal: Option<usize>,
    /// The normal map's green channel points down the image (DirectX, as
    /// Substance exports by default) rather than up (OpenGL).
    green_down: bool,
}

/// Roughness of materials without a Roughness parameter (albedo-only
/// captures): matte, since a captured albedo says nothing of gloss and a
/// glossy default made rusted steel look lacquered.
const DEFAULT_ROUGHNESS: f32 = 0.8;

/// F0 of materials without a Specular parameter (albedo-only captures):
/// none. A photo's colour already holds what the surface reflected under
/// the capture's light, its sheen included; the 4% dielectric lobe added on
/// top laid an even veil over rusted steel that lifted its darkest rust
/// from 1 to 33 levels on the plane (review: washed out).
const NO_SPECULAR: f32 = 0.0;

/// Whether the normal map (channels `c..c + 3`) is DirectX-style, told from
/// the Height parameter when there is one: a bump's normal leans away from
/// the slope, so with green pointing up the image (OpenGL) n_y follows
/// +dh/drow (rows run down) and with green pointing down it follows
/// -dh/drow. Without a Height, OpenGL is assumed.
fn normal_green_points_down(material: &Material, c: usize) -> bool {
    let Some(height) = material.param("height") else { return false };
    // Only the two channels compared, evaluated at t = 0.5.
    let m = material.degree + 1;
    let (w, h) = material.size();
    let at = |ch: usize| -> Vec<f32> {
        material
            .coefficients
            .data()
            .chunks_exact(material.coefficients.channels())
            .map(|a| evaluate(&a[ch * m..(ch + 1) * m], 0.5))
            .collect()
    };
    let (heights, green) = (at(height.start), at(c + 1));
    let mut corr = 0.0f64;
    for y in 1..h.saturating_sub(1) {
        for x in 0..w {
            let dh = heights[(y + 1) * w + x] - heights[(y - 1) * w + x];
            corr += f64::from(dh * (2.0 * green[y * w + x] - 1.0));
        }
    }
    corr < 0.0
}

impl Layout {
    fn of(material: &Material) -> Self {
        let normal = material.param("normal").filter(|r| r.len() == 3).map(|r| r.start);
        Layout {
            kd: material.param("diffuse"),
            ks: material.param("specular"),
            roughness: material.param("roughness").map(|r| r.start),
            normal,
            green_down: normal.is_some_and(|c| normal_green_points_down(material, c)),
        }
    }

    /// A texel's parameters from its evaluated channels.
    fn texel(&self, p: &[f32]) -> ([f32; 3], [f32; 3], f32, [f32; 3]) {
        let rgb = |r: &Option<Range<usize>>, default: [f32; 3]| -> [f32; 3] {
            match r {
                Some(r) if r.len() == 3 => [p[r.start], p[r.start + 1], p[r.start + 2]],
                Some(r) => [p[r.start]; 3],
                None => default,
            }
        };
        let roughness = self.roughness.map_or(DEFAULT_ROUGHNESS, |c| p[c]);
        let green = if self.green_down { -1.0 } else { 1.0 };
        let normal =
            self.normal.map_or([0.0, 0.0, 1.0], |c| normalize([2.0 * p[c] - 1.0, green * (2.0 * p[c + 1] - 1.0), 2.0 * p[c + 2] - 1.0]));
        (rgb(&self.kd, [0.5; 3]), rgb(&self.ks, [NO_SPECULAR; 3]), roughness.clamp(0.0, 1.0), normal)
    }
}

/// The material at time t on a flat plane facing the viewer, one texel per
/// pixel (sRGB).
pub fn plane(material: &Material, t: f32, lighting: &Lighting) -> Image {
    let layout = Layout::of(material);
    let frame = ShadingFrame::new(material, t, &layout, 1);
    let (w, h) = material.size();
    Image::from_fn(w, h, 3, |x, y, px| {
        let (kd, ks, r, n) = layout.texel(frame.mips[0].pixel(x, y));
        display(shade(kd, ks, r, n, lighting), lighting.exposure, px);
    })
}

/// Supersamples per pixel side on the sphere.
const SPHERE_SS: usize = 3;
/// The backdrop's grey (sRGB).
const BACKDROP: f32 = 0.12;

/// Texel coordinates of the sphere point at normalised screen position
/// (u, v), and its geometric normal; `None` off the sphere. The mapping is
/// azimuthal equidistant about the point facing the viewer: a point at
/// angle theta from it, in screen direction phi, reads the texel at
/// distance theta / (pi / 2) of the inscribed disc's radius from the
/// texture's centre, in direction phi. So texels keep one density along
/// every meridian and there is no pole: the longitude-latitude wrap it
/// replaces pinched the texture's top and bottom rows into the visible
/// pole (review), and stretched its columns by 1 / cos(latitude).
fn sphere_point(u: f32, v: f32, (w, h): (usize, usize)) -> Option<([f32; 2], [f32; 3])> {
    let z2 = 1.0 - u * u - v * v;
    if z2 <= 0.0 {
        return None;
    }
    let n = [u, v, z2.sqrt()];
    let s = (u * u + v * v).sqrt();
    let theta = s.atan2(n[2]);
    let radius = 0.5 * w.min(h) as f32;
    // Distance from the centre per unit of screen offset: theta / sin(theta)
    // tends to 1 at the centre.
    let k = if s > 1e-6 { theta / s } else { 1.0 } * radius / (PI / 2.0);
    Some(([0.5 * w as f32 + k * u, 0.5 * h as f32 - k * v], n))
}

/// The material at time t wrapped on a sphere seen from the front, in a
/// `size` x `size` image on dark grey (sRGB), supersampled and mip-mapped.
pub fn sphere(material: &Material, t: f32, size: usize, lighting: &Lighting) -> Image {
    sphere_sampled(material, t, size, lighting, SPHERE_SS, true)
}

/// [`sphere`] with `ss` x `ss` samples per pixel, mip-mapped or not.
fn sphere_sampled(material: &Material, t: f32, size: usize, lighting: &Lighting, ss: usize, mipmap: bool) -> Image {
    let layout = Layout::of(material);
    let frame = ShadingFrame::new(material, t, &layout, if mipmap { 16 } else { 1 });
    let dims = material.size();
    let channels = frame.mips[0].channels();
    let r = size as f32 / 2.0;
    let step = 1.0 / (ss as f32 * r);
    let mut out = Image::new(size, size, 3);
    out.data_mut().par_chunks_mut(size * 3).enumerate().for_each(|(y, row)| {
        let (mut value, mut tmp) = (vec![0.0f32; channels], vec![0.0f32; channels]);
        for (x, px) in row.chunks_exact_mut(3).enumerate() {
            let mut sum = [0.0f32; 3];
            for sy in 0..ss {
                for sx in 0..ss {
                    let fx = x as f32 + (sx as f32 + 0.5) / ss as f32;
                    let fy = y as f32 + (sy as f32 + 0.5) / ss as f32;
                    let (u, v) = ((fx - r) / r, (r - fy) / r);
                    let Some((tc, n_geo)) = sphere_point(u, v, dims) else {
                        sum.iter_mut().for_each(|s| *s += BACKDROP);
                        continue;
                    };
                    // The sample's footprint in texels: how far the texel
                    // coordinates move over one sample step on screen.
                    let reach = |du: f32, dv: f32| {
                        sphere_point(u + du, v + dv, dims)
                            .or_else(|| sphere_point(u - du, v - dv, dims))
                            .map_or(0.0, |(q, _)| ((q[0] - tc[0]).powi(2) + (q[1] - tc[1]).powi(2)).sqrt())
                    };
                    frame.sample(tc[0], tc[1], reach(step, 0.0).max(reach(0.0, step)), &mut value, &mut tmp);
                    let (kd, ks, rough, n_tan) = layout.texel(&value);
                    // Tangent frame: T along the texture's rows (the screen's x
                    // axis in the tangent plane), B = N x T up its columns.
                    let tangent = normalize([1.0 - n_geo[0] * n_geo[0], -n_geo[0] * n_geo[1], -n_geo[0] * n_geo[2]]);
                    let bitangent = [
                        n_geo[1] * tangent[2] - n_geo[2] * tangent[1],
                        n_geo[2] * tangent[0] - n_geo[0] * tangent[2],
                        n_geo[0] * tangent[1] - n_geo[1] * tangent[0],
                    ];
                    let n = normalize(std::array::from_fn(|c| n_tan[0] * tangent[c] + n_tan[1] * bitangent[c] + n_tan[2] * n_geo[c]));
                    let mut shown = [0.0f32; 3];
                    display(shade(kd, ks, rough, n, lighting), lighting.exposure, &mut shown);
                    sum.iter_mut().zip(shown).for_each(|(s, v)| *s += v);
                }
            }
            let k = 1.0 / (ss * ss) as f32;
            px.iter_mut().zip(sum).for_each(|(o, s)| *o = s * k);
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sun(light: [f32; 3], view: [f32; 3]) -> Lighting {
        Lighting { light, view, ambient: 0.0, ..Lighting::default() }
    }

    #[test]
    fn lambert_facing_the_light_shows_its_albedo_and_the_lobe_peaks_at_the_mirror_direction() {
        let c = shade([0.5, 0.25, 0.1], [0.0; 3], 0.8, [0.0, 0.0, 1.0], &sun([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]));
        // With Ks = 0, Schlick's F is 0 at normal incidence: only Lambert remains.
        assert!((c[0] - 0.5).abs() < 1e-4 && (c[1] - 0.25).abs() < 1e-4, "{c:?}");
        let glossy = |n: [f32; 3]| shade([0.0; 3], [0.04; 3], 0.2, normalize(n), &sun([0.5, 0.0, 0.866], [-0.5, 0.0, 0.866]))[0];
        assert!(glossy([0.0, 0.0, 1.0]) > 5.0 * glossy([0.3, 0.0, 1.0]), "the highlight is where the half vector meets the normal");
        let lighting = Lighting { light: [0.0, 0.0, -1.0], ..Lighting::default() };
        let below = shade([1.0; 3], [0.04; 3], 0.5, [0.0, 0.0, 1.0], &lighting);
        let fill = sky_irradiance([0.0, 0.0, 1.0]);
        assert!(below.iter().zip(fill).all(|(v, f)| (v - lighting.ambient * f).abs() < 1e-6), "only the sky fill when the sun is behind");
    }

    /// A bump's normal map in OpenGL and DirectX conventions is told apart
    /// by its Height, so both render lit from the same side.
    #[test]
    fn the_normal_maps_green_direction_is_read_from_the_height() {
        use crate::stbrdf::Param;
        let params = vec![Param { name: "Normal".into(), channels: 3 }, Param { name: "Height".into(), channels: 1 }];
        let bump = |x: f32, y: f32| (-((x - 16.0).powi(2) + (y - 16.0).powi(2)) / 40.0).exp();
        for down in [false, true] {
            let coef = Image::from_fn(32, 32, 8, |x, y, p| {
                let (fx, fy) = (x as f32, y as f32);
                let (dx, drow) = (bump(fx + 0.5, fy) - bump(fx - 0.5, fy), bump(fx, fy + 0.5) - bump(fx, fy - 0.5));
                let ny = if down { -drow } else { drow };
                let n = normalize([-4.0 * dx, 4.0 * ny, 1.0]);
                for c in 0..3 {
                    p[2 * c] = 0.5 + 0.5 * n[c];
                }
                p[6] = bump(fx, fy);
            });
            let m = Material::new(1, params.clone(), coef).unwrap();
            assert_eq!(Layout::of(&m).green_down, down);
            // Lit from above: the bump's upper flank is brighter than its lower one.
            let img = plane(&m, 0.0, &Lighting { light: [0.0, 0.7, 0.7], ..Lighting::default() });
            assert!(img.at(16, 12, 0) > img.at(16, 20, 0) + 0.05, "green down {down}: {} vs {}", img.at(16, 12, 0), img.at(16, 20, 0));
        }
    }

    #[test]
    fn the_sky_lights_surfaces_facing_up_more_than_those_facing_down() {
        let sky = Lighting { environment: Environment::Sky, ..Lighting::default() };
        let up = shade([0.5; 3], [0.04; 3], 0.5, [0.0, 0.8, 0.6], &sky);
        let down = shade([0.5; 3], [0.04; 3], 0.5, [0.0, -0.8, 0.6], &sky);
        assert!(up[1] > 1.5 * down[1], "{up:?} vs {down:?}");
        let front = shade([1.0; 3], [0.0; 3], 1.0, [0.0, 0.0, 1.0], &sky);
        assert!(front.iter().all(|v| (0.5..1.2).contains(v)), "a white wall is lit near 1: {front:?}");
    }

    /// An 8-bit capture (sRGB-encoded values) shown in a linear workflow
    /// keeps its level and contrast: the old preview encoded the values a
    /// second time, 40 levels too bright with half the contrast.
    #[test]
    fn an_srgb_material_previews_at_its_own_level_and_contrast() {
        use crate::stbrdf::Param;
        let kd = Image::from_fn(32, 32, 3, |x, _, p| p.fill(if (x / 4) % 2 == 0 { 0.25 } else { 0.7 }));
        let mut coef = Image::new(32, 32, 6);
        for y in 0..32 {
            for x in 0..32 {
                for c in 0..3 {
                    coef.pixel_mut(x, y)[2 * c] = kd.pixel(x, y)[c];
                }
            }
        }
        let mut m = Material::new(1, vec![Param { name: "Diffuse".into(), channels: 3 }], coef).unwrap();
        m.encoding = Encoding::Srgb;
        let p = plane(&m, 0.5, &Lighting::default());
        let (dark, light) = (p.at(1, 1, 0), p.at(5, 1, 0));
        assert!((light - dark) >= 0.8 * 0.45, "contrast {} of 0.45", light - dark);
        assert!((dark - 0.25).abs() < 0.08 && (light - 0.7).abs() < 0.08, "levels {dark} {light} against 0.25 and 0.7");
        // Near-black rust keeps its level: no specular veil is added to an
        // albedo-only capture (with a 4% lobe it showed at 0.15).
        let mut black = m.clone();
        black.coefficients.data_mut().chunks_exact_mut(2).for_each(|a| a[0] = a[0].min(0.05));
        let shown = plane(&black, 0.5, &Lighting::default()).at(1, 1, 0);
        assert!(shown < 0.08, "a 0.05 albedo shows at {shown}");
    }

    /// The sphere's mapping stretches the texture evenly: over the visible
    /// surface up to 80 degrees from its centre, texels per unit of surface
    /// differ by under 1.5x between places and directions (azimuthal
    /// equidistant: radially constant, tangentially theta / sin theta). The
    /// longitude-latitude wrap squeezed a whole row of texels into the pole.
    #[test]
    fn the_sphere_maps_texels_evenly_without_a_pole() {
        let dims = (64, 64);
        let tex = |n: [f32; 3]| sphere_point(n[0], n[1], dims).expect("on the sphere").0;
        let (mut lo, mut hi) = (f32::MAX, 0.0f32);
        for i in 1..=16 {
            let theta = (i as f32 / 16.0) * 80f32.to_radians();
            for j in 0..32 {
                let phi = j as f32 / 32.0 * 2.0 * PI;
                let at = |th: f32, ph: f32| [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
                let eps = 1e-3;
                let p = tex(at(theta, phi));
                // Texels moved per radian of surface, along the meridian
                // and across it.
                let radial = tex(at(theta + eps, phi));
                let across = tex(at(theta, phi + eps / theta.sin()));
                for q in [radial, across] {
                    let d = ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt() / eps;
                    (lo, hi) = (lo.min(d), hi.max(d));
                }
            }
        }
        assert!(hi < 1.5 * lo, "texels per radian from {lo:.2} to {hi:.2}");
    }

    /// A magnified capture stays crisp: single-texel stripes on a sphere
    /// that shows each texel over about 6 pixels keep most of their
    /// contrast at the centre (bicubic: a row's std is 0.50 of the stripes'
    /// half-difference); bilinear magnification turns them into a triangle
    /// wave (0.41, which fails the bound 0.45).
    #[test]
    fn the_sphere_keeps_magnified_texels_crisp() {
        use crate::stbrdf::Param;
        let coef = Image::from_fn(16, 16, 6, |x, _, p| {
            for c in 0..3 {
                p[2 * c] = if x % 2 == 0 { 0.3 } else { 0.6 };
            }
        });
        let m = Material::new(1, vec![Param { name: "Diffuse".into(), channels: 3 }], coef).unwrap();
        let flat = Lighting { light: [0.0, 0.0, 1.0], ambient: 0.0, ..Lighting::default() };
        let img = sphere(&m, 0.0, 64, &flat);
        let row: Vec<f32> = (26..38).map(|x| img.at(x, 32, 0)).collect();
        let mean = row.iter().sum::<f32>() / row.len() as f32;
        let std = (row.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / row.len() as f32).sqrt();
        let texels: Vec<f32> = [0.3f32, 0.6].iter().map(|&v| linear_to_srgb(pbr_neutral([srgb_to_linear(v); 3])[0])).collect();
        let full = 0.5 * (texels[1] - texels[0]);
        assert!(std > 0.45 * full, "stripe std {std:.3} of {full:.3}");
    }

    /// A checker minified on the sphere is filtered: each pixel is close to
    /// the true average of the texels it covers (a 16 x 16 supersampled
    /// reference), where one unfiltered sample per pixel sparkles.
    #[test]
    fn the_sphere_filters_minified_texels() {
        use crate::stbrdf::Param;
        let mut coef = Image::new(256, 256, 6);
        for y in 0..256 {
            for x in 0..256 {
                let v = if (x / 2 + y / 2) % 2 == 0 { 0.9 } else { 0.1 };
                for c in 0..3 {
                    coef.pixel_mut(x, y)[2 * c] = v;
                }
            }
        }
        let m = Material::new(1, vec![Param { name: "Diffuse".into(), channels: 3 }], coef).unwrap();
        let sky = Lighting { environment: Environment::Sky, ..Lighting::default() };
        let reference = sphere_sampled(&m, 0.0, 64, &sky, 16, false);
        let error =
            |img: &Image| img.data().iter().zip(reference.data()).map(|(a, b)| (a - b).abs()).sum::<f32>() / img.data().len() as f32;
        let (filtered, point) = (error(&sphere(&m, 0.0, 64, &sky)), error(&sphere_sampled(&m, 0.0, 64, &sky, 1, false)));
        assert!(filtered < 0.03 && filtered < 0.35 * point, "mean error {filtered:.3} against the reference; one point sample: {point:.3}");
    }
}
