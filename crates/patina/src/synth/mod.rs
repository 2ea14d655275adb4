//! The patch-synthesis engine every patina method is built on.
//!
//! - [`distance`]: how patches are compared, pluggable per channel group.
//! - [`nnf`] and [`patchmatch`]: nearest-neighbour fields and their search.
//! - [`vote`]: averaging overlapping patches into an image.
//! - [`problem`]: the [`Synthesis`] builder describing one problem.
//! - [`optimize`]: texture optimization (search + vote over a pyramid);
//!   [`torus`]: its wrap-around working copies for tileable outputs.
//! - [`families`]: the exemplar's materials and their shares.
//! - [`correlate`] and [`quilt`]: image quilting with FFT candidate search
//!   and minimum-error boundary cuts; [`lattice`]: the exemplar's regular
//!   structure, which quilting keeps aligned.

pub mod blend;
pub mod correlate;
pub mod distance;
pub mod families;
pub mod highlight;
pub mod lattice;
pub mod lighting;
pub mod nnf;
pub mod optimize;
pub mod patchmatch;
pub mod poisson;
pub mod problem;
pub mod quilt;
pub mod rarity;
pub mod start_light;
mod torus;
pub mod vote;

pub use distance::{GroupDistance, PatchMetric, TexelDistance};
pub use lattice::Lattice;
pub use lighting::{LightingReport, Relight};
pub use nnf::{Match, Nnf, SourceDomain};
pub use optimize::{Init, OptimizeParams, Synthesized};
pub use patchmatch::PatchMatch;
pub use problem::{Progress, Synthesis};
pub use quilt::{Placement, QuiltParams, QuiltPlan, Quilted};
pub use vote::VoteWeights;
