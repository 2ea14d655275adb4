use patina::metrics::roc_auc;
use patina::samples::{self, Weathering};
use patina::weather::{age_map, AgeParams};
fn main() {
    let configs: Vec<(&str, AgeParams)> = vec![
        ("default", AgeParams::default()),
        ("smooth .25", AgeParams { smoothing: 0.25, ..Default::default() }),
        ("smooth 1", AgeParams { smoothing: 1.0, ..Default::default() }),
        ("grid 32", AgeParams { grid: 32, ..Default::default() }),
        ("k 0.25", AgeParams { k_fraction: Some(0.25), ..Default::default() }),
        ("k 0.6", AgeParams { k_fraction: Some(0.6), ..Default::default() }),
    ];
    let size: usize = std::env::args().nth(1).map_or(256, |s| s.parse().unwrap());
    for (name, p) in &configs {
        let mut line = format!("{name:14}");
        for base in ["tiles", "gravel", "cobbles", "blotches"] {
            for kind in [Weathering::Rust, Weathering::Stain, Weathering::Cracks] {
                let clean = samples::by_name(base, size, size, 3).unwrap();
                let (img, mask) = samples::weather(&clean, kind, 0.1, 11);
                let t = std::time::Instant::now();
                let a = age_map(&img, p).unwrap();
                let auc = roc_auc(a.map.data(), mask.bits());
                line += &format!(" {:>5.2}", auc);
                let _ = t;
            }
        }
        println!("{line}");
    }
}
