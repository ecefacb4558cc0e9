//! Light transport: what a path vertex adds to the image, as the math reads.
//!
//! The wavefront stages (see [`crate::wavefront`]) own the data movement;
//! this module owns the estimators they evaluate:
//! [`settings`] says which estimator runs, [`lights`] samples light sources
//! for next-event estimation, [`bsdf`] says how surfaces reflect and emit (the shade stage samples them).

pub mod bsdf;
pub mod environment;
pub mod lights;
pub mod settings;

pub use settings::{Bounces, ROULETTE_DEPTH, Settings, View};
