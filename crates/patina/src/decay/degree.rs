//! Degree maps D in [0, 1]: where and how far the surface has decayed
//! (Hao et al. 2023, sections III-C2 and III-C4).

use super::texture::DecayClass;
use crate::image::filter::gaussian_blur;
use crate::image::noise::{smoothstep, Layer};
use crate::image::resample::{resize, Filter};
use crate::image::{Image, Mask};
use crate::rng::{self, Rng};
use crate::{Error, Result};
use rayon::prelude::*;

/// Degree below which self-growth does not act (eq. 6: D += Z where D > 0.25).
pub const GROWTH_THRESHOLD: f32 = 0.25;

/// How many times Algorithm 1 re-draws the pattern before falling back to
/// an exact quantile threshold.
const MAX_DRAWS: u64 = 64;

/// Amplitude of the fine fBm that roughens Algorithm 1's blob outlines.
const RAGGED: f32 = 0.06;
/// Width, in pattern units above the threshold, over which a blob's degree fades in.
const FEATHER: f32 = 0.04;

/// Weight of a class's affinity map in Algorithm 1's pattern (which spans
/// about [0, 1]).
pub const AFFINITY: f32 = 0.3;

/// Where a class's decay starts, from the light on the object (`form`:
/// the shading, `relief`: the fine relief, both linear luminance ratios;
/// see [`super::shading`]): moss grows in shade and recesses (dark form
/// and relief), rust starts in crevices, seams and round bolts (dark
/// relief), flakes lift at edges (strong relief either way); cracks have
/// no preference (`None`). The map is the log light's z-score inside the
/// mask, halved and held to [-1, 1]; 0 outside. Rust's and moss's add where
/// water stands ([`Mask::wet_places`]: the object's rims and its bottom) to
/// half their crevice or shade z-score before the z-score is taken, which
/// is not halved: on a slab with no crevices, rust scattered evenly over
/// the face like cow print, and moss grew as one slab over a statue's lit
/// face while its base stayed clean.
pub fn affinity(class: DecayClass, form: &Image, relief: &Image, mask: &Mask) -> Option<Image> {
    if class == DecayClass::Cracked {
        return None;
    }
    let log = |v: f32| v.max(1e-6).ln();
    let mut values: Vec<f32> = form
        .data()
        .iter()
        .zip(relief.data())
        .map(|(&f, &r)| match class {
            DecayClass::Mossy => -log(f * r),
            DecayClass::Rust => -log(r),
            _ => log(r).abs(),
        })
        .collect();
    let follows_water = matches!(class, DecayClass::Rust | DecayClass::Mossy);
    if follows_water {
        // Water stands and runs where rust and moss start: at the object's
        // rims and low down, as much as in its crevices (moss: its shade).
        let crevice = mask.standardise(&values);
        values.iter_mut().zip(crevice).zip(mask.wet_places()).for_each(|((v, c), w)| *v = 0.5 * c + w);
    }
    // Where water stands is the stronger pull: that z-score is not halved.
    let gain = if follows_water { 1.0 } else { 0.5 };
    let data =
        mask.standardise(&values).into_iter().zip(mask.bits()).map(|(z, &m)| if m { (gain * z).clamp(-1.0, 1.0) } else { 0.0 }).collect();
    Some(Image::from_data(mask.width(), mask.height(), 1, data).expect("one value per pixel"))
}

/// Algorithm 1: the initial degree map of a `mask`.
///
/// A uniform random pattern on a coarse grid (one cell per `continuity` x
/// the longer side, so a larger continuity gives larger, more continuous
/// blobs; patina gathers the cells' values into regions, see
/// [`clustered`]) is upsampled with cubic interpolation and thresholded at
/// 1 - `area`; the pattern is re-drawn until the covered fraction of the
/// mask is within +/-25% of `area` (after 64 draws the threshold becomes
/// the exact quantile). Covered pixels are filled with Perlin fBm mapped to
/// [0.1, 1]; everything else, and everything outside the mask, is 0.
/// Returns the map and the number of draws it took.
///
/// patina adds two things to the paper's step, because a hard threshold of
/// a cubic upsample gives round blobs with smooth outlines, which showed
/// as stickers in frame 0: the pattern is roughened by fine fBm
/// ([`RAGGED`] of the pattern's range, at a quarter of a cell) before the
/// threshold, and the fill fades in over [`FEATHER`] of the pattern above
/// it, so a blob's degree rises from 0 at its ragged edge and its texels
/// appear there by their onsets, not all at once.
///
/// `affinity` (optional, about -1..1 per pixel, see [`affinity`]) adds
/// [`AFFINITY`] times its blur at a third of a cell to the pattern before
/// the threshold, so blobs start where the material would: moss in shade
/// and recesses, rust in crevices and seams. The area is still met.
pub fn initial(mask: &Mask, area: f32, continuity: f32, affinity: Option<&Image>, seed: u64) -> Result<(Image, u64)> {
    if !(0.0..=1.0).contains(&area) || !area.is_finite() {
        return Err(Error::invalid(format!("--area must be in [0, 1], got {area}")));
    }
    if !(continuity > 0.0 && continuity <= 1.0) {
        return Err(Error::invalid(format!("--continuity must be in (0, 1], got {continuity}")));
    }
    let (w, h) = mask.size();
    let inside = mask.count();
    if inside == 0 {
        return Err(Error::invalid("the mask is empty: nothing can decay"));
    }
    let cell = (continuity * w.max(h) as f32).max(1.0);
    let (gw, gh) = ((w as f32 / cell).ceil() as usize + 1, (h as f32 / cell).ceil() as usize + 1);
    let bias = affinity.map(|a| gaussian_blur(a, cell / 3.0));
    let rough = Layer::new(seed, 0xf2);
    let ragged = Image::from_fn(w, h, 1, |x, y, p| p[0] = RAGGED * rough.fbm(x as f32, y as f32, (0.25 * cell).max(2.0), 3, 0.6));
    let mut draws = 0;
    let pattern = loop {
        draws += 1;
        let mut g = rng::generator(seed, &[0xa1, draws]);
        let cells: Vec<f32> = (0..gw * gh).map(|_| g.gen()).collect();
        let regions: Vec<f32> = (0..CLUSTER_GRID.0 * CLUSTER_GRID.1).map(|_| g.gen()).collect();
        let coarse = Image::from_fn(gw, gh, 1, |x, y, p| {
            p[0] = clustered(cells[y * gw + x], &regions, (x as f32 / gw as f32, y as f32 / gh as f32))
        });
        let mut fine = resize(&coarse, w, h, Filter::Cubic)?;
        if let Some(b) = &bias {
            fine.data_mut().iter_mut().zip(b.data()).for_each(|(v, a)| *v += AFFINITY * a);
        }
        // The ragged edge is part of the pattern the area is measured on.
        fine.data_mut().iter_mut().zip(ragged.data()).for_each(|(v, r)| *v += r);
        let covered = fine.data().iter().zip(mask.bits()).filter(|(&v, &m)| m && v > 1.0 - area).count();
        let fraction = covered as f32 / inside as f32;
        if (fraction - area).abs() <= 0.25 * area || area == 0.0 {
            break (fine, 1.0 - area);
        }
        if draws == MAX_DRAWS {
            let mut values: Vec<f32> = fine.data().iter().zip(mask.bits()).filter(|(_, &m)| m).map(|(&v, _)| v).collect();
            values.sort_by(f32::total_cmp);
            let k = ((1.0 - area) * values.len() as f32) as usize;
            break (fine, values[k.min(values.len() - 1)]);
        }
    };
    let (fine, threshold) = pattern;
    let fill = Layer::new(seed, 0xf1);
    let scale = cell.max(8.0);
    let degree = Image::from_fn(w, h, 1, |x, y, p| {
        let (fx, fy) = (x as f32, y as f32);
        let above = fine.at(x, y, 0) - threshold;
        p[0] = if mask.get(x, y) && above > 0.0 {
            (0.55 + 0.6 * fill.fbm(fx, fy, scale, 5, 0.5)).clamp(0.1, 1.0) * smoothstep(0.0, FEATHER, above)
        } else {
            0.0
        };
    });
    Ok((degree, draws))
}

/// The regions of [`clustered`]: a grid this many cells wide and high
/// over the image, whatever its grid of blobs.
const CLUSTER_GRID: (usize, usize) = (4, 4);

/// A blob cell's pattern value in [0, 1], still uniform over cells, from
/// its own draw `own` and the draws of the coarser `regions` grid
/// ([`CLUSTER_GRID`], bilinear at the cell's place `at` in [0, 1]^2):
/// the mean of the two, mapped back to uniform through the CDF of the mean
/// of two uniforms. Cells in a region drawn high are more often above the
/// threshold, so blobs gather in a few parts of the object and leave
/// others bare. Not in the paper, whose one grid scattered some 40 blobs
/// of one size evenly over a gravestone ("a cow print", a blind reviewer);
/// decay starts in a few places and spreads.
fn clustered(own: f32, regions: &[f32], (u, v): (f32, f32)) -> f32 {
    let (gw, gh) = CLUSTER_GRID;
    let (fx, fy) = (u * (gw - 1) as f32, v * (gh - 1) as f32);
    let (x0, y0) = ((fx as usize).min(gw - 2), (fy as usize).min(gh - 2));
    let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
    let r = |x: usize, y: usize| regions[y * gw + x];
    let top = r(x0, y0) + tx * (r(x0 + 1, y0) - r(x0, y0));
    let bottom = r(x0, y0 + 1) + tx * (r(x0 + 1, y0 + 1) - r(x0, y0 + 1));
    let s = 0.5 * (own + top + ty * (bottom - top));
    if s < 0.5 {
        2.0 * s * s
    } else {
        1.0 - 2.0 * (1.0 - s) * (1.0 - s)
    }
}

/// A user's degree map (a brush painting): the mean of its colour
/// channels (its grey for a grey painting), 0 outside the mask.
pub fn from_painting(painting: &Image, mask: &Mask) -> Result<Image> {
    if painting.size() != mask.size() {
        let ((a, b), (c, d)) = (painting.size(), mask.size());
        return Err(Error::invalid(format!("the degree map is {a}x{b} but the photo is {c}x{d}")));
    }
    let grey = channel_mean(painting);
    Ok(Image::from_fn(mask.width(), mask.height(), 1, |x, y, p| {
        p[0] = if mask.get(x, y) { grey.at(x, y, 0).clamp(0.0, 1.0) } else { 0.0 };
    }))
}

/// The mean of the first (up to) three channels of a painted map: its
/// grey value, whatever its channel layout.
pub fn channel_mean(painting: &Image) -> Image {
    let n = painting.channels().min(3);
    Image::from_fn(painting.width(), painting.height(), 1, |x, y, p| p[0] = painting.pixel(x, y)[..n].iter().sum::<f32>() / n as f32)
}

/// Parameters of decay diffusion (section III-C4).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Diffusion {
    /// Diffusion length per frame, as a fraction of the longer image side:
    /// the heat equation (eq. 4) runs for time sigma^2 / (2 alpha) per
    /// frame, a Gaussian of that sigma ([`Diffuser`]).
    pub spread: f32,
    /// Upper bound of the self-growth Z ~ U(0, growth) added per frame
    /// where D > 0.25 (eq. 6).
    pub growth: f32,
}

impl Default for Diffusion {
    fn default() -> Self {
        Diffusion { spread: 0.015, growth: 0.15 }
    }
}

/// Decay diffusion (eqs. 4-7), one frame per [`Diffuser::step`], in place.
///
/// Eq. 4, dD/dt = alpha Lap D, run for one frame's time T on the plane is
/// exactly a Gaussian blur with sigma^2 = 2 alpha T, where sigma =
/// `spread` x the longer side. Inside the mask it is solved as a
/// normalised convolution, G*(D M) / G*M. Decay neither leaks out of the
/// mask nor drains at its edge (the Neumann borders of the finite-difference
/// scheme this replaces).
///
/// A rate r(x) (the user's regularisation map, 1 = normal speed, up to 2)
/// runs the heat equation for r T. That is interpolated per pixel between
/// D (r = 0), the sigma blur (r = 1) and the sigma sqrt(2) blur (r = 2).
///
/// Then comes self-growth, D += r(x) Z with Z ~ U(0, growth) where
/// D > 0.25. Last, D = max(D_new, D_old), so decay never retreats.
///
/// Simplification: the normalised convolution carries decay across a
/// background gap narrower than about sigma between two parts of the mask,
/// which exact Neumann diffusion would not. In exchange, the cost is that
/// of two wide blurs ([`gaussian_blur`] on a shrunken copy), linear in the
/// pixel count (the mask's own blurs, the denominators, are made once per
/// sequence). The explicit scheme needed (sigma^2 / 0.5) steps of the
/// whole image, growing with the 4th power of the side: 86 s per frame at
/// 2048 px.
pub struct Diffuser<'a> {
    mask: &'a Mask,
    rate: Option<&'a Image>,
    params: Diffusion,
    sigma: f32,
    /// G_sigma * M and, when some rate exceeds 1, G_(sigma sqrt 2) * M:
    /// the normalised convolution's denominators, the same every frame.
    normalisers: (Vec<f32>, Option<Vec<f32>>),
}

impl<'a> Diffuser<'a> {
    /// The diffusion of one sequence over `mask`, with the optional rate map.
    pub fn new(mask: &'a Mask, rate: Option<&'a Image>, params: &Diffusion) -> Self {
        let (w, h) = mask.size();
        let sigma = params.spread * w.max(h) as f32;
        let bits = mask.bits();
        let inside = Image::from_fn(w, h, 1, |x, y, p| p[0] = f32::from(u8::from(bits[y * w + x])));
        let blur = |s: f32| gaussian_blur(&inside, s).data().to_vec();
        let faster = (0..w * h).any(|i| bits[i] && rate.map_or(1.0, |r| r.data()[i]) > 1.0);
        let normalisers =
            if sigma > 0.0 { (blur(sigma), faster.then(|| blur(sigma * std::f32::consts::SQRT_2))) } else { (Vec::new(), None) };
        Diffuser { mask, rate, params: *params, sigma, normalisers }
    }

    /// One frame of diffusion and growth of `degree` (see the type's doc).
    pub fn step(&self, degree: &mut Image, seed: u64, frame: u64) {
        let (mask, rate, params, sigma) = (self.mask, self.rate, &self.params, self.sigma);
        let (w, h) = mask.size();
        let old = degree.clone();
        let bits = mask.bits();
        let rate_at = |i: usize| rate.map_or(1.0, |r| r.data()[i]);
        if sigma > 0.0 {
            let masked = Image::from_fn(w, h, 1, |x, y, p| p[0] = if bits[y * w + x] { old.at(x, y, 0) } else { 0.0 });
            let diffused = |s: f32, den: &[f32]| -> Vec<f32> {
                let num = gaussian_blur(&masked, s);
                num.data().iter().zip(den).map(|(a, b)| if *b > 1e-6 { a / b } else { 0.0 }).collect()
            };
            let once = diffused(sigma, &self.normalisers.0);
            let twice = self.normalisers.1.as_ref().map(|den| diffused(sigma * std::f32::consts::SQRT_2, den));
            degree.data_mut().par_iter_mut().enumerate().filter(|(i, _)| bits[*i]).for_each(|(i, d)| {
                let r = rate_at(i).clamp(0.0, 2.0);
                *d = match &twice {
                    Some(t) if r > 1.0 => once[i] + (r - 1.0) * (t[i] - once[i]),
                    _ => *d + r * (once[i] - *d),
                };
            });
        }
        degree.data_mut().par_chunks_mut(w).zip(old.data().par_chunks(w)).enumerate().for_each(|(y, (row, before))| {
            let mut g = rng::generator(seed, &[0x96, frame, y as u64]);
            for (x, (d, &b)) in row.iter_mut().zip(before).enumerate() {
                let z: f32 = g.gen::<f32>() * params.growth;
                if !bits[y * w + x] {
                    continue;
                }
                if *d > GROWTH_THRESHOLD {
                    *d += rate_at(y * w + x) * z;
                }
                *d = d.clamp(0.0, 1.0).max(b);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(w: usize, h: usize) -> Mask {
        Mask::from_fn(w, h, |x, y| (x as f32 - 40.0).powi(2) + (y as f32 - 30.0).powi(2) < 900.0)
    }

    #[test]
    fn initial_map_covers_about_the_area_asked_inside_the_mask_only() {
        let mask = disc(80, 60);
        for seed in 0..5 {
            let (d, _) = initial(&mask, 0.25, 0.1, None, seed).unwrap();
            let covered = d.data().iter().filter(|&&v| v > 0.0).count() as f32 / mask.count() as f32;
            assert!((covered - 0.25).abs() <= 0.25 * 0.25 + 1e-6, "seed {seed}: covered {covered}");
            for (v, m) in d.data().iter().zip(mask.bits()) {
                assert!((0.0..=1.0).contains(v));
                assert!(*m || *v == 0.0);
            }
        }
    }

    /// The finite-difference heat equation with Neumann borders at the
    /// mask's edge, run for time sigma^2 / 2: the reference [`Diffuser::step`]'s
    /// normalised convolution stands in for.
    fn explicit_heat(d: &Image, mask: &Mask, sigma: f32) -> Image {
        let (w, h) = mask.size();
        let dt = 0.24f32;
        let steps = (sigma * sigma / (2.0 * dt)).ceil() as usize;
        let bits = mask.bits();
        let mut cur = d.clone();
        for _ in 0..steps {
            let prev = cur.clone();
            let c = prev.data();
            for y in 0..h {
                for x in 0..w {
                    let i = y * w + x;
                    if !bits[i] {
                        continue;
                    }
                    let nb = |ok: bool, j: usize| if ok && bits[j] { c[j] } else { c[i] };
                    let lap = nb(x > 0, i.wrapping_sub(1)) + nb(x + 1 < w, i + 1) + nb(y > 0, i.wrapping_sub(w)) + nb(y + 1 < h, i + w)
                        - 4.0 * c[i];
                    cur.data_mut()[i] = c[i] + dt * lap;
                }
            }
        }
        cur
    }

    #[test]
    fn diffusion_matches_the_heat_equation_inside_the_mask() {
        // Spots of decay in a disc; one frame of diffusion without growth
        // against the explicit finite-difference solution (measured: the
        // mean error is under 5% of the mean change).
        let mask = disc(80, 60);
        let (d0, _) = initial(&mask, 0.2, 0.15, None, 4).unwrap();
        let params = Diffusion { spread: 0.06, growth: 0.0 };
        let mut d = d0.clone();
        Diffuser::new(&mask, None, &params).step(&mut d, 1, 1);
        let want = explicit_heat(&d0, &mask, 0.06 * 80.0);
        let (mut err, mut spread, mut n) = (0f32, 0f32, 0f32);
        for (i, &inside) in mask.bits().iter().enumerate() {
            if inside {
                // `step` keeps the max with the old map; so does the reference.
                let r = want.data()[i].max(d0.data()[i]);
                err += (d.data()[i] - r).abs();
                spread += (r - d0.data()[i]).abs();
                n += 1.0;
            }
        }
        assert!(err / n < 0.1 * spread / n, "mean error {} vs mean change {}", err / n, spread / n);
    }

    #[test]
    fn diffusion_spreads_decay_without_leaving_the_mask_or_retreating() {
        let mask = disc(80, 60);
        let (mut d, _) = initial(&mask, 0.2, 0.15, None, 3).unwrap();
        let before = d.clone();
        Diffuser::new(&mask, None, &Diffusion::default()).step(&mut d, 3, 0);
        let count = |img: &Image| img.data().iter().filter(|&&v| v > 0.0).count();
        assert!(count(&d) > count(&before));
        for ((a, b), m) in d.data().iter().zip(before.data()).zip(mask.bits()) {
            assert!(a >= b);
            assert!(*m || *a == 0.0);
        }
    }
}
