//! wavepath: a data-oriented wavefront CPU path tracer.
//!
//! Data flows one way: [`scene`] loaders build a [`scene::Scene`], [`bvh`]
//! turns its geometry into an acceleration structure, the [`wavefront`]
//! stages move structure-of-arrays ray batches through it, and [`film`]
//! accumulates and writes the image.

pub mod bvh;
pub mod cli;
pub mod film;
pub mod integrator;
pub mod lanes;
pub mod prefetch;
pub mod ray;
pub mod sampling;
pub mod scene;
pub mod wavefront;
