//! stokes: a spectral path tracer that renders fluorescence correctly and fast.
//!
//! Geometry queries go to the system Embree through [`accel`], the only module allowed to
//! use `unsafe`; everything else (spectra, sampling, materials, lights, integrators, film)
//! is safe Rust. The renderer's modules depend on none of [`tools`] (benchmarks,
//! convergence charts, merging and references), which are built on top of them.
//! `docs/design.md` describes the architecture and the estimator.
#![deny(unsafe_code)]

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod color;
pub mod error;
pub mod fluoro;
pub mod header;
pub mod integrator;
pub mod light;
pub mod medium;
pub mod method;
pub mod output;
pub mod sampler;
pub mod scene;
pub mod simd;
pub mod spectral_exr;
pub mod spectrum;
pub mod texture;
pub mod tools;

pub use error::{one_line, Error};

/// The library's result: errors are [`Error`]s unless said otherwise.
pub type Result<T, E = Error> = std::result::Result<T, E>;
