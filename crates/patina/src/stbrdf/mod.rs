//! Spatio-temporal BRDF (Meister, Pospisil, Sato, Bittner, "Spatio-temporal
//! BRDF: modeling and synthesis", 2021): materials whose parameters are
//! polynomials in time.
//!
//! - [`poly`]: fitting (one shared pseudo-inverse), Horner evaluation and
//!   the closed-form time-integrated distance (eqs. 8, 11-14).

pub mod poly;
