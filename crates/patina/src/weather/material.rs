//! The weathered material's own colour, for whole regions the prevalence
//! age misses.
//!
//! The age map of [`super::age`] judges patches by how rare they are. A
//! weathering with a plain interior (a wide peel of bare plaster, a sheet of
//! rust) is rare at its rim but not inside: its interior patches are all
//! alike, so they find their twins across the interior and read as intact.
//! The intact texture then keeps islands of damage, and the past frames
//! never reveal them.
//!
//! This step is not in Bellini et al. 2016. It is a two-class colour model
//! seeded by the age map, in the spirit of GrabCut (Rother et al. 2004)
//! without the graph cut:
//! 1. The automatic cut ([`super::intact::weathered_cut`]) splits the map
//!    into weathered and intact seeds, each eroded by [`SEED_EROSION`] px
//!    so that the soft rim of the map does not mix the two materials. The
//!    intact seeds are only the clearly young pixels, below
//!    [`INTACT_SEED_SHARE`] of the cut. Until stop 50 they were everything
//!    below the cut, so a wide plain peel whose interior the map rates
//!    middling (0.25 with the cut at 0.42: its patches recur across the
//!    peel) sat in both classes, the ratio was never decisive and the
//!    interior stayed intact (37% of plain peel on gravel: AUC 0.81,
//!    residue 0.43; with young seeds 0.97 and 0.20). That was kept for a
//!    pale pavement the map rates middling behind an object's bright rim
//!    (the hydrant): with young seeds it is raised a little at the top of
//!    the photo, and the judged share rises from 0.17 to 0.19.
//! 2. A smoothed 16^3 histogram of each class's appearance (Lab).
//! 3. Per pixel, the log-likelihood ratio of its colour, weathered over
//!    intact, averaged over a Gaussian of [`REGION_SIGMA`] px. The average
//!    makes it a region decision: a stucco shadow or a dark grain line
//!    shares a crack's colour, but the pixels around it do not.
//! 4. Where that ratio is decisive ([`RATIO_LOW`]..[`RATIO_HIGH`], a soft
//!    step), the age is raised towards the weathered seeds' median age.
//!
//! It only raises ages: thin damage the map found stays found.

use super::age::ColourBins;
use super::intact::{values_within, weathered_cut};
use crate::image::filter::gaussian_blur;
use crate::image::order::median;
use crate::image::{Image, Mask};

/// Erosion of each class's seeds, in pixels.
pub const SEED_EROSION: usize = 2;
/// Smallest share of the surface the weathered seeds must cover for a
/// colour model of their own (less is noise on a clean texture).
pub const MIN_SEEDS: f32 = 0.01;
/// Share of the cut below which a pixel is an intact seed (see the module
/// docs).
pub const INTACT_SEED_SHARE: f32 = 0.3;
/// Sigma, in pixels, of the region average of the likelihood ratio.
pub const REGION_SIGMA: f32 = 3.0;
/// Averaged log-likelihood ratio at which the raise starts (2x likelier
/// weathered) and where it is complete (6x).
pub const RATIO_LOW: f32 = 0.7;
pub const RATIO_HIGH: f32 = 1.8;
/// Probability floor of a histogram bin (uniform is 1/4096).
const FLOOR: f32 = 1e-4;

/// `age` raised where the colour of the surrounding region is much likelier
/// under the weathered seeds' model than under the intact seeds' (see the
/// module docs). `appearance` is the Lab features of [`super::Features`].
/// With `within`, the cut and both classes' seeds come from its pixels
/// only.
pub fn complete_regions(appearance: &Image, age: &Image, max_fraction: f32, within: Option<&Mask>) -> Image {
    let (w, h) = age.size();
    let (cut, fraction) = weathered_cut(&values_within(age, within), max_fraction);
    if fraction < MIN_SEEDS {
        return age.clone();
    }
    let seeds = |keep: &dyn Fn(f32) -> bool| {
        let m = Mask::from_fn(w, h, |x, y| within.is_none_or(|m| m.get(x, y)) && keep(age.at(x, y, 0)));
        let core = m.erode(SEED_EROSION);
        if core.count() as f32 >= MIN_SEEDS * within.map_or(w * h, Mask::count) as f32 / 2.0 {
            core
        } else {
            m
        }
    };
    let weathered = seeds(&|a| a >= cut);
    let intact = seeds(&|a| a < INTACT_SEED_SHARE * cut);
    if intact.count() == 0 || weathered.count() == 0 {
        return age.clone();
    }
    let bins = ColourBins::new(appearance);
    let p_w = bins.probabilities(appearance, Some(&weathered));
    let p_i = bins.probabilities(appearance, Some(&intact));
    let ratio = Image::from_fn(w, h, 1, |x, y, p| {
        let b = bins.bin(appearance.pixel(x, y));
        p[0] = ((p_w[b] + FLOOR) / (p_i[b] + FLOOR)).ln().clamp(-4.0, 4.0);
    });
    let ratio = gaussian_blur(&ratio, REGION_SIGMA);
    let mut seed_ages: Vec<f32> = age.data().iter().zip(weathered.bits()).filter(|(_, &b)| b).map(|(a, _)| *a).collect();
    let target = median(&mut seed_ages).unwrap_or(0.0);
    let mut out = age.clone();
    for (a, r) in out.data_mut().iter_mut().zip(ratio.data()) {
        let t = ((r - RATIO_LOW) / (RATIO_HIGH - RATIO_LOW)).clamp(0.0, 1.0);
        *a = a.max(t * t * (3.0 - 2.0 * t) * target);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples;
    use crate::weather::features::appearance;

    /// A plain beige peel on stucco whose age map marks its rim and a few
    /// blobs inside (as prevalence does: the interior's patches are alike),
    /// with ages varying a little everywhere: the whole interior is raised
    /// to weathered, the stucco around it is not.
    #[test]
    fn a_plain_interior_ringed_by_damage_is_weathered_too() {
        let (w, h) = (160, 160);
        let stucco = samples::stucco(w, h, 4);
        let inside = |x: usize, y: usize| (40..110).contains(&x) && (50..120).contains(&y);
        let img = Image::from_fn(w, h, 3, |x, y, p| {
            if inside(x, y) {
                p.copy_from_slice(&[0.86, 0.80, 0.66]);
            } else {
                p.copy_from_slice(stucco.pixel(x, y));
            }
        });
        let rim = Mask::from_fn(w, h, |x, y| inside(x, y)).dilate(3);
        let core = Mask::from_fn(w, h, |x, y| inside(x, y)).erode(3);
        let blob = |x: usize, y: usize| {
            [(60, 70), (90, 100)].iter().any(|&(cx, cy): &(i64, i64)| (x as i64 - cx).pow(2) + (y as i64 - cy).pow(2) < 64)
        };
        let jitter = |x: usize, y: usize| ((x * 7 + y * 13) % 10) as f32 * 0.01;
        let age = Image::from_fn(w, h, 1, |x, y, p| {
            p[0] = if (rim.get(x, y) && !core.get(x, y)) || blob(x, y) { 0.9 } else { 0.05 } + jitter(x, y);
        });
        let raised = complete_regions(&appearance(&img, true).unwrap(), &age, 0.6, None);
        // Downstream, the automatic cut decides what is weathered.
        let (cut, _) = weathered_cut(&raised, 0.6);
        let share_above = |pick: &Mask, want: bool| {
            let (mut above, mut n) = (0, 0);
            for (i, &b) in pick.bits().iter().enumerate() {
                if b == want {
                    n += 1;
                    above += usize::from(raised.data()[i] >= cut);
                }
            }
            above as f32 / n as f32
        };
        let interior = Mask::from_fn(w, h, |x, y| inside(x, y)).erode(6);
        let near = Mask::from_fn(w, h, |x, y| inside(x, y)).dilate(8);
        let (mid, out) = (share_above(&interior, true), share_above(&near, false));
        assert!(mid > 0.9, "only {mid:.2} of the peel's plain interior is weathered");
        assert!(out < 0.01, "{out:.3} of the stucco around it is weathered");
        let (before, _) = weathered_cut(&age, 0.6);
        let unraised = interior.bits().iter().zip(age.data()).filter(|(b, &a)| **b && a >= before).count() as f32 / interior.count() as f32;
        assert!(unraised < 0.3, "the age map alone already had {unraised:.2} of the interior");
        // The raise never lowers an age.
        assert!(raised.data().iter().zip(age.data()).all(|(r, a)| r >= a));
    }
}
