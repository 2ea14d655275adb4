//! Measures of the defects synthesis shows on real inputs (see
//! ../shared/REVIEW.md, "Figures that back the eye"): a visible block grid,
//! lighting copied piecewise, and features repeated verbatim.

use super::nearest;
use crate::error::Result;
use crate::image::color::luminance;
use crate::image::filter::gaussian_blur;
use crate::image::Image;

/// Shortest and longest grid period looked for, in pixels.
const GRID_PERIODS: (usize, usize) = (8, 128);

/// Block-grid visibility: the strongest periodic peak of the image's
/// gradient profile. The mean absolute horizontal luminance gradient of each
/// column (and vertical, of each row) gives two profiles; for every period
/// P in 8..=128 and phase, the mean of the profile at phase + kP over the
/// profile's mean is the comb's height. A block grid (edges every P pixels)
/// gives a high comb; a stationary texture stays near 1. Compare an output's
/// value with its exemplar's: a ratio near 1 means no grid was added.
pub fn grid_peak(img: &Image) -> f32 {
    let y = luminance(img);
    let (w, h) = y.size();
    let d = y.data();
    let mut cols = vec![0f64; w.saturating_sub(1)];
    let mut rows = vec![0f64; h.saturating_sub(1)];
    for (yy, line) in d.chunks_exact(w).enumerate() {
        for (c, pair) in cols.iter_mut().zip(line.windows(2)) {
            *c += (pair[1] - pair[0]).abs() as f64;
        }
        if let (Some(r), Some(next)) = (rows.get_mut(yy), d.get((yy + 1) * w..(yy + 2) * w)) {
            *r = line.iter().zip(next).map(|(a, b)| (b - a).abs() as f64).sum();
        }
    }
    comb_peak(&cols).max(comb_peak(&rows)) as f32
}

/// The highest comb (mean at phase + kP over the mean), needing at least
/// three teeth.
fn comb_peak(profile: &[f64]) -> f64 {
    let n = profile.len();
    let mean = profile.iter().sum::<f64>() / n.max(1) as f64;
    if n < 3 * GRID_PERIODS.0 || mean <= 0.0 {
        return 1.0;
    }
    let mut best = 1.0f64;
    for period in GRID_PERIODS.0..=GRID_PERIODS.1.min(n / 3) {
        for phase in 0..period {
            let (mut s, mut k) = (0.0, 0);
            let mut i = phase;
            while i < n {
                s += profile[i];
                k += 1;
                i += period;
            }
            best = best.max(s / k as f64 / mean);
        }
    }
    best
}

/// Large-scale non-stationarity: the standard deviation of the luminance
/// blurred with a Gaussian of sigma = 1/8 of the smaller side, over its mean.
/// A vignette or a lighting ramp raises it; a stationary texture has almost
/// none left after such a blur.
pub fn nonstationarity(img: &Image) -> f32 {
    let y = luminance(img);
    let sigma = y.width().min(y.height()) as f32 / 8.0;
    let b = gaussian_blur(&y, sigma);
    let d = b.data();
    let n = d.len().max(1) as f64;
    let mean = d.iter().map(|&v| v as f64).sum::<f64>() / n;
    let var = d.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / n;
    if mean.abs() < 1e-9 {
        return 0.0;
    }
    (var.sqrt() / mean.abs()) as f32
}

/// Near-verbatim repetition: the share of textured patches (luminance std
/// of at least `min_std`) whose nearest other patch at least `min_offset`
/// pixels away is a near-exact copy (RMS difference under 1.5/255). A
/// quilt that pastes one distinctive block many times scores high; a
/// photograph of a natural surface scores near 0.
pub fn repeated_share(img: &Image, patch: usize, min_offset: usize, seed: u64) -> Result<f32> {
    let (nnf, inside) = nearest(img, img, patch, Some(min_offset), seed)?;
    let y = luminance(img);
    let r = patch / 2;
    let texels = (patch * patch * img.channels()) as f32;
    let (mut textured, mut copies) = (0usize, 0usize);
    for cy in (r..img.height().saturating_sub(r)).step_by(2) {
        for cx in (r..img.width().saturating_sub(r)).step_by(2) {
            if !inside.get(cx, cy) {
                continue;
            }
            let (mut s, mut s2) = (0f32, 0f32);
            for yy in cy - r..=cy + r {
                for xx in cx - r..=cx + r {
                    let v = y.at(xx, yy, 0);
                    s += v;
                    s2 += v * v;
                }
            }
            let n = (patch * patch) as f32;
            let std = (s2 / n - (s / n).powi(2)).max(0.0).sqrt();
            if std < MIN_TEXTURE_STD {
                continue;
            }
            textured += 1;
            let rms = (nnf.get(cx, cy).cost / texels).max(0.0).sqrt();
            copies += (rms < 1.5 / 255.0) as usize;
        }
    }
    Ok(if textured == 0 { 0.0 } else { copies as f32 / textured as f32 })
}

/// Luminance std below which a patch counts as flat (not a feature).
const MIN_TEXTURE_STD: f32 = 0.04;

/// Share of the exemplar's pixels counted as its rare features by
/// [`rare_feature_use`].
const RARE_SHARE: f32 = 0.05;

/// Stamps: how often the exemplar's rarest features are copied, relative to
/// how often its material is on average. Every output pixel is matched to
/// its nearest exemplar patch (side `patch`); an exemplar pixel's use is the
/// number of output pixels matched within a few pixels of it. The result is
/// the mean use of the rarest [`RARE_SHARE`] of the exemplar (by
/// [`crate::synth::rarity`], on neighbourhoods `feature` pixels wide) over
/// the mean use of all of it. 1 = rare features as frequent as anything
/// else (an enlargement shows each knot as often as the plain grain: a
/// stamp), below 1 = used sparingly, 0 = never copied.
pub fn rare_feature_use(output: &Image, exemplar: &Image, patch: usize, feature: usize, seed: u64) -> Result<f32> {
    let (nnf, inside) = nearest(output, exemplar, patch, None, seed)?;
    let (ew, eh) = exemplar.size();
    let mut uses = Image::new(ew, eh, 1);
    for y in 0..output.height() {
        for x in 0..output.width() {
            if inside.get(x, y) {
                let m = nnf.get(x, y);
                uses.pixel_mut(m.x as usize, m.y as usize)[0] += 1.0;
            }
        }
    }
    let uses = gaussian_blur(&uses, (patch / 2).max(1) as f32);
    let weights = vec![1.0 / exemplar.channels() as f32; exemplar.channels()];
    let rarity = crate::synth::rarity::rarity(exemplar, &weights, feature, seed)?;
    let mut order: Vec<usize> = (0..ew * eh).collect();
    order.sort_by(|&a, &b| rarity.at(b % ew, b / ew, 0).total_cmp(&rarity.at(a % ew, a / ew, 0)).then(a.cmp(&b)));
    let rare = ((ew * eh) as f32 * RARE_SHARE).ceil() as usize;
    let mean = |ids: &[usize]| ids.iter().map(|&i| uses.at(i % ew, i / ew, 0) as f64).sum::<f64>() / ids.len().max(1) as f64;
    let all = mean(&order);
    Ok(if all > 0.0 { (mean(&order[..rare]) / all) as f32 } else { 0.0 })
}

/// Blur of [`material_drift`]'s families, in pixels: materials at the
/// scale of a small feature, not pixel colours.
const FAMILY_SIGMA: f32 = 4.0;

/// Material drift: how far the output's mix of materials is from the
/// exemplar's. The exemplar's colours are clustered into
/// [`crate::synth::families`] (blurred at [`FAMILY_SIGMA`]); every output
/// pixel joins its nearest family; the result is the total variation
/// distance between the two shares, half the sum of their absolute
/// differences. 0 = the same mix; 0.4 = 40% of the output is of the wrong
/// material (a corner of teal paint grown to half of a rust enlargement).
pub fn material_drift(output: &Image, exemplar: &Image, seed: u64) -> Result<f32> {
    let weights = vec![1.0 / exemplar.channels() as f32; exemplar.channels()];
    let families = crate::synth::families::Families::of(exemplar, &weights, FAMILY_SIGMA, seed)?;
    let got = families.shares_in(output)?;
    Ok((0.5 * got.iter().zip(families.shares()).map(|(a, b)| (a - b).abs()).sum::<f64>()) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples;

    #[test]
    fn a_material_grown_past_its_share_is_measured() {
        // Cobbles with a red corner (a quarter of a quarter); the exemplar
        // tiled 2 x 2 keeps the mix, the same with the red corner grown
        // over the whole right half does not.
        let ground = samples::cobbles(96, 96, 3);
        let red = |x: usize, y: usize| x >= 72 && y >= 72;
        let ex = Image::from_fn(96, 96, 3, |x, y, p| {
            p.copy_from_slice(if red(x, y) { &[0.8, 0.15, 0.1] } else { ground.pixel(x, y) });
        });
        let tiled = Image::from_fn(192, 192, 3, |x, y, p| p.copy_from_slice(ex.pixel(x % 96, y % 96)));
        let grown =
            Image::from_fn(192, 192, 3, |x, y, p| p.copy_from_slice(if x >= 96 { &[0.8, 0.15, 0.1] } else { ex.pixel(x % 96, y % 96) }));
        let kept = material_drift(&tiled, &ex, 1).unwrap();
        let drifted = material_drift(&grown, &ex, 1).unwrap();
        assert!(kept < 0.05, "tiled: {kept}");
        assert!(drifted > 0.35, "red over half: {drifted}");
    }

    #[test]
    fn a_stamped_feature_is_told_from_a_sparing_one() {
        // Blotches with one red disc; outputs 2x its side made of the
        // exemplar tiled 2 x 2 (the disc 4 times: its share) and of the
        // same with every disc painted out (never copied).
        let ground = samples::blotches(96, 96, 7);
        let disc = |x: usize, y: usize| (x as f32 - 40.0).hypot(y as f32 - 52.0) < 8.0;
        let ex = Image::from_fn(96, 96, 3, |x, y, p| {
            p.copy_from_slice(if disc(x, y) { &[0.95, 0.1, 0.1] } else { ground.pixel(x, y) });
        });
        let tiled = Image::from_fn(192, 192, 3, |x, y, p| p.copy_from_slice(ex.pixel(x % 96, y % 96)));
        let painted = Image::from_fn(192, 192, 3, |x, y, p| {
            p.copy_from_slice(if disc(x % 96, y % 96) { ground.pixel(x % 96, (y + 40) % 96) } else { ex.pixel(x % 96, y % 96) });
        });
        let share = rare_feature_use(&tiled, &ex, 9, 16, 1).unwrap();
        let never = rare_feature_use(&painted, &ex, 9, 16, 1).unwrap();
        assert!((0.7..=1.3).contains(&share), "tiled: {share}");
        eprintln!("rare use: tiled {share:.2}, disc painted out {never:.2}");
        assert!(never < 0.6 * share, "disc painted out: {never}, tiled {share}");
    }

    #[test]
    fn a_pasted_grid_and_a_vignette_and_repeated_stamps_are_measured() {
        let tex = samples::cobbles(192, 192, 2);
        let base = grid_peak(&tex);
        // Brightness steps every 32 px (blocks at different exposure).
        let blocks = Image::from_fn(192, 192, 3, |x, y, p| {
            let gain = if (x / 32 + y / 32) % 2 == 0 { 1.0 } else { 0.8 };
            for (c, v) in p.iter_mut().enumerate() {
                *v = tex.at(x, y, c) * gain;
            }
        });
        assert!(grid_peak(&blocks) > 1.5 * base, "{} vs {base}", grid_peak(&blocks));
        let lit = Image::from_fn(192, 192, 3, |x, y, p| {
            let g = 0.4 + 0.6 * x as f32 / 191.0;
            for (c, v) in p.iter_mut().enumerate() {
                *v = tex.at(x, y, c) * g;
            }
        });
        assert!(nonstationarity(&lit) > 4.0 * nonstationarity(&tex), "{} vs {}", nonstationarity(&lit), nonstationarity(&tex));
        // The same 48 px block pasted on a lattice.
        let stamp = Image::from_fn(192, 192, 3, |x, y, p| p.copy_from_slice(tex.pixel(x % 48 + 20, y % 48 + 20)));
        let own = repeated_share(&tex, 9, 16, 1).unwrap();
        let rep = repeated_share(&stamp, 9, 16, 1).unwrap();
        assert!(own < 0.05 && rep > 0.8, "natural {own}, stamped {rep}");
    }
}
