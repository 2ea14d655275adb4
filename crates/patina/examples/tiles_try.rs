use patina::samples::{self, Weathering};
fn main() {
    for (name, img) in [
        ("tiles", samples::tiles(256, 256, 1)),
        ("tiles rust", samples::weather(&samples::tiles(256, 256, 1), Weathering::Rust, 0.1, 3).0),
        ("tiles 200 crop", samples::tiles(300, 300, 1).crop(7, 5, 200, 180).unwrap()),
        ("gravel", samples::gravel(256, 256, 1)),
        ("cobbles", samples::cobbles(256, 256, 1)),
        ("bricks", samples::bricks(256, 256, 1)),
        ("blotches", samples::blotches(256, 256, 1)),
    ] {
        let t = std::time::Instant::now();
        println!("{name}: {:?} {:?}", patina::weather::tiles::detect(&img), t.elapsed());
    }
    for p in std::env::args().skip(1) {
        let img = patina::image::io::load(&p).unwrap();
        let t = std::time::Instant::now();
        println!("{p}: {}x{} {:?} {:?}", img.width(), img.height(), patina::weather::tiles::detect(&img), t.elapsed());
    }
}
