//! Every finding of the reliability review, as a test: data loss and path
//! traversal, crashes on crafted input, unbounded work, wrong answers to bad
//! input, and output folders that must behave as transactions.

mod fuzz_support;

mod scratch_support;
use fuzz_support::crc32;
use patina::image::io::{encode_png, save_exr, save_png, BitDepth};
use patina::image::Image;
use scratch_support::Scratch;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn patina(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_patina")).args(args).output().expect("runs")
}

fn scratch(name: &str) -> Scratch {
    Scratch::new("hard", name)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir` (recursively) with its bytes.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            v.extend(snapshot(&p));
        } else {
            v.push((p.clone(), std::fs::read(&p).unwrap_or_default()));
        }
    }
    v.sort();
    v
}

/// Exit 2, one line naming `needle`, no panic, and `dir` byte-identical.
fn refused(dir: &Path, args: &[&str], needle: &str) {
    let before = snapshot(dir);
    let r = patina(args);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: not one line: {err}");
    assert!(err.to_lowercase().contains(&needle.to_lowercase()), "{args:?}: '{err}' does not mention '{needle}'");
    assert_eq!(snapshot(dir), before, "{args:?} changed the folder");
}

fn ok(args: &[&str]) -> Output {
    let r = patina(args);
    assert!(r.status.success(), "{args:?}: {}", String::from_utf8_lossy(&r.stderr));
    r
}

fn texture(w: usize, h: usize) -> Image {
    patina::samples::cobbles(w, h, 3)
}

/// A 6-frame procedural rusting time-lapse of `side` px in `dir/steps`.
fn timelapse_steps(dir: &Path, side: usize) -> PathBuf {
    let steps = dir.join("steps");
    std::fs::create_dir_all(&steps).unwrap();
    for (i, f) in patina::samples::rusting_timelapse(side, side, 6, 1).iter().enumerate() {
        save_png(f, steps.join(format!("{i:02}.png")), BitDepth::Eight).unwrap();
    }
    steps
}

/// A fitted material in `dir/mat` from a small procedural time-lapse.
fn material(dir: &Path) -> PathBuf {
    let steps = timelapse_steps(dir, 24);
    let mat = dir.join("mat");
    ok(&["stbrdf", "fit", s(&steps), "-o", s(&mat), "--degree", "2"]);
    mat
}

#[test]
fn material_commands_never_write_over_or_outside_their_inputs() {
    let dir = scratch("mat");
    let mat = material(&dir);
    let target = dir.join("target.png");
    save_png(&texture(24, 24), &target, BitDepth::Eight).unwrap();
    let m = s(&mat);
    let slash = format!("{m}/");
    std::os::unix::fs::symlink(&mat, dir.join("link")).unwrap();
    let link = dir.join("link");
    for out in [m, slash.as_str(), s(&link)] {
        refused(&dir, &["stbrdf", "enlarge", m, "-o", out], "input");
        refused(&dir, &["stbrdf", "transfer", m, "--target", s(&target), "-o", out], "input");
        refused(&dir, &["stbrdf", "render", m, "-o", out], "input");
    }
    refused(&dir, &["stbrdf", "fit", s(&dir.join("steps")), "-o", s(&dir.join("steps"))], "input");
    refused(&dir, &["stbrdf", "enlarge", m, "-o", s(&mat.join("inside"))], "inside input");

    // Parameter names become file names: traversal and absolute paths are refused.
    let json = std::fs::read_to_string(mat.join("material.json")).unwrap();
    let abs = dir.join("abs");
    for name in ["../escape", s(&abs), "a/b", ""] {
        std::fs::write(mat.join("material.json"), json.replace("\"Diffuse\"", &format!("{name:?}"))).unwrap();
        for cmd in ["enlarge", "render"] {
            refused(&dir, &["stbrdf", cmd, m, "-o", s(&dir.join("out"))], "name");
        }
    }
    assert!(!dir.join("escape-0.exr").exists() && !dir.join("abs-0.exr").exists());
    // Zero (or absurd) channel counts are refused, not a panic.
    for channels in ["0", "65", "18446744073709551615"] {
        std::fs::write(mat.join("material.json"), json.replace("\"channels\": 3", &format!("\"channels\": {channels}"))).unwrap();
        refused(&dir, &["stbrdf", "enlarge", m, "-o", s(&dir.join("out"))], "channels");
        refused(&dir, &["stbrdf", "render", m, "-o", s(&dir.join("out"))], "channels");
        refused(&dir, &["stbrdf", "transfer", m, "--target", s(&target), "-o", s(&dir.join("out"))], "channels");
    }
    std::fs::write(mat.join("material.json"), json.replace("\"degree\": 2", "\"degree\": 99")).unwrap();
    refused(&dir, &["stbrdf", "render", m, "-o", s(&dir.join("out"))], "degree");
}

#[test]
fn counts_and_numbers_are_bounded_before_any_work() {
    let dir = scratch("flags");
    let img = dir.join("in.png");
    save_png(&texture(32, 32), &img, BitDepth::Eight).unwrap();
    let i = s(&img);
    let out = dir.join("out");
    let o = s(&out);
    let png = dir.join("o.png");
    let p = s(&png);
    for args in [
        vec!["decay", i, "-o", o, "--frames", "18446744073709551615"],
        vec!["decay", i, "-o", o, "--frames", "4294967296"],
        vec!["metrics", "stationarity", i, "--pairs", "18446744073709551615"],
        vec!["weather", i, "-o", o, "--past", "100000"],
        vec!["weather", i, "-o", o, "--future", "100000"],
        vec!["weather", i, "-o", o, "--steps", "99999999999"],
        vec!["weather-transfer", "--source", i, "--target", i, "-o", o, "--frames", "100000"],
        vec!["synth", i, "-o", p, "--iters", "1000000000"],
        vec!["stbrdf", "render", o, "-o", p, "--frames", "100000"],
    ] {
        refused(&dir, &args, "outside");
    }
    for (args, needle) in [
        (vec!["synth", i, "-o", p, "--uniformity", "nan"], "finite"),
        (vec!["synth", i, "-o", p, "--uniformity", "inf"], "finite"),
        (vec!["synth", i, "-o", p, "--stop-threshold", "nan"], "finite"),
        (vec!["synth", i, "-o", p, "--guide-weight", "nan"], "finite"),
        (vec!["age-map", i, "-o", p, "--k-fraction", "nan"], "finite"),
        (vec!["weather", i, "-o", o, "--span", "inf"], "finite"),
        (vec!["weather", i, "-o", o, "--discard", "-0.5"], "outside"),
        (vec!["stone", i, "-o", o, "--times", "0,nan"], "finite"),
        (vec!["ttf", s(&dir), "-o", o, "--chunk", "4/3"], "chunk"),
        (vec!["ttf", s(&dir), "-o", o, "--chunk", "0/3"], "chunk"),
        (vec!["ttf", s(&dir), "-o", o, "--chunk", "three"], "chunk"),
        (vec!["synth", i, "-o", p, "--tile", "--relight", "stretch"], "tileable"),
        (vec!["synth", i, "-o", p, "--tile", "--size", "4x4", "--method", "quilt"], "tileable"),
        (vec!["decay-texture", "-o", p, "--tile", "--offset", "5,0"], "repeats"),
    ] {
        refused(&dir, &args, needle);
    }
}

fn chunk(kind: &[u8], data: &[u8]) -> Vec<u8> {
    let mut crc_input = kind.to_vec();
    crc_input.extend_from_slice(data);
    let mut v = (data.len() as u32).to_be_bytes().to_vec();
    v.extend_from_slice(&crc_input);
    v.extend_from_slice(&crc32(&crc_input).to_be_bytes());
    v
}

#[test]
fn crafted_and_corrupt_files_are_refused_from_their_header() {
    let dir = scratch("bombs");
    let out = dir.join("o.png");
    let o = s(&out);
    // A PNG declaring 40000 x 40000 (a valid header; the pixels never come).
    let mut ihdr = 40000u32.to_be_bytes().to_vec();
    ihdr.extend(40000u32.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]));
    png.extend(chunk(b"IEND", &[]));
    std::fs::write(dir.join("bomb.png"), &png).unwrap();
    // A 35-byte GIF whose screen is 30000 x 30000.
    let mut gif = b"GIF89a".to_vec();
    gif.extend(30000u16.to_le_bytes());
    gif.extend(30000u16.to_le_bytes());
    gif.extend([0xf0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0x2c, 0, 0, 0, 0, 1, 0, 1, 0, 0, 2, 2, 0x44, 1, 0, 0x3b]);
    std::fs::write(dir.join("bomb.gif"), &gif).unwrap();
    // An EXR whose data window is 100000 x 100000.
    save_exr(&texture(8, 8), dir.join("small.exr")).unwrap();
    let mut exr = std::fs::read(dir.join("small.exr")).unwrap();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = exr.windows(name.len()).position(|w| w == name).unwrap() + name.len() + 4;
        exr[at + 8..at + 16].copy_from_slice(&[0x9f, 0x86, 0x01, 0, 0x9f, 0x86, 0x01, 0]);
    }
    std::fs::write(dir.join("bomb.exr"), &exr).unwrap();
    for (f, needle) in [("bomb.png", "memory"), ("bomb.gif", "memory"), ("bomb.exr", "100000x100000")] {
        refused(&dir, &["synth", s(&dir.join(f)), "-o", o], needle);
        refused(&dir, &["weather", s(&dir.join(f)), "-o", s(&dir.join("w"))], needle);
    }
    // Checksums: a PNG whose IDAT CRC fails, and one whose zlib Adler-32 fails (CRC repaired).
    let mut good = Vec::new();
    encode_png(&texture(16, 16), BitDepth::Eight, &mut good).unwrap();
    let idat = good.windows(4).position(|w| w == b"IDAT").unwrap();
    let len = u32::from_be_bytes(good[idat - 4..idat].try_into().unwrap()) as usize;
    let mut bad_crc = good.clone();
    bad_crc[idat + 4 + len] ^= 0xff;
    std::fs::write(dir.join("crc.png"), &bad_crc).unwrap();
    let mut bad_adler = good.clone();
    bad_adler[idat + 4 + len - 1] ^= 0xff;
    let crc = crc32(&bad_adler[idat..idat + 4 + len]);
    bad_adler[idat + 4 + len..idat + 8 + len].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(dir.join("adler.png"), &bad_adler).unwrap();
    // A JPEG cut in half.
    let rgb: Vec<u8> = texture(64, 64).data().iter().map(|v| (v * 255.0) as u8).collect();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new(&mut jpeg).encode(&rgb, 64, 64, image::ExtendedColorType::Rgb8).unwrap();
    std::fs::write(dir.join("half.jpg"), &jpeg[..jpeg.len() / 2]).unwrap();
    for f in ["crc.png", "adler.png", "half.jpg"] {
        refused(&dir, &["synth", s(&dir.join(f)), "-o", o], f);
    }
    std::fs::write(dir.join("whole.jpg"), &jpeg).unwrap();
    ok(&["synth", s(&dir.join("whole.jpg")), "-o", o, "--size", "64x64"]);
}

#[test]
fn non_finite_pixels_are_refused_unless_allowed_and_extreme_values_end() {
    let dir = scratch("nan");
    let mut nan = texture(40, 40);
    nan.pixel_mut(3, 4)[1] = f32::NAN;
    nan.pixel_mut(9, 9)[0] = f32::INFINITY;
    save_exr(&nan, dir.join("nan.exr")).unwrap();
    let out = dir.join("o.exr");
    refused(&dir, &["synth", s(&dir.join("nan.exr")), "-o", s(&out), "--method", "quilt"], "NaN or infinite");
    let r = ok(&["synth", s(&dir.join("nan.exr")), "-o", s(&out), "--method", "quilt", "--allow-nonfinite"]);
    assert!(String::from_utf8_lossy(&r.stderr).contains("2 NaN or infinite samples set to 0"));
    let back = patina::image::io::load(&out).unwrap();
    assert!(back.data().iter().all(|v| v.is_finite()));
    // Huge finite values: refused at the door (they made intact run for minutes, or exit 1).
    for v in [-6e17f32, -1e28, 2e6] {
        let mut big = texture(64, 64);
        big.pixel_mut(5, 5)[0] = v;
        let p = dir.join(format!("big{v}.exr"));
        save_exr(&big, &p).unwrap();
        for cmd in ["age-map", "intact"] {
            refused(&dir, &[cmd, s(&p), "-o", s(&dir.join("o.png"))], "beyond");
        }
    }
    // Large but plausible HDR values are fine.
    let mut hdr = texture(64, 64);
    hdr.pixel_mut(5, 5)[0] = 60000.0;
    save_exr(&hdr, dir.join("hdr.exr")).unwrap();
    ok(&["age-map", s(&dir.join("hdr.exr")), "-o", s(&dir.join("o.png"))]);
}

#[test]
fn odd_paths_and_folders_get_clear_answers() {
    let dir = scratch("paths");
    let img = dir.join("in.png");
    save_png(&texture(48, 48), &img, BitDepth::Eight).unwrap();
    std::fs::write(dir.join("afile"), b"x").unwrap();
    refused(&dir, &["weather", s(&img), "-o", s(&dir.join("afile"))], "not a folder");
    refused(&dir, &["weather", s(&img), "-o", s(&dir.join("no/such/parent"))], "parent does not exist");
    // A folder of frames with a stray subfolder: the error names both.
    let steps = dir.join("steps");
    std::fs::create_dir_all(steps.join("extra")).unwrap();
    for i in 0..5 {
        save_png(&texture(16, 16), steps.join(format!("{i}.png")), BitDepth::Eight).unwrap();
    }
    refused(&dir, &["stbrdf", "fit", s(&steps), "-o", s(&dir.join("m"))], "extra");
    // Too many frames for a sequence.
    let many = dir.join("many");
    std::fs::create_dir_all(&many).unwrap();
    let mut one = Vec::new();
    encode_png(&Image::new(2, 2, 1), BitDepth::Eight, &mut one).unwrap();
    for i in 0..=patina::image::sequence::MAX_FRAMES {
        std::fs::write(many.join(format!("{i:05}.png")), &one).unwrap();
    }
    refused(&dir, &["ttf", s(&many), "-o", s(&dir.join("t"))], "at most 2000");
}

/// Frames listed in an output folder.
fn frames(out: &Path) -> usize {
    std::fs::read_dir(out.join("frames")).unwrap().count()
}

#[test]
fn output_folders_are_transactions() {
    let dir = scratch("tx");
    let img = dir.join("in.png");
    let (rusty, _) = patina::samples::weather(&patina::samples::tiles(64, 64, 1), patina::samples::Weathering::Rust, 0.1, 2);
    save_png(&rusty, &img, BitDepth::Eight).unwrap();
    let out = dir.join("out");
    let (i, o) = (s(&img), s(&out));
    ok(&["weather", i, "-o", o, "--past", "2", "--future", "3"]);
    assert_eq!(frames(&out), 7);
    // An existing output is kept unless --overwrite; then it is replaced whole (no stale frames).
    refused(&dir, &["weather", i, "-o", o, "--past", "0", "--future", "1"], "--overwrite");
    ok(&["weather", i, "-o", o, "--past", "0", "--future", "1", "--overwrite"]);
    assert_eq!(frames(&out), 3);
    // A material refitted at a lower degree keeps no higher coefficients.
    let steps = timelapse_steps(&dir, 16);
    let mat = dir.join("mat");
    ok(&["stbrdf", "fit", s(&steps), "-o", s(&mat), "--degree", "3"]);
    ok(&["stbrdf", "fit", s(&steps), "-o", s(&mat), "--degree", "1", "--overwrite"]);
    assert!(mat.join("Diffuse-1.exr").exists() && !mat.join("Diffuse-2.exr").exists() && !mat.join("Diffuse-3.exr").exists());
    // --overwrite never replaces a folder patina did not write, nor one holding an input.
    let mine = dir.join("mine");
    std::fs::create_dir_all(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), b"keep me").unwrap();
    refused(&dir, &["weather", i, "-o", s(&mine), "--overwrite"], "not written by patina");
    refused(&dir, &["weather", i, "-o", s(&dir), "--overwrite"], "input");
    // A failed run leaves nothing: no output folder, no staging folder.
    let bad = dir.join("bad");
    refused(&dir, &["weather", i, "-o", s(&bad), "--age-map", s(&steps.join("00.png"))], "age map");
    // Staging folders of dead processes are cleaned by the next run; a live one is kept.
    let dead = dir.join(".out.patina-staging-4294967294");
    let live = dir.join(format!(".out.patina-staging-{}", std::process::id()));
    for d in [&dead, &live] {
        std::fs::create_dir_all(d).unwrap();
        std::fs::write(d.join("000.png"), b"partial").unwrap();
    }
    ok(&["weather", i, "-o", o, "--past", "1", "--future", "1", "--overwrite"]);
    assert!(!dead.exists() && live.exists());
    let mut names: Vec<String> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    assert_eq!(names.iter().filter(|n| n.contains("patina-")).count(), 1, "only the live staging folder is left: {names:?}");
}

#[test]
fn a_killed_run_leaves_the_previous_output_or_none() {
    let dir = scratch("kill");
    let small = dir.join("small.png");
    save_png(&texture(64, 64), &small, BitDepth::Eight).unwrap();
    let big = dir.join("big.png");
    save_png(&texture(1024, 1024), &big, BitDepth::Eight).unwrap();
    let out = dir.join("out");
    ok(&["weather", s(&small), "-o", s(&out), "--past", "1", "--future", "1"]);
    let before = snapshot(&out);
    for (target, overwrite) in [(&out, true), (&dir.join("fresh"), false)] {
        let mut args = vec!["weather", s(&big), "-o", s(target)];
        if overwrite {
            args.push("--overwrite");
        }
        let mut child = Command::new(env!("CARGO_BIN_EXE_patina")).args(&args).stderr(std::process::Stdio::null()).spawn().unwrap();
        // Wait until the run has started writing, then kill it without warning.
        let name = target.file_name().unwrap().to_string_lossy().into_owned();
        let staging = dir.join(format!(".{name}.patina-staging-{}", child.id()));
        while !staging.exists() {
            assert!(child.try_wait().unwrap().is_none(), "the run ended before it could be killed");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        std::thread::sleep(std::time::Duration::from_millis(300));
        child.kill().unwrap();
        child.wait().unwrap();
        if overwrite {
            assert_eq!(snapshot(&out), before, "the previous complete output is intact");
        } else {
            assert!(!target.exists(), "no output folder from a killed run");
        }
    }
    // The next run cleans what the killed ones left.
    ok(&["weather", s(&small), "-o", s(&out), "--past", "1", "--future", "1", "--overwrite"]);
    let left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".out."))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}
