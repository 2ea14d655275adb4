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
    if let Ok(l) = std::env::var("BLOCK") { p.init_block = l.parse().unwrap(); }
    if std::env::var("MEAN").is_ok() { p.vote = patina::synth::VoteWeights::Mean; }
    let out = Synthesis::new(&src).size(w, h).seed(1).optimize(&p).unwrap();
    eprintln!("{}x{} -> {}x{} in {:?} (levels {})", src.width(), src.height(), w, h, t.elapsed(), out.levels);
    patina::image::io::save(&out.image, &a[2]).unwrap();
    patina::image::io::save(&src, format!("{}.src.png", a[2])).unwrap();
}
