use patina::image::io::{save_png, BitDepth};
use patina::weather::{age_map, intact::{intact, IntactParams}};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let img = match args[1].as_str() {
        "tiles" | "gravel" | "cobbles" => {
            let kind = match args[2].as_str() { "rust" => patina::samples::Weathering::Rust, "stain" => patina::samples::Weathering::Stain, _ => patina::samples::Weathering::Cracks };
            patina::samples::weather(&patina::samples::by_name(&args[1], 160, 160, 3).unwrap(), kind, 0.1, 11).0
        }
        p => {
            let img = patina::image::io::load(p).unwrap();
            let s = args[2].parse::<usize>().unwrap();
            let h = img.height() * s / img.width();
            patina::image::resample::resize(&img, s, h, patina::image::resample::Filter::Cubic).unwrap()
        }
    };
    let t = std::time::Instant::now();
    let a = age_map(&img, &Default::default()).unwrap();
    let ta = t.elapsed();
    let t = std::time::Instant::now();
    let i = intact(&img, &a.map, None, &IntactParams::default(), 1).unwrap();
    println!("age {:?} intact {:?} lattice {:?}", ta, t.elapsed(), i.lattice);
    save_png(&img, "/tmp/i_in.png", BitDepth::Eight).unwrap();
    save_png(&a.map, "/tmp/i_age.png", BitDepth::Eight).unwrap();
    save_png(&i.template, "/tmp/i_template.png", BitDepth::Eight).unwrap();
    save_png(&i.image, "/tmp/i_intact.png", BitDepth::Eight).unwrap();
}
