//! Age map and intact texture against injected ground truth: per base
//! texture (stochastic gravel, tiles, planks) and kind of weathering (a
//! crack network over the whole surface, 37% peeling with lips, 10% rust),
//! the age map's ROC AUC against the mask and the intact texture's residue
//! ([`patina::metrics::weathering_residue`]), with the time of both; and
//! per base the share its clean texture is judged weathered (a false
//! positive).
//!
//!     cargo run --release -p patina --example age_auc -- 256   # image side
use patina::metrics::{roc_auc, weathering_residue};
use patina::samples::{self, Weathering};
use patina::weather::{age_map, intact, AgeParams, IntactParams};
use std::time::Instant;

fn main() {
    let size: usize = std::env::args().nth(1).map_or(256, |s| s.parse().expect("image side"));
    let only: Option<String> = std::env::args().nth(2);
    println!("{:8} {:13} {:>5} {:>6} {:>8} {:>7} {:>7}", "base", "weathering", "area", "AUC", "residue", "age s", "intact s");
    println!("(then: the fraction judged weathered, and whether the intact texture used a tile grid)");
    let mut ap = AgeParams::default();
    if let Ok(k) = std::env::var("AGE_K") {
        ap.k_fraction = Some(k.parse().unwrap());
    }
    if let Ok(d) = std::env::var("AGE_DETAIL") {
        ap.detail = d.parse().unwrap();
    }
    if std::env::var("AGE_KNN").is_ok() {
        ap.prevalence = patina::weather::age::Prevalence::KNearest;
    }
    if std::env::var("AGE_NO_REGIONS").is_ok() {
        ap.regions = false;
    }
    // The age map and the intact texture of `img`, each with its time.
    let measure = |img: &patina::Image| {
        let t = Instant::now();
        let a = age_map(img, &ap).unwrap();
        let t_age = t.elapsed().as_secs_f32();
        let t = Instant::now();
        let result = intact(img, &a.map, None, &IntactParams::default(), None, 5).unwrap();
        (a, t_age, result, t.elapsed().as_secs_f32())
    };
    for base in ["stucco", "gravel", "tiles", "planks"] {
        let clean = samples::by_name(base, size, size, 3).unwrap();
        // The clean texture itself: whatever it judges weathered is a false
        // positive (its intact texture re-makes that much sound material).
        if only.as_deref().is_none_or(|o| format!("{base} clean").contains(o)) {
            let (a, t_age, result, t_intact) = measure(&clean);
            let mean_age = a.map.data().iter().sum::<f32>() / a.map.data().len() as f32;
            println!(
                "{base:8} {:13} {:5.2} {:>6} {:>8} {t_age:7.2} {t_intact:7.2} {:6.2} {} (mean age {mean_age:.2})",
                "clean",
                0.0,
                "-",
                "-",
                result.weathered_fraction,
                result.lattice.is_some()
            );
        }
        for (kind, area, name) in [
            (Weathering::CrackNetwork, 0.0, "crack network"),
            (Weathering::Peel, 0.32, "peel 37%"),
            (Weathering::Rust, 0.1, "rust 10%"),
            (Weathering::Cracks, 0.1, "cracks 10%"),
        ] {
            if only.as_deref().is_some_and(|o| !format!("{base} {name}").contains(o)) {
                continue;
            }
            let (img, mask) = samples::weather(&clean, kind, area, 11);
            let (a, t_age, result, t_intact) = measure(&img);
            let auc = roc_auc(a.map.data(), mask.bits());
            if std::env::var("AGE_DEBUG").is_ok() {
                eprintln!("{base} {name}: {:?}", a.periodicity.map(|p| p.vectors()));
            }
            let residue = weathering_residue(&result.image, &clean, &img, &mask, 5, 1).unwrap();
            let share = mask.count() as f32 / (size * size) as f32;
            let (judged, grid) = (result.weathered_fraction, result.lattice.is_some());
            println!("{base:8} {name:13} {share:5.2} {auc:6.3} {residue:8.3} {t_age:7.2} {t_intact:7.2} {judged:6.2} {grid}");
            if let Ok(dir) = std::env::var("AGE_AUC_OUT") {
                let stem = format!("{dir}/{base}_{}", name.split(' ').next().unwrap());
                patina::image::io::save(&img, format!("{stem}_input.png"), patina::image::io::BitDepth::Eight).unwrap();
                patina::image::io::save(&a.map, format!("{stem}_age.png"), patina::image::io::BitDepth::Eight).unwrap();
                patina::image::io::save(&result.image, format!("{stem}_intact.png"), patina::image::io::BitDepth::Eight).unwrap();
            }
        }
    }
}
