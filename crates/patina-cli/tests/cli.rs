//! The `patina` binary: outputs, manifests, determinism across thread
//! counts and bad-input behaviour (one line, exit 2, nothing left behind).

mod scratch_support;
use patina::image::io::{load, save_png, BitDepth};
use scratch_support::Scratch;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn patina(args: &[&str], threads: Option<usize>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_patina"));
    cmd.args(args);
    if let Some(t) = threads {
        cmd.env("RAYON_NUM_THREADS", t.to_string());
    }
    cmd.output().expect("runs")
}

fn scratch(name: &str) -> Scratch {
    Scratch::new("cli", name)
}

fn exemplar(dir: &Path) -> PathBuf {
    let p = dir.join("ex.png");
    save_png(&patina::samples::cobbles(64, 64, 3), &p, BitDepth::Eight).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Files in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn synth_writes_the_image_and_a_complete_manifest() {
    let dir = scratch("ok");
    let ex = exemplar(&dir);
    let out = dir.join("out.png");
    // The default method quilts a plain enlargement.
    let r = patina(&["synth", s(&ex), "-o", s(&out), "--size", "100x80", "--seed", "4"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("out.png.manifest.json")).unwrap()).unwrap();
    assert_eq!(m["params"]["method"], "quilt");
    let r = patina(&["synth", s(&ex), "-o", s(&out), "--size", "100x80", "--seed", "4", "--method", "optimize"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(load(&out).unwrap().size(), (100, 80));
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("out.png.manifest.json")).unwrap()).unwrap();
    assert_eq!(m["command"], "synth");
    assert_eq!(m["seed"], 4);
    assert_eq!(m["params"]["optimize"]["patch"], 5);
    assert!(m["params"]["optimize"]["levels"].as_u64().unwrap() >= 1, "resolved defaults are recorded");
    assert!(m["timings_ms"]["synthesize"].as_f64().unwrap() > 0.0);
    assert_eq!(listing(&dir), vec!["ex.png", "out.png", "out.png.manifest.json"], "no temporary files left");
}

#[test]
fn a_regular_exemplar_records_its_lattice_and_a_tile_says_which_size_closes_it() {
    let dir = scratch("lattice");
    let ex = dir.join("grid.png");
    save_png(&patina::samples::disc_grid(160, 160, 48, 1), &ex, BitDepth::Eight).unwrap();
    let run = |name: &str, size: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec!["synth", s(&ex), "-o", s(&out), "--size", size, "--seed", "2", "--method", "quilt"];
        args.extend_from_slice(extra);
        let r = patina(&args, None);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let m: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join(format!("{name}.manifest.json"))).unwrap()).unwrap();
        (String::from_utf8_lossy(&r.stderr).into_owned(), m["metrics"]["lattice"].clone())
    };
    let (note, lattice) = run("a.png", "200x200", &["--tile"]);
    let periods = lattice["periods"].as_array().expect("a lattice in the manifest");
    assert_eq!(periods.len(), 2);
    for p in periods {
        let (x, y) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
        assert!(((x * x + y * y).sqrt() - 48.0).abs() < 1.0, "{lattice}");
    }
    assert!(note.contains("192x192 would close it"), "{note}");
    let (note, _) = run("b.png", "192x192", &["--tile"]);
    assert!(!note.contains("would close"), "{note}");
    assert!(!note.contains("perspective"), "{note}");
    let (_, lattice) = run("c.png", "200x200", &["--no-lattice"]);
    assert!(lattice.is_null(), "{lattice}");
    // Boards widening down the image: no lattice kept, and a note says why.
    save_png(&patina::samples::receding_boards(200, 200, 22.0, 24.5, 3), &ex, BitDepth::Eight).unwrap();
    let (note, lattice) = run("d.png", "240x240", &[]);
    assert!(lattice.is_null(), "{lattice}");
    assert!(note.contains("perspective"), "{note}");
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("d.png.manifest.json")).unwrap()).unwrap();
    assert_eq!(m["metrics"]["drifting_periods"].as_array().map(Vec::len), Some(1), "{}", m["metrics"]);
}

#[test]
fn output_bytes_do_not_depend_on_thread_count() {
    let dir = scratch("threads");
    let ex = exemplar(&dir);
    for method in ["optimize", "quilt"] {
        let outs: Vec<Vec<u8>> = [1, 2]
            .iter()
            .map(|&t| {
                let out = dir.join(format!("{method}-{t}.png"));
                let r = patina(&["synth", s(&ex), "-o", s(&out), "--size", "96x96", "--method", method, "--seed", "7"], Some(t));
                assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
                std::fs::read(out).unwrap()
            })
            .collect();
        assert_eq!(outs[0], outs[1], "{method}: 1 and 2 threads differ");
    }
}

/// Run a failing command: exit code 2, one line on stderr naming `needle`,
/// and the folder unchanged.
fn fails_cleanly(dir: &Path, args: &[&str], needle: &str) {
    let before = listing(dir);
    let r = patina(args, None);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: not one line: {err}");
    assert!(err.to_lowercase().contains(&needle.to_lowercase()), "{args:?}: '{err}' does not mention '{needle}'");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(listing(dir), before, "{args:?} left files behind");
}

#[test]
fn bad_input_is_one_line_exit_2_and_leaves_nothing() {
    let dir = scratch("bad");
    let ex = exemplar(&dir);
    let out = dir.join("out.png");
    let (ex_s, out_s) = (s(&ex), s(&out));
    let corrupt = dir.join("corrupt.png");
    std::fs::write(&corrupt, b"\x89PNG\r\n\x1a\n garbage").unwrap();
    let tiny = dir.join("tiny.png");
    save_png(&patina::samples::cobbles(4, 4, 1), &tiny, BitDepth::Eight).unwrap();
    let guide_ok = dir.join("g64.png");
    save_png(&patina::samples::blotches(64, 64, 1), &guide_ok, BitDepth::Eight).unwrap();
    let guide_bad = dir.join("g50.png");
    save_png(&patina::samples::blotches(50, 64, 1), &guide_bad, BitDepth::Eight).unwrap();

    fails_cleanly(&dir, &["synth", s(&dir.join("missing.png")), "-o", out_s], "missing.png");
    fails_cleanly(&dir, &["synth", s(&corrupt), "-o", out_s], "corrupt.png");
    fails_cleanly(&dir, &["synth", s(&tiny), "-o", out_s], "smaller than");
    fails_cleanly(&dir, &["synth", ex_s, "-o", out_s, "--size", "0x64"], "empty");
    fails_cleanly(&dir, &["synth", ex_s, "-o", out_s, "--size", "60000x60000"], "memory");
    fails_cleanly(&dir, &["synth", ex_s, "-o", out_s, "--size", "99999x10"], "exceeds");
    fails_cleanly(&dir, &["synth", ex_s, "-o", out_s, "--source-guide", s(&guide_bad), "--target-guide", s(&guide_ok)], "source guide");
    fails_cleanly(&dir, &["synth", ex_s, "-o", out_s, "--source-guide", s(&guide_ok)], "target-guide");
    fails_cleanly(&dir, &["synth", ex_s, "-o", out_s, "--patch", "4"], "patch");
    fails_cleanly(&dir, &["synth", ex_s, "-o", s(&dir.join("out.jpg"))], ".png or .exr");
    fails_cleanly(&dir, &["synth", ex_s, "-o", s(&dir.join("nofolder/out.png"))], "does not exist");
    fails_cleanly(&dir, &["synth", ex_s, "-o", out_s, "--method", "magic"], "magic");
    fails_cleanly(&dir, &["synth", ex_s, "-o", out_s, "--method", "quilt", "--block", "200"], "block");
    // The output may never be an input: the exemplar stays byte-identical.
    let original = std::fs::read(&ex).unwrap();
    fails_cleanly(&dir, &["synth", ex_s, "-o", ex_s], "overwrite");
    assert_eq!(std::fs::read(&ex).unwrap(), original);
}

#[test]
fn guided_synth_takes_its_size_from_the_target_guide() {
    let dir = scratch("guided");
    let ex = exemplar(&dir);
    let (sg, tg) = (dir.join("sg.png"), dir.join("tg.png"));
    save_png(&patina::samples::blotches(64, 64, 1), &sg, BitDepth::Eight).unwrap();
    save_png(&patina::samples::blotches(90, 70, 2), &tg, BitDepth::Eight).unwrap();
    let out = dir.join("g.png");
    let r = patina(&["synth", s(&ex), "-o", s(&out), "--source-guide", s(&sg), "--target-guide", s(&tg), "--bits", "16"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(load(&out).unwrap().size(), (90, 70));
}

#[test]
fn demo_makes_its_own_samples_and_measures_them() {
    let dir = scratch("demo");
    let out = dir.join("demo");
    let r = patina(&["demo", "--out", s(&out)], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(
        listing(&out),
        vec!["decay", "exemplar.png", "manifest.json", "optimize.png", "quilt.png", "samples", "stbrdf", "stone", "ttf", "weather"]
    );
    // The stele erodes and the post's rust spreads.
    let read = |p: &str| -> serde_json::Value { serde_json::from_slice(&std::fs::read(out.join(p)).unwrap()).unwrap() };
    let area = read("stone/manifest.json")["metrics"]["object_pixels"].clone();
    assert!(area[3].as_f64() < area[0].as_f64(), "stele area {area}");
    let covered = read("decay/manifest.json")["metrics"]["decayed_fraction"].clone();
    assert!(covered[7].as_f64() > covered[0].as_f64(), "rust cover {covered}");
    // The time-lapse: 40 frames enlarged, no more flicker than the input's.
    let t: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("ttf/manifest.json")).unwrap()).unwrap();
    assert_eq!(t["frames"].as_array().unwrap().len(), 40);
    let (fi, fo) = (t["metrics"]["flicker_input"].as_f64().unwrap(), t["metrics"]["flicker_output"].as_f64().unwrap());
    assert!(fo < 1.5 * fi && fi < 1.5 * fo, "flicker {fo} vs input {fi}");
    // The flagship: weathering of rusty tiles, with its own manifest.
    let w: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("weather/manifest.json")).unwrap()).unwrap();
    let areas: Vec<f64> = w["metrics"]["weathered_area"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(areas.len(), 8);
    assert!(areas[0] == 0.0 && areas.windows(2).all(|p| p[1] >= p[0]) && areas[7] > areas[4], "{areas:?}");
    assert!(w["params"]["tiles"].is_object(), "the demo tiles have a grid");
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let own = m["metrics"]["exemplar_self_similarity"].as_f64().unwrap();
    for method in ["optimize", "quilt"] {
        let c = m["metrics"][format!("{method}_coherence")].as_f64().unwrap();
        assert!(c > 0.0 && c < 1.5 * own, "{method} coherence {c} vs self-similarity {own}");
    }
}

#[test]
fn weather_writes_frames_gif_and_a_manifest_with_times() {
    let dir = scratch("weather");
    let (img, _) = patina::samples::weather(&patina::samples::tiles(96, 96, 1), patina::samples::Weathering::Rust, 0.1, 2);
    let input = dir.join("rusty.png");
    save_png(&img, &input, BitDepth::Eight).unwrap();
    let out = dir.join("out");
    let r = patina(&["weather", s(&input), "--out", s(&out), "--past", "2", "--future", "2", "--seed", "5"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(listing(&out), vec!["age_map.png", "frames", "intact.png", "manifest.json", "sequence.gif"]);
    assert_eq!(listing(&out.join("frames")), vec!["000.png", "001.png", "002.png", "003.png", "004.png", "005.png"]);
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let ts: Vec<f64> = m["frames"].as_array().unwrap().iter().map(|f| f["t"].as_f64().unwrap()).collect();
    assert_eq!(ts.len(), 6);
    assert!(ts.windows(2).all(|w| w[0] < w[1]) && ts[0] == 0.0 && ts[3] == 1.0 && ts[5] == 2.0, "{ts:?}");
    assert_eq!(m["params"]["age"]["grid_used"], 12, "the grid shrinks so 96 px keeps 8 px patches");
    assert_eq!(load(out.join("frames/003.png")).unwrap().data(), load(&input).unwrap().data(), "t = 1 is the input");
    // The GIF holds every frame.
    let gif = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(std::fs::File::open(out.join("sequence.gif")).unwrap())).unwrap();
    use image::AnimationDecoder;
    assert_eq!(gif.into_frames().count(), 6);
    // Bad inputs: one line, exit 2, nothing written.
    let tiny = dir.join("tiny.png");
    save_png(&patina::image::Image::new(10, 10, 3), &tiny, BitDepth::Eight).unwrap();
    let bad = dir.join("bad");
    fails_cleanly(&dir, &["weather", s(&tiny), "--out", s(&bad)], "too small");
    assert!(!bad.exists(), "no output folder for a failed run");
    fails_cleanly(&dir, &["weather", s(&input), "--out", s(&bad), "--age-map", s(&tiny)], "age map");
    fails_cleanly(&dir, &["age-map", s(&input), "-o", s(&input)], "overwrite");
}

/// `--mask`: a stucco disc with rust on bricks. The bricks come out of
/// every frame exactly as they went in, the manifest says where the mask
/// came from, and a mask of another size or of nothing, a `--point`
/// without `--mask auto`, and a weathered pixel off the mask are refused.
#[test]
fn weather_with_a_mask_keeps_the_background_and_refuses_bad_masks() {
    let dir = scratch("weather_mask");
    let size = 128;
    let (rusty, _) = patina::samples::weather(&patina::samples::stucco(size, size, 4), patina::samples::Weathering::Rust, 0.1, 11);
    let bricks = patina::samples::bricks(size, size, 2);
    let disc = patina::image::Mask::from_fn(size, size, |x, y| (x as f32 - 64.0).hypot(y as f32 - 64.0) < 42.0);
    let img = patina::image::Image::from_fn(size, size, 3, |x, y, p| {
        p.copy_from_slice(if disc.get(x, y) { rusty.pixel(x, y) } else { bricks.pixel(x, y) })
    });
    let (input, mask) = (dir.join("in.png"), dir.join("mask.png"));
    save_png(&img, &input, BitDepth::Eight).unwrap();
    save_png(&disc.to_image(), &mask, BitDepth::Eight).unwrap();
    let out = dir.join("out");
    let r = patina(&["weather", s(&input), "--out", s(&out), "--mask", s(&mask), "--past", "1", "--future", "1", "--seed", "2"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["params"]["mask_source"], "file");
    let original = load(&input).unwrap();
    for f in ["age_map.png", "intact.png", "frames/000.png", "frames/001.png", "frames/003.png"] {
        let o = load(out.join(f)).unwrap();
        let kept = (0..size * size).filter(|&i| !disc.bits()[i]).all(|i| {
            let (x, y) = (i % size, i / size);
            if f == "age_map.png" {
                o.at(x, y, 0) == 0.0
            } else {
                o.pixel(x, y) == original.pixel(x, y)
            }
        });
        assert!(kept, "{f} changed the background");
    }
    // age-map and intact take the same mask.
    for (cmd, name) in [("age-map", "age.png"), ("intact", "intact.png")] {
        let one = dir.join(name);
        let r = patina(&[cmd, s(&input), "-o", s(&one), "--mask", s(&mask), "--seed", "2"], None);
        assert!(r.status.success(), "{cmd}: {}", String::from_utf8_lossy(&r.stderr));
        let o = load(&one).unwrap();
        let kept = (0..size * size).filter(|&i| !disc.bits()[i]).all(|i| {
            if cmd == "age-map" {
                o.data()[i] == 0.0
            } else {
                o.pixel(i % size, i / size) == original.pixel(i % size, i / size)
            }
        });
        assert!(kept, "{cmd} changed the background");
    }
    let bad = dir.join("bad");
    let small = dir.join("small.png");
    save_png(&patina::image::Image::new(64, 64, 1), &small, BitDepth::Eight).unwrap();
    fails_cleanly(&dir, &["weather", s(&input), "--out", s(&bad), "--mask", s(&small)], "mask is 64x64");
    let black = dir.join("black.png");
    save_png(&patina::image::Image::new(size, size, 1), &black, BitDepth::Eight).unwrap();
    fails_cleanly(&dir, &["weather", s(&input), "--out", s(&bad), "--mask", s(&black)], "selects no pixel");
    fails_cleanly(&dir, &["weather", s(&input), "--out", s(&bad), "--mask", s(&mask), "--point", "5,5"], "--mask auto");
    fails_cleanly(&dir, &["weather", s(&input), "--out", s(&bad), "--mask", s(&mask), "--weathered-at", "2,2"], "outside the mask");
    fails_cleanly(&dir, &["weather", s(&input), "--out", s(&bad), "--mask", s(&dir.join("none.png"))], "none.png");
}

#[test]
fn age_map_and_intact_write_single_images() {
    let dir = scratch("agemap");
    let (img, _) = patina::samples::weather(&patina::samples::gravel(96, 96, 1), patina::samples::Weathering::Stain, 0.1, 2);
    let input = dir.join("in.png");
    save_png(&img, &input, BitDepth::Eight).unwrap();
    for (cmd, name) in [("age-map", "age.png"), ("intact", "intact.png")] {
        let out = dir.join(name);
        let r = patina(&[cmd, s(&input), "-o", s(&out)], None);
        assert!(r.status.success(), "{cmd}: {}", String::from_utf8_lossy(&r.stderr));
        let o = load(&out).unwrap();
        assert_eq!(o.size(), (96, 96));
        assert_eq!(o.channels(), if cmd == "age-map" { 1 } else { 3 });
        assert!(dir.join(format!("{name}.manifest.json")).exists());
    }
}

/// A 48 x 40, `n`-frame rusting time-lapse as numbered PNGs in `dir/name`.
fn timelapse(dir: &Path, name: &str, n: usize) -> PathBuf {
    let d = dir.join(name);
    std::fs::create_dir_all(&d).unwrap();
    for (i, f) in patina::samples::rusting_timelapse(48, 40, n, 1).iter().enumerate() {
        // Unpadded numbers: natural order must put 2 before 10.
        save_png(f, d.join(format!("f{i}.png")), BitDepth::Eight).unwrap();
    }
    d
}

#[test]
fn ttf_writes_frames_gifs_and_the_svd_error_and_is_thread_independent() {
    let dir = scratch("ttf");
    let input = timelapse(&dir, "seq", 12);
    let run = |out: &Path, threads: usize| {
        let r = patina(&["ttf", s(&input), "-o", s(out), "--size", "80x64", "--jitter", "2", "--compare", "--seed", "3"], Some(threads));
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    let (a, b) = (dir.join("a"), dir.join("b"));
    run(&a, 1);
    run(&b, 2);
    assert_eq!(listing(&a), vec!["compare.gif", "frames", "manifest.json", "sequence.gif"]);
    assert_eq!(listing(&a.join("frames")).len(), 12);
    for f in listing(&a.join("frames")) {
        assert_eq!(std::fs::read(a.join("frames").join(&f)).unwrap(), std::fs::read(b.join("frames").join(&f)).unwrap(), "{f}");
    }
    assert_eq!(load(a.join("frames/000.png")).unwrap().size(), (80, 64));
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(a.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["command"], "ttf");
    assert_eq!(m["metrics"]["svd_rank"], 12, "rank 15 is clamped to the 12 frames");
    assert!(m["metrics"]["svd_relative_rms"].as_f64().unwrap() < 1e-3);
    // The first output frame is the first input frame's material: natural
    // order read f0 first (not f10).
    let first_in = load(input.join("f0.png")).unwrap();
    let first_out = load(a.join("frames/000.png")).unwrap();
    let mean = |img: &patina::Image| img.data().iter().map(|v| f64::from(*v)).sum::<f64>() / img.data().len() as f64;
    assert!((mean(&first_in) - mean(&first_out)).abs() < 0.03);
    // The GIF input path and a rate map of the output's size.
    let gif = dir.join("seq.gif");
    let frames: Vec<patina::Image> = patina::samples::rusting_timelapse(48, 40, 6, 2);
    patina::image::io::save_gif(&frames.iter().collect::<Vec<_>>(), &gif, 100).unwrap();
    let rate = dir.join("rate.png");
    save_png(&patina::Image::from_fn(80, 64, 1, |x, _, p| p[0] = if x < 40 { 0.5 } else { 1.0 }), &rate, BitDepth::Eight).unwrap();
    let c = dir.join("c");
    let r = patina(&["ttf", s(&gif), "-o", s(&c), "--rate-map", s(&rate), "--rate-scale", "2"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(listing(&c.join("frames")).len(), 3, "6 frames at twice the speed");
    assert_eq!(load(c.join("frames/000.png")).unwrap().size(), (80, 64), "the size comes from the rate map");
}

#[test]
fn ttf_bad_input_is_one_line_exit_2_and_leaves_nothing() {
    let dir = scratch("ttf-bad");
    let input = timelapse(&dir, "seq", 5);
    save_png(&patina::samples::cobbles(40, 40, 1), input.join("f3.png"), BitDepth::Eight).unwrap();
    let out = dir.join("out");
    let good = timelapse(&dir, "good", 5);
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let rate = dir.join("rate.png");
    save_png(&patina::Image::new(10, 10, 1), &rate, BitDepth::Eight).unwrap();
    let o = s(&out);
    fails_cleanly(&dir, &["ttf", s(&input), "-o", o], "f3.png");
    fails_cleanly(&dir, &["ttf", s(&empty), "-o", o], "no frames");
    fails_cleanly(&dir, &["ttf", s(&dir.join("nothing")), "-o", o], "nothing");
    fails_cleanly(&dir, &["ttf", s(&good), "-o", o, "--frames", "2..9"], "outside");
    fails_cleanly(&dir, &["ttf", s(&good), "-o", o, "--frames", "3..1"], "range");
    fails_cleanly(&dir, &["ttf", s(&good), "-o", o, "--step", "0"], "step");
    fails_cleanly(&dir, &["ttf", s(&good), "-o", o, "--block", "60x8"], "block");
    fails_cleanly(&dir, &["ttf", s(&good), "-o", o, "--size", "64x64", "--rate-map", s(&rate)], "rate map");
    fails_cleanly(&dir, &["ttf", s(&good), "-o", o, "--rate-light", "1,2"], "x,y,z");
    fails_cleanly(&dir, &["ttf", s(&good), "-o", o, "--jitter=-1"], "jitter");
    fails_cleanly(&dir, &["ttf", s(&good), "-o", o, "--rate-map", s(&rate), "--rate-light", "1,2,3"], "cannot be used");
    // Writing frames/ inside a folder whose frames/ holds the input refuses.
    let nested = dir.join("nested");
    std::fs::create_dir_all(nested.join("frames")).unwrap();
    save_png(&patina::Image::new(48, 40, 3), nested.join("frames/000.png"), BitDepth::Eight).unwrap();
    save_png(&patina::Image::new(48, 40, 3), nested.join("frames/001.png"), BitDepth::Eight).unwrap();
    let before = std::fs::read(nested.join("frames/000.png")).unwrap();
    fails_cleanly(&dir, &["ttf", s(&nested.join("frames")), "-o", s(&nested)], "overwrite");
    assert_eq!(std::fs::read(nested.join("frames/000.png")).unwrap(), before);
}

/// Drying-wood parameter maps at `n` times: one subfolder per step with
/// Diffuse.png, Specular.png and Roughness.png.
fn material_steps(dir: &Path, n: usize) -> PathBuf {
    let root = dir.join("steps");
    for i in 0..n {
        let t = i as f32 / (n - 1) as f32;
        let maps = patina::stbrdf::procedural::drying_wood_at(40, 32, t, 1);
        let d = root.join(format!("t{i}"));
        std::fs::create_dir_all(&d).unwrap();
        save_png(&maps.select_channels(0..3), d.join("Diffuse.png"), BitDepth::Sixteen).unwrap();
        save_png(&maps.select_channels(3..6), d.join("Specular.png"), BitDepth::Sixteen).unwrap();
        save_png(&maps.select_channels(6..7), d.join("Roughness.png"), BitDepth::Sixteen).unwrap();
    }
    root
}

#[test]
fn stbrdf_fits_enlarges_transfers_and_renders() {
    let dir = scratch("stbrdf");
    let steps = material_steps(&dir, 8);
    let mat = dir.join("mat");
    let ok = |args: &[&str]| {
        let r = patina(args, None);
        assert!(r.status.success(), "{args:?}: {}", String::from_utf8_lossy(&r.stderr));
    };
    ok(&["stbrdf", "fit", s(&steps), "-o", s(&mat), "--degree", "3"]);
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(mat.join("manifest.json")).unwrap()).unwrap();
    let rms: Vec<f64> =
        m["metrics"]["rms"].as_object().unwrap().values().flat_map(|v| v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap())).collect();
    assert_eq!(rms.len(), 7);
    assert!(rms.iter().all(|&r| r <= 0.03), "{rms:?}");
    let loaded = patina::stbrdf::Material::load(&mat).unwrap();
    assert_eq!((loaded.degree, loaded.channels(), loaded.size()), (3, 7, (40, 32)));
    let big = dir.join("big");
    ok(&["stbrdf", "enlarge", s(&mat), "-o", s(&big), "--scale", "1.5", "--seed", "2"]);
    assert_eq!(patina::stbrdf::Material::load(&big).unwrap().size(), (60, 48));
    // The same seed gives the same EXR bytes on 1 and 2 threads.
    let (one, two) = (dir.join("one"), dir.join("two"));
    for (out, threads) in [(&one, 1), (&two, 2)] {
        let r = patina(&["stbrdf", "enlarge", s(&mat), "-o", s(out), "--scale", "1.5", "--seed", "2"], Some(threads));
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    }
    for f in listing(&one).into_iter().filter(|f| f.ends_with(".exr")) {
        assert_eq!(std::fs::read(one.join(&f)).unwrap(), std::fs::read(two.join(&f)).unwrap(), "{f}");
    }
    let target = dir.join("target.png");
    save_png(&patina::samples::cobbles(50, 40, 1), &target, BitDepth::Eight).unwrap();
    let moved = dir.join("moved");
    ok(&["stbrdf", "transfer", s(&mat), "--target", s(&target), "--t0", "1", "-o", s(&moved)]);
    let renders = dir.join("renders");
    ok(&["stbrdf", "render", s(&moved), "-o", s(&renders), "--frames", "3", "--sphere", "64"]);
    assert_eq!(
        listing(&renders),
        vec!["frames", "manifest.json", "material.glsl", "material.hlsl", "material.shader", "material.wgsl", "sequence.gif"]
    );
    // 3 times x (3 parameter maps + plane + sphere).
    assert_eq!(listing(&renders.join("frames")).len(), 15);
    let last = load(renders.join("frames/002_basecolor.png")).unwrap();
    let want = load(&target).unwrap();
    let err = last.data().iter().zip(want.data()).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(err <= 1.5 / 255.0, "at t0 = 1 the transferred base colour is the target ({err})");
    assert!(std::fs::read_to_string(renders.join("material.wgsl")).unwrap().contains("fn evaluate_material"));
    // With a mask (the left half), the right half is the target at every t.
    let mask = dir.join("mask.png");
    save_png(&patina::Image::from_fn(50, 40, 1, |x, _, p| p[0] = if x < 25 { 1.0 } else { 0.0 }), &mask, BitDepth::Eight).unwrap();
    let masked = dir.join("masked");
    ok(&["stbrdf", "transfer", s(&mat), "--target", s(&target), "--mask", s(&mask), "-o", s(&masked)]);
    let masked_renders = dir.join("masked_renders");
    ok(&["stbrdf", "render", s(&masked), "-o", s(&masked_renders), "--frames", "3", "--sphere", "16"]);
    for i in 0..3 {
        let frame = load(masked_renders.join(format!("frames/{i:03}_basecolor.png"))).unwrap();
        for y in 0..40 {
            for x in 26..50 {
                assert_eq!(frame.pixel(x, y), &want.pixel(x, y)[..3], "frame {i}: ({x}, {y}) outside the mask changed");
            }
        }
    }
}

/// A capture whose camera shakes: cobbles stained by drying wood's damp,
/// which dries over time, seen through a 64 x 56 window that moves by
/// `moves` (x, y) px, one PNG frame per time.
fn shaking_frames(dir: &Path, moves: &[(usize, usize)]) -> PathBuf {
    let root = dir.join("shaking");
    std::fs::create_dir_all(&root).unwrap();
    for (i, &(mx, my)) in moves.iter().enumerate() {
        let t = i as f32 / (moves.len() - 1) as f32;
        let damp = patina::stbrdf::procedural::drying_wood_at(80, 72, t, 4);
        let cobbles = patina::samples::cobbles(80, 72, 4);
        let frame = patina::Image::from_fn(64, 56, 3, |x, y, p| {
            let (d, c) = (damp.pixel(x + mx, y + my), cobbles.pixel(x + mx, y + my));
            (0..3).for_each(|k| p[k] = c[k] * d[k] / 0.62);
        });
        save_png(&frame, root.join(format!("frame_{i:02}.png")), BitDepth::Sixteen).unwrap();
    }
    root
}

#[test]
fn stbrdf_fit_and_ttf_register_a_shaking_capture() {
    let dir = scratch("stbrdf-shaking");
    let moves = [(4, 4), (9, 5), (8, 3), (10, 6), (7, 4), (11, 5), (9, 2), (10, 4)];
    let frames = shaking_frames(&dir, &moves);
    let fit = |out: &str, extra: &[&str]| {
        let out = dir.join(out);
        let mut args = vec!["stbrdf", "fit", s(&frames), "-o", s(&out)];
        args.extend_from_slice(extra);
        let r = patina(&args, None);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let m: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
        let rms: f64 = m["metrics"]["rms"]["Diffuse"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).sum::<f64>() / 3.0;
        (patina::stbrdf::Material::load(&out).unwrap(), m, rms, String::from_utf8_lossy(&r.stderr).into_owned())
    };
    let (registered, m, rms, said) = fit("registered", &[]);
    let (raw, _, raw_rms, _) = fit("raw", &["--no-register"]);
    // Frame i shows frame 0's place moved back by its move; the camera
    // spans 7 px across and 4 down, so 57 x 52 of 64 x 56 are common.
    let offsets: Vec<[i64; 2]> = m["params"]["registration"]["offsets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| [o[0].as_i64().unwrap(), o[1].as_i64().unwrap()])
        .collect();
    let want: Vec<[i64; 2]> = moves.iter().map(|&(x, y)| [4 - x as i64, 4 - y as i64]).collect();
    assert_eq!(offsets, want);
    assert_eq!((registered.size(), raw.size()), ((57, 52), (64, 56)));
    assert!(said.contains("7 x 2 px") && said.contains("57x52"), "{said}");
    // Each texel's fit follows one place: it fits the frames far better.
    assert!(rms < 0.5 * raw_rms, "rms {rms} registered, {raw_rms} not");
    // ttf registers the same way: its time columns stop shaking.
    let flicker = |out: &str, extra: &[&str]| {
        let out = dir.join(out);
        let mut args = vec!["ttf", s(&frames), "-o", s(&out), "--size", "72x64", "--seed", "1"];
        args.extend_from_slice(extra);
        let r = patina(&args, None);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let m: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
        let frames: Vec<patina::Image> = (0..moves.len()).map(|i| load(out.join(format!("frames/{i:03}.png"))).unwrap()).collect();
        let steps = frames.windows(3).flat_map(|w| {
            w[1].data()
                .iter()
                .zip(w[0].data().iter().zip(w[2].data()))
                .map(|(b, (a, c))| (b - (a + c) / 2.0).abs() as f64)
                .collect::<Vec<_>>()
        });
        let (sum, n) = steps.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
        (m["params"]["registration"]["window"].clone(), sum / n as f64)
    };
    let (window, steady) = flicker("ttf", &[]);
    let (none, shaking) = flicker("ttf_raw", &["--no-register"]);
    assert_eq!((window, none), (serde_json::json!([7, 2, 57, 52]), serde_json::Value::Null));
    assert!(steady < 0.8 * shaking, "frame-to-frame change {steady} registered, {shaking} not");
    // A registered run that then fails says only its error.
    fails_cleanly(&dir, &["ttf", s(&frames), "-o", s(&dir.join("bad")), "--block", "60x8"], "block");
}

#[test]
fn stbrdf_bad_input_is_one_line_exit_2_and_leaves_nothing() {
    let dir = scratch("stbrdf-bad");
    let steps = material_steps(&dir, 3);
    let out = dir.join("out");
    let o = s(&out);
    fails_cleanly(&dir, &["stbrdf", "fit", s(&dir.join("nothing")), "-o", o], "nothing");
    fails_cleanly(&dir, &["stbrdf", "fit", s(&steps), "-o", o, "--degree", "9"], "degree");
    fails_cleanly(&dir, &["stbrdf", "fit", s(&steps), "-o", o, "--degree", "3"], "time steps");
    fails_cleanly(&dir, &["stbrdf", "fit", s(&steps), "-o", o, "--degree", "1", "--times", "0,1"], "--times");
    std::fs::remove_file(steps.join("t2/Specular.png")).unwrap();
    fails_cleanly(&dir, &["stbrdf", "fit", s(&steps), "-o", o, "--degree", "1"], "parameters");
    fails_cleanly(&dir, &["stbrdf", "render", s(&steps), "-o", o], "material");
    fails_cleanly(&dir, &["stbrdf", "enlarge", s(&dir.join("nothing")), "-o", o], "not a material folder");
}

#[test]
fn stone_writes_frames_masks_and_is_the_same_on_any_thread_count() {
    let dir = scratch("stone");
    let (w, h) = (96, 80);
    let slab = patina::Mask::from_fn(w, h, |x, y| (16..80).contains(&x) && (16..70).contains(&y));
    let photo = patina::Image::from_fn(w, h, 3, |x, y, p| {
        let v = if slab.get(x, y) {
            0.5 + if (x / 6 + y / 8) % 2 == 0 { 0.2 } else { 0.0 }
        } else {
            0.2 + 0.1 * ((x * 7 + y * 3) % 5) as f32 / 5.0
        };
        p.copy_from_slice(&[v, v, v * 0.9]);
    });
    let (img, mask) = (dir.join("photo.png"), dir.join("mask.png"));
    save_png(&photo, &img, BitDepth::Eight).unwrap();
    save_png(&slab.to_image(), &mask, BitDepth::Eight).unwrap();
    let run = |out: &Path, threads: usize| {
        let r = patina(
            &["stone", s(&img), "--mask", s(&mask), "-o", s(out), "--times", "0,50,100", "--erosion-speed", "0.003", "--n", "200"],
            Some(threads),
        );
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    let (a, b) = (dir.join("a"), dir.join("b"));
    run(&a, 1);
    run(&b, 2);
    for name in ["frames/000.png", "frames/002.png", "tendency.png", "segments.png", "mask_t002.png", "sequence.gif", "manifest.json"] {
        let (x, y) = (std::fs::read(a.join(name)).unwrap(), std::fs::read(b.join(name)).unwrap());
        if name != "manifest.json" {
            assert_eq!(x, y, "{name} differs between 1 and 2 threads");
        }
    }
    let first = patina::image::io::load(a.join("mask_t000.png")).unwrap();
    let last = patina::image::io::load(a.join("mask_t002.png")).unwrap();
    let area = |m: &patina::Image| m.data().iter().filter(|&&v| v > 0.5).count();
    // The object at t = 0 is the mask dilated by the manifest's mask_dilation (its rim).
    let manifest: serde_json::Value = serde_json::from_slice(&std::fs::read(a.join("manifest.json")).unwrap()).unwrap();
    let dilation = manifest["params"]["mask_dilation"].as_u64().expect("mask_dilation in the manifest") as usize;
    assert_eq!(area(&first), slab.dilate(dilation).count());
    assert!(area(&last) < area(&first), "the silhouette should erode");
    fails_cleanly(&dir, &["stone", s(&img), "--mask", s(&dir.join("nothing.png")), "-o", s(&dir.join("c"))], "nothing.png");
    fails_cleanly(&dir, &["stone", s(&img), "-o", s(&dir.join("c")), "--times", "50,10"], "ascending");
    save_png(&patina::Image::new(40, 40, 1), dir.join("small.png"), BitDepth::Eight).unwrap();
    fails_cleanly(&dir, &["stone", s(&img), "--mask", s(&dir.join("small.png")), "-o", s(&dir.join("c"))], "mask");
}

#[test]
fn decay_writes_every_output_and_is_the_same_on_any_thread_count() {
    let dir = scratch("decay");
    let (w, h) = (96, 80);
    let body = patina::Mask::from_fn(w, h, |x, y| (20..76).contains(&x) && (10..70).contains(&y));
    let photo = patina::Image::from_fn(w, h, 3, |x, y, p| {
        let v = if body.get(x, y) { 0.4 + 0.4 * (x as f32 / w as f32) } else { 0.5 };
        p.copy_from_slice(&[v, v * 0.5, v * 0.2]);
    });
    let (img, mask) = (dir.join("photo.png"), dir.join("mask.png"));
    save_png(&photo, &img, BitDepth::Eight).unwrap();
    save_png(&body.to_image(), &mask, BitDepth::Eight).unwrap();
    let run = |out: &Path, threads: usize| {
        let r = patina(
            &["decay", s(&img), "--mask", s(&mask), "--class", "cracked", "-o", s(out), "--frames", "4", "--seed", "9"],
            Some(threads),
        );
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    let (a, b) = (dir.join("a"), dir.join("b"));
    run(&a, 1);
    run(&b, 2);
    for name in ["texture.png", "texture_onset.png", "shading.png", "degree_000.png", "degree_003.png", "frames/003.png", "sequence.gif"] {
        assert_eq!(std::fs::read(a.join(name)).unwrap(), std::fs::read(b.join(name)).unwrap(), "{name} differs between 1 and 2 threads");
    }
    let manifest: serde_json::Value = serde_json::from_slice(&std::fs::read(a.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["frames"].as_array().unwrap().len(), 4);
    assert_eq!(manifest["params"]["class"], "cracked");
    let covered = manifest["metrics"]["decayed_fraction"].as_array().unwrap();
    assert!(covered.windows(2).all(|p| p[1].as_f64() >= p[0].as_f64()), "{covered:?}");
    // Outside the mask every frame keeps the photo's bytes.
    let (first, last) = (load(a.join("frames/000.png")).unwrap(), load(a.join("frames/003.png")).unwrap());
    let input = load(&img).unwrap();
    for frame in [&first, &last] {
        for (i, &m) in body.bits().iter().enumerate() {
            if !m {
                assert_eq!(frame.pixel(i % w, i / w), input.pixel(i % w, i / w));
            }
        }
    }
    fails_cleanly(&dir, &["decay", s(&img), "--class", "rot", "-o", s(&dir.join("c"))], "rot");
    fails_cleanly(&dir, &["decay", s(&img), "--frames", "0", "-o", s(&dir.join("c"))], "frames");
    fails_cleanly(&dir, &["decay", s(&img), "--area", "1.5", "-o", s(&dir.join("c"))], "area");
    fails_cleanly(&dir, &["decay", s(&img), "--spread", "2", "-o", s(&dir.join("c"))], "spread");
    save_png(&patina::Image::new(40, 40, 1), dir.join("small.png"), BitDepth::Eight).unwrap();
    fails_cleanly(&dir, &["decay", s(&img), "--mask", s(&dir.join("small.png")), "-o", s(&dir.join("c"))], "mask");
    fails_cleanly(&dir, &["decay", s(&dir.join("missing.jpg")), "-o", s(&dir.join("c"))], "missing.jpg");
}

#[test]
fn stone_without_a_mask_finds_the_stone_erodes_it_and_keeps_the_background() {
    let dir = scratch("stone-auto");
    let (w, h) = (200, 150);
    let slab = patina::Mask::from_fn(w, h, |x, y| ((x as f32 - 100.0) / 60.0).powi(2) + ((y as f32 - 80.0) / 50.0).powi(2) < 1.0);
    let photo = patina::Image::from_fn(w, h, 3, |x, y, p| {
        let n = patina::samples::value_noise(5, x as f32 / 2.0, y as f32 / 2.0);
        let rgb = if slab.get(x, y) {
            let v = 0.45 + 0.25 * n + if (x / 9 + y / 11) % 2 == 0 { 0.1 } else { 0.0 };
            [v, v * 0.98, v * 0.94]
        } else if y < 40 {
            [0.45, 0.62, 0.9]
        } else {
            [0.2 + 0.1 * n, 0.45 + 0.2 * n, 0.12]
        };
        p.copy_from_slice(&rgb);
    });
    let img = dir.join("photo.png");
    save_png(&photo, &img, BitDepth::Eight).unwrap();
    let out = dir.join("a");
    let r = patina(&["stone", s(&img), "-o", s(&out), "--times", "0,100", "--erosion-speed", "0.003", "--n", "200"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let found = patina::Mask::from_image(&load(out.join("mask_auto.png")).unwrap());
    let wrong = (0..w * h).filter(|&i| found.bits()[i] != slab.bits()[i]).count();
    assert!(wrong * 50 < slab.count(), "{wrong} of {} stone pixels wrong", slab.count());
    let area = |name: &str| load(out.join(name)).unwrap().data().iter().filter(|&&v| v > 0.5).count();
    assert!(area("mask_t001.png") < area("mask_t000.png"), "an automatic mask's silhouette erodes");
    let manifest: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let dilation = manifest["params"]["mask_dilation"].as_u64().unwrap() as usize;
    let (last, input) = (load(out.join("frames/001.png")).unwrap(), load(&img).unwrap());
    let object = found.dilate(dilation);
    for (i, &m) in object.bits().iter().enumerate() {
        if !m {
            assert_eq!(last.pixel(i % w, i / w), input.pixel(i % w, i / w), "background changed at {}, {}", i % w, i / w);
        }
    }
}

#[test]
fn decay_mask_auto_cuts_out_the_object_and_keeps_the_rest() {
    let dir = scratch("decay-auto");
    let (w, h) = (160, 120);
    let body = patina::Mask::from_fn(w, h, |x, y| (55..105).contains(&x) && (20..100).contains(&y));
    let photo = patina::Image::from_fn(w, h, 3, |x, y, p| {
        let n = patina::samples::value_noise(3, x as f32 / 3.0, y as f32 / 3.0);
        if body.get(x, y) {
            let v = 0.5 + 0.4 * ((x as f32 - 55.0) / 50.0);
            p.copy_from_slice(&[v, v * 0.45, v * 0.15]);
        } else {
            p.fill(0.35 + 0.15 * n);
        }
    });
    let img = dir.join("photo.png");
    save_png(&photo, &img, BitDepth::Eight).unwrap();
    let out = dir.join("a");
    let r = patina(&["decay", s(&img), "--mask", "auto", "-o", s(&out), "--frames", "3", "--seed", "2"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let found = patina::Mask::from_image(&load(out.join("mask_auto.png")).unwrap());
    let wrong = (0..w * h).filter(|&i| found.bits()[i] != body.bits()[i]).count();
    assert!(wrong * 50 < body.count(), "{wrong} of {} object pixels wrong", body.count());
    let manifest: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["params"]["mask_source"], "auto");
    assert_eq!(manifest["params"]["mask_auto_dilated_px"], 2);
    // Beyond the found mask's 2 px soft edge the last frame keeps the
    // photo's bytes; within it (here all ground: the body's edge is hard)
    // the colour matte leaves the ground nearly as it was.
    let (last, input) = (load(out.join("frames/002.png")).unwrap(), load(&img).unwrap());
    let widened = found.dilate(2);
    let mut ring = (0, 0);
    for i in 0..w * h {
        let (a, b) = (last.pixel(i % w, i / w), input.pixel(i % w, i / w));
        if !widened.bits()[i] {
            assert_eq!(a, b);
        } else if !found.bits()[i] {
            ring.0 += 1;
            ring.1 += a.iter().zip(b).any(|(p, q)| (p - q).abs() > 0.05) as usize;
        }
    }
    assert!(ring.1 * 20 < ring.0, "{} of {} soft-edge pixels changed", ring.1, ring.0);
    fails_cleanly(&dir, &["decay", s(&img), "--point", "10,10", "-o", s(&dir.join("c"))], "--mask auto");
    fails_cleanly(&dir, &["decay", s(&img), "--mask", "auto", "--point", "500,10", "-o", s(&dir.join("c"))], "outside");
    fails_cleanly(&dir, &["decay", s(&img), "--mask", "auto", "--point", "a,b", "-o", s(&dir.join("c"))], "X,Y");
}

#[test]
fn decay_texture_windows_tile_the_whole_and_stationarity_reads_it() {
    let dir = scratch("decay-texture");
    let whole = dir.join("whole.png");
    let r = patina(&["decay-texture", "--class", "mossy", "--size", "96x64", "--seed", "3", "-o", s(&whole)], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let part = dir.join("part.png");
    let r = patina(&["decay-texture", "--class", "mossy", "--size", "40x30", "--offset", "50,20", "--seed", "3", "-o", s(&part)], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let (whole_img, part_img) = (load(&whole).unwrap(), load(&part).unwrap());
    assert_eq!(whole_img.crop(50, 20, 40, 30).unwrap().data(), part_img.data());
    assert!(dir.join("whole.png.manifest.json").exists());
    let r = patina(&["metrics", "stationarity", s(&whole), "--pairs", "8"], None);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    assert!(v["mean"].as_f64().unwrap() > 0.0 && v["pairs"] == 8);
    fails_cleanly(&dir, &["decay-texture", "--class", "rust", "--size", "0x10", "-o", s(&dir.join("t.png"))], "size");
    fails_cleanly(&dir, &["decay-texture", "--exemplar", s(&whole), "--size", "64x64", "-o", s(&whole)], "overwrite");
    fails_cleanly(&dir, &["decay-texture", "--offset", "3", "-o", s(&dir.join("t.png"))], "x,y");
}
