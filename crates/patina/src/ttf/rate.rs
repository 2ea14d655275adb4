//! Rate maps (Enrique et al., section 6, eq. 8): a per-pixel speed M(x, y)
//! over the output, so that output frame t shows, at each pixel, source
//! time f_t(x, y) = t M(x, y) (fractional times blend neighbouring frames).
//! M = 0 freezes a pixel at the first frame, M = 2 runs it twice as fast.
//! The sequence ends when the fastest pixel reaches the last source frame.
//!
//! Three ways to make M:
//! - a user's greyscale painting (luminance, times a scale);
//! - a point light: M = (cos(theta) / r^2)^2 over a flat surface or a
//!   supplied normal map (weathering driven by exposure), scaled to a
//!   maximum of 1;
//! - a height map's curvature. Our formulation (the paper's eq. 11 ties the
//!   rate to curvature; the exact mapping is ours): the mean curvature is
//!   approximated by minus the Laplacian of the height, smoothed with a
//!   Gaussian of 1 px, and mapped to M = clamp(0.5 + 0.5 kappa / kappa_98,
//!   0, 1) with kappa_98 the 98th percentile of |kappa|. Exposed convex
//!   features (ridges, edges) weather fastest, flat areas at half speed,
//!   hollows slowest. Invert the height map for the opposite.

use crate::error::{Error, Result};
use crate::image::color::luminance;
use crate::image::filter::gaussian_blur;
use crate::image::order::quantile;
use crate::image::Image;

/// A per-pixel rate map over the output (one channel, values >= 0).
#[derive(Clone, Debug, PartialEq)]
pub struct RateMap(Image);

impl RateMap {
    /// From a greyscale painting: M = luminance x `scale`.
    pub fn from_image(img: &Image, scale: f32) -> Result<Self> {
        if !scale.is_finite() || scale < 0.0 {
            return Err(Error::invalid(format!("the rate scale must be a finite number >= 0, got {scale}")));
        }
        let lum = if img.channels() >= 3 { luminance(img) } else { img.select_channels(0..1) };
        let map = lum.map(|v| v.max(0.0) * scale);
        if map.data().iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("the rate map holds values that are not numbers"));
        }
        Ok(RateMap(map))
    }

    /// From a point light at (x, y, z) in output pixels (z above the
    /// surface) over a `width` x `height` surface, flat or with `normals`
    /// (an RGB normal map, n = 2 rgb - 1, of that size).
    pub fn from_light(width: usize, height: usize, light: [f32; 3], normals: Option<&Image>) -> Result<Self> {
        if light.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("the light position must be three finite numbers"));
        }
        if let Some(n) = normals {
            if n.size() != (width, height) || n.channels() < 3 {
                return Err(Error::invalid(format!(
                    "the normal map is {}x{} with {} channels but the output is {width}x{height} and needs 3",
                    n.width(),
                    n.height(),
                    n.channels()
                )));
            }
        }
        let map = Image::from_fn(width, height, 1, |x, y, p| {
            let d = [light[0] - (x as f32 + 0.5), light[1] - (y as f32 + 0.5), light[2]];
            let r2 = d.iter().map(|v| v * v).sum::<f32>().max(1e-6);
            let n = match normals {
                Some(img) => {
                    let q = img.pixel(x, y);
                    let v = [2.0 * q[0] - 1.0, 2.0 * q[1] - 1.0, 2.0 * q[2] - 1.0];
                    let len = v.iter().map(|a| a * a).sum::<f32>().sqrt().max(1e-6);
                    [v[0] / len, v[1] / len, v[2] / len]
                }
                None => [0.0, 0.0, 1.0],
            };
            let cos = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / r2.sqrt();
            p[0] = (cos.max(0.0) / r2).powi(2);
        });
        let max = map.value_range().1;
        if max <= 0.0 || !max.is_finite() {
            return Err(Error::invalid("the light does not reach the surface (it must be above it: z > 0)"));
        }
        Ok(RateMap(map.map(|v| v / max)))
    }

    /// From a height map's curvature (see the module docs).
    pub fn from_curvature(height: &Image) -> Result<Self> {
        let h = gaussian_blur(&if height.channels() >= 3 { luminance(height) } else { height.select_channels(0..1) }, 1.0);
        let (w, hh) = h.size();
        if w < 3 || hh < 3 {
            return Err(Error::invalid(format!("the height map ({w}x{hh}) must be at least 3x3")));
        }
        let at = |x: isize, y: isize| h.at(x.clamp(0, w as isize - 1) as usize, y.clamp(0, hh as isize - 1) as usize, 0);
        let kappa = Image::from_fn(w, hh, 1, |x, y, p| {
            let (x, y) = (x as isize, y as isize);
            p[0] = 4.0 * at(x, y) - at(x - 1, y) - at(x + 1, y) - at(x, y - 1) - at(x, y + 1);
        });
        let mut mags: Vec<f32> = kappa.data().iter().map(|v| v.abs()).collect();
        let k98 = quantile(&mut mags, 0.98).unwrap_or(0.0);
        if k98 <= 0.0 {
            return Err(Error::invalid("the height map is flat: it has no curvature to set rates from"));
        }
        Ok(RateMap(kappa.map(|k| (0.5 + 0.5 * k / k98).clamp(0.0, 1.0))))
    }

    /// The map multiplied by `s` (>= 0).
    pub fn scaled(self, s: f32) -> Result<Self> {
        if !s.is_finite() || s < 0.0 {
            return Err(Error::invalid(format!("the rate scale must be a finite number >= 0, got {s}")));
        }
        Ok(RateMap(self.0.map(|v| v * s)))
    }

    /// The rates (one channel).
    pub fn image(&self) -> &Image {
        &self.0
    }

    pub fn rate(&self, x: usize, y: usize) -> f32 {
        self.0.at(x, y, 0)
    }

    /// Output frames for a `source_frames`-frame input: the fastest pixel
    /// reaches the last source frame on the last output frame.
    pub fn output_frames(&self, source_frames: usize) -> Result<usize> {
        let max = self.0.value_range().1;
        if max <= 0.0 {
            return Err(Error::invalid("the rate map is 0 everywhere: nothing would ever change"));
        }
        let last = source_frames.saturating_sub(1) as f32;
        let t = ((last / max) + 1e-4).floor() as usize + 1;
        if t > 100_000 {
            return Err(Error::invalid(format!("the rate map's fastest pixel ({max}) is so slow that the output would need {t} frames")));
        }
        Ok(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_light_is_fastest_below_it_and_slower_with_distance() {
        let m = RateMap::from_light(64, 64, [20.0, 30.0, 10.0], None).unwrap();
        assert!((m.rate(19, 29) - 1.0).abs() < 0.05 || (m.rate(20, 30) - 1.0).abs() < 0.05);
        assert!(m.rate(20, 30) > m.rate(30, 30) && m.rate(30, 30) > m.rate(50, 30));
        assert!(RateMap::from_light(64, 64, [20.0, 30.0, -1.0], None).is_err());
        // Normals tilted towards -x face the light from its +x side: that
        // side speeds up relative to the spot below the light.
        let tilted = Image::from_fn(64, 64, 3, |_, _, p| p.copy_from_slice(&[0.5 - 0.35, 0.5, 0.5 + 0.35]));
        let t = RateMap::from_light(64, 64, [20.0, 30.0, 10.0], Some(&tilted)).unwrap();
        assert!(t.rate(40, 30) / t.rate(20, 30) > 1.5 * m.rate(40, 30) / m.rate(20, 30));
    }

    #[test]
    fn curvature_speeds_up_ridges_and_slows_hollows() {
        let h = Image::from_fn(64, 64, 1, |x, _, p| {
            let d = x as f32 - 32.0;
            p[0] = 0.5 + 0.4 * (-(d * d) / 20.0).exp() - 0.4 * (-((x as f32 - 10.0).powi(2)) / 20.0).exp();
        });
        let m = RateMap::from_curvature(&h).unwrap();
        assert!(m.rate(32, 10) > 0.8, "ridge {}", m.rate(32, 10));
        assert!(m.rate(10, 10) < 0.2, "hollow {}", m.rate(10, 10));
        assert!((m.rate(55, 10) - 0.5).abs() < 0.05, "flat {}", m.rate(55, 10));
    }

    #[test]
    fn the_fastest_pixel_sets_the_length() {
        let m = RateMap::from_image(&Image::from_fn(4, 1, 1, |x, _, p| p[0] = x as f32 / 3.0), 2.0).unwrap();
        assert_eq!(m.output_frames(61).unwrap(), 31);
        assert!(RateMap::from_image(&Image::new(4, 4, 1), 1.0).unwrap().output_frames(10).is_err());
    }
}
