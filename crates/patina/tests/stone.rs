//! Stone weathering in a photograph (Xue et al. 2011) on a photo the tests
//! make: a shaded relief with carved grooves and fine grain, on a textured
//! background, with an object mask.

use patina::image::color::luminance;
use patina::image::filter::gaussian_blur;
use patina::image::{Image, Mask};
use patina::metrics::{grid_peak, ks_distance, roc_auc};
use patina::samples::value_noise;
use patina::stone::{self, StoneParams};

const W: usize = 192;
const H: usize = 160;

/// The object's tight mask: the pixels the slab covers more than half of.
fn slab() -> Mask {
    Mask::from_fn(W, H, |x, y| coverage(x, y) > 0.5)
}

/// The carved field, where the inscription is.
fn carved(i: usize) -> bool {
    (60..132).contains(&(i % W)) && (52..108).contains(&(i / W))
}

/// A stroke from one point to another.
type Segment = ((f32, f32), (f32, f32));

/// Letter-like strokes: 22 segments at random places, lengths and
/// multiples of 45 degrees, inside the carved field.
fn strokes() -> Vec<Segment> {
    use patina::rng::Rng;
    let mut rng = patina::rng::generator(19, &[]);
    (0..22)
        .map(|_| {
            let (x, y) = (64.0 + rng.gen::<f32>() * 64.0, 56.0 + rng.gen::<f32>() * 48.0);
            let angle = (rng.gen::<f32>() * 8.0).floor() * std::f32::consts::FRAC_PI_4;
            let len = 8.0 + rng.gen::<f32>() * 12.0;
            let end = ((x + len * angle.cos()).clamp(62.0, 130.0), (y + len * angle.sin()).clamp(54.0, 106.0));
            ((x, y), end)
        })
        .collect()
}

/// Depth of the carving at (x, y): grooves of Gaussian profile (sigma 3
/// px) along the strokes, merged smoothly where they meet, so the carving
/// lives at scales above the per-pixel grain.
fn depth(strokes: &[Segment], x: f32, y: f32) -> f32 {
    let dist = |&((ax, ay), (bx, by)): &Segment| {
        let (dx, dy) = (bx - ax, by - ay);
        let t = (((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy).max(1e-6)).clamp(0.0, 1.0);
        ((x - ax - t * dx).powi(2) + (y - ay - t * dy).powi(2)).sqrt()
    };
    1.0 - (-strokes.iter().map(|s| (-(dist(s) / 4.2).powi(2)).exp()).sum::<f32>()).exp()
}

/// The grain: independent per-pixel noise, uniform in +-0.03.
fn grain(x: usize, y: usize) -> f32 {
    0.06 * ((patina::rng::derive(11, &[x as u64, y as u64]) >> 40) as f32 / (1u64 << 24) as f32 - 0.5)
}

/// How much of pixel (x, y) the slab covers: 1 inside, 0 outside, and a
/// 3 px ramp across its edge (a photo's anti-aliased, slightly soft rim).
fn coverage(x: usize, y: usize) -> f32 {
    let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
    let inside = (fx - 24.0).min(W as f32 - 24.0 - fx).min(fy - 24.0).min(H as f32 - 24.0 - fy);
    ((inside + 1.5) / 3.0).clamp(0.0, 1.0)
}

/// The background: a mottled green.
fn background(x: usize, y: usize) -> [f32; 3] {
    let m = value_noise(5, x as f32 / 6.0, y as f32 / 6.0);
    [0.15 + 0.1 * m, 0.35 + 0.2 * m, 0.12 + 0.05 * m]
}

/// Carved relief lit from the top left (grooves with a dark upper and a
/// bright lower wall, darker at the bottom), plus per-pixel grain, on the
/// background; the slab's rim is darker (its edge turns away from the
/// light) and blends into the background over 3 px.
fn photo() -> Image {
    photo_on(background)
}

/// [`photo`]'s slab on the given background.
fn photo_on(background: impl Fn(usize, usize) -> [f32; 3]) -> Image {
    let strokes = strokes();
    Image::from_fn(W, H, 3, |x, y, p| {
        let (fx, fy) = (x as f32, y as f32);
        let d = |dx: f32, dy: f32| depth(&strokes, fx + dx, fy + dy);
        let shade = 0.9 * (d(-1.0, -1.0) - d(1.0, 1.0)) - 0.15 * d(0.0, 0.0);
        let a = coverage(x, y);
        let v = (0.55 + shade + grain(x, y)).clamp(0.0, 1.0) * if a < 1.0 { 0.6 } else { 1.0 };
        let bg = background(x, y);
        let stone = [v, v * 0.97, v * 0.92];
        for c in 0..3 {
            p[c] = a * stone[c] + (1.0 - a) * bg[c];
        }
    })
}

/// The slab's grain alone, flat, as the ground truth for the grain band.
fn grain_only() -> Image {
    Image::from_fn(W, H, 3, |x, y, p| p.fill(0.55 + grain(x, y)))
}

/// Mean square of the band between two Gaussian scales, over `region`.
fn band_energy(img: &Image, region: &[usize], fine: f32, coarse: f32) -> f64 {
    let l = luminance(img);
    let (a, b) = (if fine > 0.0 { gaussian_blur(&l, fine) } else { l }, gaussian_blur(&luminance(img), coarse));
    region.iter().map(|&i| ((a.data()[i] - b.data()[i]) as f64).powi(2)).sum::<f64>() / region.len() as f64
}

#[test]
fn carvings_wear_away_while_the_grain_stays_and_no_lattice_appears() {
    let params = StoneParams { roughen: false, erosion: false, n: 400.0, ..Default::default() };
    let input = photo();
    let prep = stone::prepare(&input, Some(&slab()), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[0.0, 50.0, 100.0, 200.0], 1, None).unwrap();
    // The carved field is the ground truth for where weathering acts.
    let busy: Vec<usize> = (0..W * H).filter(|&i| carved(i)).collect();
    // The plain slab, away from its rim.
    let inner = slab().erode(6);
    let plain: Vec<usize> = (0..W * H).filter(|&i| inner.bits()[i] && !carved(i)).collect();
    let lines = strokes();
    let grooves: Vec<usize> = busy.iter().copied().filter(|&i| depth(&lines, (i % W) as f32, (i / W) as f32) > 0.3).collect();
    // The tendency tells the grooves from the plain slab.
    let scores: Vec<f32> = grooves.iter().chain(&plain).map(|&i| prep.tendency.data()[i]).collect();
    let labels: Vec<bool> = grooves.iter().map(|_| true).chain(plain.iter().map(|_| false)).collect();
    let auc = roc_auc(&scores, &labels);
    assert!(auc >= 0.9, "tendency AUC {auc}");
    // The carving band (1.5 to 6 px) wears with t, to at most 3/4 at t = 200.
    let carving: Vec<f64> = frames.iter().map(|f| band_energy(&f.image, &busy, 1.5, 6.0)).collect();
    for pair in carving.windows(2) {
        assert!(pair[1] < pair[0], "the carving must wear with t: {carving:?}");
    }
    assert!(carving[3] <= 0.75 * carving[0], "carving kept {:.2} at t = 200", carving[3] / carving[0]);
    // The sub-pixel grain keeps at least 3/4 of its energy at every t. It is
    // measured between the grooves of the carved field, where the stone
    // wears (the patches there are at w < 0.7 by t = 200) but the
    // grooves put nothing into the band: the grain alone is the truth.
    let between: Vec<usize> = busy.iter().copied().filter(|&i| depth(&lines, (i % W) as f32, (i / W) as f32) < 0.02).collect();
    let weights = prep.borrowing.weights(&prep.mask, (params.k, 200.0), &stone::update::chips(W, H, 1));
    let mean_w = between.iter().map(|&i| weights.data()[i]).sum::<f32>() / between.len() as f32;
    assert!(between.len() > 300 && mean_w < 0.7, "{} px between the grooves at w = {mean_w}", between.len());
    let truth = band_energy(&grain_only(), &between, 0.0, 1.0);
    let grooves = band_energy(&input, &between, 0.0, 1.0) - truth;
    assert!(grooves.abs() < 0.1 * truth, "the test's grooves leak into the grain band: {grooves} vs {truth}");
    for f in &frames {
        let g = band_energy(&f.image, &between, 0.0, 1.0) / truth;
        assert!(g >= 0.75, "t = {}: grain kept {g:.2}", f.t);
    }
    // No lattice: the block-grid peak of the worn slab stays near the input's.
    let inner = |img: &Image| img.crop(28, 28, W - 56, H - 56).unwrap();
    let (before, after) = (grid_peak(&inner(&input)), grid_peak(&inner(&frames[3].image)));
    assert!(after <= 1.5 * before, "grid peak {before} -> {after}");
    eprintln!(
        "carving kept {:.2}, grain kept {:.2}, grid peak {before:.2} -> {after:.2}, tendency AUC {auc:.2}",
        carving[3] / carving[0],
        band_energy(&frames[3].image, &between, 0.0, 1.0) / truth
    );
}

/// Grime in the grooves (brown, the stronger the deeper) is colour on the
/// stone, not relief: as the carving wears, the grooves keep their tint.
#[test]
fn grime_in_the_grooves_keeps_its_colour_as_the_carving_wears() {
    let lines = strokes();
    let clean = photo();
    let input = Image::from_fn(W, H, 3, |x, y, p| {
        let dirt = if slab().get(x, y) { depth(&lines, x as f32, y as f32) } else { 0.0 };
        let tint = [1.0, 1.0 - 0.2 * dirt, 1.0 - 0.45 * dirt];
        p.iter_mut().zip(clean.pixel(x, y)).zip(tint).for_each(|((o, v), k)| *o = v * k);
    });
    let params = StoneParams { roughen: false, pits: false, erosion: false, n: 400.0, ..Default::default() };
    let prep = stone::prepare(&input, Some(&slab()), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[0.0, 200.0], 1, None).unwrap();
    let grooves: Vec<usize> = (0..W * H).filter(|&i| carved(i) && depth(&lines, (i % W) as f32, (i / W) as f32) > 0.5).collect();
    // Red over blue, averaged over the grooves.
    let warmth =
        |img: &Image| grooves.iter().map(|&i| img.data()[3 * i] / img.data()[3 * i + 2].max(1e-3)).sum::<f32>() / grooves.len() as f32;
    let (before, after) = (warmth(&input), warmth(&frames[1].image));
    let carving = band_energy(&frames[1].image, &grooves, 1.5, 6.0) / band_energy(&input, &grooves, 1.5, 6.0);
    assert!(carving < 0.75, "the carving kept {carving:.2}: it must wear for the test to mean anything");
    assert!(after - 1.0 > 0.8 * (before - 1.0), "the grooves' red/blue went {before:.3} -> {after:.3}");
    eprintln!("grooves' red/blue {before:.3} -> {after:.3}, carving kept {carving:.2}");
}

/// A deep shadow's tint is the sky's, not the stone's: where the wear fills
/// a shadowed groove wall in (lifting it more than threefold), the wall
/// takes the lit stone's colour instead of turning into a bright blue patch.
#[test]
fn shadows_filled_in_by_the_wear_take_the_lit_stones_colour() {
    let clean = photo();
    // Sky-lit shadow: the darker a slab pixel is than the plain stone
    // (0.55), the bluer.
    let shadow = |x: usize, y: usize| if slab().get(x, y) { ((0.55 - clean.at(x, y, 0)) / 0.4).clamp(0.0, 1.0) } else { 0.0 };
    let input = Image::from_fn(W, H, 3, |x, y, p| {
        let s = shadow(x, y);
        let tint = [1.0 - 0.35 * s, 1.0 - 0.1 * s, 1.0];
        p.iter_mut().zip(clean.pixel(x, y)).zip(tint).for_each(|((o, v), k)| *o = v * k);
    });
    let params = StoneParams { roughen: false, pits: false, erosion: false, n: 400.0, ..Default::default() };
    let prep = stone::prepare(&input, Some(&slab()), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[200.0], 1, None).unwrap();
    let linear = |img: &Image| luminance(&img.map(|v| v.powf(2.2)));
    let (before, after) = (linear(&input), linear(&frames[0].image));
    let lifted: Vec<usize> =
        (0..W * H).filter(|&i| carved(i) && shadow(i % W, i / W) > 0.5 && after.data()[i] > 3.0 * before.data()[i]).collect();
    assert!(lifted.len() >= 40, "only {} shadow pixels were lifted threefold: the test needs them", lifted.len());
    // Blue over red, averaged over the lifted shadows.
    let coolness =
        |img: &Image| lifted.iter().map(|&i| img.data()[3 * i + 2] / img.data()[3 * i].max(1e-3)).sum::<f32>() / lifted.len() as f32;
    let (was, is) = (coolness(&input), coolness(&frames[0].image));
    assert!(is - 1.0 < 0.5 * (was - 1.0), "the lifted shadows' blue/red went {was:.3} -> {is:.3}");
    eprintln!("{} lifted shadow pixels, blue/red {was:.3} -> {is:.3}", lifted.len());
}

/// The photo's own pits open, not heal: small dark holes in the plain
/// stone between the carving stay at least as dark, against the stone
/// around them, as the carving around them wears.
#[test]
fn the_stones_own_pits_stay_open_as_the_carving_wears() {
    let lines = strokes();
    let plain = |x: f32, y: f32| (-3..=3).all(|d| depth(&lines, x + d as f32, y) < 0.15 && depth(&lines, x, y + d as f32) < 0.15);
    let mut centres: Vec<(f32, f32)> = Vec::new();
    for (x, y) in (0..30).flat_map(|i| (0..23).map(move |j| (64.5 + 2.0 * i as f32, 56.5 + 2.0 * j as f32))) {
        if plain(x, y) && centres.iter().all(|&(a, b)| (a - x).hypot(b - y) > 9.0) {
            centres.push((x, y));
        }
    }
    assert!(centres.len() >= 6, "only {} plain places for pits", centres.len());
    let in_pit = |x: usize, y: usize| centres.iter().any(|&(cx, cy)| (x as f32 + 0.5 - cx).hypot(y as f32 + 0.5 - cy) < 1.6);
    let clean = photo();
    let input = Image::from_fn(W, H, 3, |x, y, p| {
        let k = if in_pit(x, y) { 0.3 } else { 1.0 };
        p.iter_mut().zip(clean.pixel(x, y)).for_each(|(o, v)| *o = v * k);
    });
    let params = StoneParams { roughen: false, erosion: false, n: 400.0, ..Default::default() };
    let prep = stone::prepare(&input, Some(&slab()), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[200.0], 1, None).unwrap();
    // Each pit's luminance (linear) over the stone's 3.5 to 5.5 px around it.
    let depth = |img: &Image| {
        let l = luminance(&img.map(|v| v.powf(2.2)));
        let mean = |keep: &dyn Fn(f32) -> bool, c: (f32, f32)| {
            let v: Vec<f32> =
                (0..W * H).filter(|&i| keep(((i % W) as f32 + 0.5 - c.0).hypot((i / W) as f32 + 0.5 - c.1))).map(|i| l.data()[i]).collect();
            v.iter().sum::<f32>() / v.len() as f32
        };
        centres.iter().map(|&c| mean(&|r| r < 1.0, c) / mean(&|r| (3.5..5.5).contains(&r), c)).sum::<f32>() / centres.len() as f32
    };
    let field: Vec<usize> = (0..W * H).filter(|&i| carved(i) && !in_pit(i % W, i / W)).collect();
    let carving = band_energy(&frames[0].image, &field, 1.5, 6.0) / band_energy(&input, &field, 1.5, 6.0);
    let (before, after) = (depth(&input), depth(&frames[0].image));
    assert!(carving < 0.75, "the carving kept {carving:.2}: it must wear for the test to mean anything");
    assert!(after <= before * 1.1, "the pits healed: luminance over their surroundings {before:.3} -> {after:.3}");
    eprintln!("pits {before:.3} -> {after:.3} of their surroundings, carving kept {carving:.2}");
}

/// Grass over the stone is not stone: thin green blades across the slab
/// stay as they are while the carving beside them wears.
#[test]
fn grass_over_the_stone_stays_as_it_is() {
    // Blades: 2 px wide lines leaning from the slab's foot.
    let blade = |x: usize, y: usize| {
        let (fx, fy) = (x as f32, y as f32);
        (0..6).any(|k| {
            let x0 = 40.0 + 22.0 * k as f32;
            let lean = if k % 2 == 0 { 0.35 } else { -0.3 };
            (108.0..136.0).contains(&fy) && (fx - (x0 + lean * (136.0 - fy))).abs() < 1.0
        })
    };
    let clean = photo();
    let input = Image::from_fn(W, H, 3, |x, y, p| {
        if blade(x, y) {
            p.copy_from_slice(&[0.35, 0.55, 0.12]);
        } else {
            p.copy_from_slice(clean.pixel(x, y));
        }
    });
    let params = StoneParams { erosion: false, n: 400.0, ..Default::default() };
    let prep = stone::prepare(&input, Some(&slab()), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[200.0], 1, None).unwrap();
    // Blade pixels whose neighbours are blade too (the core).
    let core: Vec<usize> = (0..W * H)
        .filter(|&i| slab().bits()[i] && [0, 1, W, W + 1].iter().all(|&d| i + d < W * H && blade((i + d) % W, (i + d) / W)))
        .collect();
    let change = core
        .iter()
        .map(|&i| (0..3).map(|c| (frames[0].image.data()[3 * i + c] - input.data()[3 * i + c]).abs()).sum::<f32>() / 3.0)
        .sum::<f32>()
        / core.len() as f32;
    let field: Vec<usize> = (0..W * H).filter(|&i| carved(i)).collect();
    let carving = band_energy(&frames[0].image, &field, 1.5, 6.0) / band_energy(&input, &field, 1.5, 6.0);
    assert!(core.len() > 60, "only {} blade pixels", core.len());
    assert!(carving < 0.75, "the carving kept {carving:.2}: it must wear for the test to mean anything");
    assert!(change < 0.01, "the blades changed by {change:.3} on average");
    eprintln!("blades changed by {change:.4}, carving kept {carving:.2}");
}

#[test]
fn the_form_keeps_its_luminance_histogram() {
    let params = StoneParams { erosion: false, n: 400.0, ..Default::default() };
    let (input, mask) = (photo(), slab());
    let prep = stone::prepare(&input, Some(&mask), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[100.0], 2, None).unwrap();
    let values = |img: &Image| {
        let l = gaussian_blur(&luminance(img), prep.scale);
        (0..W * H).filter(|&i| mask.bits()[i]).map(|i| l.data()[i]).collect::<Vec<f32>>()
    };
    assert_ne!(input.data(), frames[0].image.data(), "the frame should differ from the input");
    let ks = ks_distance(&values(&input), &values(&frames[0].image));
    assert!(ks <= 0.05, "KS distance {ks}");
}

#[test]
fn the_silhouette_erodes_fastest_at_the_top_without_a_ghost_outline() {
    let params = StoneParams { erosion_speed: 0.0015, ..Default::default() };
    let input = photo();
    let mask = slab();
    let prep = stone::prepare(&input, Some(&mask), None, &params).unwrap();
    // The tight mask is dilated to take in the anti-aliased rim.
    assert!(prep.mask.count() > mask.count() && (0..W * H).all(|i| !mask.bits()[i] || prep.mask.bits()[i]));
    let frames = stone::sequence(&prep, &[0.0, 25.0, 50.0, 100.0], 3, None).unwrap();
    let areas: Vec<usize> = frames.iter().map(|f| f.mask.count()).collect();
    assert_eq!(areas[0], prep.mask.count());
    for pair in areas.windows(2) {
        assert!(pair[1] < pair[0], "the object must shrink at every step: {areas:?}");
    }
    let last = &frames[3];
    let lost = |rows: std::ops::Range<usize>| {
        rows.flat_map(|y| (0..W).map(move |x| (x, y))).filter(|&(x, y)| mask.get(x, y) && !last.mask.get(x, y)).count()
    };
    let (top, bottom) = (lost(24..40), lost(H - 40..H - 24));
    assert!(top > bottom * 6 / 5, "top lost {top} px, bottom {bottom}");
    // Outside the dilated mask every pixel is the input's, bit for bit.
    for f in &frames {
        for y in 0..H {
            for x in 0..W {
                if !prep.mask.get(x, y) {
                    assert_eq!(f.image.pixel(x, y), input.pixel(x, y), "t = {}: background ({x}, {y}) changed", f.t);
                }
            }
        }
    }
    // Removed pixels away from the new outline show the background (the
    // test knows it), with no dark ring where the rim was.
    let standing = last.mask.dilate(1);
    let removed: Vec<(usize, usize)> =
        (0..W * H).map(|i| (i % W, i / W)).filter(|&(x, y)| prep.mask.get(x, y) && !standing.get(x, y)).collect();
    assert!(removed.len() > 200, "only {} px removed", removed.len());
    let error = |&(x, y): &(usize, usize)| {
        let (o, b) = (last.image.pixel(x, y), background(x, y));
        ((o[0] - b[0]).powi(2) + (o[1] - b[1]).powi(2) + (o[2] - b[2]).powi(2)).sqrt()
    };
    let mean = removed.iter().map(error).sum::<f32>() / removed.len() as f32;
    let rim: Vec<&(usize, usize)> = removed.iter().filter(|&&(x, y)| coverage(x, y) > 0.0 && coverage(x, y) < 1.0).collect();
    let rim_mean = rim.iter().map(|p| error(p)).sum::<f32>() / rim.len().max(1) as f32;
    // The rim itself, had it stayed, would be this far from the background.
    let ghost = rim.iter().map(|&&(x, y)| {
        let (o, b) = (input.pixel(x, y), background(x, y));
        ((o[0] - b[0]).powi(2) + (o[1] - b[1]).powi(2) + (o[2] - b[2]).powi(2)).sqrt()
    });
    let ghost_mean = ghost.sum::<f32>() / rim.len().max(1) as f32;
    assert!(rim.len() > 40, "only {} rim pixels removed", rim.len());
    eprintln!("removed pixels off the background by {mean:.3} (rim {rim_mean:.3}; left as it was {ghost_mean:.3})");
    assert!(
        mean.max(rim_mean) < 0.06f32.min(0.5 * ghost_mean),
        "removed pixels differ from the background by {mean} (rim {rim_mean}; left as it was {ghost_mean})"
    );
}

/// The ring a tight mask is dilated by (part stone, part background) is
/// eroded with the object but never weathered: standing, it keeps the
/// photo's pixels, so where it stays (the foot, or without erosion) no
/// weathered fringe of background shows along the outline.
#[test]
fn the_rim_ring_keeps_the_photo_while_it_stands() {
    let params = StoneParams { erosion: false, ..Default::default() };
    let (input, mask) = (photo(), slab());
    let prep = stone::prepare(&input, Some(&mask), None, &params).unwrap();
    let ring: Vec<usize> = (0..W * H).filter(|&i| prep.mask.bits()[i] && !mask.bits()[i]).collect();
    assert!(ring.len() > 500, "the ring has {} px", ring.len());
    let last = stone::sequence(&prep, &[0.0, 200.0], 3, None).unwrap().pop().unwrap();
    let changed = ring.iter().filter(|&&i| last.image.pixel(i % W, i / W) != input.pixel(i % W, i / W)).count();
    assert_eq!(changed, 0, "{changed} of {} ring pixels weathered", ring.len());
    // The stone proper does weather.
    let inside = (0..W * H).filter(|&i| mask.bits()[i] && last.image.pixel(i % W, i / W) != input.pixel(i % W, i / W)).count();
    assert!(inside * 2 > mask.count(), "only {inside} of {} stone pixels changed", mask.count());
}

/// Diagonal stripes, 10 px apart: a background whose every pixel the
/// test knows and that a mirror across the outline turns into chevrons.
fn stripes(x: usize, y: usize) -> [f32; 3] {
    if (x + y) % 10 < 5 {
        [0.2, 0.45, 0.15]
    } else {
        [0.55, 0.3, 0.2]
    }
}

#[test]
fn the_background_behind_eroded_stone_continues_its_pattern() {
    let params = StoneParams { erosion_speed: 0.0015, ..Default::default() };
    let input = photo_on(stripes);
    let prep = stone::prepare(&input, Some(&slab()), None, &params).unwrap();
    let frames = stone::sequence(&prep, &[0.0, 100.0], 3, None).unwrap();
    let last = &frames[1];
    // Removed pixels at least 2 px from the standing stone (the outline
    // blends over 2 px) and 3 px inside the old rim, which the photo mixes.
    let standing = last.mask.dilate(2);
    let inner = slab().erode(1);
    let removed: Vec<(usize, usize)> =
        (0..W * H).map(|i| (i % W, i / W)).filter(|&(x, y)| inner.get(x, y) && !standing.get(x, y)).collect();
    assert!(removed.len() > 150, "only {} px removed", removed.len());
    let wrong = removed
        .iter()
        .filter(|&&(x, y)| {
            let (o, b) = (last.image.pixel(x, y), stripes(x, y));
            ((o[0] - b[0]).powi(2) + (o[1] - b[1]).powi(2) + (o[2] - b[2]).powi(2)).sqrt() > 0.15
        })
        .count() as f32
        / removed.len() as f32;
    eprintln!("{:.2} of {} removed pixels off the stripes", wrong, removed.len());
    assert!(wrong < 0.25, "{wrong:.2} of the removed pixels are not the stripes behind them");
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

/// A flat light stone on a flat dark ground: where the silhouette has
/// eroded, the new outline is anti-aliased on both sides, not a pixel cut.
/// Across every standing/eroded pixel pair along it, the step in value is
/// measured against the full stone-to-ground contrast.
#[test]
fn the_eroded_outline_is_anti_aliased() {
    let (w, h) = (160, 140);
    let object = Mask::from_fn(w, h, |x, y| (30..130).contains(&x) && (30..120).contains(&y));
    let input = Image::from_fn(w, h, 3, |x, y, p| p.fill(if object.get(x, y) { 0.8 } else { 0.1 }));
    let params = StoneParams { erosion_speed: 0.004, roughen: false, pits: false, mask_dilation: 0, ..Default::default() };
    let prep = stone::prepare(&input, Some(&object), None, &params).unwrap();
    let last = stone::sequence(&prep, &[100.0], 1, None).unwrap().remove(0);
    let l = luminance(&last.image);
    let (mut steps, mut sharp) = (0usize, 0usize);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            // A standing pixel next to an eroded one (not the original outline).
            if !last.mask.get(x, y) {
                continue;
            }
            for (nx, ny) in [(x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)] {
                if object.get(nx, ny) && !last.mask.get(nx, ny) {
                    steps += 1;
                    if (l.at(x, y, 0) - l.at(nx, ny, 0)).abs() > 0.6 * (0.8 - 0.1) {
                        sharp += 1;
                    }
                }
            }
        }
    }
    assert!(steps > 100, "the silhouette should erode: {steps} outline steps");
    assert!(sharp * 10 < steps, "{sharp} of {steps} steps along the eroded outline are hard cuts");
}
