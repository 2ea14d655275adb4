//! `patina metrics`: quality measures on images.

use crate::output::parse_size;
use patina::{metrics, Error, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub measure: Measure,
}

#[derive(clap::Subcommand)]
pub enum Measure {
    /// Stationarity (Hao et al. 2023, eq. 10, with a fixed filter bank for VGG16): mean relative distance between
    /// the Gram matrices of filter responses of random non-overlapping crop pairs. Lower = more stationary.
    Stationarity(StationarityArgs),
}

#[derive(clap::Args)]
pub struct StationarityArgs {
    /// Image to measure.
    pub image: PathBuf,
    /// Number of random crop pairs.
    #[arg(long, default_value_t = 64, value_parser = |s: &str| crate::flags::count(s, 1, 10000))]
    pub pairs: usize,
    /// Crop size WIDTHxHEIGHT [default: a quarter of the image's width and height]. Use one fixed size to compare images of different sizes.
    #[arg(long, value_parser = parse_size)]
    pub crop: Option<(usize, usize)>,
    /// Random seed for the crop positions.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

pub fn run(args: Args) -> Result<()> {
    match args.measure {
        Measure::Stationarity(a) => {
            let img = crate::input::load(&a.image)?;
            let s = metrics::stationarity(&img, a.crop, a.pairs, a.seed)?;
            let line = serde_json::to_string(&s).map_err(|e| Error::Internal(e.to_string()))?;
            println!("{line}");
            Ok(())
        }
    }
}
