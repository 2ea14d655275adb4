//! Age-map accuracy table: ROC AUC of the age map against the injected
//! weathering mask, per base texture (tiles, gravel, cobbles, blotches) and
//! kind (rust, stain, cracks), for a few parameter choices.
//!
//!     cargo run --release -p patina --example age_auc -- 160   # image side
use patina::metrics::roc_auc;
use patina::samples::{self, Weathering};
use patina::weather::{age_map, AgeParams};
fn main() {
    let configs: Vec<(&str, AgeParams)> = vec![
        ("default", AgeParams::default()),
        ("k 0.1", AgeParams { k_fraction: Some(0.1), ..Default::default() }),
        ("k 0.2", AgeParams { k_fraction: Some(0.2), ..Default::default() }),
        ("k10", AgeParams { k_fraction: None, ..Default::default() }),
    ];
    let size: usize = std::env::args().nth(1).map_or(256, |s| s.parse().unwrap());
    let bases = ["tiles", "gravel", "cobbles", "blotches"];
    println!("{:14} {}", "AUC", bases.map(|b| format!("{:>17}", format!("{b}: R/S/C"))).join(" "));
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
