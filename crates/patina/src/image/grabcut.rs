//! Foreground/background segmentation by iterated graph cuts on colour
//! mixture models: GrabCut (Rother, Kolmogorov, Blake, SIGGRAPH 2004).
//!
//! Each side is a Gaussian mixture (K full-covariance components) over a
//! per-pixel feature (e.g. Lab). Its data term is the mixture's negative
//! log-likelihood, D_a(z) = -log sum_k pi_k N(z; mu_k, Sigma_k), and the
//! smoothness term is the paper's contrast-sensitive Potts model,
//! V(m, n) = gamma exp(-beta |z_m - z_n|^2) / dist(m, n), with
//! beta = 1 / (2 <|z_m - z_n|^2>) over neighbouring pairs. Each iteration
//! refits both mixtures to the current labels and re-cuts with
//! [`GridCut`]; only pixels marked probable may change side.
//!
//! One addition for use without a user: [`refine`], which re-cuts only a
//! band around a coarse outline at full resolution with the coarse level's
//! models, so the outline follows the photo's own edges, not the coarse
//! grid.

use super::cluster::{kmeans, nearest};
use super::color::to_lab;
use super::maxflow::{self, GridCut};
use super::region;
use super::resample::{resize, Filter};
use super::{Image, Mask};
use crate::rng::{self, Generator};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

/// What is known about a pixel before the cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seed {
    /// Background, held there.
    Background,
    /// Background to start with; the cut may move it.
    ProbablyBackground,
    /// Foreground to start with; the cut may move it.
    ProbablyForeground,
    /// Foreground, held there.
    Foreground,
}

impl Seed {
    fn foreground(self) -> bool {
        matches!(self, Seed::ProbablyForeground | Seed::Foreground)
    }
    fn fixed(self) -> bool {
        matches!(self, Seed::Background | Seed::Foreground)
    }
}

/// GrabCut's settings.
#[derive(Clone, Copy, Debug)]
pub struct GrabCutParams {
    /// Mixture components per side (the paper's K = 5).
    pub components: usize,
    /// Refit-and-cut rounds.
    pub iterations: usize,
    /// gamma, the weight of the smoothness term (the paper's 50).
    pub gamma: f32,
}

impl Default for GrabCutParams {
    fn default() -> Self {
        GrabCutParams { components: 5, iterations: 5, gamma: 50.0 }
    }
}

/// Both sides' colour models after a cut, for [`refine`].
#[derive(Clone, Debug)]
pub struct Models {
    foreground: Gmm,
    background: Gmm,
}

/// The labels (`true` = foreground) of `features` (3 channels) after
/// `params.iterations` rounds, and the models they end with. `seed` drives
/// the mixtures' k-means++ start only.
pub fn segment(features: &Image, seeds: &[Seed], params: &GrabCutParams, seed: u64) -> (Vec<bool>, Models) {
    let (w, h) = features.size();
    assert_eq!(seeds.len(), w * h, "one seed per pixel");
    assert!((1..=MAX_COMPONENTS).contains(&params.components), "1 to {MAX_COMPONENTS} components");
    let z = points(features);
    let mut labels: Vec<bool> = seeds.iter().map(|s| s.foreground()).collect();
    let mut g = rng::generator(seed, &[0x96ab]);
    let pairs = Pairs::of(&z, w, h, params.gamma);
    let mut models = fit(&z, &labels, params.components, &mut g);
    for round in 0..params.iterations.max(1) {
        if round > 0 {
            models = fit(&z, &labels, params.components, &mut g);
        }
        let cut = cut(&z, w, h, seeds, &models, &pairs);
        if cut == labels {
            break;
        }
        labels = cut;
    }
    (labels, models)
}

/// Re-cut the pixels within `band` px of `coarse`'s outline at the
/// resolution of `features` with `models`; the rest keeps `coarse`'s label.
pub fn refine(features: &Image, coarse: &Mask, band: usize, models: &Models, gamma: f32) -> Mask {
    let (w, h) = features.size();
    let (inner, outer) = (coarse.erode(band), coarse.dilate(band));
    let seeds: Vec<Seed> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if inner.get(x, y) {
                Seed::Foreground
            } else if !outer.get(x, y) {
                Seed::Background
            } else if coarse.get(x, y) {
                Seed::ProbablyForeground
            } else {
                Seed::ProbablyBackground
            }
        })
        .collect();
    let z = points(features);
    let pairs = Pairs::of(&z, w, h, gamma);
    let labels = cut(&z, w, h, &seeds, models, &pairs);
    Mask::from_fn(w, h, |x, y| labels[y * w + x])
}

/// The fixed seed of the mixtures' k-means in [`cut_out`] and
/// [`salient_object`]: an object mask depends on the photo only, not on a
/// run's seed.
const MASK_SEED: u64 = 0x6ab;
/// Longer side of the working copy [`cut_out`] runs GrabCut on.
pub const CUT_SIDE: usize = 384;
/// Pixels deeper inside the starting region than this share of its
/// deepest point are held as foreground.
const CORE: f32 = 0.5;
/// Pixels farther outside the starting region than this share of the
/// working copy's longer side are held as background.
const REACH: f32 = 0.12;
/// The final opening's radius is the shorter side over this.
const OPENING: usize = 200;

/// The object in `rgb` (sRGB-encoded) that `start` (a rough region at any
/// resolution) points at, cut out at full resolution:
/// 1. GrabCut on a copy CUT_SIDE px long: `start`'s core is held as
///    foreground, the frame and whatever lies far from `start` as
///    background, the rest is decided by the cut (features: Lab, with
///    lightness scaled by `lightness` so shading counts less than colour);
/// 2. the subject component (under `focus`, in full-resolution pixels, if
///    given) with its holes filled;
/// 3. a band of 2 working pixels round its outline re-cut at full
///    resolution with the working level's models;
/// 4. a small opening (shorter side / 200) against hair-thin spurs, then
///    the subject again, holes filled.
pub fn cut_out(rgb: &Image, start: &Mask, lightness: f32, focus: Option<(usize, usize)>) -> Mask {
    let (w, h) = rgb.size();
    let (sw, sh) = start.size();
    if start.count() == 0 || start.count() == sw * sh {
        return Mask::from_fn(w, h, |x, y| start.get(scaled(x, w, sw), scaled(y, h, sh)));
    }
    let features = |img: &Image| {
        let mut lab = to_lab(img);
        lab.data_mut().chunks_exact_mut(3).for_each(|p| p[0] *= lightness);
        lab
    };
    let scale = (CUT_SIDE as f32 / w.max(h) as f32).min(1.0);
    let (cw, ch) = (((w as f32 * scale).round() as usize).max(1), ((h as f32 * scale).round() as usize).max(1));
    let small = features(&resize(rgb, cw, ch, Filter::Linear).expect("a smaller size"));
    let begin = Mask::from_fn(cw, ch, |x, y| start.get(scaled(x, cw, sw), scaled(y, ch, sh)));
    let depth = begin.signed_distance();
    let core = depth.iter().copied().fold(0f32, f32::max) * CORE;
    let reach = (cw.max(ch) as f32 * REACH).max(4.0);
    let small_focus = focus.map(|(x, y)| (scaled(x, w, cw), scaled(y, h, ch)));
    let seeds: Vec<Seed> = (0..cw * ch)
        .map(|i| {
            let (x, y) = (i % cw, i / cw);
            let frame = x == 0 || y == 0 || x + 1 == cw || y + 1 == ch;
            let focused = small_focus.is_some_and(|(fx, fy)| fx.abs_diff(x).max(fy.abs_diff(y)) <= 1);
            match depth[i] {
                _ if focused => Seed::Foreground,
                d if d >= core => Seed::Foreground,
                d if d > 0.0 => Seed::ProbablyForeground,
                d if d < -reach || frame => Seed::Background,
                _ => Seed::ProbablyBackground,
            }
        })
        .collect();
    let params = GrabCutParams::default();
    let (labels, models) = segment(&small, &seeds, &params, MASK_SEED);
    let object = region::fill_holes(&region::subject(&labels, cw, ch, small_focus), cw, ch);
    let coarse = Mask::from_fn(w, h, |x, y| object[scaled(y, h, ch) * cw + scaled(x, w, cw)]);
    let band = ((w.max(h) as f32 / CUT_SIDE as f32).ceil() as usize * 2).max(2);
    let full = features(rgb);
    let fine = refine(&full, &coarse, band, &models, params.gamma);
    let r = (w.min(h) / OPENING).max(1);
    let opened = fine.erode(r).dilate(r);
    let filled = region::fill_holes(&region::subject(opened.bits(), w, h, focus), w, h);
    let trimmed = without_spurs(&Mask::from_fn(w, h, |x, y| filled[y * w + x]), (w.min(h) / SPUR).max(1), focus);
    let kept = without_strays(trimmed.bits(), &points(&full), w, h);
    // Dropping strays can leave slivers between them (a glyph's rim): open
    // again by a pixel (a wider square opened each blade's gap in the
    // object into a polygon of bare stone). Not the subject again: a
    // stray shadow band may have parted a hydrant's nut from its body.
    Mask::from_fn(w, h, |x, y| kept[y * w + x]).erode(1).dilate(1)
}

/// Parts of a found object narrower than 2 x (shorter side / this) + 1
/// px that reach farther than that from its body are cut off ([`without_spurs`]).
const SPUR: usize = 100;

/// `object` without its spurs: the parts that an opening of radius `r`
/// removes and that lie more than `r` from what remains (the body, its
/// subject component). A same-coloured thing touching the object, like
/// the white glyph of a marker card against a white statue, joins it
/// through a strip the cut cannot split by colour, and stands out from
/// the body as a thin arm; the object's own outline within `r` of its
/// body (corners, rims) is kept whole.
fn without_spurs(object: &Mask, r: usize, focus: Option<(usize, usize)>) -> Mask {
    let (w, h) = object.size();
    let opened = object.erode(r).dilate(r);
    let body = region::subject(opened.bits(), w, h, focus);
    if !body.iter().any(|&b| b) {
        return object.clone();
    }
    let near = Mask::from_fn(w, h, |x, y| body[y * w + x]).dilate(r);
    let kept: Vec<bool> = object.bits().iter().zip(near.bits()).map(|(&o, &n)| o && n).collect();
    let subject = region::subject(&kept, w, h, focus);
    Mask::from_fn(w, h, |x, y| subject[y * w + x])
}

/// How much likelier (in nats, -log p) the background mixture must find a
/// pixel than the object's core for [`without_strays`] to drop it.
const STRAY_MARGIN: f64 = 2.0;
/// Strays are thinner than 2 x this + 1 pixels.
const STRAY_WIDTH: usize = 6;

/// `object` without its strays: thin runs of pixels (under 2
/// [`STRAY_WIDTH`] + 1 px across) whose colour a mixture of the
/// background explains by [`STRAY_MARGIN`] better than a mixture of the
/// object's core (its pixels deeper than [`CORE`] of its deepest) and
/// that reach the outside through such pixels. Thin things in front of
/// the object, like grass blades across a gravestone's base, are a pixel
/// or two wide: the cut's smoothness term keeps them, the coarse level
/// never saw them, and its object model has learnt their colours. A
/// background-coloured spot enclosed by the object (a lichen patch, a
/// dark letter) is kept.
fn without_strays(object: &[bool], z: &[Vector3<f64>], w: usize, h: usize) -> Vec<bool> {
    let depth = Mask::from_fn(w, h, |x, y| object[y * w + x]).distance_inside();
    let deepest = depth.iter().copied().filter(|d| d.is_finite()).fold(0f32, f32::max);
    // Every third pixel of the core and of the background fits the mixtures.
    let (sample, labels): (Vec<Vector3<f64>>, Vec<bool>) = (0..w * h)
        .step_by(3)
        .filter_map(|i| {
            let core = depth[i] > deepest * CORE;
            (core || !object[i]).then_some((z[i], core))
        })
        .unzip();
    if !labels.iter().any(|&l| l) || labels.iter().all(|&l| l) {
        return object.to_vec();
    }
    let mut g = rng::generator(MASK_SEED, &[0x57a7]);
    let models = fit(&sample, &labels, GrabCutParams::default().components, &mut g);
    let stray: Vec<bool> = z
        .par_iter()
        .zip(object.par_iter())
        .map(|(p, &inside)| inside && models.background.cost(p) + STRAY_MARGIN < models.foreground.cost(p))
        .collect();
    // Only thin strays: a part of the object in a background-like colour
    // (a hydrant's grey operating nut) is thicker than a blade.
    let thick = Mask::from_fn(w, h, |x, y| stray[y * w + x]).erode(STRAY_WIDTH).dilate(STRAY_WIDTH);
    let stray: Vec<bool> = stray.iter().zip(thick.bits()).map(|(&s, &t)| s && !t).collect();
    let open: Vec<bool> = object.iter().zip(&stray).map(|(&o, &s)| !o || s).collect();
    let (label, count) = region::components(&open, w, h);
    let mut outside = vec![false; count];
    for (i, &o) in object.iter().enumerate() {
        if !o {
            outside[label[i] as usize] = true;
        }
    }
    (0..w * h).map(|i| object[i] && !(stray[i] && outside[label[i] as usize])).collect()
}

/// `i` of `n` on a grid of `m`.
fn scaled(i: usize, n: usize, m: usize) -> usize {
    (i * m / n).min(m - 1)
}

/// A flood from a point never stops at a Lab distance under this.
const FLOOD_FLOOR: f32 = 6.0;
/// Nor at a Lab distance over this.
const FLOOD_CEILING: f32 = 40.0;
/// A flood covering more than this share of the picture is split again.
const MOST: f32 = 0.85;
/// Longer side of the copy [`salient_object`] finds its start on.
const SALIENCY_SIDE: usize = 192;
/// Width of the frame strip taken as background, as a share of each side.
const FRAME: f32 = 0.05;

/// The photo's main object (`rgb` sRGB-encoded): the object under `focus`
/// (full-resolution pixels) if given, else the largest central region
/// unlike the picture's frame. Saliency here is the frame's own colour
/// model: a Gaussian mixture fitted to a strip along the four edges gives
/// each pixel a cost -log p(z | frame); pixels above the Otsu threshold of
/// that cost are "not background", smoothed by majority votes, and their
/// subject component (holes filled) starts [`cut_out`]. With `focus`
/// outside that start, the start is instead the region of colours like the
/// point's own that is connected to it ([`flood`]), so an object that
/// fills the frame, or any other object, can be picked too.
///
/// Simplification: "salient" means "unlike the frame" (the boundary prior
/// of most saliency detectors); without `focus`, an object that fills the
/// frame or shares its colours with it is missed (the gravestone 0405
/// photo gives the trees above it).
pub fn salient_object(rgb: &Image, focus: Option<(usize, usize)>) -> Mask {
    let (w, h) = rgb.size();
    let scale = (SALIENCY_SIDE as f32 / w.max(h) as f32).min(1.0);
    let (sw, sh) = (((w as f32 * scale).round() as usize).max(2), ((h as f32 * scale).round() as usize).max(2));
    let lab = to_lab(&resize(rgb, sw, sh, Filter::Linear).expect("a smaller size"));
    let z = points(&lab);
    let (fx, fy) = (((sw as f32 * FRAME).ceil() as usize).max(1), ((sh as f32 * FRAME).ceil() as usize).max(1));
    let inner: Vec<bool> = (0..sw * sh).map(|i| (fx..sw - fx).contains(&(i % sw)) && (fy..sh - fy).contains(&(i / sw))).collect();
    let mut g = rng::generator(MASK_SEED, &[0x5a11e7]);
    let frame = fit(&z, &inner, GrabCutParams::default().components, &mut g).background;
    let cost: Vec<f32> = z.par_iter().map(|p| frame.cost(p) as f32).collect();
    let threshold = super::filter::otsu(&cost);
    let mut salient: Vec<bool> = cost.iter().map(|&c| c > threshold).collect();
    for _ in 0..3 {
        salient = region::majority(&salient, sw, sh);
    }
    let mut start = region::fill_holes(&region::subject(&salient, sw, sh, None), sw, sh);
    if let Some((x, y)) = focus {
        let at = (scaled(x, w, sw), scaled(y, h, sh));
        if !start[at.1 * sw + at.0] {
            start = flood(&z, sw, sh, at);
        }
    }
    cut_out(rgb, &Mask::from_fn(sw, sh, |x, y| start[y * sw + x]), 1.0, focus)
}

/// The pixels connected to `at` through colours like its own: Lab
/// distance to the mean of its 5 x 5 neighbourhood below a threshold,
/// smoothed by majority votes, holes filled. The threshold is the Otsu
/// split of all pixels' distances (6-40 Lab units, so it neither stops at
/// noise nor crosses a clear colour edge); while that region covers more than [`MOST`] of the
/// picture (nothing was told apart), the split is taken again among the
/// nearer distances only. The cut then takes the start to the object's
/// edges.
fn flood(z: &[Vector3<f64>], w: usize, h: usize, at: (usize, usize)) -> Vec<bool> {
    let (ax, ay) = at;
    let window =
        || (ay.saturating_sub(2)..(ay + 3).min(h)).flat_map(move |y| (ax.saturating_sub(2)..(ax + 3).min(w)).map(move |x| y * w + x));
    let mean: Vector3<f64> = window().map(|i| z[i]).sum::<Vector3<f64>>() / window().count() as f64;
    let distance: Vec<f32> = z.iter().map(|p| (p - mean).norm() as f32).collect();
    let mut threshold = super::filter::otsu(&distance).clamp(FLOOD_FLOOR, FLOOD_CEILING);
    loop {
        let mut like: Vec<bool> = distance.iter().map(|&d| d < threshold).collect();
        for _ in 0..2 {
            like = region::majority(&like, w, h);
        }
        like[ay * w + ax] = true;
        let start = region::fill_holes(&region::subject(&like, w, h, Some(at)), w, h);
        let covered = start.iter().filter(|&&b| b).count() as f32 / (w * h) as f32;
        let nearer: Vec<f32> = distance.iter().copied().filter(|&d| d < threshold).collect();
        let next = super::filter::otsu(&nearer).max(FLOOD_FLOOR);
        if covered <= MOST || next >= threshold || threshold <= FLOOD_FLOOR {
            return start;
        }
        threshold = next;
    }
}

fn points(features: &Image) -> Vec<Vector3<f64>> {
    assert!(features.channels() >= 3, "three feature channels");
    let c = features.channels();
    features.data().chunks_exact(c).map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)).collect()
}

/// The smoothness term's weights per pixel and direction 0-3.
struct Pairs(Vec<[f32; 4]>);

impl Pairs {
    fn of(z: &[Vector3<f64>], w: usize, h: usize, gamma: f32) -> Self {
        let squared = |i: usize, d: u8| maxflow::neighbour(w, h, i, d).map(|j| (z[i] - z[j]).norm_squared());
        let (sum, count) =
            (0..w * h).flat_map(|i| (0..4u8).filter_map(move |d| squared(i, d))).fold((0.0f64, 0usize), |(s, n), v| (s + v, n + 1));
        let beta = if sum > 0.0 { count as f64 / (2.0 * sum) } else { 0.0 };
        let weights = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let mut v = [0.0f32; 4];
                for d in 0..4u8 {
                    if let Some(s) = squared(i, d) {
                        let length = if d % 2 == 1 { std::f64::consts::SQRT_2 } else { 1.0 };
                        v[d as usize] = (gamma as f64 * (-beta * s).exp() / length) as f32;
                    }
                }
                v
            })
            .collect();
        Pairs(weights)
    }
}

fn cut(z: &[Vector3<f64>], w: usize, h: usize, seeds: &[Seed], models: &Models, pairs: &Pairs) -> Vec<bool> {
    let costs: Vec<(f32, f32)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            if seeds[i].fixed() {
                return (0.0, 0.0);
            }
            let fg = models.foreground.cost(&z[i]);
            let bg = models.background.cost(&z[i]);
            let floor = fg.min(bg);
            ((fg - floor) as f32, (bg - floor) as f32)
        })
        .collect();
    let mut grid = GridCut::new(w, h);
    for i in 0..w * h {
        match seeds[i] {
            Seed::Foreground => grid.fix(i, true),
            Seed::Background => grid.fix(i, false),
            _ => grid.set_costs(i, costs[i].0, costs[i].1),
        }
        for d in 0..4 {
            grid.set_pair(i, d, pairs.0[i][d]);
        }
    }
    grid.solve()
}

/// A Gaussian mixture with full covariances.
#[derive(Clone, Debug)]
struct Gmm {
    weight: Vec<f64>,
    mean: Vec<Vector3<f64>>,
    inverse: Vec<Matrix3<f64>>,
    /// log(weight) - log(det Sigma) / 2 - 3 log(2 pi) / 2.
    log_norm: Vec<f64>,
}

/// Variance added to each covariance's diagonal (feature units squared),
/// so a flat region does not give a singular component.
const VARIANCE_FLOOR: f64 = 0.5;
/// The most mixture components a side may have.
pub const MAX_COMPONENTS: usize = 16;
/// At most this many points (an even stride) seed the k-means.
const KMEANS_SAMPLES: usize = 4000;

impl Gmm {
    /// -log of the mixture density at `z`.
    fn cost(&self, z: &Vector3<f64>) -> f64 {
        let mut terms = [f64::NEG_INFINITY; MAX_COMPONENTS];
        for (k, t) in terms.iter_mut().enumerate().take(self.weight.len()) {
            *t = self.log_density(k, z);
        }
        let best = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let rest: f64 = terms[..self.weight.len()].iter().map(|t| (t - best).exp()).sum();
        -(best + rest.ln())
    }

    /// log(pi_k N(z; mu_k, Sigma_k)).
    fn log_density(&self, k: usize, z: &Vector3<f64>) -> f64 {
        let d = z - self.mean[k];
        self.log_norm[k] - 0.5 * (d.transpose() * self.inverse[k] * d)[0]
    }

    /// The component most likely to have drawn `z`.
    fn component(&self, z: &Vector3<f64>) -> usize {
        (0..self.weight.len()).map(|k| (k, self.log_density(k, z))).fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a }).0
    }

    /// Weights, means and covariances of the points grouped by `groups`.
    fn from_groups(points: &[&Vector3<f64>], groups: &[usize], k: usize) -> Gmm {
        let mut n = vec![0.0f64; k];
        let mut sum = vec![Vector3::zeros(); k];
        let mut outer = vec![Matrix3::zeros(); k];
        for (p, &g) in points.iter().zip(groups) {
            n[g] += 1.0;
            sum[g] += *p;
            outer[g] += *p * p.transpose();
        }
        let total: f64 = n.iter().sum::<f64>().max(1.0);
        let mut gmm = Gmm { weight: vec![], mean: vec![], inverse: vec![], log_norm: vec![] };
        for c in 0..k {
            if n[c] < 1.0 {
                continue;
            }
            let mean = sum[c] / n[c];
            let cov = outer[c] / n[c] - mean * mean.transpose() + Matrix3::identity() * VARIANCE_FLOOR;
            let det = cov.determinant().max(1e-12);
            let inverse = cov.try_inverse().unwrap_or_else(|| Matrix3::identity() / VARIANCE_FLOOR);
            let weight = n[c] / total;
            gmm.log_norm.push(weight.ln() - 0.5 * det.ln() - 1.5 * (2.0 * std::f64::consts::PI).ln());
            gmm.weight.push(weight);
            gmm.mean.push(mean);
            gmm.inverse.push(inverse);
        }
        if gmm.weight.is_empty() {
            // No points: a broad component that fits nothing well.
            gmm.weight.push(1.0);
            gmm.mean.push(Vector3::zeros());
            gmm.inverse.push(Matrix3::identity() / 1e4);
            gmm.log_norm.push(-0.5 * (1e12f64).ln() - 1.5 * (2.0 * std::f64::consts::PI).ln());
        }
        gmm
    }
}

/// Both mixtures fitted to `labels`: k-means++ starts on a sample, then
/// each point joins its nearest centre and the components are fitted.
/// (GrabCut's first round starts from k-means; later rounds assign each
/// point to its most likely component of the previous round's model.)
fn fit(z: &[Vector3<f64>], labels: &[bool], k: usize, g: &mut Generator) -> Models {
    let mut side = |fg: bool| -> Gmm {
        let points: Vec<&Vector3<f64>> = z.iter().zip(labels).filter(|(_, &l)| l == fg).map(|(p, _)| p).collect();
        if points.is_empty() {
            return Gmm::from_groups(&[], &[], 1);
        }
        let stride = points.len().div_ceil(KMEANS_SAMPLES).max(1);
        let sample: Vec<Vector3<f64>> = points.iter().step_by(stride).map(|p| **p).collect();
        let centres = kmeans(&sample, k.min(sample.len()), g);
        let groups: Vec<usize> = points.par_iter().map(|p| nearest(p, &centres)).collect();
        let first = Gmm::from_groups(&points, &groups, centres.len());
        // One round of most-likely-component assignment, as the paper's step 1.
        let groups: Vec<usize> = points.par_iter().map(|p| first.component(p)).collect();
        Gmm::from_groups(&points, &groups, first.weight.len())
    };
    Models { foreground: side(true), background: side(false) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples::value_noise;

    /// A two-coloured textured object on a two-coloured textured ground,
    /// with a loose initial region: the cut finds the object's outline.
    #[test]
    fn a_loose_box_around_an_object_is_cut_to_its_outline() {
        let (w, h) = (120, 90);
        let inside = |x: usize, y: usize| ((x as f32 - 60.0) / 32.0).powi(2) + ((y as f32 - 45.0) / 25.0).powi(2) < 1.0;
        let img = Image::from_fn(w, h, 3, |x, y, p| {
            let n = value_noise(5, x as f32 / 4.0, y as f32 / 4.0);
            let stripe = (x / 6 + y / 9) % 2 == 0;
            let c = match (inside(x, y), stripe) {
                (true, true) => [60.0, 40.0, 30.0],
                (true, false) => [45.0, 30.0, 35.0],
                (false, true) => [55.0, -30.0, 20.0],
                (false, false) => [35.0, -10.0, -25.0],
            };
            for k in 0..3 {
                p[k] = c[k] + 8.0 * (n - 0.5);
            }
        });
        let seeds: Vec<Seed> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (15..105).contains(&x) && (10..80).contains(&y) {
                    Seed::ProbablyForeground
                } else {
                    Seed::Background
                }
            })
            .collect();
        let (labels, _) = segment(&img, &seeds, &GrabCutParams::default(), 1);
        let truth = (0..w * h).filter(|&i| inside(i % w, i / w)).count();
        let wrong = (0..w * h).filter(|&i| labels[i] != inside(i % w, i / w)).count();
        assert!(wrong * 100 < truth * 3, "{wrong} of {truth} wrong");
        // The box's own start (everything inside it) would be far off.
        let boxed = (0..w * h).filter(|&i| seeds[i].foreground() != inside(i % w, i / w)).count();
        assert!(boxed > 10 * wrong.max(1));
    }

    #[test]
    fn refining_at_full_resolution_follows_the_true_outline() {
        let (w, h) = (160, 120);
        let inside = |x: f32, y: f32| (x - 80.0).powi(2) + (y - 60.0).powi(2) < 40.0f32.powi(2);
        let img = Image::from_fn(w, h, 3, |x, y, p| {
            let c = if inside(x as f32 + 0.5, y as f32 + 0.5) { [70.0, 20.0, 10.0] } else { [40.0, -10.0, 30.0] };
            p.copy_from_slice(&c);
        });
        // A blocky coarse mask (8 px blocks) as from a low-resolution level.
        let coarse = Mask::from_fn(w, h, |x, y| inside((x / 8 * 8 + 4) as f32, (y / 8 * 8 + 4) as f32));
        let seeds: Vec<Seed> = coarse.bits().iter().map(|&b| if b { Seed::ProbablyForeground } else { Seed::ProbablyBackground }).collect();
        let (_, models) = segment(&img, &seeds, &GrabCutParams { iterations: 1, ..Default::default() }, 1);
        let fine = refine(&img, &coarse, 6, &models, 50.0);
        let wrong = |m: &Mask| (0..w * h).filter(|&i| m.bits()[i] != inside((i % w) as f32 + 0.5, (i / w) as f32 + 0.5)).count();
        assert!(wrong(&fine) * 10 < wrong(&coarse), "refined {} wrong, coarse {}", wrong(&fine), wrong(&coarse));
    }

    /// Pale grass blades (2 px wide) rise from the ground across the
    /// base of a grey slab: the cut's smoothness keeps such thin runs, and
    /// the stray pass drops them, while a green spot enclosed by the slab
    /// (a lichen patch) stays part of it.
    #[test]
    fn thin_background_blades_in_front_of_the_object_are_left_out() {
        let (w, h) = (240, 240);
        let slab = |x: usize, y: usize| (60..180).contains(&x) && (30..200).contains(&y);
        // Within 25 px of the slab's base, short of its core (30 px in).
        let blade =
            |x: usize, y: usize| y >= 175 && [80usize, 101, 122, 143, 164].iter().any(|&b| (b..b + 2).contains(&(x + (y - 175) / 12)));
        let spot = |x: usize, y: usize| (110..118).contains(&x) && (80..88).contains(&y);
        let img = Image::from_fn(w, h, 3, |x, y, p| {
            let n = value_noise(7, x as f32 / 3.0, y as f32 / 3.0) - 0.5;
            // Pale blades: a third of the way from the grass to the stone.
            let rgb = if slab(x, y) && blade(x, y) {
                [0.42 + 0.06 * n, 0.52 + 0.06 * n, 0.33 + 0.05 * n]
            } else if slab(x, y) && !spot(x, y) {
                [0.55 + 0.06 * n, 0.56 + 0.06 * n, 0.57 + 0.06 * n]
            } else {
                [0.35 + 0.1 * n, 0.5 + 0.1 * n, 0.2 + 0.05 * n]
            };
            p.copy_from_slice(&rgb);
        });
        let found = salient_object(&img, Some((120, 100)));
        let (mut blades, mut kept_blades, mut stone, mut kept_stone) = (0, 0, 0, 0);
        for y in 0..h {
            for x in 0..w {
                if slab(x, y) && blade(x, y) {
                    blades += 1;
                    kept_blades += found.get(x, y) as usize;
                } else if slab(x, y) {
                    stone += 1;
                    kept_stone += found.get(x, y) as usize;
                }
            }
        }
        assert!(kept_blades * 5 < blades, "{kept_blades} of {blades} blade pixels kept");
        assert!(kept_stone as f32 > 0.98 * stone as f32, "{kept_stone} of {stone} slab pixels kept");
        assert!((110..118).all(|x| (80..88).all(|y| found.get(x, y))), "the enclosed spot is part of the slab");
    }

    /// A white disc (a statue) against a black card carrying a white glyph
    /// (a marker), whose strokes touch the disc: the glyph is the disc's
    /// colour and joins it, and only its thinness tells it apart.
    #[test]
    fn a_thin_same_coloured_arm_touching_the_object_is_cut_off() {
        let (w, h) = (300, 300);
        let disc = |x: usize, y: usize| (x as f32 - 130.0).hypot(y as f32 - 150.0) < 80.0;
        // The card, and two more at the picture's corners (as a calibration
        // sheet's markers lie round a photographed object): black is ground.
        let card =
            |x: usize, y: usize| ((200..260).contains(&x) && (120..180).contains(&y)) || (x < 50 && y < 50) || (x >= 250 && y >= 250);
        // An E-shaped glyph of 6 px strokes, its spine against the disc's edge.
        let glyph = |x: usize, y: usize| {
            card(x, y)
                && ((205..211).contains(&x) || ((205..250).contains(&x) && [128usize, 147, 166].iter().any(|&r| (r..r + 6).contains(&y))))
        };
        let img = Image::from_fn(w, h, 3, |x, y, p| {
            let n = value_noise(9, x as f32 / 2.0, y as f32 / 2.0) - 0.5;
            let rgb = if disc(x, y) || glyph(x, y) {
                [0.85 + 0.05 * n; 3]
            } else if card(x, y) {
                [0.06, 0.06, 0.07]
            } else {
                [0.55 + 0.08 * n, 0.42 + 0.08 * n, 0.3]
            };
            p.copy_from_slice(&rgb);
        });
        let found = salient_object(&img, None);
        let count = |f: &dyn Fn(usize, usize) -> bool| (0..w * h).filter(|&i| f(i % w, i / w)).count();
        let glyph_only = |x: usize, y: usize| glyph(x, y) && !disc(x, y);
        let kept_glyph = count(&|x, y| glyph_only(x, y) && found.get(x, y));
        let kept_disc = count(&|x, y| disc(x, y) && found.get(x, y));
        // The spine along the outline is within reach of the body; the arms go.
        assert!(kept_glyph * 3 < count(&glyph_only), "{kept_glyph} of {} glyph pixels kept", count(&glyph_only));
        assert!(kept_disc as f32 > 0.98 * count(&disc) as f32, "{kept_disc} of {} disc pixels kept", count(&disc));
    }

    /// A scene with a lit orange cylinder in the middle, a blue box off
    /// centre and a slab that fills the lower width, on textured grey.
    fn scene() -> (Image, Mask, Mask, Mask) {
        let (w, h) = (320, 240);
        let cylinder = Mask::from_fn(w, h, |x, y| (120..200).contains(&x) && (40..170).contains(&y));
        let boxed = Mask::from_fn(w, h, |x, y| (24..64).contains(&x) && (30..70).contains(&y));
        let slab = Mask::from_fn(w, h, |_, y| y >= 200);
        let img = Image::from_fn(w, h, 3, |x, y, p| {
            let n = value_noise(4, x as f32 / 3.0, y as f32 / 3.0);
            let rgb = if cylinder.get(x, y) {
                let shade = 0.35 + 0.65 * ((x as f32 - 120.0) / 80.0 * 3.0).sin().max(0.0);
                [0.9 * shade, 0.4 * shade, 0.1 * shade]
            } else if boxed.get(x, y) {
                [0.15, 0.25, 0.7]
            } else if slab.get(x, y) {
                [0.62 + 0.05 * n, 0.55 + 0.05 * n, 0.45]
            } else {
                [0.4 + 0.15 * n, 0.4 + 0.15 * n, 0.42 + 0.15 * n]
            };
            p.copy_from_slice(&rgb);
        });
        (img, cylinder, boxed, slab)
    }

    fn iou(a: &Mask, b: &Mask) -> f32 {
        let both = a.bits().iter().zip(b.bits()).filter(|(x, y)| **x && **y).count();
        let either = a.bits().iter().zip(b.bits()).filter(|(x, y)| **x || **y).count();
        both as f32 / either.max(1) as f32
    }

    #[test]
    fn the_main_object_or_the_one_under_a_point_is_cut_out() {
        let (img, cylinder, boxed, slab) = scene();
        let main = salient_object(&img, None);
        assert!(iou(&main, &cylinder) > 0.95, "main object IoU {}", iou(&main, &cylinder));
        let picked = salient_object(&img, Some((40, 50)));
        assert!(iou(&picked, &boxed) > 0.95, "pointed box IoU {}", iou(&picked, &boxed));
        // The slab touches three sides of the frame: only a point finds it.
        let floor = salient_object(&img, Some((300, 220)));
        assert!(iou(&floor, &slab) > 0.95, "pointed slab IoU {}", iou(&floor, &slab));
    }
}
