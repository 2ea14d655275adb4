//! Stone weathering on real photos: the figures per photo.
//!
//!     cargo run --release -p patina --example stone_quality -- PHOTO...
//!
//! Each photo is weathered with its automatic mask (as `patina stone`
//! does without `--mask`, but with the silhouette kept, so the figures
//! measure the surface's wear only) at t = 100 and 200. Over the object (its mask
//! shrunk by the feather), the table gives the carving band's energy
//! (luminance between Gaussians of 1.5 and 6 px) and the sub-pixel grain's
//! (luminance minus a Gaussian of 1 px), each over the input's, and the
//! block-grid peak of the object's bounding box over the input's.

use patina::image::color::luminance;
use patina::image::filter::gaussian_blur;
use patina::image::{io, Image};
use patina::metrics::grid_peak;
use patina::stone::{self, select, StoneParams};

fn band(img: &Image, region: &[usize], fine: f32, coarse: f32) -> f64 {
    let l = luminance(img);
    let a = if fine > 0.0 { gaussian_blur(&l, fine) } else { l.clone() };
    let b = gaussian_blur(&l, coarse);
    region.iter().map(|&i| ((a.data()[i] - b.data()[i]) as f64).powi(2)).sum::<f64>() / region.len() as f64
}

fn main() {
    println!("| photo | t | carving band | grain | grid peak |");
    println!("|---|---:|---:|---:|---:|");
    for path in std::env::args().skip(1) {
        let photo = io::load(&path).expect("photo");
        let mask = select::auto_mask(&photo);
        let params = StoneParams { erosion: false, feather: select::AUTO_FEATHER, ..Default::default() };
        let prep = stone::prepare(&photo, Some(&mask), None, &params).expect("prepare");
        let frames = stone::sequence(&prep, &[0.0, 100.0, 200.0], 0, None).expect("sequence");
        let inner = mask.erode(select::AUTO_FEATHER as usize);
        let region: Vec<usize> = (0..inner.bits().len()).filter(|&i| inner.bits()[i]).collect();
        let w = mask.width();
        let (x0, y0, x1, y1) = patina::image::pixel_bounds(region.iter().copied(), w).expect("an object");
        let boxed = |img: &Image| img.crop(x0, y0, x1 - x0 + 1, y1 - y0 + 1).expect("inside");
        let name = std::path::Path::new(&path).file_stem().unwrap().to_string_lossy().to_string();
        for f in &frames[1..] {
            println!(
                "| {name} | {} | {:.2} | {:.2} | {:.2} |",
                f.t,
                band(&f.image, &region, 1.5, 6.0) / band(&frames[0].image, &region, 1.5, 6.0),
                band(&f.image, &region, 0.0, 1.0) / band(&frames[0].image, &region, 0.0, 1.0),
                grid_peak(&boxed(&f.image)) / grid_peak(&boxed(&frames[0].image))
            );
        }
    }
}
