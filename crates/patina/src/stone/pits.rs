//! Pitting: the small cavities weathering leaves in stone, where grains
//! and crystals fall out. Not in the paper (its roughening adds a fractal
//! to the luminance); added because worn stone without pits reads as a
//! softened photo (issue 19).
//!
//! Candidate pits sit one per cell of a jittered grid. Each has its own
//! threshold u in [0, 1) and opens once d(x)^nu' (1 - exp(-k t)) > u, so
//! pits appear first and densest where the tendency is high and only ever
//! grow in number with t. A pit is a small cavity (0.6 to 2 px radius, its
//! outline wobbling by up to half of that), darkened like a cavity in
//! shadow by its own depth, its rim on the side facing the light (the top
//! left) slightly brightened, anti-aliased at the edge.

use crate::image::color::luminance;
use crate::image::filter::closing;
use crate::image::{Image, Mask};
use rayon::prelude::*;

/// Spacing (px) of the candidate grid.
pub const SPACING: f32 = 6.0;
/// Share of light the darkest pit's floor keeps (the others up to 0.3 more).
const FLOOR: f32 = 0.5;
/// Brightening of the lit rim.
const RIM: f32 = 0.12;
/// Exponent on the tendency: pits concentrate where the stone is busiest.
const FOCUS: f32 = 2.0;
/// Share of the candidates open where d = 1 once fully weathered: more
/// read as pepper sprinkled on the stone.
const MAX_OPEN: f32 = 0.35;

/// One candidate pit: centre, radius and opening threshold.
struct Pit {
    x: f32,
    y: f32,
    radius: f32,
    threshold: f32,
    /// Share of light its floor keeps.
    floor: f32,
    /// Outline wobble: amplitudes and phases of the 2nd and 3rd angular
    /// harmonics of the radius, so no two pits are the same round dot.
    wobble: [f32; 4],
}

fn candidate(seed: u64, cx: i64, cy: i64) -> Pit {
    let h = crate::rng::derive(seed ^ 0x9175, &[cx as u64, cy as u64]);
    let unit = |shift: u32| ((h >> shift) & 0xffff) as f32 / 65536.0;
    let g = crate::rng::derive(h, &[1]);
    let more = |shift: u32| ((g >> shift) & 0xffff) as f32 / 65536.0;
    let tau = std::f32::consts::TAU;
    Pit {
        x: (cx as f32 + unit(0)) * SPACING,
        y: (cy as f32 + unit(16)) * SPACING,
        radius: 0.6 + 1.4 * unit(32).powi(2),
        threshold: unit(48),
        floor: FLOOR + 0.3 * more(0),
        wobble: [0.45 * more(16), tau * more(32), 0.3 * more(48), tau * more(8)],
    }
}

/// Multiply the luminance of `linear` (colour channels by the same ratio)
/// by the pits open at time t, for smoothing speed `k`. Pixels with d = 0
/// (the background) are unchanged.
pub fn pit(linear: &Image, tendency: &Image, k: f32, t: f32, seed: u64) -> Image {
    let (w, h, c) = (linear.width(), linear.height(), linear.channels());
    let growth = 1.0 - (-k * t).exp();
    let mut out = linear.clone();
    if growth <= 0.0 {
        return out;
    }
    out.data_mut().par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
        let (gy, fy) = ((y as f32 / SPACING).floor() as i64, y as f32 + 0.5);
        for x in 0..w {
            let d = tendency.at(x, y, 0);
            if d <= 0.0 {
                continue;
            }
            let (gx, fx) = ((x as f32 / SPACING).floor() as i64, x as f32 + 0.5);
            let mut factor = 1.0f32;
            for cy in gy - 1..=gy + 1 {
                for cx in gx - 1..=gx + 1 {
                    let p = candidate(seed, cx, cy);
                    let (px, py) = (p.x.clamp(0.0, w as f32 - 1.0) as usize, p.y.clamp(0.0, h as f32 - 1.0) as usize);
                    if tendency.at(px, py, 0).powf(FOCUS) * growth * MAX_OPEN <= p.threshold {
                        continue;
                    }
                    let (dx, dy) = (fx - p.x, fy - p.y);
                    let r = (dx * dx + dy * dy).sqrt();
                    if r > 2.0 * p.radius + 2.0 {
                        continue;
                    }
                    let angle = dy.atan2(dx);
                    let [a2, p2, a3, p3] = p.wobble;
                    let radius = p.radius * (1.0 + a2 * (2.0 * angle + p2).cos() + a3 * (3.0 * angle + p3).cos());
                    // Anti-aliased outline: full inside radius - 0.5, none past radius + 0.5.
                    let inside = (radius + 0.5 - r).clamp(0.0, 1.0);
                    factor *= 1.0 - (1.0 - p.floor) * inside;
                    // The lit rim: a thin ring on the upper-left side.
                    let ring = (1.0 - (r - radius - 0.7).abs()).clamp(0.0, 1.0) * ((-dx - dy) / (r + 1e-3) * 0.7).max(0.0);
                    factor *= 1.0 + RIM * ring;
                }
            }
            if factor != 1.0 {
                row[x * c..(x + 1) * c].iter_mut().for_each(|v| *v *= factor);
            }
        }
    });
    out
}

/// The photo's own pits: the small dark cavities it already has, which
/// weathering opens further rather than heals. Not in the paper, whose
/// patch update borrows calm stone's gradients over them: the black pits
/// in a Buddha's curls closed up as the stone wore, the opposite of what
/// weather does (a blind review named it).
///
/// A pit is a compact dark spot: pixels darker than [`OWN_PIT_RATIO`] of
/// the luminance's grey closing over a (2 [`OWN_PIT_REACH`] + 1)^2 square
/// (the surface the pit is sunk into), in a 4-connected piece of at most
/// [`OWN_PIT_AREA`] px whose bounding box is at most [`OWN_PIT_ELONGATION`]
/// times longer than wide and which plain surface encloses
/// ([`OWN_PIT_ENCLOSED`]). Longer dark runs, and pieces that run on into
/// shadow, are carving (a letter's shadowed groove) and wear as carving
/// does.
pub struct OwnPits {
    /// Per pixel, luminance over the closing on the pits and the pixel
    /// around them (below 1), 1 elsewhere.
    depth: Image,
}

/// Half side (px) of the square the pits' surroundings are taken over.
pub const OWN_PIT_REACH: usize = 3;
/// A pit pixel has at most this share of its surroundings' luminance.
pub const OWN_PIT_RATIO: f32 = 0.6;
/// Largest pit (px).
pub const OWN_PIT_AREA: usize = 48;
/// Longest side of a pit's bounding box over its shortest.
pub const OWN_PIT_ELONGATION: usize = 3;
/// Share of the ring 1-2 px around a pit that must be plain surface (at
/// least [`OWN_PIT_RIM`] of its surroundings' luminance): a pit is a hole
/// in the surface, where a piece of a letter's shadowed groove runs on
/// into more shadow.
pub const OWN_PIT_ENCLOSED: f32 = 0.85;
/// Luminance share of the surroundings from which a pixel is plain surface.
pub const OWN_PIT_RIM: f32 = 0.8;
/// How much deeper (as an exponent on the pit's depth ratio) the pits get
/// once fully weathered: at 1 - exp(-k t) = 1 a pit of ratio q reaches
/// q^(1 + this).
pub const OWN_PIT_DEEPENING: f32 = 0.5;

impl OwnPits {
    /// The pits of `linear` (RGB, linear light) on `object`.
    pub fn find(linear: &Image, object: &Mask) -> OwnPits {
        let (w, h) = object.size();
        let lum = luminance(linear);
        let surface = closing(&lum, OWN_PIT_REACH);
        let ratio: Vec<f32> =
            lum.data().iter().zip(surface.data()).map(|(&l, &c)| if c > 1e-6 { (l / c).clamp(0.0, 1.0) } else { 1.0 }).collect();
        let dark: Vec<bool> = (0..w * h).map(|i| object.bits()[i] && ratio[i] < OWN_PIT_RATIO).collect();
        let (label, count) = crate::image::region::components(&dark, w, h);
        // Per piece: pixel count and bounding box.
        let mut pieces = vec![(0usize, usize::MAX, usize::MAX, 0usize, 0usize); count];
        for (i, &l) in label.iter().enumerate() {
            if l != u32::MAX {
                let (x, y) = (i % w, i / w);
                let p = &mut pieces[l as usize];
                *p = (p.0 + 1, p.1.min(x), p.2.min(y), p.3.max(x), p.4.max(y));
            }
        }
        // Whether plain surface encloses piece `l` (box `x0..=x1`,
        // `y0..=y1`): the share of plain pixels among the ring of pixels
        // not dark within 2 px (a 5 x 5 window) of it.
        let enclosed = |l: u32, (x0, y0, x1, y1): (usize, usize, usize, usize)| {
            let (mut around, mut plain) = (0usize, 0usize);
            for y in y0.saturating_sub(2)..=(y1 + 2).min(h - 1) {
                for x in x0.saturating_sub(2)..=(x1 + 2).min(w - 1) {
                    let i = y * w + x;
                    let touches = || {
                        (y.saturating_sub(2)..=(y + 2).min(h - 1))
                            .any(|yy| (x.saturating_sub(2)..=(x + 2).min(w - 1)).any(|xx| label[yy * w + xx] == l))
                    };
                    if !dark[i] && touches() {
                        around += 1;
                        plain += usize::from(ratio[i] >= OWN_PIT_RIM);
                    }
                }
            }
            plain as f32 >= OWN_PIT_ENCLOSED * around as f32
        };
        let is_pit: Vec<bool> = pieces
            .iter()
            .enumerate()
            .map(|(l, &(n, x0, y0, x1, y1))| {
                let (a, b) = (x1 - x0 + 1, y1 - y0 + 1);
                n <= OWN_PIT_AREA && a.max(b) <= OWN_PIT_ELONGATION * a.min(b) && enclosed(l as u32, (x0, y0, x1, y1))
            })
            .collect();
        let pits = Mask::from_fn(w, h, |x, y| label[y * w + x] != u32::MAX && is_pit[label[y * w + x] as usize]).dilate(1);
        let depth = Image::from_fn(w, h, 1, |x, y, p| p[0] = if pits.get(x, y) && object.get(x, y) { ratio[y * w + x] } else { 1.0 });
        OwnPits { depth }
    }

    /// `worn` (RGB, linear light) with the pits back: each pit pixel is at
    /// most the worn surface around it (its closing) times its depth ratio
    /// q^(1 + [`OWN_PIT_DEEPENING`] (1 - exp(-k t))), the colour channels
    /// scaled alike. At t = 0 a pit is as deep as in the photo.
    pub fn keep(&self, worn: &Image, k: f32, t: f32) -> Image {
        let (w, c) = (worn.width(), worn.channels());
        let exponent = 1.0 + OWN_PIT_DEEPENING * (1.0 - (-k * t).exp());
        let lum = luminance(worn);
        let surface = closing(&lum, OWN_PIT_REACH);
        let mut out = worn.clone();
        out.data_mut().par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
            for x in 0..w {
                let q = self.depth.at(x, y, 0);
                if q >= 1.0 {
                    continue;
                }
                let (now, target) = (lum.at(x, y, 0), surface.at(x, y, 0) * q.powf(exponent));
                if target < now && now > 1e-6 {
                    row[x * c..(x + 1) * c].iter_mut().for_each(|v| *v *= target / now);
                }
            }
        });
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pits_open_where_the_tendency_is_high_and_only_grow_in_number() {
        let (w, h) = (120, 60);
        let img = Image::from_fn(w, h, 3, |_, _, p| p.fill(0.5));
        let d = Image::from_fn(w, h, 1, |x, _, p| p[0] = if x < 60 { 0.15 } else { 0.9 });
        let dark = |im: &Image, xs: std::ops::Range<usize>| {
            xs.flat_map(|x| (0..h).map(move |y| (x, y))).filter(|&(x, y)| im.at(x, y, 0) < 0.45).count()
        };
        let mut last = (0, 0);
        for t in [0.0, 50.0, 100.0, 200.0, 400.0] {
            let out = pit(&img, &d, 0.01, t, 3);
            let now = (dark(&out, 0..60), dark(&out, 60..120));
            assert!(now.0 >= last.0 && now.1 >= last.1, "pits closed between times: {last:?} -> {now:?}");
            last = now;
        }
        assert_eq!(pit(&img, &d, 0.01, 0.0, 3).data(), img.data(), "no pits at t = 0");
        assert!(last.1 > 150 && last.1 > 4 * last.0.max(1), "pits calm {} vs busy {}", last.0, last.1);
    }
}
