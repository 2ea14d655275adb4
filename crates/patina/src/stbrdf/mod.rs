//! Spatio-temporal BRDF (Meister, Pospisil, Sato, Bittner, "Spatio-temporal
//! BRDF: modeling and synthesis", 2021): materials whose parameters are
//! polynomials in time.
//!
//! - [`material`]: the material (named parameters, coefficient image),
//!   its folder of EXRs and `material.json`, tsvbrdf folders, evaluation.
//! - [`enlarge`]: texture optimization on coefficients with the
//!   closed-form distance (section 6.1).
//! - [`fit`]: a material from parameter maps at N times.
//! - [`procedural`]: drying wet wood, for tests and the demo.
//! - [`transfer`]: a material's behaviour carried onto a target texture,
//!   exact at t0 (section 6.2, eq. 16).
//! - [`render`]: Lambert + GGX previews on a plane and a sphere (eqs. 6-7).
//! - [`shader`]: WGSL and GLSL that evaluate the material at time t.
//! - [`poly`]: fitting (one shared pseudo-inverse), Horner evaluation and
//!   the closed-form time-integrated distance (eqs. 8, 11-14).

pub mod enlarge;
pub mod fit;
pub mod material;
pub mod poly;
pub mod procedural;
pub mod render;
pub mod shader;
pub mod transfer;

pub use material::{Encoding, Material, Param};
