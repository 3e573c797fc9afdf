//! stokes: a spectral path tracer that renders fluorescence correctly and fast.
//!
//! Geometry queries go to the system Embree through [`accel`], the only module allowed to
//! use `unsafe`; everything else (spectra, sampling, materials, lights, integrators, film)
//! is safe Rust.
#![deny(unsafe_code)]

pub mod accel;
pub mod bench_rays;
pub mod bench_render;
pub mod bsdf;
pub mod camera;
pub mod chart;
pub mod color;
pub mod converge;
pub mod fluoro;
pub mod integrator;
pub mod light;
pub mod medium;
pub mod merge;
pub mod output;
pub mod sampler;
pub mod scene;
pub mod spectrum;
