use patina::image::io::{save_png, BitDepth};
use patina::samples::{self, Weathering};
use patina::weather::{age_map, intact, transfer, AgeParams, IntactParams};
fn main() {
    let (source, _) = samples::weather(&samples::tiles(160, 160, 3), Weathering::Rust, 0.1, 11);
    let target = samples::gravel(160, 160, 2);
    let age = age_map(&source, &AgeParams::default()).unwrap();
    let s_intact = intact(&source, &age.map, None, &IntactParams::default(), 1).unwrap();
    let frames = transfer::transfer(&transfer::Source { image: &source, age: &age.map, intact: &s_intact.image }, &target, &[0.5, 1.0], &patina::weather::rebuild::RebuildParams { guide_weight: std::env::args().nth(1).unwrap().parse().unwrap(), ..Default::default() }, 3, &|_| {}).unwrap();
    save_png(&source, "/tmp/t_s.png", BitDepth::Eight).unwrap();
    save_png(&target, "/tmp/t_t.png", BitDepth::Eight).unwrap();
    for (i, f) in frames.iter().enumerate() { save_png(&f.image, format!("/tmp/t_f{i}.png"), BitDepth::Eight).unwrap(); }
}
