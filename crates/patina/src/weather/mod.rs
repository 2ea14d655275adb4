//! Texture weathering from a single image (Bellini, Kleiman, Cohen-Or,
//! "Time-varying Weathering in Texture Space", SIGGRAPH 2016).

pub mod age;
pub mod features;

pub use age::{age_map, AgeMap, AgeParams};
pub use features::Features;
pub mod tiles;
pub mod intact;
pub mod rebuild;
