//! Colour: sRGB transfer curve, luminance and CIE L*a*b* (D65).

use super::{ChannelGroup, Image};

/// sRGB-encoded value in [0, 1] to linear light (IEC 61966-2-1).
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light to sRGB encoding.
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.max(0.0).powf(1.0 / 2.4) - 0.055
    }
}

/// Apply `f` to colour channels, leaving any `alpha` group untouched.
fn map_colour(img: &Image, f: impl Fn(f32) -> f32) -> Image {
    let alpha = img.group("alpha");
    let n = img.channels();
    let mut out = img.clone();
    for px in out.data_mut().chunks_exact_mut(n) {
        for (c, v) in px.iter_mut().enumerate() {
            if !alpha.as_ref().is_some_and(|a| a.contains(&c)) {
                *v = f(*v);
            }
        }
    }
    out
}

/// Linearise an sRGB-encoded image (alpha untouched).
pub fn to_linear(img: &Image) -> Image {
    map_colour(img, srgb_to_linear)
}

/// Encode a linear image as sRGB (alpha untouched).
pub fn to_srgb(img: &Image) -> Image {
    map_colour(img, linear_to_srgb)
}

/// Rec. 709 luminance weights.
pub const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// One-channel luminance: Rec. 709 weights over the first three channels, or
/// channel 0 of a gray image. Applied to the values as given (use
/// [`to_linear`] first for photometric luminance, skip it for luma).
pub fn luminance(img: &Image) -> Image {
    let n = img.channels();
    let data = img.data().chunks_exact(n).map(|p| if n >= 3 { pixel_luminance(p) } else { p[0] }).collect();
    Image::from_data(img.width(), img.height(), 1, data).expect("sizes match")
}

/// One pixel's Rec. 709 luminance (its first three values), as [`luminance`] takes it.
pub fn pixel_luminance(p: &[f32]) -> f32 {
    LUMA[0] * p[0] + LUMA[1] * p[1] + LUMA[2] * p[2]
}

const WHITE: [f32; 3] = [0.950_47, 1.0, 1.088_83];

fn lab_f(t: f32) -> f32 {
    const D: f32 = 6.0 / 29.0;
    if t > D * D * D {
        t.cbrt()
    } else {
        t / (3.0 * D * D) + 4.0 / 29.0
    }
}

fn lab_f_inv(t: f32) -> f32 {
    const D: f32 = 6.0 / 29.0;
    if t > D {
        t * t * t
    } else {
        3.0 * D * D * (t - 4.0 / 29.0)
    }
}

/// sRGB-encoded RGB pixel to CIE L*a*b* (L in [0, 100]).
pub fn srgb_pixel_to_lab(rgb: [f32; 3]) -> [f32; 3] {
    linear_pixel_to_lab(rgb.map(srgb_to_linear))
}

/// Linear RGB pixel to CIE L*a*b* (L in [0, 100]).
pub fn linear_pixel_to_lab([r, g, b]: [f32; 3]) -> [f32; 3] {
    let x = 0.412_456_4 * r + 0.357_576_1 * g + 0.180_437_5 * b;
    let y = 0.212_672_9 * r + 0.715_152_2 * g + 0.072_175 * b;
    let z = 0.019_333_9 * r + 0.119_192 * g + 0.950_304_1 * b;
    lab_from_fs([lab_f(x / WHITE[0]), lab_f(y / WHITE[1]), lab_f(z / WHITE[2])])
}

/// The f(X/Xn), f(Y/Yn), f(Z/Zn) of a CIE L*a*b* colour.
fn lab_fs(lab: [f32; 3]) -> [f32; 3] {
    let fy = (lab[0] + 16.0) / 116.0;
    [fy + lab[1] / 500.0, fy, fy - lab[2] / 200.0]
}

/// CIE L*a*b* from f(X/Xn), f(Y/Yn), f(Z/Zn).
fn lab_from_fs([fx, fy, fz]: [f32; 3]) -> [f32; 3] {
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// CIE L*a*b* to an sRGB-encoded RGB pixel (not clamped).
pub fn lab_pixel_to_srgb(lab: [f32; 3]) -> [f32; 3] {
    let [fx, fy, fz] = lab_fs(lab);
    let (x, y, z) = (WHITE[0] * lab_f_inv(fx), WHITE[1] * lab_f_inv(fy), WHITE[2] * lab_f_inv(fz));
    let r = 3.240_454_2 * x - 1.537_138_5 * y - 0.498_531_4 * z;
    let g = -0.969_266 * x + 1.876_010_8 * y + 0.041_556 * z;
    let b = 0.055_643_4 * x - 0.204_025_9 * y + 1.057_225_2 * z;
    [r, g, b].map(linear_to_srgb)
}

/// A CIE L*a*b* colour under `k` times the light (XYZ scaled by `k`):
/// the same surface in a shadow (k < 1) or lit more brightly. Exact over
/// the whole range, the linear segment of L* near black included.
pub fn lab_pixel_lit(lab: [f32; 3], k: f32) -> [f32; 3] {
    lab_from_fs(lab_fs(lab).map(|f| lab_f(k * lab_f_inv(f))))
}

fn map_pixels3(img: &Image, group: &str, f: impl Fn([f32; 3]) -> [f32; 3]) -> Image {
    let n = img.channels();
    let mut data = Vec::with_capacity(img.width() * img.height() * 3);
    for p in img.data().chunks_exact(n) {
        let v = if n >= 3 { [p[0], p[1], p[2]] } else { [p[0]; 3] };
        data.extend_from_slice(&f(v));
    }
    let mut out = Image::from_data(img.width(), img.height(), 3, data).expect("sizes match");
    out.set_groups(vec![ChannelGroup { name: group.into(), channels: 0..3 }]).expect("one group");
    out
}

/// sRGB-encoded image (first three channels, or gray) to a 3-channel Lab image.
pub fn to_lab(img: &Image) -> Image {
    map_pixels3(img, "lab", srgb_pixel_to_lab)
}

/// 3-channel Lab image to sRGB encoding, clamped to [0, 1].
pub fn from_lab(img: &Image) -> Image {
    map_pixels3(img, "rgb", |lab| lab_pixel_to_srgb(lab).map(|v| v.clamp(0.0, 1.0)))
}

/// `img` with colour: gray (and gray + alpha) become RGB (RGBA) by
/// repeating the gray value; images with 3 or more channels are returned
/// as they are.
pub fn with_colour(img: &Image) -> Image {
    match img.channels() {
        1 | 2 => Image::from_fn(img.width(), img.height(), img.channels() + 2, |x, y, p| {
            let s = img.pixel(x, y);
            p[..3].fill(s[0]);
            if s.len() == 2 {
                p[3] = s[1];
            }
        }),
        _ => img.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A surface under k times the light: its linear RGB is k times as
    /// much, down to near black (where the cube-root form of L* ends and
    /// scaling L* + 16 and a*b* by k^(1/3) leaves the gamut).
    #[test]
    fn a_lab_colour_lit_k_times_is_its_linear_rgb_times_k() {
        for rgb in [[0.3f32, 0.12, 0.05], [0.05, 0.02, 0.01], [0.6, 0.6, 0.55]] {
            let lab = linear_pixel_to_lab(rgb);
            for k in [1.0f32, 0.5, 0.1, 0.02] {
                let back = lab_pixel_to_srgb(lab_pixel_lit(lab, k)).map(srgb_to_linear);
                for c in 0..3 {
                    assert!((back[c] - k * rgb[c]).abs() < 1e-4 + 1e-3 * k * rgb[c], "{rgb:?} x {k}: {back:?}");
                }
            }
        }
    }

    #[test]
    fn srgb_curve_inverts_and_lab_matches_reference_values() {
        for i in 0..=100 {
            let v = i as f32 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(v)) - v).abs() < 1e-5);
        }
        // Reference values (CIE, D65): white, mid gray, pure red.
        let w = srgb_pixel_to_lab([1.0, 1.0, 1.0]);
        assert!((w[0] - 100.0).abs() < 0.01 && w[1].abs() < 0.01 && w[2].abs() < 0.01);
        let red = srgb_pixel_to_lab([1.0, 0.0, 0.0]);
        assert!((red[0] - 53.24).abs() < 0.05 && (red[1] - 80.09).abs() < 0.1 && (red[2] - 67.20).abs() < 0.1);
        let img = Image::from_fn(8, 8, 3, |x, y, p| p.copy_from_slice(&[x as f32 / 7.0, y as f32 / 7.0, 0.3]));
        let back = from_lab(&to_lab(&img));
        for (a, b) in img.data().iter().zip(back.data()) {
            assert!((a - b).abs() < 1e-3);
        }
    }
}
