//! Spatio-temporal material quality on real captures: prints a table.
//!
//!     cargo run --release -p patina --example stbrdf_quality -- MATERIAL_OR_FRAMES...
//!
//! Each argument is a material folder (ours or meistdan/tsvbrdf's) or a
//! folder of time-lapse frames (fitted as an albedo-only degree-3
//! material). Without arguments a lit drying-wood material is made. Per
//! material, after a 2x enlargement (seed 1):
//! - grid: the block-grid peak of the enlarged basecolor over the input's
//!   (the worst of t = 0, 0.5, 1; issue 20 asks for at most 1.5);
//! - contrast: the luminance std of the enlarged basecolor at t = 1 over
//!   the input's (at least 0.85), both without their large scale (a
//!   Gaussian of 1/8 of the input's side), where the capture's light lives;
//! - lighting: the large-scale non-stationarity of the enlarged
//!   time-averaged basecolor, and the input's;
//! - preview: the shaded plane's luminance std over its basecolor's, both
//!   sRGB-encoded, at t = 1 (at least 0.8), and the mean level difference.

use patina::image::color::{linear_to_srgb, luminance};
use patina::image::filter::gaussian_blur;
use patina::image::sequence::load_sequence;
use patina::metrics::{grid_peak, nonstationarity};
use patina::stbrdf::enlarge::{EnlargeParams, Illumination};
use patina::stbrdf::render::{self, Lighting};
use patina::stbrdf::{enlarge, fit, procedural, Encoding, Material, Param};
use patina::Image;
use std::path::Path;
use std::time::Instant;

fn load(arg: &str) -> Material {
    let path = Path::new(arg);
    if let Ok(m) = Material::load(path) {
        return m;
    }
    let seq = load_sequence(path).expect("a material or a folder of frames");
    let frames: Vec<Image> = seq.frames.into_iter().map(|f| f.select_channels(0..3)).collect();
    let n = frames.len();
    let times: Vec<f32> = (0..n).map(|i| i as f32 / (n - 1).max(1) as f32).collect();
    let mut m = fit::fit(&frames, &times, 3, vec![Param { name: "Diffuse".into(), channels: 3 }]).expect("fit").material;
    m.encoding = Encoding::Srgb;
    m
}

fn basecolor(m: &Material, t: f32) -> Image {
    m.evaluate(t).select_channels(m.param("diffuse").expect("a Diffuse parameter"))
}

fn std_mean(img: &Image) -> (f64, f64) {
    let y = luminance(img);
    let d = y.data();
    let n = d.len() as f64;
    let mean = d.iter().map(|&v| v as f64).sum::<f64>() / n;
    ((d.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / n).sqrt(), mean)
}

/// The luminance std left after removing the large scale (a Gaussian of
/// `sigma` px): the contrast of spots and grain, not of the capture's light.
fn detail_std(img: &Image, sigma: f32) -> f64 {
    let y = luminance(img);
    let low = gaussian_blur(&y, sigma);
    let d: Vec<f64> = y.data().iter().zip(low.data()).map(|(a, b)| (a - b) as f64).collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    (d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt()
}

fn time_average(m: &Material) -> Image {
    let frames: Vec<Image> = (0..11).map(|i| basecolor(m, i as f32 / 10.0)).collect();
    patina::image::sequence::temporal_mean(&frames).expect("mean")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let materials: Vec<(String, Material)> = if args.is_empty() {
        let (frames, times) = procedural::drying_wood(96, 96, 11, 3);
        let mut m = fit::fit(&frames, &times, 3, procedural::drying_wood_params()).expect("fit").material;
        procedural::light_ramp(&mut m);
        vec![("lit drying wood".into(), m)]
    } else {
        args.iter().map(|a| (Path::new(a).file_name().unwrap_or_default().to_string_lossy().into_owned(), load(a))).collect()
    };
    println!(
        "| material | size | variant | enlarge | grid (out/in) | contrast t=1 | lighting out / in | preview contrast | preview level |"
    );
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|");
    let variants = [
        ("paper (keep light, no blend)", EnlargeParams { illumination: Illumination::Keep, blend_seams: false, ..Default::default() }),
        ("flat light, no blend", EnlargeParams { illumination: Illumination::Flat, blend_seams: false, ..Default::default() }),
        ("default (auto light, blend)", EnlargeParams::default()),
    ];
    for (name, m) in materials {
        let (w, h) = m.size();
        let lighting = Lighting::default();
        let plane = render::plane(&m, 1.0, &lighting);
        let mut base = basecolor(&m, 1.0);
        if m.encoding == Encoding::Linear {
            base.data_mut().iter_mut().for_each(|v| *v = linear_to_srgb(v.clamp(0.0, 1.0)));
        }
        let ((ps, pm), (bs, bm)) = (std_mean(&plane), std_mean(&base));
        for (variant, params) in &variants {
            let clock = Instant::now();
            let big = enlarge::enlarge(&m, (2 * w, 2 * h), params, None, 1, None).expect("enlarge");
            let secs = clock.elapsed().as_secs_f64();
            let grid =
                [0.0, 0.5, 1.0].iter().map(|&t| grid_peak(&basecolor(&big, t)) / grid_peak(&basecolor(&m, t))).fold(0.0f32, f32::max);
            let sigma = w.min(h) as f32 / 8.0;
            let contrast = detail_std(&basecolor(&big, 1.0), sigma) / detail_std(&basecolor(&m, 1.0), sigma);
            let (lit_out, lit_in) = (nonstationarity(&time_average(&big)), nonstationarity(&time_average(&m)));
            println!(
                "| {name} | {w}x{h} | {variant} | {secs:.2} s | {grid:.2} | {contrast:.2} | {lit_out:.3} / {lit_in:.3} | {:.2} | {:+.0} levels |",
                ps / bs,
                255.0 * (pm - bm)
            );
        }
    }
}
