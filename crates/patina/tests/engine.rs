//! Quality, determinism and input checks of the synthesis engine, on
//! exemplars the tests make themselves (patina::samples).

use patina::metrics::{bidirectional, material_drift, seam_visibility, self_similarity};
use patina::samples;
use patina::synth::{Lattice, OptimizeParams, QuiltParams, QuiltPlan, Synthesis};
use patina::{Error, Image, Mask};

/// Largest mean of `map` (NaN-free) over `win` x `win` windows, stride 4.
fn worst_window(map: &Image, win: usize) -> f32 {
    let mut worst = 0f32;
    for y in (0..=map.height() - win).step_by(4) {
        for x in (0..=map.width() - win).step_by(4) {
            let (mut s, mut n) = (0f32, 0);
            for yy in y..y + win {
                for xx in x..x + win {
                    let v = map.at(xx, yy, 0);
                    if v.is_finite() {
                        s += v;
                        n += 1;
                    }
                }
            }
            if n > 0 {
                worst = worst.max(s / n as f32);
            }
        }
    }
    worst
}

/// The quality bar for 2x enlargement: coherence within 1.5x of the
/// exemplar's self-similarity, and no exemplar window of a quarter of its
/// side left unrepresented: the window mean of the completeness distance
/// stays under 1x the self-similarity. (Measured: windows the output never
/// uses sit at about 1.4x, see the negative control below; the optimizer's
/// worst windows at about 0.8x.)
fn enlargement_quality(out: &Image, ex: &Image) -> (bool, bool, String) {
    let own = self_similarity(ex, 5, 1).unwrap();
    let b = bidirectional(out, ex, 5, 2).unwrap();
    let worst = worst_window(&b.completeness_map, ex.width() / 4);
    let report = format!("self {own:.4} coherence {:.4} completeness {:.4} worst window {worst:.4}", b.coherence, b.completeness);
    (b.coherence <= 1.5 * own, worst <= own, report)
}

#[test]
fn optimized_enlargement_is_coherent_and_complete() {
    for (name, ex) in
        [("cobbles", samples::cobbles(96, 96, 4)), ("bricks", samples::bricks(96, 96, 4)), ("blotches", samples::blotches(96, 96, 4))]
    {
        let out = Synthesis::new(&ex).size(192, 192).seed(3).optimize(&OptimizeParams::default()).unwrap();
        let (coherent, complete, report) = enlargement_quality(&out.image, &ex);
        eprintln!("{name}: {report}");
        assert!(coherent, "{name}: coherence too far from self-similarity: {report}");
        assert!(complete, "{name}: part of the exemplar is never used: {report}");
    }
}

#[test]
fn the_completeness_check_catches_an_output_that_ignores_half_the_exemplar() {
    // Negative control: tile the left half only. Coherent, but incomplete.
    let ex = samples::cobbles(96, 96, 4);
    let half = ex.crop(0, 0, 48, 96).unwrap();
    let out = Image::from_fn(192, 192, 3, |x, y, p| p.copy_from_slice(half.pixel(x % 48, y % 96)));
    let (_, complete, report) = enlargement_quality(&out, &ex);
    assert!(!complete, "half the exemplar is missing yet the check passed: {report}");
}

/// Fraction of horizontally adjacent blocks (in the first row, where a
/// block's only constraint is its left neighbour) that continue their left
/// neighbour verbatim in the exemplar (same shift from canvas to source).
fn continuation_fraction(plan: &QuiltPlan) -> f32 {
    let mut row: Vec<_> = plan.placements.iter().filter(|p| p.y == 0).collect();
    row.sort_by_key(|p| p.x);
    let shift = |p: &patina::synth::Placement| (p.source_x as isize - p.x as isize, p.source_y as isize);
    let cont = row.windows(2).filter(|ab| shift(ab[0]) == shift(ab[1])).count();
    cont as f32 / (row.len() - 1) as f32
}

#[test]
fn quilting_boundary_cut_hides_seams_better_than_blending() {
    // Default block (32) and overlap (block / 6 = 5). Seams are measured with
    // 3 x 3 patches: wider ones reach past the overlap band and dilute it.
    for (name, ex) in
        [("cobbles", samples::cobbles(128, 128, 5)), ("bricks", samples::bricks(128, 128, 5)), ("blotches", samples::blotches(128, 128, 5))]
    {
        let run = |cut: bool| {
            // The cut itself, before any gradient-domain blending.
            let p = QuiltParams { boundary_cut: cut, blend: false, ..QuiltParams::default() };
            let q = Synthesis::new(&ex).size(256, 256).seed(9).quilt(&p).unwrap();
            seam_visibility(&q.image, &ex, &q.plan.overlap_mask(), 3, 3).unwrap()
        };
        let (cut, blend) = (run(true), run(false));
        eprintln!("{name}: seam visibility cut {cut:.4} blend {blend:.4}");
        assert!(cut < 0.85 * blend, "{name}: cut {cut} vs blend {blend}");
    }
}

#[test]
fn quilting_candidate_floor_prevents_verbatim_copying() {
    // With a zero-error continuation available, the plain (1 + tol) x min
    // rule keeps only it and copies the exemplar verbatim.
    let ex = samples::blotches(128, 128, 6);
    let run = |k: usize| {
        let p = QuiltParams { min_candidates: k, block: Some((24, 24)), ..QuiltParams::default() };
        continuation_fraction(&Synthesis::new(&ex).size(256, 256).seed(2).quilt(&p).unwrap().plan)
    };
    let (plain, floored) = (run(1), run(QuiltParams::default().min_candidates));
    eprintln!("continuations: plain rule {plain:.2}, with floor {floored:.2}");
    assert!(plain > 0.6, "the plain rule should show the verbatim-copy failure: {plain}");
    assert!(floored < 0.3, "verbatim copying with the floor: {floored}");
}

/// A blue-tinted stochastic material, easy to tell from cobbles by colour.
fn blue_material(w: usize, h: usize) -> Image {
    let b = samples::blotches(w, h, 8);
    Image::from_fn(w, h, 3, |x, y, p| {
        let v = b.pixel(x, y);
        p.copy_from_slice(&[v[0] * 0.5, v[1] * 0.7, (v[2] + 0.45).min(1.0)]);
    })
}

fn guided_accuracy(out: &Image, target_guide: &Image) -> f32 {
    let mut right = 0;
    for y in 0..out.height() {
        for x in 0..out.width() {
            let p = out.pixel(x, y);
            let is_blue = p[2] > p[0];
            right += (is_blue == (target_guide.at(x, y, 0) > 0.5)) as usize;
        }
    }
    right as f32 / (out.width() * out.height()) as f32
}

#[test]
fn guided_synthesis_puts_each_material_where_the_guide_says() {
    let (a, b) = (samples::cobbles(96, 96, 1), blue_material(96, 96));
    let source = Image::from_fn(96, 96, 3, |x, y, p| p.copy_from_slice(if x < 48 { a.pixel(x, y) } else { b.pixel(x, y) }));
    let sguide = Image::from_fn(96, 96, 1, |x, _, p| p[0] = if x < 48 { 0.0 } else { 1.0 });
    let tguide = Image::from_fn(128, 128, 1, |x, y, p| {
        let d = ((x as f32 - 64.0).powi(2) + (y as f32 - 64.0).powi(2)).sqrt();
        p[0] = if d < 40.0 { 1.0 } else { 0.0 };
    });
    let problem = Synthesis::new(&source).guides(&sguide, &tguide, 2.0).seed(4);
    let optimized = problem.optimize(&OptimizeParams::default()).unwrap().image;
    let quilted = problem.quilt(&QuiltParams { block: Some((16, 16)), ..QuiltParams::default() }).unwrap().image;
    let (ao, aq) = (guided_accuracy(&optimized, &tguide), guided_accuracy(&quilted, &tguide));
    eprintln!("guided accuracy: optimize {ao:.3}, quilt {aq:.3}");
    assert!(ao > 0.9, "optimize: {ao}");
    assert!(aq > 0.9, "quilt: {aq}");
}

#[test]
fn filling_a_hole_keeps_the_rest_and_matches_the_texture() {
    let ex = samples::cobbles(96, 96, 2);
    let hole = Mask::from_fn(96, 96, |x, y| (36..60).contains(&x) && (36..60).contains(&y));
    let allowed = Mask::from_fn(96, 96, |x, y| !hole.dilate(2).get(x, y));
    let mut damaged = ex.clone();
    for y in 36..60 {
        for x in 36..60 {
            damaged.pixel_mut(x, y).copy_from_slice(&[1.0, 0.0, 1.0]);
        }
    }
    let out =
        Synthesis::new(&damaged).fill(&damaged, &hole).source_mask(&allowed).seed(1).optimize(&OptimizeParams::default()).unwrap().image;
    for y in 0..96 {
        for x in 0..96 {
            if !hole.get(x, y) {
                assert_eq!(out.pixel(x, y), damaged.pixel(x, y), "pixel {x},{y} outside the hole changed");
            }
        }
    }
    let own = self_similarity(&ex, 5, 1).unwrap();
    let b = bidirectional(&out.crop(36, 36, 24, 24).unwrap(), &ex, 5, 1).unwrap();
    eprintln!("fill: coherence {:.4} self {own:.4}", b.coherence);
    assert!(b.coherence < 1.5 * own, "filled region {} vs self-similarity {own}", b.coherence);
}

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(f)
}

#[test]
fn results_are_identical_at_any_thread_count() {
    let ex = samples::cobbles(80, 80, 7);
    let guide_s = Image::from_fn(80, 80, 1, |x, _, p| p[0] = x as f32 / 80.0);
    let guide_t = Image::from_fn(150, 110, 1, |_, y, p| p[0] = y as f32 / 110.0);
    let run = || {
        let plain = Synthesis::new(&ex).size(150, 110).seed(11);
        let guided = Synthesis::new(&ex).guides(&guide_s, &guide_t, 1.0).seed(11);
        vec![
            plain.optimize(&OptimizeParams::default()).unwrap().image,
            plain.quilt(&QuiltParams::default()).unwrap().image,
            guided.optimize(&OptimizeParams::default()).unwrap().image,
            guided.quilt(&QuiltParams::default()).unwrap().image,
        ]
    };
    let (one, two) = (in_pool(1, run), in_pool(2, run));
    for (a, b) in one.iter().zip(&two) {
        let bits = |i: &Image| i.data().iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
        assert_eq!(bits(a), bits(b));
    }
    let other_seed = Synthesis::new(&ex).size(150, 110).seed(12).optimize(&OptimizeParams::default()).unwrap().image;
    assert_ne!(one[0], other_seed, "the seed must matter");
}

#[test]
fn bad_problems_are_clear_errors() {
    let ex = samples::cobbles(32, 32, 1);
    let tiny = Image::new(4, 4, 3);
    let is_invalid = |r: Result<patina::synth::Synthesized, Error>| matches!(r, Err(Error::InvalidInput(_)));
    assert!(is_invalid(Synthesis::new(&tiny).size(64, 64).optimize(&OptimizeParams::default())));
    assert!(is_invalid(Synthesis::new(&ex).size(0, 64).optimize(&OptimizeParams::default())));
    assert!(is_invalid(Synthesis::new(&ex).size(64, 64).optimize(&OptimizeParams { patch: 4, ..OptimizeParams::default() })));
    let g1 = Image::new(31, 32, 1);
    let g2 = Image::new(64, 64, 1);
    assert!(is_invalid(Synthesis::new(&ex).guides(&g1, &g2, 1.0).optimize(&OptimizeParams::default())));
    assert!(matches!(Synthesis::new(&ex).size(60000, 60000).optimize(&OptimizeParams::default()), Err(Error::TooLarge { .. })));
    assert!(matches!(
        Synthesis::new(&ex).size(64, 64).quilt(&QuiltParams { block: Some((40, 40)), ..QuiltParams::default() }),
        Err(Error::InvalidInput(_))
    ));
}

/// Copies of a red disc in `img`: red pixels over one disc's area.
fn red_copies(img: &Image, disc_area: f32) -> f32 {
    img.data().chunks_exact(3).filter(|p| p[0] > 0.8 && p[1] < 0.3).count() as f32 / disc_area
}

#[test]
fn one_distinctive_feature_is_copied_less_than_its_share() {
    // One red disc on a stochastic ground; a 2x enlargement has 4x the
    // area, so about 4 discs is its share if every part of the exemplar
    // were used alike. A one-off feature repeated that often reads as a
    // stamp; the rarity bound keeps it to about one or two, and its
    // first-use bonus keeps it from being dropped.
    let ground = samples::blotches(96, 96, 7);
    let ex = Image::from_fn(96, 96, 3, |x, y, p| {
        let d = ((x as f32 - 40.0).powi(2) + (y as f32 - 52.0).powi(2)).sqrt();
        if d < 8.0 {
            p.copy_from_slice(&[0.95, 0.1, 0.1]);
        } else {
            p.copy_from_slice(ground.pixel(x, y));
        }
    });
    let area = red_copies(&ex, 1.0);
    let (mut bounded, mut common, mut free_total, mut optimized_total) = (0.0, 0.0, 0.0, 0.0);
    const SEEDS: u64 = 8;
    for seed in 0..SEEDS {
        let run = |p: &QuiltParams| red_copies(&Synthesis::new(&ex).size(192, 192).seed(seed).quilt(p).unwrap().image, area);
        let q = run(&QuiltParams::default());
        let c = run(&QuiltParams { rarity: 0.0, ..QuiltParams::default() });
        let u = run(&QuiltParams { rarity: 0.0, reuse: 0.0, families: 0.0, ..QuiltParams::default() });
        let optimized = Synthesis::new(&ex).size(192, 192).seed(seed).optimize(&OptimizeParams::default()).unwrap().image;
        let o = red_copies(&optimized, area);
        eprintln!(
            "seed {seed}: disc copies quilt {q:.1}, optimize {o:.1}, without the rarity bound {c:.1}, without any reuse bound {u:.1}"
        );
        assert!(q <= 3.0, "seed {seed}: the quilt has {q:.1} copies of one disc");
        bounded += q;
        optimized_total += o;
        common += c;
        free_total += u;
    }
    // Measured over seeds 0-7: quilt 1.1-2.6 copies, mean 1.8 (with the
    // material-share bound on: 0.2-2.8, mean 1.5; over seeds 0-15 a seed
    // in 8 drops the disc to a fragment in either); optimize 0.9-3.0;
    // without the rarity bound about 3.
    let n = SEEDS as f32;
    assert!((0.75..=2.0).contains(&(bounded / n)), "mean disc copies of the quilt {:.2}", bounded / n);
    assert!(optimized_total / n <= 2.5, "mean disc copies of optimize {:.2}", optimized_total / n);
    assert!(
        bounded < common && common < free_total,
        "copies over {SEEDS} seeds: {bounded:.1} with the bounds, {common:.1} without the rarity bound, {free_total:.1} without any"
    );
}

#[test]
fn a_material_in_one_corner_does_not_spread_under_the_material_bound() {
    // Stucco with a corner of teal gravel (9% of the exemplar). With plain
    // overlap costs, once a quilt holds a teal block, teal continues teal
    // more cheaply than it meets the stucco (which it does only along one
    // short edge of the exemplar), so with no bound the corner spreads:
    // measured, teal covers 0.11-0.33. The material-share bound
    // (`families`, off by default) alone stops it, and overshoots:
    // 0.02-0.11. (Here the reuse bound alone also keeps teal at 0.02-0.07;
    // on the real rust blooms exemplar it does not, see
    // QuiltParams::families. The default relative overlap costs, with no
    // bound, give 0.001-0.025 here: the corner is not spread but dropped.)
    let (stucco, gravel) = (samples::stucco(96, 96, 4), samples::gravel(96, 96, 5));
    let ex = Image::from_fn(96, 96, 3, |x, y, p| {
        if x + y > 150 {
            let g = gravel.pixel(x, y);
            p.copy_from_slice(&[0.2 + 0.4 * g[0], 0.45 + 0.4 * g[1], 0.45 + 0.4 * g[2]]);
        } else {
            p.copy_from_slice(stucco.pixel(x, y));
        }
    });
    let teal = |img: &Image| img.data().chunks_exact(3).filter(|p| p[1] > p[0] + 0.1).count() as f32 / (img.width() * img.height()) as f32;
    let share = teal(&ex);
    let plain = QuiltParams { reuse: 0.0, rarity: 0.0, families: 0.0, relative: 0.0, ..QuiltParams::default() };
    let (mut bounded, mut free, mut drift) = (0.0, 0.0, 0.0);
    for seed in 0..4 {
        let run = |p: &QuiltParams| Synthesis::new(&ex).size(192, 192).seed(seed).quilt(p).unwrap().image;
        let b = run(&QuiltParams { families: 1.0, ..plain.clone() });
        let f = run(&plain);
        eprintln!("seed {seed}: teal share {:.3} with the bound, {:.3} with none; exemplar {share:.3}", teal(&b), teal(&f));
        assert!(teal(&b) < 1.5 * share, "seed {seed}: teal covers {:.3} with the bound; the exemplar {share:.3}", teal(&b));
        bounded += (teal(&b) - share).abs();
        free += (teal(&f) - share).abs();
        drift += material_drift(&b, &ex, 1).unwrap() - material_drift(&f, &ex, 1).unwrap();
    }
    // Measured: off by 0.20 with the bound, 0.47 with none.
    assert!(bounded < 0.6 * free, "teal share off the exemplar's by {bounded:.3} over 4 seeds with the bound, {free:.3} with none");
    assert!(drift < 0.0, "the material drift measure does not see it: {drift:.3} more with the bound over 4 seeds");
}

/// `img` shifted by half its size with wrap-around, so that its tile edges
/// meet in a cross through the middle.
fn rolled(img: &Image) -> Image {
    let (w, h) = img.size();
    Image::from_fn(w, h, img.channels(), |x, y, p| p.copy_from_slice(img.pixel((x + w / 2) % w, (y + h / 2) % h)))
}

/// How much worse the seams across a tile's edges are than its other
/// seams: the coherence distance (to the exemplar) of the patches on the
/// cut lines within 2 px of the edges, seen in the rolled image where they
/// join, over that of the cut lines elsewhere. The cut lines are where the
/// source position of the synthesis' field does not continue to the right
/// or below (across the edge too). Near 1 when the tile continues across
/// its edges as it does inside; high when its edges do not meet.
fn wrap_seam_visibility(out: &patina::synth::Synthesized, ex: &Image) -> f32 {
    let (w, h) = out.image.size();
    let at = |x: usize, y: usize| out.nnf.get(x % w, y % h);
    let cut = |x: usize, y: usize| {
        let (p, r, b) = (at(x, y), at(x + 1, y), at(x, y + 1));
        (r.x, r.y) != (p.x + 1, p.y) || (b.x, b.y) != (p.x, p.y + 1)
    };
    let edge = |x: usize, y: usize| x < 2 || y < 2 || x + 2 >= w || y + 2 >= h;
    let inner = Mask::from_fn(w, h, |x, y| cut(x, y) && x >= 8 && y >= 8 && x + 8 < w && y + 8 < h);
    // In the rolled image, pixel (x, y) is the tile's (x + w/2, y + h/2).
    let across = Mask::from_fn(w, h, |x, y| {
        let (tx, ty) = ((x + w / 2) % w, (y + h / 2) % h);
        edge(tx, ty) && cut(tx, ty)
    });
    let across_edges = seam_visibility(&rolled(&out.image), ex, &across.dilate(1), 5, 1).unwrap();
    let elsewhere = seam_visibility(&out.image, ex, &inner.dilate(1), 5, 1).unwrap();
    across_edges / elsewhere
}

#[test]
fn tileable_outputs_continue_across_their_edges() {
    for (name, ex) in [("cobbles", samples::cobbles(96, 96, 6)), ("bricks", samples::bricks(96, 96, 6))] {
        let problem = Synthesis::new(&ex).size(160, 128).seed(2);
        let tile = problem.clone().tileable(true).optimize(&OptimizeParams::default()).unwrap();
        let plain = problem.optimize(&OptimizeParams::default()).unwrap();
        let (t, p) = (wrap_seam_visibility(&tile, &ex), wrap_seam_visibility(&plain, &ex));
        eprintln!("{name}: seams across the edges / other seams: tileable {t:.2}, plain {p:.2}");
        // Measured over seeds 1-7: cobbles 0.96-1.23 (plain 2.2-2.6);
        // bricks 1.01-1.74 (plain 4.5-6.3), whose courses have a period the
        // tile's height need not be a multiple of, so somewhere a course
        // must step.
        assert!(t < 2.0, "{name}: the seams across the tile's edges are {t:.2}x as visible as its others");
        assert!(p > 1.5 * t, "{name}: the check cannot tell a plain output ({p:.2}) from a tileable one ({t:.2})");
        // And it is as good a texture as the plain enlargement.
        let (coherent, complete, report) = enlargement_quality(&tile.image, &ex);
        assert!(coherent && complete, "{name}: tileable output quality: {report}");
    }
    // Refused where the output cannot wrap.
    let ex = samples::bricks(64, 64, 1);
    let hole = Mask::filled(64, 64, false);
    let e = Synthesis::new(&ex).tileable(true).fill(&ex, &hole).optimize(&OptimizeParams::default()).unwrap_err();
    assert!(e.to_string().contains("tileable"), "{e}");
    let e = Synthesis::new(&ex).size(10, 10).tileable(true).quilt(&QuiltParams::default()).unwrap_err();
    assert!(e.to_string().contains("tileable"), "{e}");
    // Image quilting tiles too: its last blocks are cut against the first.
    let edge_step = |img: &Image| {
        let (w, h) = img.size();
        let step = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(p, q)| (p - q).abs()).sum::<f32>();
        let across: f32 = (0..h).map(|y| step(img.pixel(w - 1, y), img.pixel(0, y))).sum::<f32>() / h as f32;
        let inside: f32 =
            (0..h).flat_map(|y| (0..w - 1).map(move |x| (x, y))).map(|(x, y)| step(img.pixel(x, y), img.pixel(x + 1, y))).sum::<f32>()
                / ((w - 1) * h) as f32;
        across / inside
    };
    let quilt = |tile: bool| Synthesis::new(&ex).size(150, 120).seed(4).tileable(tile).quilt(&QuiltParams::default()).unwrap();
    let (tiled, plain) = (quilt(true), quilt(false));
    assert!(tiled.plan.wrap && !plain.plan.wrap);
    let (t, p) = (edge_step(&tiled.image), edge_step(&plain.image));
    // Measured 1.5 and 4.4 (6.9 with plain overlap costs, whose quilt
    // holds more of the bricks' plain faces, so its steps inside are
    // smaller): a cut is a step (the quilt has no blend to hide it), and
    // the plain quilt's edges are unrelated pixels.
    assert!(t < 2.2 && p > 2.5 * t, "quilt: step across the edge over the mean step: tileable {t:.2}, plain {p:.2}");
}

/// Share of output pixels whose source shift (source minus output
/// position) is within 2 px of a whole number of `period`s from the most
/// common shift: how much of the output keeps one grid phase.
fn in_phase_share(shifts: &[(i64, i64)], period: i64) -> f32 {
    let p = period as usize;
    let mut counts = vec![0usize; p * p];
    for &(dx, dy) in shifts {
        counts[dy.rem_euclid(period) as usize * p + dx.rem_euclid(period) as usize] += 1;
    }
    let mode = (0..p * p).max_by_key(|&i| (counts[i], std::cmp::Reverse(i))).unwrap();
    let off = |d: i64, r: usize| {
        let e = (d - r as i64).rem_euclid(period);
        e.min(period - e)
    };
    let ok = shifts.iter().filter(|&&(dx, dy)| off(dx, mode % p) <= 2 && off(dy, mode / p) <= 2).count();
    ok as f32 / shifts.len() as f32
}

#[test]
fn a_regular_grid_of_varied_tiles_stays_in_one_phase() {
    // Round tiles on a 48 px grid, each stained differently: the overlap
    // cost alone lets blocks split tiles (the stains differ more than the
    // layout does); kept on the exemplar's lattice, every tile stays whole.
    let period = 48;
    let ex = samples::disc_grid(160, 160, period as usize, 2);
    let (w, h) = (320usize, 320usize);
    let weights = [1.0 / 3.0; 3];
    // The optimized output still holds the exemplar's grid.
    let keeps_grid = |img: &Image| {
        Lattice::detect(img, &weights).is_some_and(|l| {
            l.periods.len() == 2 && l.periods.iter().all(|p| ((p[0].powi(2) + p[1].powi(2)).sqrt() - period as f32).abs() < 1.0)
        })
    };
    let (mut on_total, mut off_total) = (0.0, 0.0);
    for seed in 0..3 {
        let run = |lattice: bool| {
            let quilted = Synthesis::new(&ex).size(w, h).seed(seed).quilt(&QuiltParams { lattice, ..QuiltParams::default() }).unwrap();
            let pos = quilted.plan.source_positions();
            let shifts: Vec<(i64, i64)> =
                (0..w * h).map(|i| (pos[i].0 as i64 - (i % w) as i64, pos[i].1 as i64 - (i / w) as i64)).collect();
            let params = OptimizeParams { lattice, ..OptimizeParams::default() };
            let optimized = Synthesis::new(&ex).size(w, h).seed(seed).optimize(&params).unwrap().image;
            (in_phase_share(&shifts, period), keeps_grid(&optimized), quilted.lattice.is_some())
        };
        let ((q, grid, found), (qf, grid_off, _)) = (run(true), run(false));
        eprintln!("seed {seed}: quilt in phase {q:.3} (without the lattice {qf:.3}); optimized keeps the grid {grid} (without {grid_off})");
        assert!(found, "seed {seed}: no lattice found on the grid");
        assert!(q >= 0.95, "seed {seed}: only {q:.3} of the quilt in the grid's phase");
        assert!(grid, "seed {seed}: the optimized output lost the 48 px grid");
        on_total += q;
        off_total += qf;
    }
    // Without the lattice the quilt splits tiles (the test can tell).
    assert!(off_total < on_total - 0.5, "the lattice does not help quilting: {on_total:.2} vs {off_total:.2} over 3 seeds");
}

#[test]
fn a_layout_made_elsewhere_is_healed_at_its_cuts_and_kept_inside_its_blocks() {
    // Two halves of cobbles from different parts of the exemplar, joined by
    // a straight cut: stones are sliced in half along it.
    let ex = samples::cobbles(128, 96, 4);
    let (w, h) = (96, 64);
    let layout: Vec<(u32, u32)> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            if x < 48 {
                (x + 3, y + 3)
            } else {
                (x + 27, y + 29)
            }
        })
        .collect();
    let pasted = Image::from_fn(w, h, 3, |x, y, p| {
        let (sx, sy) = layout[y * w + x];
        p.copy_from_slice(ex.pixel(sx as usize, sy as usize));
    });
    let params = OptimizeParams { search_radius: Some(4), ..OptimizeParams::default() };
    let healed = Synthesis::new(&ex).size(w, h).seed(2).heal_layout(&layout).optimize(&params).unwrap();
    let cut = Mask::from_fn(w, h, |x, _| (46..50).contains(&x));
    let (before, after) = (seam_visibility(&pasted, &ex, &cut, 7, 1).unwrap(), seam_visibility(&healed.image, &ex, &cut, 7, 1).unwrap());
    // Measured 0.079 pasted, 0.060 healed (0.060-0.062 with search radii 4-100).
    assert!(after < 0.85 * before, "coherence distance on the cut: {before} pasted, {after} healed");
    // Away from the cut the blocks stay verbatim copies of the layout.
    for y in 0..h {
        for x in (4..30).chain(66..92) {
            let m = healed.nnf.get(x, y);
            assert_eq!((m.x, m.y), layout[y * w + x], "pixel ({x}, {y}) moved");
        }
    }
    // The heal only shifts the layout's own blocks: each search looks at
    // most 4 px from a match, so matches drift from the two blocks'
    // offsets only as far as a few searches in a row take them. Measured:
    // 13 of 6144 pixels more than 8 px off, at most 15 px; searching the
    // whole exemplar, 148 and 68 px.
    let drift: Vec<i64> = healed
        .nnf
        .matches()
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let off = |dx: i64, dy: i64| (m.x as i64 - x - dx).abs().max((m.y as i64 - y - dy).abs());
            off(3, 3).min(off(27, 29))
        })
        .collect();
    let far = drift.iter().filter(|&&d| d > 8).count();
    assert!(far < 50 && drift.iter().all(|&d| d <= 24), "{far} pixels over 8 px off, at most {:?}", drift.iter().max());
    // A layout of the wrong size is refused by name.
    let short = &layout[..10];
    let err = Synthesis::new(&ex).size(w, h).heal_layout(short).optimize(&params).unwrap_err();
    assert!(err.to_string().contains("layout"), "{err}");
}
