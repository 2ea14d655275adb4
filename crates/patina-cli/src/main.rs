//! `patina`: the command-line tool. Argument parsing, file I/O, progress
//! and manifests only; every algorithm lives in the `patina` library.

mod decay;
mod demo;
mod flags;
mod input;
mod metrics;
mod output;
mod progress;
mod stbrdf;
mod stone;
mod synth;
mod ttf;
mod view;
mod weather;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// patina: make surfaces age. Example-based synthesis of textures and their
/// weathering over time.
#[derive(Parser)]
#[command(name = "patina", version, about, long_about = None)]
struct Cli {
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

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind as K;
            if matches!(e.kind(), K::DisplayHelp | K::DisplayVersion | K::DisplayHelpOnMissingArgumentOrSubcommand) {
                e.exit();
            }
            // One line: clap's message up to its usage block, joined.
            let text = e.to_string();
            let message: Vec<&str> = text.lines().take_while(|l| !l.trim().is_empty()).map(str::trim).collect();
            let message = message.join(" ");
            eprintln!("patina: {} (see 'patina --help')", message.trim_start_matches("error: "));
            return ExitCode::from(2);
        }
    };
    input::configure(patina::image::io::LoadOptions { allow_nonfinite: cli.allow_nonfinite });
    match dispatch(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line, whatever the error's text holds.
            let text = e.to_string();
            eprintln!("patina: {}", text.split_whitespace().collect::<Vec<_>>().join(" "));
            ExitCode::from(if e.is_usage() { 2 } else { 1 })
        }
    }
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
