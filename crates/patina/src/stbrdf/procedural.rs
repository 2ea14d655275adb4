//! A procedural time-varying material for tests and the demo: wet wood
//! drying. A wetness front set by fractal noise recedes over t in [0, 1];
//! wet wood is darker (albedo x 0.55), glossier (roughness 0.25 instead of
//! 0.7) and a little more specular.

use super::material::Param;
use crate::image::Image;
use crate::samples::fractal_noise;

/// The parameters of [`drying_wood`]: Kd (RGB), Ks (RGB), roughness.
pub fn drying_wood_params() -> Vec<Param> {
    vec![
        Param { name: "Diffuse".into(), channels: 3 },
        Param { name: "Specular".into(), channels: 3 },
        Param { name: "Roughness".into(), channels: 1 },
    ]
}

/// Smoothstep from 0 at `a` to 1 at `b`.
fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The material's parameter maps (7 channels) at time `t`.
pub fn drying_wood_at(width: usize, height: usize, t: f32, seed: u64) -> Image {
    Image::from_fn(width, height, 7, |x, y, p| {
        let (fx, fy) = (x as f32, y as f32);
        let warp = fractal_noise(seed ^ 0x31, fx, fy, 40.0, 3);
        let grain = 0.5 + 0.5 * (fy * 0.35 + 9.0 * warp).sin();
        let fibre = fractal_noise(seed ^ 0x32, fx * 0.15, fy * 2.0, 6.0, 2);
        let shade = 0.78 + 0.22 * grain * (0.7 + 0.6 * fibre);
        let dry = [0.62 * shade, 0.43 * shade, 0.26 * shade];
        // Where the wood dries late (tau near 1) and where early.
        let tau = 0.15 + 0.75 * fractal_noise(seed ^ 0x33, fx, fy, 48.0, 4);
        let wet = 1.0 - smoothstep(tau - 0.35, tau + 0.35, t);
        for c in 0..3 {
            p[c] = dry[c] * (1.0 - 0.45 * wet);
            p[3 + c] = 0.03 + 0.05 * wet;
        }
        p[6] = 0.7 - 0.45 * wet;
    })
}

/// `steps` samples of the drying over t = 0..1 (evenly spaced) and their times.
pub fn drying_wood(width: usize, height: usize, steps: usize, seed: u64) -> (Vec<Image>, Vec<f32>) {
    let times: Vec<f32> = (0..steps).map(|i| i as f32 / (steps.max(2) - 1) as f32).collect();
    (times.iter().map(|&t| drying_wood_at(width, height, t, seed)).collect(), times)
}

/// `material` as a capture under uneven light ([`crate::samples::light_gain`]:
/// a vignette times a left-to-right ramp): every coefficient of its
/// Diffuse parameter multiplied by the gain, so the albedo is lit at every
/// t. The ground truth for lighting-aware enlargement.
pub fn light_ramp(material: &mut super::Material) {
    let Some(kd) = material.param("diffuse") else { return };
    let m = material.degree + 1;
    let (w, h) = material.size();
    for y in 0..h {
        for x in 0..w {
            let g = crate::samples::light_gain(x, y, w, h);
            material.coefficients.pixel_mut(x, y)[kd.start * m..kd.end * m].iter_mut().for_each(|v| *v *= g);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stbrdf::fit::fit;

    #[test]
    fn drying_wood_is_fitted_by_cubics_within_0_03_and_exactly_by_its_own_polynomials() {
        let (frames, times) = drying_wood(48, 40, 21, 5);
        let f = fit(&frames, &times, 3, drying_wood_params()).unwrap();
        assert!(f.rms.iter().all(|&r| r <= 0.03), "{:?}", f.rms);
        // The wetness changes something: the fit is not a constant.
        let (a, b) = (f.material.evaluate(0.0), f.material.evaluate(1.0));
        assert!(a.pixel(10, 10)[6] < b.pixel(10, 10)[6] - 0.1, "roughness rises as it dries");
        // Frames made from the fitted polynomials are fitted back exactly.
        let again: Vec<Image> = times.iter().map(|&t| f.material.evaluate(t)).collect();
        let g = fit(&again, &times, 3, drying_wood_params()).unwrap();
        let err =
            g.material.coefficients.data().iter().zip(f.material.coefficients.data()).map(|(p, q)| (p - q).abs()).fold(0.0f32, f32::max);
        assert!(err < 1e-5, "{err}");
        assert!(g.rms.iter().all(|&r| r < 1e-5), "{:?}", g.rms);
    }
}
