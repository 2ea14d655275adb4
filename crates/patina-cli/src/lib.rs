//! The `patina` command line: argument parsing, file I/O, progress and
//! manifests only; every algorithm lives in the `patina` library.
//!
//! A library as well as the `patina` binary, so that an embedding (the
//! Python package) runs exactly the CLI's jobs, flags, defaults and
//! manifests in-process: [`parse`], then [`execute`], or [`embed::run`] to
//! also receive progress, cancel and the output images.

mod decay;
mod demo;
pub mod embed;
mod flags;
mod input;
mod metrics;
mod object;
mod output;
mod progress;
mod stbrdf;
mod stone;
mod synth;
mod ttf;
mod view;
mod weather;

use clap::{Parser, Subcommand};
use std::ffi::OsString;

/// patina: make surfaces age. Example-based synthesis of textures and their
/// weathering over time.
#[derive(Parser)]
#[command(name = "patina", version, about, long_about = None)]
pub struct Cli {
    /// Read NaN and infinite samples in EXR inputs as 0 (and say how many) instead of refusing the file.
    #[arg(long, global = true)]
    allow_nonfinite: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Synthesize a texture from an exemplar (enlargement or guided synthesis).
    Synth(synth::Args),
    /// Age a weathered texture forwards and backwards in time (Bellini et al. 2016): age map, intact texture, frames, GIF.
    Weather(weather::Args),
    /// Write the age map of a weathered texture (white = weathered).
    AgeMap(weather::SingleArgs),
    /// Write the intact (un-weathered) texture of a weathered texture.
    Intact(weather::SingleArgs),
    /// Carry one texture's weathering onto another (Bellini et al. 2016, section 7).
    WeatherTransfer(weather::TransferArgs),
    /// Synthesize a larger time-lapse from a small one (Enrique, Koudelka et al.): whole time columns quilted along one seam.
    Ttf(ttf::Args),
    /// Spatio-temporal BRDF materials (Meister et al. 2021): fit, enlarge, transfer, render.
    Stbrdf(stbrdf::Args),
    /// Weather the stone in a photo (Xue et al. 2011): carvings wear smooth, rough spots grow, the silhouette erodes.
    Stone(stone::Args),
    /// Make a clean object in a photo rust, peel, crack or grow moss over time (Hao et al. 2023).
    Decay(decay::Args),
    /// Generate a decay texture (rust, peeling, cracked, mossy) of any size, or synthesize one from a decay photo.
    DecayTexture(decay::TextureArgs),
    /// Measure images (stationarity).
    Metrics(metrics::Args),
    /// Run patina on built-in procedural samples, writing into ./patina-demo/.
    Demo(demo::Args),
    /// Browse an output folder in a local web viewer: frames with a time slider, before/after wipe, maps, live materials.
    View(view::Args),
}

/// Parse a command line (`argv[0]` is the program name).
pub fn parse<I, T>(argv: I) -> Result<Cli, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    Cli::try_parse_from(argv)
}

/// Whether a parse "error" is really a request for help or the version,
/// to be printed rather than reported.
pub fn is_display(e: &clap::Error) -> bool {
    use clap::error::ErrorKind as K;
    matches!(e.kind(), K::DisplayHelp | K::DisplayVersion | K::DisplayHelpOnMissingArgumentOrSubcommand)
}

/// A parse error as the one line the CLI prints (after `patina: `): clap's
/// message up to its usage block, joined.
pub fn parse_message(e: &clap::Error) -> String {
    let text = e.to_string();
    let message: Vec<&str> = text.lines().take_while(|l| !l.trim().is_empty()).map(str::trim).collect();
    format!("{} (see 'patina --help')", message.join(" ").trim_start_matches("error: "))
}

/// A run error as the one line the CLI prints (after `patina: `).
pub fn error_message(e: &patina::Error) -> String {
    e.to_string().split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Run a parsed command line.
pub fn execute(cli: Cli) -> patina::Result<()> {
    input::configure(patina::image::io::LoadOptions { allow_nonfinite: cli.allow_nonfinite });
    dispatch(cli.command)
}

/// Run one subcommand.
fn dispatch(command: Command) -> patina::Result<()> {
    match command {
        Command::Synth(a) => synth::run(a),
        Command::Weather(a) => weather::run(a),
        Command::Stone(a) => stone::run(a),
        Command::AgeMap(a) => weather::run_age_map(a),
        Command::Intact(a) => weather::run_intact(a),
        Command::WeatherTransfer(a) => weather::run_transfer(a),
        Command::Ttf(a) => ttf::run(a),
        Command::Stbrdf(a) => stbrdf::run(a),
        Command::Decay(a) => decay::run(a),
        Command::DecayTexture(a) => decay::run_texture(a),
        Command::Metrics(a) => metrics::run(a),
        Command::Demo(a) => demo::run(a),
        Command::View(a) => view::run(a),
    }
}
