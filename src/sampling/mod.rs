//! Deterministic random numbers and sample warps.
//!
//! Every random number the renderer uses is a pure function of
//! (seed, pixel, sample index, dimension), so an image does not depend on
//! how work is split over threads or batches.

pub mod rng;
pub mod slots;
pub mod warp;

pub use rng::SampleStream;
