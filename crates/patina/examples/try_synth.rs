//! Scratch: synthesize from a file or sample and save (for looking at results).
use patina::synth::{OptimizeParams, Synthesis};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let src = match patina::samples::by_name(&a[1], 128, 128, 1) { Some(i) => i, None => patina::image::io::load(&a[1]).unwrap() };
    let scale: f32 = a[3].parse().unwrap();
    let (w, h) = ((src.width() as f32 * scale) as usize, (src.height() as f32 * scale) as usize);
    let t = std::time::Instant::now();
    let mut p = OptimizeParams::default();
    if let Ok(l) = std::env::var("LEVELS") { p.levels = Some(l.parse().unwrap()); }
    if let Ok(l) = std::env::var("UNI") { p.uniformity = l.parse().unwrap(); }
    if std::env::var("RANDOM").is_ok() { p.init = patina::synth::Init::Random; }
    if std::env::var("ROBUST").is_ok() { p.vote = patina::synth::VoteWeights::Robust; }
    if std::env::var("MEAN").is_ok() { p.vote = patina::synth::VoteWeights::Mean; }
    let image = if std::env::var("QUILT").is_ok() {
        let mut q = patina::synth::QuiltParams::default();
        if std::env::var("BLEND").is_ok() { q.boundary_cut = false; }
        if let Ok(k) = std::env::var("K") { q.min_candidates = k.parse().unwrap(); }
        Synthesis::new(&src).size(w, h).seed(1).quilt(&q).unwrap().image
    } else {
        Synthesis::new(&src).size(w, h).seed(1).optimize(&p).unwrap().image
    };
    eprintln!("{}x{} -> {}x{} in {:?}", src.width(), src.height(), w, h, t.elapsed());
    patina::image::io::save(&image, &a[2]).unwrap();
    patina::image::io::save(&src, format!("{}.src.png", a[2])).unwrap();
}
