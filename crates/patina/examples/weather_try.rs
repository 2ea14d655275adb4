use patina::image::io::{save_png, BitDepth};
use patina::weather::{weather, Overrides, WeatherParams};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let img = match args[1].as_str() {
        "tiles" | "gravel" | "cobbles" => {
            let kind = match args[2].as_str() { "rust" => patina::samples::Weathering::Rust, "stain" => patina::samples::Weathering::Stain, _ => patina::samples::Weathering::Cracks };
            patina::samples::weather(&patina::samples::by_name(&args[1], 256, 256, 3).unwrap(), kind, 0.1, 11).0
        }
        p => {
            let img = patina::image::io::load(p).unwrap();
            let s = args[2].parse::<usize>().unwrap();
            let h = img.height() * s / img.width();
            patina::image::resample::resize(&img, s, h, patina::image::resample::Filter::Cubic).unwrap()
        }
    };
    let t = std::time::Instant::now();
    let r = weather(&img, &WeatherParams::default(), Overrides::default(), 1, &|s| eprintln!("{s:?} {:?}", t.elapsed())).unwrap();
    let _ = std::fs::remove_dir_all("/tmp/w"); std::fs::create_dir_all("/tmp/w").unwrap();
    save_png(&r.age, "/tmp/w/age.png", BitDepth::Eight).unwrap();
    for f in &r.frames {
        let d = patina::weather::rebuild::colour_distance(&f.image, &r.intact).unwrap();
        println!("t {:.2} weathered area {:.3}", f.t, d.iter().filter(|&&v| v > 0.1).count() as f32 / d.len() as f32);
    }
    for (i, f) in r.frames.iter().enumerate() {
        save_png(&f.image, format!("/tmp/w/{i:02}_t{:.2}.png", f.t), BitDepth::Eight).unwrap();
    }
}
#[allow(dead_code)]
fn _unused() {}
