//! Shaded previews of a material at time t (Meister et al., eqs. 6-7):
//! Lambert diffuse plus a GGX microfacet specular lobe with Smith
//! shadowing-masking and Schlick's Fresnel, under one directional light and
//! a fixed view, on a flat plane (one texel per pixel) and on a sphere
//! (the material wrapped by longitude and latitude, sampled bilinearly).
//!
//! Conventions: parameters are linear; alpha = roughness^2; Ks is the
//! Fresnel reflectance at normal incidence (F0); a `Normal` parameter is a
//! tangent-space map (n = 2 rgb - 1). The light has radiance pi, so a white
//! Lambert surface facing it shows 1. Output is sRGB-encoded for viewing.

use super::material::Material;
use crate::image::color::linear_to_srgb;
use crate::image::Image;
use std::f32::consts::PI;
use std::ops::Range;

/// Light and view directions (towards the light / the viewer, unit length
/// after normalisation) and the ambient share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    pub light: [f32; 3],
    pub view: [f32; 3],
    pub ambient: f32,
}

impl Default for Lighting {
    fn default() -> Self {
        Lighting { light: [0.45, -0.55, 0.70], view: [0.0, 0.0, 1.0], ambient: 0.08 }
    }
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
    [v[0] / l, v[1] / l, v[2] / l]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Outgoing radiance (linear RGB) of one texel: eq. (6) with the GGX lobe
/// of eq. (7).
pub fn shade(kd: [f32; 3], ks: [f32; 3], roughness: f32, n: [f32; 3], lighting: &Lighting) -> [f32; 3] {
    let (l, v) = (normalize(lighting.light), normalize(lighting.view));
    let h = normalize([l[0] + v[0], l[1] + v[1], l[2] + v[2]]);
    let (nl, nv, nh, vh) = (dot(n, l), dot(n, v).max(1e-4), dot(n, h).max(0.0), dot(v, h).max(0.0));
    let mut out = [0.0f32; 3];
    for c in 0..3 {
        out[c] = lighting.ambient * kd[c];
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

/// Bilinear lookup of an evaluated frame at continuous texel coordinates
/// (texel centres at +0.5; wraps horizontally, clamps vertically).
fn bilinear(frame: &Image, fx: f32, fy: f32, out: &mut [f32]) {
    let (w, h) = frame.size();
    let (x, y) = (fx - 0.5, (fy - 0.5).clamp(0.0, (h - 1) as f32));
    let (x0, y0) = (x.floor(), y.floor());
    let (ax, ay) = (x - x0, y - y0);
    let wrap = |v: f32| (v as isize).rem_euclid(w as isize) as usize;
    let (xa, xb) = (wrap(x0), wrap(x0 + 1.0));
    let (ya, yb) = (y0 as usize, (y0 as usize + 1).min(h - 1));
    let (p00, p10, p01, p11) = (frame.pixel(xa, ya), frame.pixel(xb, ya), frame.pixel(xa, yb), frame.pixel(xb, yb));
    for (c, o) in out.iter_mut().enumerate() {
        *o = (1.0 - ay) * ((1.0 - ax) * p00[c] + ax * p10[c]) + ay * ((1.0 - ax) * p01[c] + ax * p11[c]);
    }
}

/// Where the shading parameters sit in an evaluated frame, looked up once
/// per render rather than per pixel.
struct Layout {
    kd: Option<Range<usize>>,
    ks: Option<Range<usize>>,
    roughness: Option<usize>,
    normal: Option<usize>,
}

impl Layout {
    fn of(material: &Material) -> Self {
        Layout {
            kd: material.param("diffuse"),
            ks: material.param("specular"),
            roughness: material.param("roughness").map(|r| r.start),
            normal: material.param("normal").filter(|r| r.len() == 3).map(|r| r.start),
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
        let roughness = self.roughness.map_or(0.5, |c| p[c]);
        let normal = self.normal.map_or([0.0, 0.0, 1.0], |c| normalize([2.0 * p[c] - 1.0, 2.0 * p[c + 1] - 1.0, 2.0 * p[c + 2] - 1.0]));
        (rgb(&self.kd, [0.5; 3]), rgb(&self.ks, [0.04; 3]), roughness.clamp(0.0, 1.0), normal)
    }
}

/// The material at time t on a flat plane, one texel per pixel (sRGB).
pub fn plane(material: &Material, t: f32, lighting: &Lighting) -> Image {
    let frame = material.evaluate(t);
    let (w, h) = material.size();
    let layout = Layout::of(material);
    Image::from_fn(w, h, 3, |x, y, px| {
        let (kd, ks, r, n) = layout.texel(frame.pixel(x, y));
        let c = shade(kd, ks, r, n, lighting);
        for (o, v) in px.iter_mut().zip(c) {
            *o = linear_to_srgb(v.clamp(0.0, 1.0));
        }
    })
}

/// The material at time t wrapped on a sphere seen from the front, in a
/// `size` x `size` image on dark grey (sRGB).
pub fn sphere(material: &Material, t: f32, size: usize, lighting: &Lighting) -> Image {
    let frame = material.evaluate(t);
    let (w, h) = material.size();
    let layout = Layout::of(material);
    let mut value = vec![0.0f32; frame.channels()];
    Image::from_fn(size, size, 3, |x, y, px| {
        let r = size as f32 / 2.0;
        let (u, v) = ((x as f32 + 0.5 - r) / r, (r - y as f32 - 0.5) / r);
        let z2 = 1.0 - u * u - v * v;
        if z2 <= 0.0 {
            px.iter_mut().for_each(|o| *o = 0.12);
            return;
        }
        let n_geo = [u, v, z2.sqrt()];
        // Longitude across the front half maps to the texture's width,
        // latitude to its height.
        let lon = n_geo[0].atan2(n_geo[2]);
        let lat = n_geo[1].asin();
        bilinear(&frame, (lon / PI + 0.5) * w as f32, (0.5 - lat / PI) * h as f32, &mut value);
        let (kd, ks, rough, n_tan) = layout.texel(&value);
        // Tangent frame: T along longitude, B along latitude.
        let tangent = normalize([n_geo[2], 0.0, -n_geo[0]]);
        let bitangent = [
            n_geo[1] * tangent[2] - n_geo[2] * tangent[1],
            n_geo[2] * tangent[0] - n_geo[0] * tangent[2],
            n_geo[0] * tangent[1] - n_geo[1] * tangent[0],
        ];
        let n = normalize([
            n_tan[0] * tangent[0] + n_tan[1] * bitangent[0] + n_tan[2] * n_geo[0],
            n_tan[0] * tangent[1] + n_tan[1] * bitangent[1] + n_tan[2] * n_geo[1],
            n_tan[0] * tangent[2] + n_tan[1] * bitangent[2] + n_tan[2] * n_geo[2],
        ]);
        let c = shade(kd, ks, rough, n, lighting);
        for (o, v) in px.iter_mut().zip(c) {
            *o = linear_to_srgb(v.clamp(0.0, 1.0));
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambert_facing_the_light_shows_its_albedo_and_the_lobe_peaks_at_the_mirror_direction() {
        let head_on = Lighting { light: [0.0, 0.0, 1.0], view: [0.0, 0.0, 1.0], ambient: 0.0 };
        let c = shade([0.5, 0.25, 0.1], [0.0; 3], 0.8, [0.0, 0.0, 1.0], &head_on);
        // With Ks = 0, Schlick's F is 0 at normal incidence: only Lambert remains.
        assert!((c[0] - 0.5).abs() < 1e-4 && (c[1] - 0.25).abs() < 1e-4, "{c:?}");
        let glossy = |n: [f32; 3]| {
            shade([0.0; 3], [0.04; 3], 0.2, normalize(n), &Lighting { light: [0.5, 0.0, 0.866], view: [-0.5, 0.0, 0.866], ambient: 0.0 })[0]
        };
        assert!(glossy([0.0, 0.0, 1.0]) > 5.0 * glossy([0.3, 0.0, 1.0]), "the highlight is where the half vector meets the normal");
        let below = shade([1.0; 3], [0.04; 3], 0.5, [0.0, 0.0, 1.0], &Lighting { light: [0.0, 0.0, -1.0], ..Lighting::default() });
        assert!(below.iter().all(|v| (v - 0.08).abs() < 1e-6), "only ambient when the light is behind");
    }
}
