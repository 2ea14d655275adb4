//! Stone weathering in a photograph (Xue et al. 2011) on a photo the tests
//! make: a shaded relief with carved grooves and fine grain, on a textured
//! background, with an object mask.

use patina::image::color::luminance;
use patina::image::filter::gaussian_blur;
use patina::image::{Image, Mask};
use patina::metrics::ks_distance;
use patina::samples::value_noise;
use patina::stone::{self, StoneParams};

const W: usize = 192;
const H: usize = 160;

/// The object: a slab inset 24 px from every side.
fn slab() -> Mask {
    Mask::from_fn(W, H, |x, y| (24..W - 24).contains(&x) && (24..H - 24).contains(&y))
}

/// Carved relief, lit from the top left: grooves (a letter-like lattice of
/// bars over a fifth of the slab, like an inscription) with a bright upper and dark lower lip, plus per-pixel grain; the
/// background is a mottled green.
fn photo() -> Image {
    let slab = slab();
    Image::from_fn(W, H, 3, |x, y, p| {
        let grain = 0.08 * (value_noise(11, x as f32 * 1.7, y as f32 * 1.7) - 0.5);
        if slab.get(x, y) {
            // Smooth groove profiles (a bright upper lip, a dark lower one), so
            // the carving lives at scales above the per-pixel grain.
            let groove = |u: usize, period: usize| {
                let r = (u % period) as f32;
                0.25 * (-((r - 5.0) / 2.0).powi(2)).exp() - 0.2 * (-((r - 10.0) / 2.4).powi(2)).exp()
            };
            let carve = if (56..104).contains(&y) && (60..132).contains(&x) { groove(x, 18) + groove(y, 22) } else { 0.0 };
            let v = (0.55 + carve + grain).clamp(0.0, 1.0);
            p.copy_from_slice(&[v, v * 0.97, v * 0.92]);
        } else {
            let m = value_noise(5, x as f32 / 6.0, y as f32 / 6.0);
            p.copy_from_slice(&[0.15 + 0.1 * m, 0.35 + 0.2 * m, 0.12 + 0.05 * m]);
        }
    })
}

/// Mean square of the band between two Gaussian scales, over `region`.
fn band_energy(img: &Image, region: &[usize], fine: f32, coarse: f32) -> f64 {
    let l = luminance(img);
    let (a, b) = (if fine > 0.0 { gaussian_blur(&l, fine) } else { l }, gaussian_blur(&luminance(img), coarse));
    region.iter().map(|&i| ((a.data()[i] - b.data()[i]) as f64).powi(2)).sum::<f64>() / region.len() as f64
}

#[test]
fn carvings_wear_smooth_over_time_while_the_grain_stays() {
    let params = StoneParams { roughen: false, erosion: false, n: 400.0, ..Default::default() };
    let prep = stone::prepare(&photo(), Some(&slab()), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[0.0, 25.0, 50.0, 100.0], 1, None).unwrap();
    // The carved field is the ground truth for where weathering acts.
    let carved = |i: usize| (60..132).contains(&(i % W)) && (56..104).contains(&(i / W));
    let busy: Vec<usize> = (0..W * H).filter(|&i| carved(i)).collect();
    let plain: Vec<usize> = (0..W * H).filter(|&i| slab().bits()[i] && !carved(i)).collect();
    let mean_d = |px: &[usize]| px.iter().map(|&i| prep.tendency.data()[i]).sum::<f32>() / px.len() as f32;
    assert!(mean_d(&busy) > 2.0 * mean_d(&plain), "tendency: carved {} vs plain {}", mean_d(&busy), mean_d(&plain));
    let large: Vec<f64> = frames.iter().map(|f| band_energy(&f.image, &busy, 1.5, 5.0)).collect();
    for pair in large.windows(2) {
        assert!(pair[1] < pair[0], "large-scale detail must decrease with t: {large:?}");
    }
    assert!(large[3] < 0.95 * large[0], "carvings barely softened: {large:?}");
    let grain: Vec<f64> = frames.iter().map(|f| band_energy(&f.image, &busy, 0.0, 1.0)).collect();
    for g in &grain {
        assert!((g / grain[0] - 1.0).abs() <= 0.25, "fine grain must stay within 25%: {grain:?}");
    }
}

#[test]
fn the_silhouette_erodes_monotonically_and_fastest_at_the_top() {
    let params = StoneParams { erosion_speed: 0.0015, ..Default::default() };
    let input = photo();
    let mask = slab();
    let prep = stone::prepare(&input, Some(&mask), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[0.0, 25.0, 50.0, 100.0], 3, None).unwrap();
    let areas: Vec<usize> = frames.iter().map(|f| f.mask.count()).collect();
    assert_eq!(areas[0], mask.count());
    for pair in areas.windows(2) {
        assert!(pair[1] < pair[0], "the object must shrink at every step: {areas:?}");
    }
    let last = &frames[3];
    let lost = |rows: std::ops::Range<usize>| {
        rows.flat_map(|y| (0..W).map(move |x| (x, y))).filter(|&(x, y)| mask.get(x, y) && !last.mask.get(x, y)).count()
    };
    let (top, bottom) = (lost(24..40), lost(H - 40..H - 24));
    assert!(top > bottom * 6 / 5, "top lost {top} px, bottom {bottom}");
    // Only object pixels change: the background is bit-identical except where stone was removed.
    for f in &frames {
        for y in 0..H {
            for x in 0..W {
                if !mask.get(x, y) {
                    assert_eq!(f.image.pixel(x, y), input.pixel(x, y), "t = {}: background ({x}, {y}) changed", f.t);
                }
            }
        }
    }
    // Removed pixels are filled from the background (green), not left as stone.
    let removed: Vec<(usize, usize)> =
        (0..W * H).map(|i| (i % W, i / W)).filter(|&(x, y)| mask.get(x, y) && !last.mask.get(x, y)).collect();
    let green = removed.iter().filter(|&&(x, y)| last.image.at(x, y, 1) > last.image.at(x, y, 0) + 0.08).count();
    assert!(green * 10 >= removed.len() * 9, "{green} of {} eroded pixels look like background", removed.len());
}

#[test]
fn the_luminance_histogram_matches_the_original() {
    let params = StoneParams { erosion: false, n: 400.0, ..Default::default() };
    let (input, mask) = (photo(), slab());
    let prep = stone::prepare(&input, Some(&mask), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[100.0], 2, None).unwrap();
    let values = |img: &Image| {
        let l = luminance(img);
        (0..W * H).filter(|&i| mask.bits()[i]).map(|i| (l.data()[i] * 255.0).round() / 255.0).collect::<Vec<f32>>()
    };
    let (before, after) = (values(&input), values(&frames[0].image));
    assert_ne!(before, after, "the frame should differ from the input");
    let ks = ks_distance(&before, &after);
    assert!(ks <= 0.05, "KS distance {ks}");
}

#[test]
fn the_same_seed_gives_the_same_frames_and_bad_input_is_refused() {
    let params = StoneParams { erosion_speed: 0.0015, ..Default::default() };
    let prep = stone::prepare(&photo(), Some(&slab()), None, &params).unwrap();
    let a = stone::sequence(&prep, &[50.0], 4, None).unwrap();
    let b = stone::sequence(&prep, &[50.0], 4, None).unwrap();
    assert_eq!(a[0].image.data(), b[0].image.data());
    let small = Mask::filled(10, 10, true);
    assert!(stone::prepare(&photo(), Some(&small), None, &params).err().unwrap().to_string().contains("mask"));
    assert!(stone::sequence(&prep, &[50.0, 10.0], 4, None).is_err());
    let bad = StoneParams { eta: -1.0, ..params };
    assert!(stone::prepare(&photo(), Some(&slab()), None, &bad).err().unwrap().to_string().contains("eta"));
}
