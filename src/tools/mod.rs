//! Tools built on the renderer: what the `stokes` subcommands other than `render` do.
//! Nothing in the renderer depends on them.
//!
//! - [`merge`]: `stokes merge`, the spp-weighted mean of renders with disjoint samples;
//! - [`reference`]: `stokes reference`, long references that can be resumed;
//! - [`converge`]: `stokes converge`, error against time and spp for several methods;
//! - [`submit`]: `stokes submit slurm`, a render split into a Slurm job array and a merge;
//! - [`converge_chart`]: what `converge` draws (styles by meaning, other renderers' curves,
//!   redrawing from a CSV) and how it names methods;
//! - [`chart`]: the log–log charts `converge` draws;
//! - [`figure`]: `stokes figure`, renders side by side as a labelled PNG strip with their
//!   differences to a reference and a table of their errors;
//! - [`convert`]: `stokes convert-bispectral`, a measured matrix (BFC, CSV) as CSV;
//! - [`bench_rays`], [`bench_render`], [`bench_limit`]: `stokes bench rays|render|limit`;
//! - [`spread`]: the medians, quartiles and paired ratios they report;
//! - [`machine`]: the CPU each of their reports names.

pub mod bench_limit;
pub mod bench_rays;
pub mod bench_render;
pub mod chart;
pub mod converge;
pub mod converge_chart;
pub mod convert;
pub mod figure;
pub mod machine;
pub mod merge;
pub mod reference;
pub mod spread;
pub mod submit;
