//! # patina
//!
//! Make surfaces age: example-based synthesis of weathering over time for
//! textures, time-lapse sequences, materials and photographs.
//!
//! Layers, each depending only on those above it:
//! - [`image`]: the multi-channel f32 image, codecs, colour, filters, pyramids.
//! - [`synth`]: the one patch-synthesis engine (PatchMatch, texture
//!   optimization, image quilting) every method is built on.
//! - [`metrics`]: quality measures shared by tests, benchmarks and the CLI.
//! - [`samples`]: procedural textures the demo and the tests make themselves.

pub mod decay;
pub mod error;
pub mod image;
pub mod metrics;
pub mod rng;
pub mod samples;
pub mod stbrdf;
pub mod stone;
pub mod synth;
pub mod ttf;
pub mod weather;

pub use error::{Error, Result};
pub use image::{ChannelGroup, Image, Mask};
