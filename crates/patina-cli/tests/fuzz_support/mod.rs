//! A seeded mutator for patina's inputs (PNG, JPEG, GIF, EXR and material
//! folders) and the rules every run on a mutated input must keep: exit 0 or
//! 2, at most one line on stderr, no panic, and nothing left behind but a
//! complete output. Shared by the `fuzz` test and the `fuzz` example, which
//! runs the same mutator for as long as asked.

#![allow(dead_code)]

use patina::image::io::{encode_png, save_exr, BitDepth};
use patina::image::Image;
use std::path::{Path, PathBuf};
use std::process::Command;

/// SplitMix64: a tiny seeded generator, so a failing case is replayed from
/// its (format, seed) alone.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn texture(w: usize, h: usize, c: usize) -> Image {
    Image::from_fn(w, h, c, |x, y, p| {
        for (i, v) in p.iter_mut().enumerate() {
            *v = (((x * 37 + y * 91 + i * 53) % 97) as f32 / 96.0 + 0.3 * ((x / 4 + y / 4) % 2) as f32).min(1.0);
        }
    })
}

/// Small valid files of each format: (format, bytes).
pub fn seeds() -> Vec<(&'static str, Vec<u8>)> {
    let mut v = Vec::new();
    let mut png = Vec::new();
    encode_png(&texture(24, 20, 3), BitDepth::Eight, &mut png).unwrap();
    v.push(("png", png));
    let mut png16 = Vec::new();
    encode_png(&texture(20, 24, 2), BitDepth::Sixteen, &mut png16).unwrap();
    v.push(("png", png16));
    let rgb: Vec<u8> = texture(24, 24, 3).data().iter().map(|x| (x * 255.0) as u8).collect();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 85).encode(&rgb, 24, 24, image::ExtendedColorType::Rgb8).unwrap();
    v.push(("jpeg", jpeg));
    let mut gif = Vec::new();
    {
        let mut enc = gif::Encoder::new(&mut gif, 16, 16, &[]).unwrap();
        for k in 0..2u8 {
            let mut rgba: Vec<u8> = (0..16 * 16).flat_map(|i| [(i as u8).wrapping_mul(7 + k), 90, 200 - k * 50, 255]).collect();
            enc.write_frame(&gif::Frame::from_rgba_speed(16, 16, &mut rgba, 10)).unwrap();
        }
    }
    v.push(("gif", gif));
    let dir = std::env::temp_dir().join(format!("patina-fuzz-seed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("s.exr");
    save_exr(&texture(20, 20, 3).map(|x| x * 2.0 - 0.5), &p).unwrap();
    v.push(("exr", std::fs::read(&p).unwrap()));
    let _ = std::fs::remove_dir_all(&dir);
    v
}

/// Values that break naive size and offset arithmetic.
const INTERESTING: [u32; 8] = [0, 1, 0x7f, 0xff, 0xffff, 0x7fff_ffff, 0xffff_ffff, 100_000];

/// One random mutation of `bytes`: bit flips, interesting values written
/// over 1 or 4 bytes (sizes, lengths and offsets), truncation, inserted
/// or deleted runs, a duplicated block. PNG chunk checksums are then
/// repaired half the time, so the decoder's deeper paths are reached too.
pub fn mutate(bytes: &[u8], format: &str, rng: &mut Rng) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for _ in 0..1 + rng.below(4) {
        if b.is_empty() {
            b.push(0);
        }
        let at = rng.below(b.len());
        match rng.below(7) {
            0 => b[at] ^= 1 << rng.below(8),
            1 => b[at] = INTERESTING[rng.below(INTERESTING.len())] as u8,
            2 => {
                let v = INTERESTING[rng.below(INTERESTING.len())].to_be_bytes();
                let v = if rng.below(2) == 0 { v } else { u32::from_be_bytes(v).to_le_bytes() };
                for (k, x) in v.iter().enumerate() {
                    if at + k < b.len() {
                        b[at + k] = *x;
                    }
                }
            }
            3 => b.truncate(at),
            4 => {
                let n = 1 + rng.below(16);
                let ins: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                b.splice(at..at, ins);
            }
            5 => {
                let end = (at + 1 + rng.below(32)).min(b.len());
                b.drain(at..end);
            }
            _ => {
                let end = (at + 1 + rng.below(64)).min(b.len());
                let block = b[at..end].to_vec();
                let to = rng.below(b.len());
                b.splice(to..to, block);
            }
        }
    }
    if format == "png" && rng.below(2) == 0 {
        fix_png_crcs(&mut b);
    }
    b
}

/// The CRC-32 of PNG chunks (ISO 3309, reflected 0xEDB88320).
pub fn crc32(data: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &byte in data {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// Recompute every whole chunk's CRC of a PNG.
fn fix_png_crcs(b: &mut [u8]) {
    let mut at = 8;
    while at + 12 <= b.len() {
        let len = u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]) as usize;
        let Some(end) = at.checked_add(8 + len).filter(|&e| e + 4 <= b.len()) else { return };
        let crc = crc32(&b[at + 4..end]);
        b[end..end + 4].copy_from_slice(&crc.to_be_bytes());
        at = end + 4;
    }
}

/// A material folder with a mutated `material.json` (names, channel
/// counts, degree and shapes are untrusted) beside valid coefficient maps.
pub fn material_case(dir: &Path, rng: &mut Rng) -> PathBuf {
    let mat = dir.join("mat");
    std::fs::create_dir_all(&mat).unwrap();
    let names = ["Roughness", "../escape", "/tmp/abs", "", "Diffuse", "a b", "Normal", "Spec\u{0}", "Height"];
    let mut params = vec![serde_json::json!({ "name": "Diffuse", "channels": 3 })];
    let mut degree = serde_json::json!(2);
    // A valid descriptor, then 0 to 3 changes to it.
    for _ in 0..rng.below(4) {
        match rng.below(6) {
            0 => params.push(serde_json::json!({ "name": names[rng.below(names.len())], "channels": 1 })),
            1 if !params.is_empty() => params[0]["name"] = serde_json::json!(names[rng.below(names.len())]),
            2 if !params.is_empty() => params[0]["channels"] = serde_json::json!([0u64, 1, 2, 65, 1 << 33][rng.below(5)]),
            3 => degree = serde_json::json!([0u64, 1, 7, 1 << 40][rng.below(4)]),
            4 => degree = serde_json::json!("two"),
            5 => params.clear(),
            _ => {}
        }
    }
    let mut text = serde_json::to_vec(&serde_json::json!({ "degree": degree, "params": params })).unwrap();
    if rng.below(4) == 0 {
        text = mutate(&text, "json", rng);
    }
    std::fs::write(mat.join("material.json"), text).unwrap();
    for name in ["Diffuse", "Roughness", "Normal"] {
        for k in 0..3 {
            save_exr(&texture(16, 16, 3), mat.join(format!("{name}-{k}.exr"))).unwrap();
        }
    }
    mat
}

/// The `patina` binary: cargo's for tests; for the example, the one built
/// beside it (target/PROFILE/patina).
fn patina_bin() -> PathBuf {
    match option_env!("CARGO_BIN_EXE_patina") {
        Some(p) => PathBuf::from(p),
        None => {
            let exe = std::env::current_exe().expect("own path");
            exe.parent().and_then(Path::parent).expect("target/PROFILE/examples").join("patina")
        }
    }
}

/// Entries of `dir`, sorted.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// Run `patina args` in `out_dir` (which holds nothing else) and check the
/// rules: exit 0 or 2, one stderr line on failure, no panic, and `out_dir`
/// holding exactly `outputs` on success and nothing on failure.
pub fn check_run(args: &[&str], out_dir: &Path, outputs: &[&str]) -> Result<bool, String> {
    let r = Command::new(patina_bin()).args(args).env("RAYON_NUM_THREADS", "1").output().map_err(|e| e.to_string())?;
    let err = String::from_utf8_lossy(&r.stderr);
    let left = listing(out_dir);
    match r.status.code() {
        Some(0) => {
            let mut want: Vec<String> = outputs.iter().map(|s| s.to_string()).collect();
            want.sort();
            if left != want {
                return Err(format!("success left {left:?}, expected {want:?}"));
            }
        }
        Some(2) => {
            if err.trim_end().lines().count() != 1 {
                return Err(format!("failure printed {} lines: {err}", err.trim_end().lines().count()));
            }
            if !left.is_empty() {
                return Err(format!("failure left {left:?}: {err}"));
            }
        }
        code => return Err(format!("exit {code:?}: {err}")),
    }
    if err.contains("panicked") {
        return Err(format!("panic: {err}"));
    }
    Ok(r.status.success())
}

/// One fuzz case: mutate seed `k` of `seeds` with `case_seed`, decode it in
/// process (no panic) and run it through the CLI. `work` is an empty
/// scratch folder the case may use. Ok(true) when the mutated file was
/// accepted and synthesized from.
pub fn run_case(seeds: &[(&'static str, Vec<u8>)], k: usize, case_seed: u64, work: &Path) -> Result<bool, String> {
    let mut rng = Rng::new(case_seed);
    let (format, bytes) = &seeds[k];
    let mutated = mutate(bytes, format, &mut rng);
    let name = format!("in.{format}");
    let input = work.join(&name);
    std::fs::write(&input, &mutated).unwrap();
    let decoded = std::panic::catch_unwind(|| patina::image::io::decode(&mutated, Path::new(&name)));
    match decoded {
        Err(_) => return Err(format!("{format} seed {case_seed}: decode panicked")),
        Ok(Err(patina::Error::Internal(m))) => return Err(format!("{format} seed {case_seed}: internal error {m}")),
        Ok(_) => {}
    }
    let out_dir = work.join("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    let out = out_dir.join("o.png");
    let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
    let ok = check_run(&["synth", i, "-o", o, "--method", "quilt", "--size", "24x24"], &out_dir, &["o.png", "o.png.manifest.json"])
        .map_err(|e| format!("{format} seed {case_seed}: synth: {e}"))?;
    std::fs::remove_dir_all(&out_dir).unwrap();
    Ok(ok)
}

/// One material case: a mutated material folder rendered and enlarged.
/// Ok(true) when both runs accepted it.
pub fn run_material_case(case_seed: u64, work: &Path) -> Result<bool, String> {
    let mut rng = Rng::new(case_seed);
    let mat = material_case(work, &mut rng);
    let before: Vec<Vec<u8>> = listing(&mat).iter().map(|f| std::fs::read(mat.join(f)).unwrap()).collect();
    let out_dir = work.join("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    let m = mat.to_str().unwrap();
    let mut accepted = true;
    for (cmd, extra) in [("render", ["--frames", "2", "--sphere", "8"]), ("enlarge", ["--size", "20x20", "--seed", "1"])] {
        let seq = out_dir.join(cmd);
        let mut args = vec!["stbrdf", cmd, m, "-o", seq.to_str().unwrap()];
        args.extend(extra);
        accepted &= check_run(&args, &out_dir, &[cmd]).map_err(|e| format!("material seed {case_seed}: {cmd}: {e}"))?;
        std::fs::remove_dir_all(&out_dir).unwrap();
        std::fs::create_dir_all(&out_dir).unwrap();
    }
    let after: Vec<Vec<u8>> = listing(&mat).iter().map(|f| std::fs::read(mat.join(f)).unwrap()).collect();
    if before != after {
        return Err(format!("material seed {case_seed}: the input material changed"));
    }
    // Nothing escaped the folders: no file named after a traversal attempt.
    if work.parent().is_some_and(|p| p.join("escape-0.exr").exists()) || Path::new("/tmp/abs-0.exr").exists() {
        return Err(format!("material seed {case_seed}: a file was written outside the output folder"));
    }
    Ok(accepted)
}
