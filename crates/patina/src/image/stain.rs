//! A stained zone around what a weathering method lays over a photo:
//! rust bleeds an orange-brown glaze into the paint around it and runs
//! down the object in streaks, a flake casts a thin shadow, moss leaves a
//! damp dark rim. The zone is the visible weight w blurred by the zone's
//! width (shifted by its offset, its rim made ragged by coordinate noise),
//! so a big patch gets a full rim and a speck a faint one; a method
//! multiplies its background there by the zone's tint. Decay's compositor
//! and stbrdf's grow transfer both use it.

use super::filter::{gaussian_blur, shrunk_blur};
use super::noise::{smoothstep, Layer};
use super::Image;
use rayon::prelude::*;
use serde::Serialize;

/// The stained zone around visible weathering.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Transition {
    /// Gaussian width of the zone, in pixels (0: no zone).
    pub width: f32,
    /// The linear-RGB factor the zone applies at its full strength.
    pub tint: [f32; 3],
    /// The zone's strength at the edge of a large weathered patch, in [0, 1].
    pub strength: f32,
    /// Where the zone falls relative to the weathering, in pixels (a flake's
    /// shadow falls down-right).
    pub offset: [f32; 2],
    /// How far the zone runs down the image below the weathering, in pixels, as
    /// thin streaks (rust's runoff: water carries the oxide down the
    /// object); 0 for none.
    pub drip: f32,
    /// How dense the runoff is against the rim it leaves from: its weight
    /// below the weathering is min(1, gain x the carried rim x the
    /// streaks). 1 keeps it as dense as the rim.
    pub drip_gain: f32,
}

impl Transition {
    /// No zone: eq. 3 alone.
    pub const NONE: Transition = Transition { width: 0.0, tint: [1.0; 3], strength: 0.0, offset: [0.0; 2], drip: 0.0, drip_gain: 1.0 };

    /// Where each pixel reads the zone's rim, and how dense the zone is
    /// there: the part of [`Transition::weights`] that does not change
    /// from frame to frame, made once per photo. `None` for no zone.
    pub fn field(&self, width: usize, height: usize, seed: u64) -> Option<StainField> {
        if self.width <= 0.0 || self.strength <= 0.0 {
            return None;
        }
        let [dx, dy] = self.offset;
        let (warp_x, warp_y, density) = (Layer::new(seed, 950), Layer::new(seed, 951), Layer::new(seed, 952));
        let scale = 2.0 * self.width.max(1.0);
        let mut field = StainField {
            transition: *self,
            width,
            source: vec![0; width * height],
            density: vec![0.0; width * height],
            streaks: Vec::new(),
        };
        if self.drip > 0.0 {
            // Streaks: noise stretched 6:1 down the image (10 px across, 60
            // px along), so the runoff parts into rivulets; a broader field
            // gathers them into runs and dry gaps, so they are not spaced
            // like the teeth of a comb.
            let (streak, runs) = (Layer::new(seed, 953), Layer::new(seed, 954));
            field.streaks = vec![0.0; width * height];
            field.streaks.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
                for (x, v) in row.iter_mut().enumerate() {
                    let (fx, fy) = (x as f32, y as f32);
                    *v = smoothstep(-0.2, 0.15, streak.fbm(6.0 * fx, fy, 60.0, 3, 0.5))
                        * smoothstep(-0.25, 0.2, runs.fbm(3.0 * fx, fy, 120.0, 2, 0.5));
                }
            });
        }
        field.source.par_chunks_mut(width).zip(field.density.par_chunks_mut(width)).enumerate().for_each(|(y, (src, dense))| {
            for x in 0..width {
                let (fx, fy) = (x as f32, y as f32);
                let sx = fx - dx + self.width * warp_x.fbm(fx, fy, scale, 3, 0.5);
                let sy = fy - dy + self.width * warp_y.fbm(fx, fy, scale, 3, 0.5);
                let sx = sx.round().clamp(0.0, (width - 1) as f32) as usize;
                let sy = sy.round().clamp(0.0, (height - 1) as f32) as usize;
                src[x] = (sy * width + sx) as u32;
                dense[x] = (0.7 + 0.6 * density.fbm(fx, fy, 0.5 * scale, 3, 0.6)).clamp(0.4, 1.0);
            }
        });
        Some(field)
    }
}

/// A [`Transition`] laid out over one photo ([`Transition::field`]).
pub struct StainField {
    transition: Transition,
    /// The photo's width (the runoff runs down its columns).
    width: usize,
    /// Per pixel, the pixel whose blurred weight it reads: shifted by the
    /// offset and displaced by up to one width with coordinate noise (so
    /// the rim is ragged, as stains are, not a glow of even width).
    source: Vec<u32>,
    /// Per pixel, a noisy density in [0.4, 1].
    density: Vec<f32>,
    /// Per pixel, how much of the runoff passes there, in [0, 1] (empty
    /// without a drip).
    streaks: Vec<f32>,
}

impl StainField {
    /// The zone's weight per pixel at `degree` (how far the weathering has
    /// begun there: decay's degree map D), given the visible weight
    /// map `w`: strength x min(1, 2 x blur(w)) read at the pixel's source,
    /// times its density, times (1 - w) (the texture covers its own
    /// pixels), faded in over the first 0.01 of D (none where D = 0).
    /// With a drip, the rim is at least the runoff from above: the
    /// unwarped rim carried down each column, fading by e every `drip`
    /// pixels, times the streaks and the drip's gain, at most 1.
    pub fn weights(&self, w: &Image, degree: &Image) -> Vec<f32> {
        let t = &self.transition;
        let near = coarse_blur(w, t.width);
        let (w, degree, near) = (w.data(), degree.data(), near.data());
        let runoff = (t.drip > 0.0).then(|| {
            let fade = (-1.0 / t.drip).exp();
            let mut carried = vec![0f32; self.width];
            let mut out = vec![0f32; near.len()];
            for (row, out) in near.chunks_exact(self.width).zip(out.chunks_exact_mut(self.width)) {
                for ((c, &n), o) in carried.iter_mut().zip(row).zip(out) {
                    *c = (*c * fade).max((2.0 * n).min(1.0));
                    *o = *c;
                }
            }
            out
        });
        let mut out = vec![0f32; w.len()];
        out.par_iter_mut().enumerate().for_each(|(i, o)| {
            let d = degree[i];
            if d > 0.0 && w[i] < 1.0 {
                let mut rim = (2.0 * near[self.source[i] as usize]).min(1.0);
                if let Some(r) = &runoff {
                    rim = rim.max((t.drip_gain * r[i] * self.streaks[i]).min(1.0));
                }
                *o = t.strength * rim * self.density[i] * (1.0 - w[i]) * smoothstep(0.0, 0.01, d);
            }
        });
        out
    }

    /// The linear-RGB factor of the zone at full strength.
    pub fn tint(&self) -> [f32; 3] {
        self.transition.tint
    }
}

/// A Gaussian blur of `img` by `sigma` computed on a copy shrunk by f =
/// floor(sigma / 2) ([`shrunk_blur`], the construction of
/// [`gaussian_blur`]'s wide blurs, from a smaller sigma): a stain's rim is
/// smooth, and the direct blur of a 3-megapixel frame at sigma 9 took
/// 0.6 s, four times the rest of the frame.
fn coarse_blur(img: &Image, sigma: f32) -> Image {
    let f = (sigma / 2.0).floor();
    (f >= 2.0).then(|| shrunk_blur(img, sigma, f)).flatten().unwrap_or_else(|| gaussian_blur(img, sigma))
}
