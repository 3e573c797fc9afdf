//! Participating media: homogeneous media with an optional fluorescent dye, the
//! Henyey–Greenstein phase function, and the three distance-tracking strategies of
//! Mojzík, Fichet and Wilkie (EGSR 2018) for camera paths (docs/design.md, "Distance tracking in media").
//!
//! - [`phase`]: [`HenyeyGreenstein`] (direction convention: `wo` points back along the
//!   incoming ray, `wi` is the new direction, cos θ = −`wo`·`wi`, g > 0 forward).
//! - [`homogeneous`]: [`Homogeneous`]: σ_a, σ_s, a phase function and an optional dye
//!   (absorption coefficient σ_dye, emission shape, quantum yield) or re-radiation matrix;
//!   the camera-path coefficients σ̂_t = σ_a + σ_s + σ_f (σ_f = σ_dye, or a matrix's σ_sa)
//!   and σ̂_s = σ_s + σ_se; shift sampling at a collision with value/pdf = σ̂_s.
//! - [`tracking`]: [`Tracking`] (`classic`, `max`, `fluo-aware`) and the distance samplers
//!   with their per-lane pdfs for the balance heuristic over the lanes.
//!
//! Units: every coefficient is in 1/scene-unit (the unit of the scene's coordinates),
//! wavelengths in nm, the dye's F in 1/(scene-unit·nm).
//!
//! # Scene syntax
//! (parsed by [`Homogeneous::from_desc`] in [`desc`]; a shape's `interior` names the medium inside it)
//! ```toml
//! [media.fog]             # σ_a and/or σ_s, or albedo together with sigma_t; g defaults to 0
//! albedo = 0.8
//! sigma_t = 2.0
//! g = 0.3
//!
//! [media.dye]             # an exclusively fluorescent medium
//! sigma_a = 0.0
//! sigma_s = 0.0
//! # σ_dye = concentration × absorption (1/scene-unit, may exceed 1); emission is a shape;
//! # cell_nm is the width of the re-radiation grid's cells (default 2 nm)
//! dye = { absorption = { wavelengths = [400, 440, 480], values = [0, 1, 0] }, concentration = 4.0, emission = { wavelengths = [490, 525, 600], values = [0, 1, 0] }, quantum_yield = 0.95 }
//!
//! [media.paper]           # a general re-radiation matrix instead of a dye
//! # the file as a fluorescent_diffuse material's `matrix` reads it (CSV, BFC or bispectral
//! # EXR; m[i][o] the fraction per cell); scale is the coefficient per scene unit; the
//! # extinction it adds is its row sum σ_sa; its diagonal is not used (that is sigma_s)
//! matrix = { file = "data/medium.csv", scale = 1.0 }
//! ```
//! The tracking method is chosen on the command line, `--tracking classic|max|fluo-aware`
//! ([`Tracking`]; its names and the scene-dependent default are in [`crate::method`]).
//!
//! How the integrator uses them on a segment of length d inside a medium, with lane 0 the
//! hero: `st = sigma_t_hat(λ)`, `ss = sigma_s_hat(λ)`, then [`tracking::sample_distance`];
//! on a collision at t, `beta *= transmittance(st, t) / pdf.x` and `ratio *= pdf / pdf.x`
//! with `pdf = pdf_collision(..)`, followed by a shift sample per lane (its value over pdf
//! supplies σ̂_s) and a phase-function sample; at the surface the same with
//! `prob_surface(..)` and `transmittance(st, d)`.

pub mod desc;
pub mod homogeneous;
pub mod phase;
pub mod tracking;

pub use desc::{MediumDesc, MediumDyeDesc, MediumMatrixDesc};
pub use homogeneous::Homogeneous;
pub use phase::HenyeyGreenstein;
pub use tracking::{DistanceSample, Tracking};
