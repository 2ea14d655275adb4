//! Smoothing by patch updating (Xue et al. 2011, section 3.2): each patch
//! borrows the gradients of a calmer patch of the same shape (eq. 1 picks
//! it, eq. 2 blends them over time) and the image is re-integrated from
//! the blend, one screened Poisson problem for the whole image.

use super::segment::Patch;
use super::{bounds, set_pixels};
use crate::image::filter::equalize;
use crate::image::order::median;
use crate::image::{Image, Mask};
use crate::synth::poisson;
use rayon::prelude::*;

/// Cost weights of eq. (1).
#[derive(Clone, Copy, Debug)]
pub struct MatchParams {
    /// w_d: weight of the candidate's mean tendency.
    pub wd: f32,
    /// Pixels of a patch sampled at the coarse search levels (all pixels at
    /// the finest); keeps the whole-image search O(patches x candidates x this).
    pub coarse_samples: usize,
}

impl Default for MatchParams {
    fn default() -> Self {
        MatchParams { wd: 1.0, coarse_samples: 64 }
    }
}

/// Per-pixel data the search reads.
pub struct SearchMaps<'a> {
    pub intensity: &'a Image,
    pub tendency: &'a Image,
    pub mask: &'a Mask,
}

/// Eq. (1) for the patch shifted by (dx, dy), on the pixel subset `pixels`:
/// V = |mean I(p) - mean I(p0)| + |N(p) - N(p0)| / N(p0) + w_d mean d(p),
/// where N(p) counts the shifted pixels that land on the object.
fn cost(maps: &SearchMaps, pixels: &[u32], mean_i0: f32, (dx, dy): (isize, isize), wd: f32) -> f32 {
    let (w, h) = maps.mask.size();
    let (mut n, mut si, mut sd) = (0usize, 0f32, 0f32);
    for &p in pixels {
        let (x, y) = ((p as usize % w) as isize + dx, (p as usize / w) as isize + dy);
        if x < 0 || y < 0 || x >= w as isize || y >= h as isize || !maps.mask.get(x as usize, y as usize) {
            continue;
        }
        n += 1;
        si += maps.intensity.at(x as usize, y as usize, 0);
        sd += maps.tendency.at(x as usize, y as usize, 0);
    }
    if n == 0 {
        return f32::INFINITY;
    }
    let n0 = pixels.len() as f32;
    (si / n as f32 - mean_i0).abs() + (n as f32 - n0).abs() / n0 + wd * sd / n as f32
}

/// The offset (c1 - c0) of each patch's best match under eq. (1).
///
/// The paper's hierarchical search: candidates on a grid of interval 2^xi
/// over the object's bounding box (2^xi ~ sqrt(N) / 64, so about 4096
/// candidates), then the interval halves and the 3 x 3 candidates around the
/// best are tried, down to 1 px. Coarse levels score a regular subset of the
/// patch's pixels; the final 1 px level scores all of them.
pub fn best_offsets(patches: &[Patch], maps: &SearchMaps, params: &MatchParams) -> Vec<(isize, isize)> {
    let (w, _) = maps.mask.size();
    let object = maps.mask.count().max(1);
    let Some((bx0, by0, bx1, by1)) = bounds(set_pixels(maps.mask), w) else {
        return vec![(0, 0); patches.len()];
    };
    let top = ((object as f32).sqrt() / 64.0).log2().floor().max(0.0) as u32;
    patches
        .par_iter()
        .map(|patch| {
            let step = patch.pixels.len().div_ceil(params.coarse_samples.max(1));
            let coarse: Vec<u32> = patch.pixels.iter().step_by(step).copied().collect();
            let mean_of = |px: &[u32]| px.iter().map(|&p| maps.intensity.data()[p as usize]).sum::<f32>() / px.len() as f32;
            let (mean_all, mean_coarse) = (mean_of(&patch.pixels), mean_of(&coarse));
            let (cx, cy) = (patch.centroid.0.round() as isize, patch.centroid.1.round() as isize);
            let mut interval = 1isize << top;
            let mut best = ((0isize, 0isize), cost(maps, &coarse, mean_coarse, (0, 0), params.wd));
            let mut y = by0 as isize;
            while y <= by1 as isize {
                let mut x = bx0 as isize;
                while x <= bx1 as isize {
                    let off = (x - cx, y - cy);
                    let c = cost(maps, &coarse, mean_coarse, off, params.wd);
                    if c < best.1 {
                        best = (off, c);
                    }
                    x += interval;
                }
                y += interval;
            }
            while interval > 1 {
                interval /= 2;
                let (pixels, mean) = if interval == 1 { (&patch.pixels[..], mean_all) } else { (&coarse[..], mean_coarse) };
                let centre = best.0;
                best = (centre, cost(maps, pixels, mean, centre, params.wd));
                for (ky, kx) in (-1..=1).flat_map(|a| (-1..=1).map(move |b| (a, b))) {
                    let off = (centre.0 + kx * interval, centre.1 + ky * interval);
                    let c = cost(maps, pixels, mean, off, params.wd);
                    if c < best.1 {
                        best = (off, c);
                    }
                }
            }
            best.0
        })
        .collect()
}

/// What the update borrows from the photo, the same at every t: each
/// pixel's match offset (its patch's, from eq. 1), the finest band's local
/// amplitude and the stone's grain level ([`GrainLevels`]), the local mean
/// tendency the weights come from, and the patch scale.
pub struct Borrowing {
    offset: Vec<(isize, isize)>,
    grain: GrainLevels,
    local_tendency: Image,
    scale: f32,
}

impl Borrowing {
    /// For `patches` and their `offsets` over `object`; `fine` is the
    /// finest band, `scale` the patch size.
    pub fn new(tendency: &Image, fine: &Image, object: &Mask, (patches, offsets): (&[Patch], &[(isize, isize)]), scale: f32) -> Self {
        let mut offset = vec![(0isize, 0isize); object.width() * object.height()];
        for (patch, &off) in patches.iter().zip(offsets) {
            patch.pixels.iter().for_each(|&p| offset[p as usize] = off);
        }
        let sigma = (scale / 2.0).max(1.0);
        let local_tendency = local_mean(tendency, &object.to_image(), sigma, 0.0);
        Borrowing { offset, grain: GrainLevels::new(fine, patches, scale), local_tendency, scale }
    }

    /// Per pixel, how sharp the photo's grain is there: the grain level over
    /// the object's typical one, at most 1 (0 off the object). Low where the
    /// photo is out of focus (a statue's far side), whose grain is blurred:
    /// roughening and pits are scaled by it, so they do not sprinkle
    /// pixel-sharp speckle over a soft part of the photo.
    pub fn sharpness(&self) -> Image {
        let typical = self.grain.typical.max(1e-6);
        self.grain.level.map(|v| (v / typical).clamp(0.0, 1.0))
    }

    /// Per-pixel weights of eq. (2), w = exp(-k d_p t), chipped by
    /// `chips` ([`chips`]), 1 off `object`.
    ///
    /// Departures:
    /// - The paper's d_p is the mean tendency of the patch p0 the pixel
    ///   belongs to. Where the tendency is even (granite, a lettered slab),
    ///   the segmentation's oversized regions are bisected into rectangles,
    ///   and per-patch weights wore them to different depths: a visible
    ///   lattice of blocks. Here d_p is the tendency's mean over a Gaussian
    ///   of half the patch size around the pixel (normalized over the
    ///   object): the same local average, without patch outlines.
    /// - Stone does not wear evenly: grains and flakes come away in pieces,
    ///   so a worn edge is broken, not defocused. A smooth w faded every
    ///   carved edge by the same share and read as blur (on a granite
    ///   slab, raised letters turned into soft dark ghosts). Here w is a
    ///   share of area instead: a pixel is worn (weight 0) where the chip
    ///   field u(x) ([`chips`], uniform) exceeds w, kept (1) where it is
    ///   below, with a ramp of [`CHIP_SOFTNESS`] between; so about 1 - w
    ///   of any neighbourhood is worn, and what is left keeps its sharp
    ///   edges. The map is then softened by [`WEIGHT_SIGMA`].
    pub fn weights(&self, object: &Mask, (k, t): (f32, f32), chips: &Image) -> Image {
        let (w, h) = object.size();
        let map = Image::from_fn(w, h, 1, |x, y, p| {
            p[0] = if object.get(x, y) {
                let d = EXPOSURE + (1.0 - EXPOSURE) * self.local_tendency.at(x, y, 0);
                let wt = (-k * d * t).exp();
                ((wt - chips.at(x, y, 0)) / CHIP_SOFTNESS + 0.5).clamp(0.0, 1.0)
            } else {
                1.0
            }
        });
        // Snap the blur's rounding back to 1: sqrt(1 - w^2) would turn a
        // 1e-7 shortfall into a 5e-4 share of borrowed texture.
        crate::image::filter::gaussian_blur(&map, WEIGHT_SIGMA).map(|v| if v > 1.0 - 1e-5 { 1.0 } else { v })
    }
}

/// The share of the busiest stone's wear rate that every pixel of the
/// object wears at, whatever its tendency: d_p in eq. (2) is
/// EXPOSURE + (1 - EXPOSURE) d. Not in the paper, whose calm stone
/// (d near 0) never wears: the Buddhas' faces, brows and eyelids stayed
/// as carved at t = 200 beside hair worn smooth, a visible border at the
/// hairline (two blind reviews). Weather reaches every exposed surface.
pub const EXPOSURE: f32 = 0.25;

/// Width of the ramp between kept and worn stone, in units of w.
pub const CHIP_SOFTNESS: f32 = 0.2;
/// Wavelength (px) of the largest chips.
pub const CHIP_SCALE: f32 = 8.0;

/// The chip field of [`Borrowing::weights`]: fractal (fBm) noise of
/// wavelength [`CHIP_SCALE`] px and three finer octaves, made uniform by
/// rank ([`equalize`]) and mapped to [s/2, 1 - s/2] (s = [`CHIP_SOFTNESS`]),
/// so that a threshold at w wears about 1 - w of the pixels, none at w = 1
/// and all at w = 0.
pub fn chips(w: usize, h: usize, seed: u64) -> Image {
    let layer = crate::image::noise::Layer::new(seed ^ 0x57_0e, 3);
    let raw = Image::from_fn(w, h, 1, |x, y, p| p[0] = layer.fbm(x as f32, y as f32, CHIP_SCALE, 4, 0.6));
    equalize(&raw).map(|u| 0.5 * CHIP_SOFTNESS + (1.0 - CHIP_SOFTNESS) * u)
}

/// The mean of `values` over a Gaussian of `sigma` around each pixel,
/// counting only the pixels where `inside` is 1 (a normalised
/// convolution); `fallback` where no such pixel is near.
fn local_mean(values: &Image, inside: &Image, sigma: f32, fallback: f32) -> Image {
    let (num, den) = crate::image::filter::weighted_blur(values, inside, sigma);
    Image::from_fn(values.width(), values.height(), 1, |x, y, p| {
        p[0] = if den.at(x, y, 0) > 1e-6 { num.at(x, y, 0) / den.at(x, y, 0) } else { fallback }
    })
}

/// Blur of the weight map (px).
pub const WEIGHT_SIGMA: f32 = 2.0;

/// Eq. (2) and the Poisson solve for the photo split as `(base, fine)`
/// (relief, and its finest band: grain and the sharpest carved edges),
/// with the weights w of [`Borrowing::weights`]: every object gradient of
/// the relief becomes the blend
/// grad B_t(x) = w grad B_0(x) + sqrt(1 - w^2) grad B_0(x + c1 - c0)
/// of its own and its patch's match (eq. 1's offset; where the shifted
/// pixels are off `sources`, the object proper without its rim, its own is
/// kept) on every edge inside `object`, and the relief is integrated from
/// it; the finest band F keeps its grain and loses what stands above it
/// as w ([`GrainLevels`]). Returns B_t + F_t.
///
/// Departures from the paper, as issue 19 allows:
/// - The paper re-solves each patch on its own with its border fixed to
///   I_0, which leaves every patch outline at full relief, a lattice of
///   bright blotches once oversized segments are bisected. Here one
///   screened Poisson problem covers the whole image
///   ([`poisson::Solver`]): the blended gradients are followed at scales
///   up to the patch size `scale` (lambda = 1 / scale^2), and larger scales
///   (the object's form and lighting) stay anchored to I_0.
/// - Eq. (2) blends with w and 1 - w. The stone texture of p0 and of its
///   calm match p1 is uncorrelated, so that blend loses up to half of its
///   energy and reads as blur: pecked sandstone wore as smooth as concrete
///   and granite lost its speckle. With w and sqrt(1 - w^2) the texture
///   keeps its energy, now borrowed from calm stone, while a carved edge
///   (in p0 only) still fades as w. The form below the patch scale is
///   in both and could gain up to sqrt 2 where 0 < w < 1, but the chipped
///   weights are 0 or 1 almost everywhere.
/// - The finest band is not borrowed, nor integrated (a least-squares
///   solve of borrowed grain smeared it into swirls): it is worn pixel by
///   pixel where it stands above the stone's grain ([`GrainLevels`]).
///
/// w = 1 (t = 0) reproduces the input exactly.
pub fn update((base, fine): (&Image, &Image), weights: &Image, (object, sources): (&Mask, &Mask), borrowing: &Borrowing) -> Image {
    let (w, h, c) = (base.width(), base.height(), base.channels());
    let offset = &borrowing.offset;
    let lambda = 1.0 / borrowing.scale.max(1.0).powi(2);
    let inside = |x: isize, y: isize| x >= 0 && y >= 0 && x < w as isize && y < h as isize && sources.get(x as usize, y as usize);
    let mut out = Image::from_fn(w, h, c, |x, y, p| {
        p.iter_mut().zip(base.pixel(x, y).iter().zip(fine.pixel(x, y))).for_each(|(o, (b, f))| *o = b + f)
    });
    let mut solver = poisson::Solver::new(w, h);
    for ch in 0..c {
        // The mismatch on each edge: the blended gradient minus the own one.
        let mismatch = |horizontal: bool| -> Vec<f32> {
            let mut m = vec![0f32; w * h];
            m.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                for (x, out) in row.iter_mut().enumerate() {
                    let (qx, qy) = if horizontal { (x + 1, y) } else { (x, y + 1) };
                    if qx >= w || qy >= h || !object.get(x, y) || !object.get(qx, qy) {
                        continue;
                    }
                    let (dx, dy) = offset[y * w + x];
                    let (sx, sy, tx, ty) = (x as isize + dx, y as isize + dy, qx as isize + dx, qy as isize + dy);
                    if !inside(sx, sy) || !inside(tx, ty) {
                        continue;
                    }
                    let (sx, sy, tx, ty) = (sx as usize, sy as usize, tx as usize, ty as usize);
                    let own = base.at(qx, qy, ch) - base.at(x, y, ch);
                    let borrowed = base.at(tx, ty, ch) - base.at(sx, sy, ch);
                    let wt = 0.5 * (weights.at(x, y, 0) + weights.at(qx, qy, 0));
                    *out = (wt - 1.0) * own + borrowed_share(wt) * borrowed;
                }
            });
            m
        };
        let d = solver.integrate(&mismatch(true), &mismatch(false), lambda);
        for (v, dv) in out.data_mut().iter_mut().skip(ch).step_by(c).zip(d) {
            *v += dv;
        }
    }
    // The finest band: what stands above the stone's grain wears.
    let grain = &borrowing.grain;
    out.data_mut().par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            if !object.get(x, y) {
                continue;
            }
            let kept = grain.kept(x, y, weights.at(x, y, 0));
            if kept < 1.0 {
                row[x * c..(x + 1) * c].iter_mut().zip(fine.pixel(x, y)).for_each(|(o, v)| *o += (kept - 1.0) * v);
            }
        }
    });
    out
}

/// The energy-preserving partner of weight w: sqrt(1 - w^2), so that own
/// and borrowed uncorrelated texture blended as w and this keep their
/// energy (see [`update`]).
fn borrowed_share(w: f32) -> f32 {
    (1.0 - w * w).max(0.0).sqrt()
}

/// Multiple of the stone's grain level above which the finest band counts
/// as carved edge and wears ([`GrainLevels`]).
pub const GRAIN_THRESHOLD: f32 = 1.5;

/// Scale (px) over which the finest band's amplitude is measured.
pub const AMPLITUDE_SIGMA: f32 = 1.0;

/// The finest band split into grain, which stays, and carved edges, which
/// wear, by amplitude: a carved edge stands well above the stone's grain.
///
/// The amplitude a(x) is the finest band's RMS over its channels, averaged
/// (as energy) over a Gaussian of [`AMPLITUDE_SIGMA`]: an edge is a run of
/// strong pixels and keeps its level, a lone strong grain is diluted by its
/// neighbours. Measured per pixel, the clip cut every edge into a dotted
/// line of pixels above and below it (salt-and-pepper rings around the
/// Buddha's curls). The grain level g(x) is each patch's median of a, at
/// most the object's typical level (the median over its patches: in the
/// busy hair, where carved edges are most of every patch, a patch's own
/// median kept the curls at t = 200), averaged over a Gaussian of half the
/// patch size so that no patch outline shows; the median is robust to the
/// carved edges a patch holds.
/// With tau = [`GRAIN_THRESHOLD`] g, a pixel at weight w keeps
/// (tau + w (a - tau)) / a of its finest band where a > tau, all of it
/// elsewhere: the grain stays at full strength (the issue's "stone grain
/// stays"), and what stands above it fades with w like the relief.
///
/// Replaces the grain borrowing of earlier versions (w F(x) +
/// sqrt(1 - w^2) g F(x + c1 - c0)): eq. (1)'s calm matches are calm because
/// their grain is weak (a quarter of the busy stone's on the Buddhas and the
/// globe), so borrowed grain left a sandblasted surface, or a white frost
/// where its gain was raised. In a blind review of the five photos the
/// amplitude split was preferred on four (not on the slate, whose faint
/// letters are close to its grain and wear less).
struct GrainLevels {
    amplitude: Image,
    level: Image,
    /// The object's typical level: the median over its patches.
    typical: f32,
}

impl GrainLevels {
    fn new(fine: &Image, patches: &[Patch], scale: f32) -> Self {
        let (w, h, c) = (fine.width(), fine.height(), fine.channels());
        let energy = Image::from_fn(w, h, 1, |x, y, p| p[0] = fine.pixel(x, y).iter().map(|v| v * v).sum::<f32>() / c as f32);
        let amplitude = crate::image::filter::gaussian_blur(&energy, AMPLITUDE_SIGMA).map(|v| v.max(0.0).sqrt());
        let levels: Vec<f32> = patches
            .par_iter()
            .map(|patch| median(&mut patch.pixels.iter().map(|&p| amplitude.data()[p as usize]).collect::<Vec<f32>>()).unwrap_or(0.0))
            .collect();
        let typical = median(&mut levels.clone()).unwrap_or(0.0);
        let mut map = Image::new(w, h, 1);
        let mut weight = Image::new(w, h, 1);
        for (patch, &level) in patches.iter().zip(&levels) {
            for &p in &patch.pixels {
                map.data_mut()[p as usize] = level.min(typical);
                weight.data_mut()[p as usize] = 1.0;
            }
        }
        GrainLevels { amplitude, level: local_mean(&map, &weight, (scale / 2.0).max(1.0), 0.0), typical }
    }

    /// The share of the finest band a pixel at weight `wt` keeps.
    fn kept(&self, x: usize, y: usize, wt: f32) -> f32 {
        let (a, tau) = (self.amplitude.at(x, y, 0), GRAIN_THRESHOLD * self.level.at(x, y, 0));
        if a <= tau {
            1.0
        } else {
            (tau + wt * (a - tau)) / a
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::filter::gaussian_blur;
    use crate::stone::segment::{segment, SegmentParams};

    /// A lit ramp (the form) with fine bumps on the right half (the carving)
    /// and a calm left half; every patch borrows from 48 px to its left.
    fn relief() -> (Image, Image, Mask, Vec<Patch>, Vec<(isize, isize)>) {
        let (w, h) = (96, 64);
        let img = Image::from_fn(w, h, 1, |x, y, p| {
            let bumps = if x >= 48 { 0.15 * ((x as f32 * 0.9).sin() * (y as f32 * 0.8).cos()) } else { 0.0 };
            p[0] = 0.3 + 0.4 * y as f32 / h as f32 + bumps;
        });
        let d = Image::from_fn(w, h, 1, |x, _, p| p[0] = if x >= 48 { 1.0 } else { 0.1 });
        let mask = Mask::filled(w, h, true);
        let patches = segment(&d, &mask, &SegmentParams { n: 24.0, ..Default::default() });
        let offsets = patches.iter().map(|p| if p.centroid.0 >= 48.0 { (-48isize, 0isize) } else { (0, 0) }).collect();
        (img, d, mask, patches, offsets)
    }

    /// Hashed noise, uniform in [-1/2, 1/2).
    fn noise(seed: u64, x: usize, y: usize) -> f32 {
        (crate::rng::derive(seed, &[x as u64, y as u64]) >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    }

    /// The mean of a one-channel image over columns `xs` and rows 8..56.
    fn column_mean(img: &Image, xs: std::ops::Range<usize>) -> f32 {
        let n = xs.len() * 48;
        xs.flat_map(|x| (8..56).map(move |y| (x, y))).map(|(x, y)| img.at(x, y, 0)).sum::<f32>() / n as f32
    }

    #[test]
    fn weight_one_reproduces_the_input() {
        let (img, d, mask, patches, offsets) = relief();
        // t = 0 gives w = 1 for every patch.
        let zero = img.map(|_| 0.0);
        let borrowing = Borrowing::new(&d, &zero, &mask, (&patches, &offsets), 12.0);
        let out = update((&img, &zero), &borrowing.weights(&mask, (0.01, 0.0), &chips(96, 64, 1)), (&mask, &mask), &borrowing);
        let err = img.data().iter().zip(out.data()).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
        assert!(err <= 1e-5, "max error {err}");
    }

    /// Half-worn carving (mean weight 1/2) is worn in pieces: what is left
    /// keeps its full relief and the rest is gone, instead of every bump
    /// fading to half (which reads as a defocused photo).
    #[test]
    fn carving_wears_away_in_pieces_not_as_an_even_fade() {
        let (img, d, mask, patches, offsets) = relief();
        let zero = img.map(|_| 0.0);
        let borrowing = Borrowing::new(&d, &zero, &mask, (&patches, &offsets), 12.0);
        // d = 1 on the right half: w = exp(-0.01 t) = 1/2.
        let t = 2f32.ln() / 0.01;
        let out = update((&img, &zero), &borrowing.weights(&mask, (0.01, t), &chips(96, 64, 5)), (&mask, &mask), &borrowing);
        // The bumps' share left in each 4 x 4 block of the carved half,
        // by regression of the worn image's detail on the input's.
        let detail = |im: &Image| {
            let s = gaussian_blur(im, 4.0);
            Image::from_fn(96, 64, 1, |x, y, p| p[0] = im.at(x, y, 0) - s.at(x, y, 0))
        };
        let (a, b) = (detail(&img), detail(&out));
        let mut left = Vec::new();
        for by in (8..56).step_by(4) {
            for bx in (60..92).step_by(4) {
                let (mut cov, mut var) = (0f32, 0f32);
                for (x, y) in (by..by + 4).flat_map(|y| (bx..bx + 4).map(move |x| (x, y))) {
                    cov += a.at(x, y, 0) * b.at(x, y, 0);
                    var += a.at(x, y, 0).powi(2);
                }
                left.push(cov / var.max(1e-9));
            }
        }
        let share = |f: &dyn Fn(f32) -> bool| left.iter().filter(|&&v| f(v)).count() as f32 / left.len() as f32;
        let (kept, gone, half) = (share(&|v| v > 0.75), share(&|v| v < 0.25), share(&|v| (0.35..0.65).contains(&v)));
        // An even fade puts every block near 1/2 (kept 0, gone 0, half 1).
        assert!(kept > 0.1 && gone > 0.05, "kept {kept:.2}, gone {gone:.2} of {} blocks", left.len());
        assert!(half < 0.7, "{half:.2} of the blocks faded to about half");
        eprintln!("kept {kept:.2}, gone {gone:.2}, about half {half:.2}");
    }

    #[test]
    fn borrowing_calm_gradients_wears_the_carving_and_keeps_the_form() {
        let (img, d, mask, patches, offsets) = relief();
        let zero = img.map(|_| 0.0);
        let borrowing = Borrowing::new(&d, &zero, &mask, (&patches, &offsets), 12.0);
        let out = update((&img, &zero), &borrowing.weights(&mask, (0.01, 400.0), &chips(96, 64, 1)), (&mask, &mask), &borrowing);
        let band = |im: &Image, x0: usize| {
            let smooth = gaussian_blur(im, 3.0);
            (8..56)
                .flat_map(|y| (x0..x0 + 32).map(move |x| (x, y)))
                .map(|(x, y)| (im.at(x, y, 0) - smooth.at(x, y, 0)).powi(2))
                .sum::<f32>()
        };
        // exp(-4) of the bumps' gradient is left: their energy nearly goes.
        assert!(band(&out, 56) < 0.05 * band(&img, 56), "carving {} -> {}", band(&img, 56), band(&out, 56));
        // The form (the ramp, seen through a wide blur) stays.
        let (a, b) = (gaussian_blur(&img, 16.0), gaussian_blur(&out, 16.0));
        let worst = (0..96 * 64).map(|i| (a.data()[i] - b.data()[i]).abs()).fold(0f32, f32::max);
        assert!(worst < 0.02, "form changed by {worst}");
    }

    /// Stone with strong grain whose calm match (eq. 1 picks calm stone
    /// because its grain is weak) has a quarter of it, and a carved line:
    /// worn, the stone keeps its own grain and loses the line's edges.
    #[test]
    fn worn_stone_keeps_its_own_grain_and_loses_its_carved_edges() {
        let (w, h) = (96, 64);
        let img = Image::from_fn(w, h, 3, |x, y, p| {
            let grain = if x >= 48 { 0.16 } else { 0.04 } * noise(7, x, y);
            let line = if (72..74).contains(&x) { -0.4 } else { 0.0 };
            p.fill(0.5 + grain + line);
        });
        let base = gaussian_blur(&img, crate::stone::GRAIN_SIGMA);
        let fine = Image::from_fn(w, h, 3, |x, y, p| {
            p.iter_mut().zip(img.pixel(x, y).iter().zip(base.pixel(x, y))).for_each(|(o, (a, b))| *o = a - b)
        });
        let d = Image::from_fn(w, h, 1, |x, _, p| p[0] = if x >= 48 { 1.0 } else { 0.1 });
        let mask = Mask::filled(w, h, true);
        let patches = segment(&d, &mask, &SegmentParams { n: 24.0, ..Default::default() });
        let offsets: Vec<_> = patches.iter().map(|p| if p.centroid.0 >= 48.0 { (-48isize, 0isize) } else { (0, 0) }).collect();
        let borrowing = Borrowing::new(&d, &fine, &mask, (&patches, &offsets), 12.0);
        let weights = borrowing.weights(&mask, (0.01, 400.0), &chips(w, h, 2));
        let out = update((&base, &fine), &weights, (&mask, &mask), &borrowing);
        // The finest band's energy (luminance minus a 1 px Gaussian) over
        // the given columns of the worn half, output over input.
        let energy = |im: &Image, xs: std::ops::Range<usize>| {
            let s = gaussian_blur(im, 1.0);
            let xs2 = xs.clone();
            (8..56).flat_map(|y| xs2.clone().map(move |x| (x, y))).map(|(x, y)| (im.at(x, y, 0) - s.at(x, y, 0)).powi(2)).sum::<f32>()
                / (xs.len() * 48) as f32
        };
        let grain = energy(&out, 54..68) / energy(&img, 54..68);
        let edges = energy(&out, 70..76) / energy(&img, 70..76);
        assert!(grain > 0.8, "the grain kept {grain:.2} of its energy");
        assert!(edges < 0.6, "the carved line's edges kept {edges:.2} of theirs");
        eprintln!("grain kept {grain:.2}, line edges kept {edges:.2}");
    }

    /// Calm stone (d = 0) wears too, at [`EXPOSURE`] of the busiest
    /// stone's rate, and never faster than busy stone.
    #[test]
    fn calm_stone_wears_at_the_exposure_rate() {
        let (img, d, mask, patches, offsets) = relief();
        let borrowing = Borrowing::new(&d.map(|v| if v < 0.5 { 0.0 } else { v }), &img.map(|_| 0.0), &mask, (&patches, &offsets), 12.0);
        let weights = borrowing.weights(&mask, (0.01, 200.0), &chips(96, 64, 4));
        let (calm, busy) = (column_mean(&weights, 4..40), column_mean(&weights, 56..92));
        // exp(-0.01 * 0.25 * 200) = 0.61 of the calm pixels kept, exp(-2) of the busy.
        assert!((0.45..0.8).contains(&calm), "calm stone kept {calm:.2}");
        assert!(busy < calm - 0.3, "busy stone kept {busy:.2}, calm {calm:.2}");
    }

    /// Where the photo's grain is blurred (out of focus), the sharpness
    /// that roughening and pits are scaled by is low.
    #[test]
    fn sharpness_is_low_where_the_grain_is_blurred() {
        let (_, d, mask, patches, offsets) = relief();
        let sharp = Image::from_fn(96, 64, 3, |x, y, p| p.fill(0.2 * noise(3, x, y)));
        let soft = gaussian_blur(&sharp, 1.5);
        // A blurred left third of a sharp object.
        let fine = Image::from_fn(96, 64, 3, |x, y, p| p.copy_from_slice(if x < 32 { soft.pixel(x, y) } else { sharp.pixel(x, y) }));
        let sharpness = Borrowing::new(&d, &fine, &mask, (&patches, &offsets), 12.0).sharpness();
        let (blurred, sharpest) = (column_mean(&sharpness, 2..24), column_mean(&sharpness, 44..92));
        eprintln!("sharpness: blurred {blurred:.2}, sharp {sharpest:.2}");
        assert!(sharpest > 0.9 && blurred < 0.6, "sharp {sharpest:.2}, blurred {blurred:.2}");
        // A photo sharp all over is sharp everywhere.
        let all = Borrowing::new(&d, &sharp, &mask, (&patches, &offsets), 12.0).sharpness();
        let low = (0..96 * 64).map(|i| all.data()[i]).fold(1f32, f32::min);
        assert!(low > 0.7, "a uniformly sharp photo reads {low:.2} somewhere");
    }
}
