//! Texture weathering (Bellini et al. 2016) against ground truth the tests
//! make: clean procedural textures with weathering injected in a known mask.

use patina::image::Image;
use patina::metrics::{pacing, roc_auc, weathering_residue};
use patina::samples::{self, Weathering};
use patina::weather::rebuild::colour_distance;
use patina::weather::{self, age_map, intact, layers::Layers, tiles, transfer, AgeParams, IntactParams, Overrides, WeatherParams};

const SIZE: usize = 160;
const KINDS: [Weathering; 3] = [Weathering::Rust, Weathering::Stain, Weathering::Cracks];

fn clean(base: &str) -> Image {
    samples::by_name(base, SIZE, SIZE, 3).unwrap()
}

/// Share of pixels farther than 0.1 (colour distance) from `intact`.
fn weathered_area(frame: &Image, intact: &Image) -> f32 {
    let d = colour_distance(frame, intact).unwrap();
    d.iter().filter(|&&v| v > 0.1).count() as f32 / d.len() as f32
}

/// The ground truth of the issue: on a stochastic base (stucco), tiles and
/// planks, a crack network over the whole surface, 37% peeling with lips,
/// and 10% rust. Per case, the lowest age-map AUC and the highest intact
/// residue this version reaches, with some margin; below them, a change
/// made the method worse. (The goal is AUC 0.9 and residue 0.2 on
/// every case. Not there yet: the crack network on planks, AUC 0.83 since
/// the boards are found under the cracks (their grooves are then kept out
/// of the age map, and so are the cracks that run along them), and the
/// residue of the peels on stucco, 0.39: the fill copies the stucco's
/// grain verbatim, and the seams between copies are patches the clean
/// stucco does not hold; a smoother fill scored 0.27 and was judged worse
/// on real photos.) The planks' peel needs the weathered material's
/// colour model ([`patina::weather::material`]): without it the peels'
/// plain interiors stay intact (AUC 0.95, residue 0.22). The peel on a
/// busy base (gravel) needs that model's intact seeds to be the clearly
/// young pixels only: with every pixel below the cut as an intact seed,
/// the peels' plain interiors (rated middling) were seeds of both classes
/// and stayed intact (AUC 0.81, residue 0.43; now 0.97 and 0.20), and
/// the link of the rim's faint pixels to the peel
/// ([`patina::weather::intact::allowed_sources`]; residue 0.12).
const GROUND_TRUTH: [(&str, Weathering, f32, f32, f32); 10] = [
    ("stucco", Weathering::CrackNetwork, 0.0, 0.89, 0.3),
    ("stucco", Weathering::Peel, 0.32, 0.95, 0.4),
    ("stucco", Weathering::Rust, 0.1, 0.97, 0.17),
    ("gravel", Weathering::Peel, 0.32, 0.93, 0.17),
    ("tiles", Weathering::CrackNetwork, 0.0, 0.89, 0.05),
    ("tiles", Weathering::Peel, 0.32, 0.97, 0.05),
    ("tiles", Weathering::Rust, 0.1, 0.98, 0.05),
    ("planks", Weathering::CrackNetwork, 0.0, 0.8, 0.12),
    ("planks", Weathering::Peel, 0.32, 0.98, 0.08),
    ("planks", Weathering::Rust, 0.1, 0.95, 0.1),
];

/// Round tiles of which a third have darkened all over, each in its own
/// shade, with a blotchy stain of their own (the stained circle tiles of
/// ../shared/data) are still a grid: the intact texture is their median
/// tile, so the darkened discs come back light and keep their rims. (A
/// colour test of the median tile threw such grids away, and the
/// stochastic fill then erased the rims of the discs it re-made.)
#[test]
fn discs_darkened_each_in_its_own_shade_keep_their_grid_and_come_back_light() {
    let (p, side) = (40, 240);
    let original = samples::disc_grid(side, side, p, 2);
    let darkened = |x: usize, y: usize| {
        let (i, j) = ((x / p) as u64, (y / p) as u64);
        let h = (i * 7 + j * 13 + i * j * 3) % 9;
        (h < 3).then(|| 0.3 + 0.1 * h as f32 + 0.25 * samples::fractal_noise(9, x as f32, y as f32, 6.0, 2))
    };
    let img = Image::from_fn(side, side, 3, |x, y, px| {
        px.copy_from_slice(original.pixel(x, y));
        if let Some(k) = darkened(x, y) {
            px.iter_mut().for_each(|v| *v *= k);
        }
    });
    let age = age_map(&img, &AgeParams::default()).unwrap();
    let result = intact(&img, &age.map, None, &IntactParams::default(), None, 5).unwrap();
    assert!(result.lattice.is_some(), "no grid kept");
    let pf = p as f32;
    let radius = |x: usize, y: usize| {
        let (u, v) = ((x % p) as f32 + 0.5 - pf / 2.0, (y % p) as f32 + 0.5 - pf / 2.0);
        (u * u + v * v).sqrt() / (0.47 * pf)
    };
    let luminance = |im: &Image, x: usize, y: usize| im.pixel(x, y).iter().sum::<f32>() / 3.0;
    let (mut rims, mut rims_light, mut inside, mut lift, mut darkening) = (0, 0, 0, 0.0, 0.0);
    for y in 0..side {
        for x in 0..side {
            if darkened(x, y).is_none() {
                continue;
            }
            let r = radius(x, y);
            if (0.96..0.99).contains(&r) {
                rims += 1;
                rims_light += usize::from(luminance(&result.image, x, y) > 0.55);
            } else if r < 0.8 {
                inside += 1;
                lift += luminance(&result.image, x, y) - luminance(&img, x, y);
                darkening += luminance(&original, x, y) - luminance(&img, x, y);
            }
        }
    }
    let rim_share = rims_light as f32 / rims as f32;
    assert!(rim_share > 0.8, "only {rim_share:.2} of the darkened discs' rims are light");
    // The discs' own shades differ, so the median tile undoes the darkening
    // on average only (0.66 of it).
    let (lift, darkening) = (lift / inside as f32, darkening / inside as f32);
    assert!(lift > 0.5 * darkening, "the darkened discs are lifted by {lift:.3} of {darkening:.3}");
}

#[test]
fn the_age_map_and_the_intact_texture_find_and_remove_injected_weathering() {
    let size = 256;
    let mut aucs = Vec::new();
    for (base, kind, area, min_auc, max_residue) in GROUND_TRUTH {
        let original = samples::by_name(base, size, size, 3).unwrap();
        let (img, mask) = samples::weather(&original, kind, area, 11);
        let share = mask.count() as f32 / (size * size) as f32;
        let expected = if area > 0.0 { area..area + 0.12 } else { 0.02..0.12 };
        assert!(expected.contains(&share), "{base} {kind:?}: injected area {share}");
        let age = age_map(&img, &AgeParams::default()).unwrap();
        let (lo, hi) = age.map.value_range();
        assert!(lo >= 0.0 && hi <= 1.0, "normalised to [0, 1]: {lo}..{hi}");
        let auc = roc_auc(age.map.data(), mask.bits());
        assert!(auc >= min_auc, "{base} with {kind:?}: ROC AUC {auc:.3} < {min_auc}");
        let result = intact(&img, &age.map, None, &IntactParams::default(), None, 5).unwrap();
        let residue = weathering_residue(&result.image, &original, &img, &mask, 5, 1).unwrap();
        assert!(residue <= max_residue, "{base} with {kind:?}: intact keeps {:.0}% of the weathering", 100.0 * residue);
        assert_eq!(result.lattice.is_some(), base == "tiles", "{base} {kind:?}: grid found = {:?}", result.lattice);
        aucs.push(auc);
    }
    let mean = aucs.iter().sum::<f32>() / aucs.len() as f32;
    assert!(mean >= 0.9, "mean AUC {mean:.3}");
}

#[test]
fn the_age_map_finds_injected_weathering_on_regular_and_stochastic_textures() {
    for base in ["tiles", "gravel"] {
        for kind in KINDS {
            let (img, mask) = samples::weather(&clean(base), kind, 0.1, 11);
            let share = mask.count() as f32 / (SIZE * SIZE) as f32;
            assert!((0.05..0.2).contains(&share), "{base} {kind:?}: injected area {share}");
            let age = age_map(&img, &AgeParams::default()).unwrap();
            let (lo, hi) = age.map.value_range();
            assert!(lo >= 0.0 && hi <= 1.0 && hi > 0.99, "normalised to [0, 1]: {lo}..{hi}");
            let auc = roc_auc(age.map.data(), mask.bits());
            // Wandering cracks between 7 px pebbles, whose gaps are as dark,
            // are the hardest of these small cases.
            let floor = if base == "gravel" && kind == Weathering::Cracks { 0.78 } else { 0.85 };
            assert!(auc >= floor, "{base} with {kind:?}: ROC AUC {auc:.3}");
        }
    }
}

#[test]
fn the_age_map_of_a_clean_texture_flags_nothing_in_particular() {
    // Negative control: a random "mask" on a clean texture is not found.
    let img = clean("gravel");
    let (_, mask) = samples::weather(&img, Weathering::Rust, 0.1, 11);
    let age = age_map(&img, &AgeParams::default()).unwrap();
    let auc = roc_auc(age.map.data(), mask.bits());
    assert!((0.25..0.75).contains(&auc), "clean texture: AUC {auc:.3} should be near chance");
}

#[test]
fn tile_detection_finds_the_period_and_calls_gravel_stochastic() {
    let p = samples::TILE_PERIOD as f32;
    for (name, img) in [
        ("tiles", samples::tiles(SIZE, SIZE, 1)),
        ("shifted crop", samples::tiles(300, 300, 1).crop(7, 5, 200, 180).unwrap()),
        ("rusty tiles", samples::weather(&samples::tiles(SIZE, SIZE, 1), Weathering::Rust, 0.1, 3).0),
    ] {
        let l = tiles::detect(&img).unwrap_or_else(|| panic!("{name}: no grid found"));
        let mut periods = [l.a, l.b].map(|v| (v[0].abs(), v[1].abs()));
        periods.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (vertical, horizontal) = (periods[0], periods[1]);
        assert!((horizontal.0 - p).abs() <= 1.0 && horizontal.1 <= 1.0, "{name}: {l:?}");
        assert!((vertical.1 - p).abs() <= 1.0 && vertical.0 <= 1.0, "{name}: {l:?}");
    }
    for name in ["gravel", "cobbles", "blotches"] {
        assert_eq!(tiles::detect(&samples::by_name(name, SIZE, SIZE, 1).unwrap()), None, "{name} is stochastic");
    }
}

#[test]
fn sequences_grow_weathering_monotonically_in_both_directions() {
    let (img, _) = samples::weather(&clean("tiles"), Weathering::Rust, 0.1, 11);
    let r = weather::weather(&img, &WeatherParams::default(), Overrides::default(), 9, &|_| {}).unwrap();
    let ts: Vec<f32> = r.frames.iter().map(|f| f.t).collect();
    assert_eq!(ts.len(), 8);
    assert!(ts.windows(2).all(|w| w[0] < w[1]), "time order: {ts:?}");
    assert_eq!((ts[0], ts[4], ts[7]), (0.0, 1.0, 2.0));
    let areas: Vec<f32> = r.frames.iter().map(|f| weathered_area(&f.image, &r.intact)).collect();
    assert!(areas[0] == 0.0, "t = 0 is the intact texture");
    assert!(areas.windows(2).all(|w| w[1] >= w[0]), "weathered area grows with t: {areas:?}");
    assert!(areas[3] > areas[1], "de-weathering frames differ: {areas:?}");
    assert!(areas[7] > areas[5] && areas[5] > areas[4], "future frames grow strictly: {areas:?}");
    assert!(areas[7] >= 1.5 * areas[4], "t = 2 has {:.3} weathered vs {:.3} at t = 1", areas[7], areas[4]);
    // Past frames: no flicker. A pixel changes when the growing damage
    // reaches it (drawn as rim when it is near the front), maybe once more
    // while the rim band still covers it, and once when the rim moves on
    // and it becomes the input; almost never in every step (measured: 53
    // of 3404 three times, 2 in all four steps).
    let past_steps: Vec<Vec<f32>> = r.frames[..5].windows(2).map(|w| colour_distance(&w[0].image, &w[1].image).unwrap()).collect();
    let past_times = |i: usize| past_steps.iter().filter(|s| s[i] > 0.05).count();
    let n = past_steps[0].len();
    let uncovered = (0..n).filter(|&i| past_times(i) > 0).count();
    let (thrice, always) = ((0..n).filter(|&i| past_times(i) == 3).count(), (0..n).filter(|&i| past_times(i) > 3).count());
    eprintln!("past: uncovered {uncovered}, changed three times {thrice}, in every step {always}");
    assert!(uncovered > 0 && (always as f32) < 0.01 * uncovered as f32, "{always} of {uncovered} past pixels changed in every step");
    assert!((thrice as f32) < 0.1 * uncovered as f32, "{thrice} of {uncovered} past pixels changed three times");
    // Future frames: no flicker. A pixel changes when the front crosses it
    // and, once, when the front's rim moves on past it; never in every
    // step (new damage may be closer to the intact colour than what it
    // replaces, so distance is not the rule).
    let steps: Vec<Vec<f32>> = r.frames[4..].windows(2).map(|w| colour_distance(&w[0].image, &w[1].image).unwrap()).collect();
    let times = |i: usize| steps.iter().filter(|s| s[i] > 0.05).count();
    let changed = (0..steps[0].len()).filter(|&i| times(i) > 0).count();
    let twice = (0..steps[0].len()).filter(|&i| times(i) == 2).count();
    let always = (0..steps[0].len()).filter(|&i| times(i) > 2).count();
    eprintln!("changed {changed} twice {twice} always {always}");
    assert!(always as f32 <= 0.01 * changed as f32, "{always} of {changed} changed pixels change in every future step");
    assert!(twice as f32 <= 0.35 * changed as f32, "{twice} of {changed} changed pixels change twice");
}

#[test]
fn future_frames_add_new_weathered_regions_not_only_darker_old_ones() {
    let (img, mask) = samples::weather(&clean("tiles"), Weathering::Rust, 0.1, 11);
    let r = weather::weather(&img, &WeatherParams::default(), Overrides::default(), 9, &|_| {}).unwrap();
    let last = &r.frames.last().unwrap().image;
    let d = colour_distance(last, &r.intact).unwrap();
    let far = mask.dilate(4);
    let new = d.iter().enumerate().filter(|(i, &v)| v > 0.1 && !far.bits()[*i]).count();
    assert!(new as f32 > 0.02 * (SIZE * SIZE) as f32, "only {new} newly weathered pixels away from the old rust");
}

#[test]
fn transfer_carries_rust_onto_a_clean_texture() {
    let (source, _) = samples::weather(&clean("tiles"), Weathering::Rust, 0.1, 11);
    let target = samples::gravel(SIZE, SIZE, 2);
    let age = age_map(&source, &AgeParams::default()).unwrap();
    let s_intact = intact(&source, &age.map, None, &IntactParams::default(), None, 1).unwrap();
    let frames = transfer::transfer(
        &transfer::Source { image: &source, age: &age.map, intact: &s_intact.image },
        &target,
        &[0.5, 1.0],
        &Default::default(),
        3,
        &|_| {},
    )
    .unwrap();
    let rusty = |img: &Image| img.data().chunks_exact(3).filter(|p| p[0] > 0.45 && p[0] - p[2] > 0.3).count() as f32 / (SIZE * SIZE) as f32;
    let (before, half, full) = (rusty(&target), rusty(&frames[0].image), rusty(&frames[1].image));
    assert!(full > before + 0.03 && full >= half, "rust share: target {before:.3}, t = 0.5 {half:.3}, t = 1 {full:.3}");
    assert!(weathered_area(&frames[1].image, &target) >= weathered_area(&frames[0].image, &target));
}

#[test]
fn weathering_is_the_same_at_any_thread_count() {
    let (img, _) = samples::weather(&samples::tiles(96, 96, 1), Weathering::Stain, 0.1, 4);
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (1, 1);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| weather::weather(&img, &p, Overrides::default(), 21, &|_| {}).unwrap())
    };
    let (a, b) = (run(1), run(3));
    assert_eq!(a.age.data(), b.age.data());
    for (x, y) in a.frames.iter().zip(&b.frames) {
        assert_eq!(x.image.data(), y.image.data(), "frame t = {}", x.t);
    }
}

#[test]
fn user_maps_replace_the_automatic_ones_and_bad_sizes_are_refused() {
    let (img, mask) = samples::weather(&samples::tiles(96, 96, 1), Weathering::Rust, 0.1, 4);
    let original = samples::tiles(96, 96, 1);
    let age = mask.to_image();
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (1, 0);
    let r =
        weather::weather(&img, &p, Overrides { age: Some(&age), intact: Some(&original), labels: None, ..Default::default() }, 1, &|_| {})
            .unwrap();
    assert_eq!(r.age.data(), age.data(), "the user age map is used as given");
    assert_eq!(r.frames[0].image.data(), original.data(), "t = 0 is the user's intact texture");
    let small = Image::new(50, 50, 1);
    let e = weather::weather(&img, &p, Overrides { age: Some(&small), ..Default::default() }, 1, &|_| {}).unwrap_err();
    assert!(e.is_usage() && e.to_string().contains("age map"), "{e}");
    // A grey intact texture of the photo's size, with and without a mask:
    // the message gives the photo's size, not the mask's work area (which
    // it gave with a mask until stop 69).
    let grey = original.select_channels(0..1);
    let part = patina::image::Mask::from_fn(96, 96, |x, y| (20..70).contains(&x) && (10..80).contains(&y));
    for mask in [None, Some(&part)] {
        let e = weather::weather(&img, &p, Overrides { intact: Some(&grey), mask, ..Default::default() }, 1, &|_| {}).unwrap_err();
        assert!(e.is_usage() && e.to_string().contains("(96x96, 1 channels) must match the input (96x96, 3 channels)"), "{e}");
    }
    let tiny = Image::new(12, 12, 3);
    let e = age_map(&tiny, &AgeParams::default()).unwrap_err();
    assert!(e.is_usage() && e.to_string().contains("too small"), "{e}");
}

#[test]
fn layers_split_two_materials_by_colour() {
    // Left: teal paint; right: grey stone; each with its own grain.
    let img = Image::from_fn(64, 48, 3, |x, y, p| {
        let n = samples::value_noise(1, x as f32 / 3.0, y as f32 / 3.0) * 0.1;
        let c = if x < 32 { [0.2, 0.6, 0.6] } else { [0.5, 0.5, 0.48] };
        (0..3).for_each(|i| p[i] = c[i] + n);
    });
    let layers = Layers::kmeans(&img, 2, 7).unwrap();
    assert_eq!(layers.count, 2);
    let left = layers.labels[0];
    for y in 0..48 {
        for x in 0..64 {
            assert_eq!(layers.labels[y * 64 + x] == left, x < 32, "pixel {x},{y}");
        }
    }
    // Each layer's age spans [0, 1] after per-layer normalisation.
    let age = Image::from_fn(64, 48, 1, |x, _, p| p[0] = if x < 32 { 0.1 + x as f32 / 320.0 } else { 0.5 + x as f32 / 640.0 });
    let norm = layers.normalise_age(&age);
    assert_eq!(norm.at(0, 0, 0), 0.0);
    assert_eq!(norm.at(31, 0, 0), 1.0);
    assert_eq!(norm.at(32, 0, 0), 0.0);
}

#[test]
fn past_frames_pace_the_change_evenly() {
    // 37% peeling on planks: the paper's age thresholds revealed most of
    // it in one step; ranks spread it over the three past steps.
    let (img, _) = samples::weather(&samples::planks(192, 192, 3), Weathering::Peel, 0.32, 11);
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (3, 0);
    let r = weather::weather(&img, &p, Overrides::default(), 2, &|_| {}).unwrap();
    let frames: Vec<&Image> = r.frames.iter().map(|f| &f.image).collect();
    assert_eq!(frames.len(), 5);
    let pace = pacing(&frames).unwrap();
    assert!(pace <= 0.45, "one step brings {:.0}% of the intact -> input change", 100.0 * pace);
}

#[test]
fn future_frames_grow_from_the_existing_damage() {
    let (img, mask) = samples::weather(&samples::stucco(192, 192, 3), Weathering::Rust, 0.1, 11);
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (0, 2);
    let r = weather::weather(&img, &p, Overrides::default(), 2, &|_| {}).unwrap();
    let last = &r.frames.last().unwrap().image;
    let d = colour_distance(last, &img).unwrap();
    let changed: Vec<bool> = d.iter().map(|&v| v > 0.1).collect();
    let share = changed.iter().filter(|&&c| c).count() as f32 / d.len() as f32;
    assert!(share >= 0.05, "only {:.1}% of the pixels age from t = 1 to t = 2", 100.0 * share);
    let near = mask.dilate(8);
    let from_front =
        changed.iter().zip(near.bits()).filter(|(c, n)| **c && **n).count() as f32 / changed.iter().filter(|&&c| c).count() as f32;
    assert!(from_front >= 0.6, "only {:.0}% of the new weathering touches the old", 100.0 * from_front);
    // The new damage is rust, not a darkening: its hue is the rust's.
    let rusty = |p: &[f32]| p[0] > p[2] + 0.15;
    let new_rust = last.data().chunks_exact(3).zip(&changed).zip(mask.bits()).filter(|((p, c), m)| **c && !**m && rusty(p)).count();
    let new_total = changed.iter().zip(mask.bits()).filter(|(c, m)| **c && !**m).count().max(1);
    assert!(new_rust as f32 >= 0.5 * new_total as f32, "{new_rust} of {new_total} newly changed pixels look like rust");
}

/// The future grows the damage in proportion to the damage there is: a
/// surface with a few small blooms (2.5% of it) is not half covered at
/// t = 2, and one with many (10%) grows more than one with few.
#[test]
fn future_growth_follows_the_damage_there_is() {
    use patina::weather::growth::clean_share_weathered;
    // The law: the weathered area's odds double per unit of t, with a floor.
    for f in [0.025f32, 0.1, 0.37] {
        let at2 = f + (1.0 - f) * clean_share_weathered(f, 2.0);
        let odds = |f: f32| f / (1.0 - f);
        assert!((odds(at2) / odds(f) - 2.0).abs() < 0.05 || at2 - f <= 0.0701, "{f} -> {at2}");
        assert!(at2 - f >= 0.0699, "{f} grows by only {:.3} by t = 2", at2 - f);
        let mid = f + (1.0 - f) * clean_share_weathered(f, 1.5);
        assert!(f < mid && mid < at2, "{f} -> {mid} -> {at2}: not monotone");
    }
    // On images: the share of damage at t = 2 over the share at t = 1.
    let grown_share = |area: f32| {
        let (img, mask) = samples::weather(&samples::stucco(160, 160, 3), Weathering::Rust, area, 7);
        let last = grown_to_t2(&img, &mask, 3);
        let d = colour_distance(&last, &img).unwrap();
        let new = d.iter().zip(mask.bits()).filter(|(v, m)| **v > 0.1 && !**m).count() as f32;
        (new / (160.0 * 160.0), mask.count() as f32 / (160.0 * 160.0))
    };
    let (few_new, few) = grown_share(0.03);
    let (many_new, many) = grown_share(0.12);
    assert!(few_new <= 0.15, "{:.1}% damage grew by {:.1}% of the surface", 100.0 * few, 100.0 * few_new);
    assert!(many_new > few_new, "more damage grew less: {many_new:.3} (from {many:.3}) vs {few_new:.3} (from {few:.3})");
}

#[test]
fn boards_are_stripes_and_their_grooves_do_not_age() {
    let img = samples::planks(256, 256, 3);
    match tiles::periods(&img) {
        Some(tiles::Periodicity::Stripes(v)) => {
            assert!(v[0].abs() < 1.0 && (v[1].abs() - samples::PLANK_PERIOD as f32).abs() < 1.0, "period {v:?}")
        }
        other => panic!("planks: {other:?}"),
    }
    // The age map of clean planks: the grooves (every 26th row) are not
    // older than the boards.
    let age = age_map(&img, &AgeParams::default()).unwrap();
    let groove = |y: usize| y % samples::PLANK_PERIOD < 2;
    let mean = |pick: &dyn Fn(usize) -> bool| {
        let rows: Vec<usize> = (8..248).filter(|&y| pick(y)).collect();
        rows.iter().map(|&y| (8..248).map(|x| age.map.at(x, y, 0)).sum::<f32>()).sum::<f32>() / (rows.len() * 240) as f32
    };
    let (g, b) = (mean(&groove), mean(&|y| !groove(y)));
    assert!(g <= b + 0.1, "grooves age {g:.3}, boards {b:.3}");
}

#[test]
fn the_weathered_cut_adapts_to_the_damage_and_respects_its_cap() {
    // The cut follows the damage: a 5% crack network, then 37% peeling.
    // (A clean texture is still judged 30-50% weathered: the age map's
    // rarest patches are always rare relative to the rest, and the faint
    // pixels around them are linked to them. Not this method's input, but
    // a known weakness.)
    let clean = samples::stucco(192, 192, 3);
    let judged = |img: &Image| {
        let a = age_map(img, &AgeParams::default()).unwrap();
        intact(img, &a.map, None, &IntactParams::default(), None, 1).unwrap().weathered_fraction
    };
    let cracks = judged(&samples::weather(&clean, Weathering::CrackNetwork, 0.0, 11).0);
    let (img, _) = samples::weather(&clean, Weathering::Peel, 0.32, 11);
    let peel = judged(&img);
    assert!(cracks <= 0.25, "a 5% crack network judged {:.0}% weathered", 100.0 * cracks);
    assert!((0.3..=0.6).contains(&peel) && peel > cracks + 0.1, "37% peel judged {:.0}% weathered", 100.0 * peel);
    let a = age_map(&img, &AgeParams::default()).unwrap();
    let capped = IntactParams { weathered_max: 0.15, ..IntactParams::default() };
    let r = intact(&img, &a.map, None, &capped, None, 1).unwrap();
    assert!(r.weathered_fraction <= 0.16, "the cap 15% gave {:.0}%", 100.0 * r.weathered_fraction);
}

/// Four blooms with a dark rim on `base`: interior `colour` (plus the
/// base's grain), a 2 px dark rim, and the weathered mask (interior and rim).
const BLOOM_CENTRES: [(f32, f32, f32); 4] = [(0.3, 0.3, 13.0), (0.7, 0.35, 11.0), (0.35, 0.72, 12.0), (0.72, 0.74, 14.0)];

fn rimmed_blooms(base: &Image, colour: [f32; 3]) -> (Image, patina::image::Mask) {
    let size = base.width();
    let dist = |x: usize, y: usize| {
        BLOOM_CENTRES
            .iter()
            .map(|&(cx, cy, r)| ((x as f32 - cx * size as f32).hypot(y as f32 - cy * size as f32)) - r)
            .fold(f32::INFINITY, f32::min)
    };
    let img = Image::from_fn(size, size, 3, |x, y, p| {
        let d = dist(x, y);
        let grain = base.at(x, y, 0) - 0.5;
        let colour = if d < -2.0 {
            colour
        } else if d < 0.0 {
            [0.15, 0.08, 0.05]
        } else {
            [base.at(x, y, 0), base.at(x, y, 1), base.at(x, y, 2)]
        };
        for c in 0..3 {
            p[c] = (colour[c] + if d < 0.0 { 0.5 * grain } else { 0.0 }).clamp(0.0, 1.0);
        }
    });
    (img, patina::image::Mask::from_fn(size, size, |x, y| dist(x, y) < 0.0))
}

/// The last of 3 future frames (t = 2) of `img` grown from `mask` as its age map.
fn grown_to_t2(img: &Image, mask: &patina::image::Mask, seed: u64) -> Image {
    grown_to(img, mask, seed, 2.0)
}

/// The last of 3 future frames, at time `t`, of `img` grown from `mask` as
/// its age map.
fn grown_to(img: &Image, mask: &patina::image::Mask, seed: u64, t: f32) -> Image {
    let r = aged_from(img, mask, seed, 0, 3, t - 1.0);
    r.frames.last().unwrap().image.clone()
}

/// The whole method on `img` with `mask` as its age map: `past` and
/// `future` frames, the last at t = 1 + `span`.
fn aged_from(img: &Image, mask: &patina::image::Mask, seed: u64, past: usize, future: usize, span: f32) -> weather::Weathered {
    let age = mask.to_image();
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future, p.sequence.future_span) = (past, future, span);
    weather::weather(img, &p, Overrides { age: Some(&age), ..Default::default() }, seed, &|_| {}).unwrap()
}

/// The orange of [`rimmed_blooms`]' interiors (the plaster is never orange).
fn orange(q: &[f32]) -> bool {
    q[0] > 0.6 && q[2] < 0.35
}

#[test]
fn growing_damage_carries_its_rim_with_the_front_instead_of_leaving_rings() {
    let (img, mask) = rimmed_blooms(&samples::stucco(SIZE, SIZE, 5), [0.85, 0.45, 0.15]);
    let last = &grown_to_t2(&img, &mask, 7);
    // (The plaster is never orange and has 5 pixels this dark.)
    let dark = |im: &Image, x: usize, y: usize| im.pixel(x, y).iter().take(3).all(|&v| v < 0.3);
    // The damage at t = 2: orange or dark. It has grown.
    let damage = patina::image::Mask::from_fn(SIZE, SIZE, |x, y| orange(last.pixel(x, y)) || dark(last, x, y)).dilate(1).erode(1);
    assert!(damage.count() as f32 >= 1.3 * mask.count() as f32, "damage {} vs {} at t = 1", damage.count(), mask.count());
    // Old rims now deep inside the damage: dark pixels more than 5 px from
    // its edge, against the rim pixels the input had.
    let inside = damage.distance_inside();
    let rim_in = (0..SIZE * SIZE).filter(|&i| dark(&img, i % SIZE, i / SIZE)).count();
    let buried = (0..SIZE * SIZE).filter(|&i| inside[i] > 5.0 && dark(last, i % SIZE, i / SIZE)).count();
    // The damage's own edge is rimmed, as the input's is.
    let edge: Vec<usize> = (0..SIZE * SIZE).filter(|&i| inside[i] > 0.0 && inside[i] <= 2.0).collect();
    let rimmed = edge.iter().filter(|&&i| dark(last, i % SIZE, i / SIZE)).count() as f32 / edge.len().max(1) as f32;
    eprintln!("buried {buried} of {rim_in} rim pixels; edge rimmed {rimmed:.2}");
    assert!((buried as f32) < 0.3 * rim_in as f32, "{buried} dark pixels stay deep inside the grown damage ({rim_in} rim pixels at t = 1)");
    assert!(rimmed >= 0.25, "only {:.0}% of the grown damage's edge is rimmed", 100.0 * rimmed);
}

/// Receding damage keeps its rim: at t = 0.5 the blooms are smaller, and
/// their edge is in part dark rim as the input's is, not only a cut
/// through their orange interiors.
#[test]
fn receding_damage_keeps_its_rim() {
    let (img, mask) = rimmed_blooms(&samples::stucco(SIZE, SIZE, 5), [0.85, 0.45, 0.15]);
    let r = aged_from(&img, &mask, 7, 3, 0, 1.0);
    let half = &r.frames[2];
    assert_eq!(half.t, 0.5);
    let frame = &half.image;
    let dark = |x: usize, y: usize| frame.pixel(x, y).iter().take(3).all(|&v| v < 0.3);
    let damage = patina::image::Mask::from_fn(SIZE, SIZE, |x, y| orange(frame.pixel(x, y)) || dark(x, y)).dilate(1).erode(1);
    let share = damage.count() as f32 / mask.count() as f32;
    assert!((0.2..0.8).contains(&share), "at t = 0.5 the damage is {share:.2} of the input's");
    let inside = damage.distance_inside();
    let edge: Vec<usize> = (0..SIZE * SIZE).filter(|&i| inside[i] > 0.0 && inside[i] <= 2.0).collect();
    let rimmed = edge.iter().filter(|&&i| dark(i % SIZE, i / SIZE)).count() as f32 / edge.len().max(1) as f32;
    eprintln!("receded to {share:.2}; edge rimmed {rimmed:.2}");
    // Measured 0.22 (the rim is redrawn in pieces where the thin band's
    // fill finds it); a cut through the interiors, as until stop 50, 0.02.
    assert!(rimmed >= 0.12, "only {:.0}% of the receded damage's edge is rimmed", 100.0 * rimmed);
}

/// A crack network de-weathers by its cracks getting shorter and fewer,
/// not by breaking into dashes: at t = 0.5 the damage has few pieces
/// for its area, against the pieces the whole network has.
#[test]
fn receding_cracks_shorten_instead_of_breaking_into_dashes() {
    let (img, mask) = samples::weather(&samples::stucco(SIZE, SIZE, 5), Weathering::CrackNetwork, 0.0, 11);
    let r = aged_from(&img, &mask, 7, 3, 0, 1.0);
    // Pieces of damage (4-connected, after a 1 px closing) per 1000 damaged pixels.
    let pieces = |frame: &Image| {
        let d = colour_distance(frame, &r.intact).unwrap();
        let damage = patina::image::Mask::from_fn(SIZE, SIZE, |x, y| d[y * SIZE + x] > 0.1).dilate(1).erode(1);
        let (_, count) = patina::image::region::components(damage.bits(), SIZE, SIZE);
        (count as f32 * 1000.0 / damage.count().max(1) as f32, damage.count())
    };
    let (whole, whole_area) = pieces(&r.frames[4].image);
    let (half, half_area) = pieces(&r.frames[2].image);
    eprintln!("pieces per 1000 px: t = 1 {whole:.2} ({whole_area} px), t = 0.5 {half:.2} ({half_area} px)");
    assert!(half_area > 0 && half_area < whole_area, "t = 0.5 has {half_area} damaged pixels, t = 1 {whole_area}");
    // Measured 3.66 against 0.38; the reveal of stop 49 (by age and depth)
    // gave 35.9: dashes.
    assert!(half <= 15.0 * whole, "t = 0.5 has {half:.2} pieces per 1000 px, the network {whole:.2}");
}

#[test]
fn damage_grows_along_the_grain_of_boards_and_evenly_on_plaster() {
    // Blue paint blooms on boards (grain along x) and on plaster; the new
    // damage's spread from each bloom's centre, along x over along y.
    let spread = |base: &Image| {
        let (img, mask) = rimmed_blooms(base, [0.2, 0.45, 0.85]);
        let last = &grown_to_t2(&img, &mask, 3);
        let (mut sx, mut sy) = (0.0f32, 0.0f32);
        for y in 0..SIZE {
            for x in 0..SIZE {
                let q = last.pixel(x, y);
                let damaged = (q[2] > 0.6 && q[0] < 0.4) || q.iter().take(3).all(|&v| v < 0.3);
                if !damaged || mask.get(x, y) {
                    continue;
                }
                // New damage within twice a bloom's radius of its centre.
                for &(cx, cy, rad) in &BLOOM_CENTRES {
                    let (dx, dy) = (x as f32 - cx * SIZE as f32, y as f32 - cy * SIZE as f32);
                    if dx.hypot(dy) < 2.0 * rad {
                        sx += dx.abs();
                        sy += dy.abs();
                    }
                }
            }
        }
        sx / sy.max(1e-6)
    };
    let boards = spread(&samples::planks(SIZE, SIZE, 2));
    let plaster = spread(&samples::stucco(SIZE, SIZE, 2));
    eprintln!("spread x/y: boards {boards:.2}, plaster {plaster:.2}");
    assert!(boards >= 1.25 * plaster, "damage spreads {boards:.2}x more along the boards than across, {plaster:.2}x on plaster");
    assert!((0.75..1.33).contains(&plaster), "on plaster the spread is {plaster:.2}x along x");
}

#[test]
fn grown_damage_is_whole_material_not_pixel_speckle() {
    // New damage must look like the input's damage at the pixel scale: its
    // pixel-to-pixel roughness (mean |4-neighbour Laplacian| of luminance)
    // near the input's, not a checkerboard of alternating sources. Grown to
    // t = 3, so the new damage has interiors (the blooms are 7% of the
    // surface and grow by about as much per unit of t).
    let (img, mask) = rimmed_blooms(&samples::stucco(SIZE, SIZE, 5), [0.85, 0.45, 0.15]);
    let last = &grown_to(&img, &mask, 7, 3.0);
    let lum = |im: &Image, x: usize, y: usize| {
        let q = im.pixel(x, y);
        0.3 * q[0] + 0.59 * q[1] + 0.11 * q[2]
    };
    let laplacian = |im: &Image, x: usize, y: usize| {
        (4.0 * lum(im, x, y) - lum(im, x - 1, y) - lum(im, x + 1, y) - lum(im, x, y - 1) - lum(im, x, y + 1)).abs()
    };
    let (mut new, mut old) = ((0.0f32, 0usize), (0.0f32, 0usize));
    // Interiors only (3 px from any edge): edges are rough by nature.
    let interior = mask.erode(3);
    let grown = patina::image::Mask::from_fn(SIZE, SIZE, |x, y| orange(last.pixel(x, y))).erode(3);
    let near_old = mask.dilate(3);
    for y in 1..SIZE - 1 {
        for x in 1..SIZE - 1 {
            if interior.get(x, y) {
                old = (old.0 + laplacian(&img, x, y), old.1 + 1);
            } else if grown.get(x, y) && !near_old.get(x, y) {
                new = (new.0 + laplacian(last, x, y), new.1 + 1);
            }
        }
    }
    assert!(new.1 > 200, "only {} new damaged pixels", new.1);
    let (new, old) = (new.0 / new.1 as f32, old.0 / old.1 as f32);
    eprintln!("roughness of new damage {new:.4}, of the input's {old:.4}");
    assert!(
        (0.6..=1.5).contains(&(new / old)),
        "new damage is {:.2}x as rough as the input's damage (a smooth wash or a speckle)",
        new / old
    );
}

#[test]
fn past_frames_reveal_each_damage_from_its_core_not_its_rim_first() {
    // Blooms whose rim is older than their interior (as real age maps of
    // rust blooms have it): by age alone the rims came first and half-way
    // frames showed rings of damage around intact middles.
    let base = samples::stucco(SIZE, SIZE, 5);
    let (img, mask) = rimmed_blooms(&base, [0.85, 0.45, 0.15]);
    let inside = mask.distance_inside();
    let age = Image::from_fn(SIZE, SIZE, 1, |x, y, p| {
        let d = inside[y * SIZE + x];
        p[0] = if d <= 0.0 {
            0.0
        } else if d <= 3.0 {
            1.0
        } else {
            0.6
        }
    });
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (3, 0);
    let r = weather::weather(&img, &p, Overrides { age: Some(&age), intact: Some(&base), ..Default::default() }, 7, &|_| {}).unwrap();
    let half = &r.frames[2].image;
    assert!((r.frames[2].t - 0.5).abs() < 1e-6);
    let d = colour_distance(half, &base).unwrap();
    let revealed: Vec<usize> = (0..SIZE * SIZE).filter(|&i| mask.bits()[i] && d[i] > 0.1).collect();
    let on_rim = revealed.iter().filter(|&&i| inside[i] <= 3.0).count() as f32 / revealed.len().max(1) as f32;
    let rim_share = (0..SIZE * SIZE).filter(|&i| mask.bits()[i] && inside[i] <= 3.0).count() as f32 / mask.count() as f32;
    eprintln!("half-way: {} damage pixels shown, {:.2} of them on the rim (rim is {rim_share:.2} of the damage)", revealed.len(), on_rim);
    assert!(revealed.len() as f32 > 0.2 * mask.count() as f32, "half-way shows {} of {} damage pixels", revealed.len(), mask.count());
    assert!(on_rim < rim_share, "half-way, {:.0}% of the shown damage is rim (the rim is {:.0}% of it)", 100.0 * on_rim, 100.0 * rim_share);
}

#[test]
fn past_frames_pace_the_change_not_the_changed_pixels() {
    // An intact texture that differs slightly everywhere (as rebuilt ones
    // do) and strongly on four blooms: by changed-pixel count the faint
    // pixels ranked last and the first step brought most of the visible
    // change.
    let base = samples::stucco(SIZE, SIZE, 5);
    let (img, mask) = rimmed_blooms(&base, [0.85, 0.45, 0.15]);
    let intact = Image::from_fn(SIZE, SIZE, 3, |x, y, p| {
        let faint = if (x + y) % 2 == 0 { 0.03 } else { -0.03 };
        for (c, v) in p.iter_mut().enumerate() {
            *v = base.at(x, y, c) + faint;
        }
    });
    let age = mask.to_image();
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (3, 0);
    let r = weather::weather(&img, &p, Overrides { age: Some(&age), intact: Some(&intact), ..Default::default() }, 7, &|_| {}).unwrap();
    let frames: Vec<&Image> = r.frames.iter().map(|f| &f.image).collect();
    let pace = pacing(&frames).unwrap();
    eprintln!("largest step: {pace:.2} of the change");
    assert!(pace <= 0.35, "one step brings {:.0}% of the intact -> input change", 100.0 * pace);
}

#[test]
fn a_clean_texture_that_repeats_itself_is_not_judged_weathered() {
    // A clean planks texture laid twice side by side (tileable textures
    // and walls of repeated panels do this): every region has a
    // near-exact twin. The coverage test must still count ordinary matches
    // in the other regions as matches, not only the near-exact twin.
    use patina::rng::Rng;
    let half = samples::by_name("planks", SIZE / 2, SIZE, 3).unwrap();
    let mut rng = patina::rng::generator(17, &[]);
    let img = Image::from_fn(SIZE, SIZE, 3, |x, y, p| {
        let jitter = rng.gen_range(-0.01f32..0.01);
        for (c, v) in p.iter_mut().enumerate() {
            *v = (half.at(x % (SIZE / 2), y, c) + jitter).clamp(0.0, 1.0);
        }
    });
    let params = AgeParams { detail: 0.0, regions: false, ..AgeParams::default() };
    let age = age_map(&img, &params).unwrap();
    let mean = age.map.data().iter().sum::<f32>() / age.map.data().len() as f32;
    let (_, judged) = weather::intact::weathered_cut(&age.map, 0.6);
    // With the floor at half the median own-match: mean age 0.57, judged
    // 0.48; with the typical-match floor: 0.27 and 0.33. Still not clean
    // (the coverage test calls a third of a clean texture weathered at
    // this size); these bounds hold the gain.
    assert!(mean < 0.4, "a clean texture that repeats ages {mean:.3} on average");
    eprintln!("repeating clean planks: mean age {mean:.3}, judged weathered {judged:.3}");
    assert!(judged < 0.4, "{judged:.3} of a clean texture that repeats is judged weathered");
}

/// Roof courses seen in perspective: a stucco surface crossed by courses
/// (a dark shadow under a bright lip) whose spacing widens from 20 px at
/// the top to 26 px at the bottom, so no one period holds for the whole
/// image, with a dozen small rust spots (the known damage). Also the mask
/// of the course edges (shadow and lip rows) away from the spots.
fn perspective_courses(size: usize, seed: u64) -> (Image, patina::image::Mask, patina::image::Mask) {
    use patina::rng::Rng;
    let base = samples::stucco(size, size, seed);
    let (top, bottom) = (20.0f32, 26.0f32);
    let slope = (bottom - top) / size as f32;
    // Course coordinate: the integral of 1 / period(y).
    let phase = |y: f32| (1.0 + slope * y / top).ln() / slope;
    let mut rng = patina::rng::generator(seed, &[0x5f]);
    let spots: Vec<(f32, f32, f32)> = (0..12)
        .map(|_| (rng.gen_range(12.0..size as f32 - 12.0), rng.gen_range(12.0..size as f32 - 12.0), rng.gen_range(3.0f32..5.0)))
        .collect();
    let rust = |x: usize, y: usize| spots.iter().any(|&(sx, sy, r)| (x as f32 - sx).powi(2) + (y as f32 - sy).powi(2) <= r * r);
    let img = Image::from_fn(size, size, 3, |x, y, p| {
        let f = phase(y as f32).fract();
        let shade = if f < 0.12 {
            0.3
        } else if f < 0.2 {
            1.35
        } else {
            1.0 - 0.2 * f
        };
        for (c, v) in p.iter_mut().enumerate() {
            *v = (base.at(x, y, c) * shade).clamp(0.0, 1.0);
        }
        if rust(x, y) {
            p.copy_from_slice(&[0.55, 0.25, 0.1]);
        }
    });
    let damage = patina::image::Mask::from_fn(size, size, |x, y| rust(x, y));
    let near = damage.dilate(6);
    let edges = patina::image::Mask::from_fn(size, size, |x, y| phase(y as f32).fract() < 0.2 && !near.get(x, y));
    (img, damage, edges)
}

/// Structure that repeats at a drifting period (roof courses in
/// perspective, louvres) is not weathering: their edge patches are rare
/// by density, but each recurs one local period away, so the local
/// regularity keeps them out of the age map while the rust spots stay.
/// Measured: the course edges' mean age is 0.17 (0.19 of the spots'); no
/// whole-image period is found, and without the local one it is 0.58
/// (0.62 of the spots'). The spots' AUC is 0.99 either way.
#[test]
fn courses_in_perspective_do_not_age_and_the_spots_on_them_do() {
    let (img, damage, edges) = perspective_courses(192, 4);
    let age = age_map(&img, &AgeParams::default()).unwrap();
    assert!(age.periodicity.is_none(), "the courses' drifting period was found for the whole image: {:?}", age.periodicity);
    let auc = roc_auc(age.map.data(), damage.bits());
    let mean = |m: &patina::image::Mask| {
        m.bits().iter().zip(age.map.data()).filter(|(&b, _)| b).map(|(_, &a)| a).sum::<f32>() / m.count().max(1) as f32
    };
    let (on_edges, on_spots) = (mean(&edges), mean(&damage));
    eprintln!("courses: spot AUC {auc:.3}, mean age on course edges {on_edges:.3}, on spots {on_spots:.3}");
    assert!(auc >= 0.9, "the rust spots among perspective courses: AUC {auc:.3}");
    assert!(on_edges <= 0.4 * on_spots, "course edges age {on_edges:.3} against the spots' {on_spots:.3}");
}

/// Rust blooms in four discs of [`samples::disc_grid`] (the stained
/// circle tiles of ../shared/data) grow within their own discs before
/// they cross the rims: the intact texture's strongest edges (the discs'
/// rims) slow the front. Measured at t = 3, the share of the new rust
/// outside the blooms' discs: 0.045 with the barrier, 0.124 without it
/// (0.036 with a barrier twice as strong). At t = 4 the discs are full
/// and both cross.
#[test]
fn damage_fills_its_own_tile_before_crossing_its_rim() {
    let period = 40;
    let base = samples::disc_grid(SIZE, SIZE, period, 5);
    let hit = [(0usize, 1usize), (2, 0), (1, 3), (3, 2)];
    let centre = |(i, j): (usize, usize)| ((i * period) as f32 + period as f32 / 2.0, (j * period) as f32 + period as f32 / 2.0);
    let in_disc =
        |x: usize, y: usize, t: (usize, usize)| (x as f32 + 0.5 - centre(t).0).hypot(y as f32 + 0.5 - centre(t).1) < 0.45 * period as f32;
    let bloom = |x: usize, y: usize| hit.iter().any(|&t| (x as f32 + 0.5 - centre(t).0).hypot(y as f32 + 0.5 - centre(t).1) < 6.0);
    let img = Image::from_fn(SIZE, SIZE, 3, |x, y, p| {
        for c in 0..3 {
            p[c] = if bloom(x, y) { [0.6, 0.28, 0.1][c] + 0.2 * (base.at(x, y, c) - 0.4) } else { base.at(x, y, c) };
        }
    });
    let mask = patina::image::Mask::from_fn(SIZE, SIZE, bloom);
    let last = grown_to(&img, &mask, 3, 3.0);
    let (mut inside, mut outside) = (0usize, 0usize);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let q = last.pixel(x, y);
            let rusty = q[0] > q[1] + 0.1 && q[1] > q[2];
            if rusty && !mask.get(x, y) {
                if hit.iter().any(|&t| in_disc(x, y, t)) {
                    inside += 1;
                } else {
                    outside += 1;
                }
            }
        }
    }
    let share = outside as f32 / (inside + outside).max(1) as f32;
    eprintln!("new rust: {inside} px in the blooms' discs, {outside} px beyond them ({share:.3})");
    assert!(inside > 400, "the blooms barely grew: {inside} new px in their discs");
    assert!(share <= 0.08, "{share:.3} of the new rust crossed the rims");
}

/// Fine damage (a scatter of rust dots 2-3 px across, like lichen on a
/// roof) grows by its share: at t = 2 the damage drawn (the input's and
/// every pixel the frames re-drew) holds the share
/// [`clean_share_weathered`](patina::weather::growth::clean_share_weathered)
/// asks for. The arrival times' quantile alone gave about half (the
/// outline's smoothing rounds small growth away, and slivers are not
/// drawn). Measured: 1.00 of the asked share, 0.37 before.
#[test]
fn fine_damage_grows_by_its_whole_share() {
    use patina::rng::Rng;
    use patina::weather::growth::clean_share_weathered;
    let base = samples::stucco(SIZE, SIZE, 6);
    let mut rng = patina::rng::generator(6, &[0xd0]);
    let dots: Vec<(f32, f32)> = (0..60).map(|_| (rng.gen_range(4.0..SIZE as f32 - 4.0), rng.gen_range(4.0..SIZE as f32 - 4.0))).collect();
    let dot = |x: usize, y: usize| dots.iter().any(|&(cx, cy)| (x as f32 + 0.5 - cx).hypot(y as f32 + 0.5 - cy) < 1.6);
    let img = Image::from_fn(SIZE, SIZE, 3, |x, y, p| {
        for c in 0..3 {
            p[c] = if dot(x, y) { [0.75, 0.6, 0.1][c] } else { base.at(x, y, c) };
        }
    });
    let mask = patina::image::Mask::from_fn(SIZE, SIZE, dot);
    let last = grown_to_t2(&img, &mask, 2);
    let changed = (0..SIZE * SIZE).filter(|&i| !mask.bits()[i] && last.pixel(i % SIZE, i / SIZE) != img.pixel(i % SIZE, i / SIZE)).count();
    let initial = mask.count() as f32 / (SIZE * SIZE) as f32;
    let asked = clean_share_weathered(initial, 2.0) * (SIZE * SIZE - mask.count()) as f32;
    let ratio = changed as f32 / asked;
    eprintln!("fine damage ({:.3} of the surface): {changed} px drawn by t = 2, {ratio:.2} of the {asked:.0} asked", initial);
    assert!(ratio >= 0.8, "fine damage grew by {ratio:.2} of its share");
}

/// An object of stucco with 10% rust (a disc a third of the picture) on a
/// background of bricks, and the object's mask, and the rust's.
fn rusty_disc_on_bricks(size: usize) -> (Image, patina::image::Mask, patina::image::Mask) {
    let (rusty, rust) = samples::weather(&samples::stucco(size, size, 4), Weathering::Rust, 0.1, 11);
    let bricks = samples::bricks(size, size, 2);
    let c = size as f32 / 2.0;
    let object = patina::image::Mask::from_fn(size, size, |x, y| (x as f32 - c).hypot(y as f32 - c) < 0.33 * size as f32);
    let img =
        Image::from_fn(size, size, 3, |x, y, p| p.copy_from_slice(if object.get(x, y) { rusty.pixel(x, y) } else { bricks.pixel(x, y) }));
    let rust = patina::image::Mask::from_fn(size, size, |x, y| object.get(x, y) && rust.get(x, y));
    (img, object, rust)
}

/// The AUC of `age` for `truth` over the pixels of `object` only.
fn auc_within(age: &Image, truth: &patina::image::Mask, object: &patina::image::Mask) -> f32 {
    let (a, t): (Vec<f32>, Vec<bool>) =
        object.bits().iter().enumerate().filter(|(_, &b)| b).map(|(i, _)| (age.data()[i], truth.bits()[i])).unzip();
    roc_auc(&a, &t)
}

/// With a mask, the object is judged on its own: stucco with rust spots on
/// a disc a third of the picture, on bricks. Without the mask the disc's
/// clean stucco, absent from two thirds of the picture's regions, is
/// judged weathered (mean age 0.61, the rust's AUC within the disc 0.37);
/// with it, the bricks are neither matches nor regions (0.10 and 0.998).
/// Every frame keeps every brick pixel exactly, the age map is 0 there,
/// the intact disc is clean stucco, and the rust grows inside the disc.
#[test]
fn a_mask_judges_and_weathers_the_object_alone_and_keeps_the_background() {
    let size = 192;
    let (img, object, rust) = rusty_disc_on_bricks(size);
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (2, 2);
    let masked = weather::weather(&img, &p, Overrides { mask: Some(&object), ..Default::default() }, 3, &|_| {}).unwrap();
    let whole = weather::weather(&img, &p, Overrides::default(), 3, &|_| {}).unwrap();
    let outside = |i: usize| !object.bits()[i];
    for f in &masked.frames {
        assert!(
            (0..size * size).filter(|&i| outside(i)).all(|i| f.image.pixel(i % size, i / size) == img.pixel(i % size, i / size)),
            "t = {} changed the background",
            f.t
        );
    }
    assert!((0..size * size).filter(|&i| outside(i)).all(|i| masked.age.data()[i] == 0.0), "the background has an age");
    let (a_masked, a_whole) = (auc_within(&masked.age, &rust, &object), auc_within(&whole.age, &rust, &object));
    assert!(a_masked >= 0.95 && a_whole < 0.7, "rust AUC within the disc: {a_masked:.3} masked, {a_whole:.3} without");
    let clean_age = |age: &Image| {
        let v: Vec<f32> = (0..size * size).filter(|&i| object.bits()[i] && !rust.bits()[i]).map(|i| age.data()[i]).collect();
        v.iter().sum::<f32>() / v.len() as f32
    };
    assert!(clean_age(&masked.age) < 0.2, "clean stucco's mean age {:.2} with the mask", clean_age(&masked.age));
    let d_intact = colour_distance(&masked.intact, &img).unwrap();
    let removed = (0..size * size).filter(|&i| rust.bits()[i] && d_intact[i] > 0.1).count() as f32 / rust.count() as f32;
    assert!(removed > 0.9, "the intact disc keeps {:.0}% of the rust", 100.0 * (1.0 - removed));
    let last = colour_distance(&masked.frames.last().unwrap().image, &img).unwrap();
    let grown = (0..size * size).filter(|&i| object.bits()[i] && last[i] > 0.1).count() as f32 / object.count() as f32;
    assert!(grown > 0.08, "only {grown:.3} of the disc changed by t = 2");
}

/// Rust over 60-80% of stucco: prevalence calls the rust the material
/// and the stucco islands its weathering (AUC under 0.01). A pixel
/// pointed at on the rust turns the map over (AUC above 0.99), and the
/// weathered share may then pass the usual cap; pointed at the rust of a
/// map that found it, nothing turns.
#[test]
fn a_weathered_pixel_turns_over_a_map_that_called_the_majority_intact() {
    let size = 160;
    let deepest = |m: &patina::image::Mask| {
        let d = m.distance_inside();
        let i = (0..size * size).max_by(|&a, &b| d[a].total_cmp(&d[b]).then(b.cmp(&a))).unwrap();
        (i % size, i / size)
    };
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (1, 1);
    for area in [0.6, 0.8] {
        let (img, truth) = samples::weather(&samples::stucco(size, size, 4), Weathering::Rust, area, 11);
        let plain = weather::weather(&img, &p, Overrides::default(), 3, &|_| {}).unwrap();
        let hinted =
            weather::weather(&img, &p, Overrides { weathered_at: Some(deepest(&truth)), ..Default::default() }, 3, &|_| {}).unwrap();
        let (a_plain, a_hinted) = (roc_auc(plain.age.data(), truth.bits()), roc_auc(hinted.age.data(), truth.bits()));
        assert!(hinted.flipped && a_plain < 0.1 && a_hinted > 0.95, "{area}: AUC {a_plain:.3} plain, {a_hinted:.3} pointed at");
        let judged = hinted.weathered.unwrap().1;
        assert!(judged > 0.9 * area, "{area}: {judged:.2} judged weathered once turned over");
    }
    let (img, truth) = samples::weather(&samples::stucco(size, size, 4), Weathering::Rust, 0.1, 11);
    let hinted = weather::weather(&img, &p, Overrides { weathered_at: Some(deepest(&truth)), ..Default::default() }, 3, &|_| {}).unwrap();
    assert!(!hinted.flipped, "a map that found the rust was turned over");
    assert!(roc_auc(hinted.age.data(), truth.bits()) > 0.9);
}

/// A wide piece of rust that holds two older colonies (its age peaks at
/// its two ends) recedes towards both, not from one end to the other:
/// at t = 0.25 damage remains at each colony. With one seed per piece
/// the far colony had gone.
#[test]
fn a_wide_piece_recedes_towards_each_of_its_older_colonies() {
    let size = 192;
    let base = samples::stucco(size, size, 5);
    let blob = |x: usize, y: usize| (24..168).contains(&x) && (66..126).contains(&y);
    let colonies = [(48.0f32, 96.0f32), (144.0, 96.0)];
    let img = Image::from_fn(size, size, 3, |x, y, p| {
        let grain = base.at(x, y, 0) - 0.5;
        let rust = [0.55 + 0.3 * grain, 0.25 + 0.15 * grain, 0.08];
        p.copy_from_slice(if blob(x, y) { &rust } else { base.pixel(x, y) });
    });
    let age = Image::from_fn(size, size, 1, |x, y, p| {
        let peak =
            colonies.iter().map(|&(cx, cy)| (-((x as f32 - cx).powi(2) + (y as f32 - cy).powi(2)) / 128.0).exp()).fold(0.0, f32::max);
        p[0] = if blob(x, y) { 0.6 + 0.35 * peak } else { 0.0 };
    });
    let mut p = WeatherParams::default();
    (p.sequence.past, p.sequence.future) = (3, 0);
    let r = weather::weather(&img, &p, Overrides { age: Some(&age), intact: Some(&base), ..Default::default() }, 7, &|_| {}).unwrap();
    let early = colour_distance(&r.frames[1].image, &base).unwrap();
    let near = |(cx, cy): (f32, f32)| {
        let around: Vec<usize> = (0..size * size).filter(|&i| ((i % size) as f32 - cx).hypot((i / size) as f32 - cy) < 10.0).collect();
        around.iter().filter(|&&i| early[i] > 0.1).count() as f32 / around.len() as f32
    };
    let (left, right) = (near(colonies[0]), near(colonies[1]));
    eprintln!("t = 0.25: damage covers {left:.2} and {right:.2} of the two colonies");
    assert!(left > 0.5 && right > 0.5, "at t = 0.25, damage covers {left:.2} and {right:.2} of the two colonies");
}
