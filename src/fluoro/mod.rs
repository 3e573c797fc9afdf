//! Re-radiation (bispectral) data and wavelength-shift sampling for camera paths.
//!
//! A fluorescent surface re-radiates with M(λi → λo) = D(λo)·δ(λi − λo) + F(λi, λo): the
//! outgoing spectral radiance at λo is D(λo)·L(λo) + ∫ F(λi, λo) L(λi) dλi (docs/design.md, "Fluorescent events").
//!
//! # Units and conventions
//! - Wavelengths are in nm. D (the diagonal, the ordinary reflectance) is dimensionless.
//!   Negative or NaN values of the diagonal spectrum count as 0 everywhere in this module.
//! - F is a density over λi, in nm⁻¹. It is piecewise constant on a uniform grid of `n`
//!   cells `[start + k·h, start + (k+1)·h)`: F(λi, λo) = F[cell(λi)][cell(λo)], and
//!   F[i][o] = 0 unless i < o (a strict Stokes shift at cell level: no light is ever moved
//!   to a shorter wavelength, not even inside one cell).
//! - F is zero outside the grid **and outside the renderer's range**
//!   [[`LAMBDA_MIN`], [`LAMBDA_MAX`]): a cell that sticks out of the range is clipped to it,
//!   so every sampled input wavelength lies in the range. σ_sa and σ_se are integrals over
//!   that range.
//! - Out-shifting σ_sa(λi) = ∫ F(λi, λo) dλo and in-shifting σ_se(λo) = ∫ F(λi, λo) dλi
//!   are dimensionless. A surface conserves energy when D(λi) + σ_sa(λi) ≤ 1
//!   ([`Reradiation::energy_gain_rows`] lists the cells where it does not); σ_se is not
//!   bounded by 1 (many input wavelengths can feed one output wavelength).
//!
//! # Sources
//! - [`Reradiation::diagonal_only`]: no fluorescence, exactly a plain diffuse reflectance.
//! - [`Reradiation::from_dye`]: a parametric dye (absorption, emission, quantum yield).
//! - [`Reradiation::from_csv`]: a measured matrix (format below).
//! - [`Reradiation::from_file`]: a measured matrix in that CSV format, in the Labsphere
//!   BFC-450 format of the RIT bispectral database ([`bfc`]), or as a bispectral OpenEXR
//!   image ([`exr`]; [`Reradiation::to_exr`] writes one).
//!
//! # Measured matrix format (CSV)
//! ```text
//! # comments and blank lines are skipped; `#` also starts a comment mid-line
//! nm,   360,   370,   380, ...     <- header: a label, then the emission cell CENTRES (nm)
//! 360, 0.052, 0.000, 0.001, ...    <- excitation cell centre, then m[i][o] for every o
//! 370, 0.000, 0.061, 0.002, ...
//! ```
//! Fields are separated by commas (or, on a line without a comma, by whitespace). The
//! wavelengths are **cell centres**, evenly spaced with step h (the cell width); the
//! excitation wavelengths (first column) must be the same list as the emission wavelengths
//! (the header), so the matrix is square. Entry m[i][o] is the fraction of spectral radiance
//! in excitation cell i that is re-emitted into emission cell o (dimensionless: with a
//! constant incident spectral radiance L over cell i, cell o leaves with m[i][o]·L), so
//! F = m / h. The diagonal m[i][i] is the ordinary reflectance: it becomes D as a
//! [`Tabulated`] spectrum through the cell centres, held constant from the first and last
//! centre out to the outer edges of the first and last cell. On import, negative entries and
//! non-zero entries below the diagonal (emission shorter than excitation) are set to 0 and
//! counted in an [`ImportReport`]; an entry that is both is counted once, as anti-Stokes.
//!
//! # Shift sampling
//! On a camera path the output wavelength λo is known and the input λi is sampled
//! ([`Reradiation::sample_input`]): keep λo with probability D/(D + σ_se), otherwise draw λi
//! ∝ F(·, λo) (a cell from the column's CDF, uniform inside the cell). Either way the
//! sample's value over its pdf is D(λo) + σ_se(λo).

pub mod bfc;
pub mod exr;
mod import;
pub mod map;

pub use bfc::BfcReport;
pub use exr::ExrReport;
pub use import::ImportReport;

use crate::error::{Detail, Error, Key, KeyError};

/// What importing a measured matrix changed, by format.
#[derive(Debug, Clone, PartialEq)]
pub enum MatrixReport {
    /// A CSV matrix: entries set to 0.
    Csv(ImportReport),
    /// A BFC file: entries set to 0, columns dropped, rows not measured.
    Bfc(BfcReport),
    /// A bispectral EXR: pixels averaged, entries set to 0.
    Exr(ExrReport),
}

impl MatrixReport {
    /// Whether the import changed nothing a user should hear about.
    pub fn is_clean(&self) -> bool {
        match self {
            MatrixReport::Csv(r) => r.is_clean(),
            MatrixReport::Bfc(r) => {
                r.clamped.is_clean()
                    && r.excitation_dropped.is_none()
                    && r.emission_unmeasured.is_none()
            }
            MatrixReport::Exr(r) => r.is_clean(),
        }
    }
}

impl std::fmt::Display for MatrixReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MatrixReport::Csv(r) => r.fmt(f),
            MatrixReport::Bfc(r) => r.fmt(f),
            MatrixReport::Exr(r) => r.fmt(f),
        }
    }
}
use crate::simd::{map4, Float};
use crate::spectrum::{Spectrum, LAMBDA_MAX, LAMBDA_MIN, LAMBDA_RANGE};
use glam::Vec4;
use std::path::Path;

/// Checks a dye's quantum yield and grid cell width (`dye` is the dye's key, on a surface
/// or in a medium); returns the cell width, 2 nm unless given.
pub fn dye_cell_width(
    dye: &Key,
    quantum_yield: f32,
    cell_nm: Option<f32>,
) -> Result<f32, KeyError> {
    if !(0.0..=1.0).contains(&quantum_yield) {
        return Err(dye
            .field("quantum_yield")
            .expected("a number in [0, 1]", quantum_yield));
    }
    let cell = cell_nm.unwrap_or(2.0);
    if !(cell.is_finite() && (0.5..=50.0).contains(&cell)) {
        return Err(dye
            .field("cell_nm")
            .expected("a width in [0.5, 50] nm", cell));
    }
    Ok(cell)
}

/// The most cells a grid may have (an n×n matrix and an n×n table of CDFs are stored).
pub const MAX_CELLS: usize = 1024;

/// A re-radiation function M(λi → λo): a continuous diagonal D and a gridded off-diagonal
/// density F (see the module docs for units).
#[derive(Clone, Debug)]
pub struct Reradiation {
    diagonal: Spectrum,
    /// Nominal start of cell 0 (nm); may lie below [`LAMBDA_MIN`].
    start: f32,
    /// Cell width h (nm).
    cell_nm: f32,
    inv_cell: f32,
    /// Number of cells.
    n: usize,
    /// Where F may be non-zero: the grid clipped to the renderer's range, `[lo, hi)`.
    lo: f32,
    hi: f32,
    /// F (nm⁻¹), row-major: `f[i * n + o]`, zero unless `i < o`.
    f: Vec<f32>,
    /// σ_se per column (emission cell).
    sigma_se: Vec<f32>,
    /// σ_sa per row (excitation cell).
    sigma_sa: Vec<f32>,
    /// Column CDFs over the excitation cell, column-major: `cdf[o * n + i]` for `i < o`;
    /// the last cell of positive weight holds exactly 1.
    cdf: Vec<f32>,
    fluorescent: bool,
}

/// A sampled input wavelength at a fluorescent vertex (see [`Reradiation::sample_input`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftSample {
    /// The input wavelength λi (nm); equal to λo when `kept`.
    pub lambda_i: f32,
    /// Whether the wavelength was kept (the diagonal D) rather than shifted (F).
    pub kept: bool,
    /// For a kept wavelength the discrete probability D/(D+σ_se); for a shift the density
    /// F(λi, λo)/(D+σ_se) in nm⁻¹.
    pub pdf: f32,
    /// M for this event: D(λo) if kept, F(λi, λo) if shifted; `value / pdf = D + σ_se`.
    pub value: f32,
}

/// The least share of a dye's absorption that must lie below some of its emission.
const MIN_REEMITTABLE: f64 = 1e-3;

/// Checks that a dye can re-emit: that it absorbs somewhere, and that at least
/// [`MIN_REEMITTABLE`] of its absorption ∫A lies in cells with emission above them (only
/// there does F re-emit, with a Stokes shift). `a`, `e` and `w` are A, E and the width per
/// cell, `tail[i]` the emission above cell i.
///
/// A dye that cannot re-emit is an error, not a warning: its keys would change nothing
/// visible (on a surface the dye only adds F; in a medium it would be a plain absorber,
/// which `sigma_a` says directly), and such input is almost always a mistake (bands
/// swapped, or one given in µm), like an emission that is zero everywhere. The share is
/// measured rather than required to be non-zero because Gaussian bands have tails: a
/// dye absorbing at 600 nm and emitting at 450 nm overlaps in tails of 10⁻⁴ and would
/// render as if it were not there. A quantum yield of 0 is accepted: it says so on
/// purpose.
fn check_stokes_shift(
    grid: &Reradiation,
    a: &[f64],
    e: &[f64],
    w: &[f64],
    tail: &[f64],
) -> Result<(), Detail> {
    let Some(first_absorbed) = a.iter().position(|&v| v > 0.0) else {
        return Err(Detail::Text(format!(
            "dye absorption is zero at every cell centre over {LAMBDA_MIN}–{LAMBDA_MAX} nm: the dye would do nothing"
        )));
    };
    let absorbed: f64 = a.iter().zip(w).map(|(a, w)| a * w).sum();
    let reemittable: f64 = (0..a.len())
        .filter(|&i| tail[i] > 0.0)
        .map(|i| a[i] * w[i])
        .sum();
    let share = reemittable / absorbed;
    if share < MIN_REEMITTABLE {
        let last_emitted = e.iter().rposition(|&v| v > 0.0).unwrap_or(0);
        let found = if share == 0.0 {
            "none".to_string()
        } else {
            format!("only {share:.1e}")
        };
        return Err(Detail::expected(
            "emission at longer wavelengths than absorption (a Stokes shift)",
            format!(
                "absorption from {} nm and emission up to {} nm, so that {found} of the absorbed light can be re-emitted: the dye would do nothing visible",
                grid.cell_bounds(first_absorbed).0,
                grid.cell_bounds(last_emitted).1
            ),
        ));
    }
    Ok(())
}

impl Reradiation {
    /// Only a diagonal (no fluorescence): [`Self::sample_input`] always keeps the
    /// wavelength with probability 1 and value D, exactly like a plain diffuse reflectance.
    pub fn diagonal_only(d: Spectrum) -> Reradiation {
        Reradiation {
            diagonal: d,
            start: LAMBDA_MIN,
            cell_nm: LAMBDA_RANGE,
            inv_cell: 1.0 / LAMBDA_RANGE,
            n: 0,
            lo: LAMBDA_MIN,
            hi: LAMBDA_MIN,
            f: Vec::new(),
            sigma_se: Vec::new(),
            sigma_sa: Vec::new(),
            cdf: Vec::new(),
            fluorescent: false,
        }
    }

    /// A parametric dye with the quantum yield applying to energy:
    /// [`Self::from_dye_with_scaling`] with `energy_scaling = false`.
    pub fn from_dye(
        diagonal: Spectrum,
        absorption: &Spectrum,
        emission: &Spectrum,
        quantum_yield: f32,
        cell_nm: f32,
    ) -> Result<Reradiation, Detail> {
        Self::from_dye_with_scaling(
            diagonal,
            absorption,
            emission,
            quantum_yield,
            cell_nm,
            false,
        )
    }

    /// A parametric dye on cells of `cell_nm` nm starting at [`LAMBDA_MIN`] (the last cell is
    /// clipped at [`LAMBDA_MAX`]); A and E are evaluated at the cell centres (of the clipped
    /// cell). With Φ = `quantum_yield`:
    ///
    /// F(λi, λo) = Φ · A(λi) · E(λo) · [λo > λi] / ∫_{λ' > λi} E(λ') dλ'
    ///
    /// i.e. the absorbed fraction A(λi) is re-emitted with yield Φ, spread over the part of
    /// the emission band above λi (cell level: over the cells o > i). Then
    /// σ_sa(λi) = Φ·A(λi) wherever some emission lies above λi (elsewhere the absorbed light
    /// is simply lost).
    ///
    /// `energy_scaling = false` (the default of [`Self::from_dye`]): Φ is the fraction of
    /// absorbed *energy* re-emitted, so σ_sa = Φ·A exactly and the energy balance of the
    /// surface is D + Φ·A. `energy_scaling = true`: Φ is a *photon* yield and E a photon
    /// spectrum; each re-emitted photon carries λi/λo of the absorbed photon's energy, so F
    /// is multiplied by λi/λo (cell centres) and σ_sa < Φ·A (the Stokes loss).
    ///
    /// `absorption` is the fraction absorbed, in [0, 1]; `emission` a non-negative shape
    /// (its scale does not matter); `diagonal` the surface's ordinary reflectance, which for
    /// energy conservation should not exceed 1 − Φ·A (check with
    /// [`Self::energy_gain_rows`]).
    pub fn from_dye_with_scaling(
        diagonal: Spectrum,
        absorption: &Spectrum,
        emission: &Spectrum,
        quantum_yield: f32,
        cell_nm: f32,
        energy_scaling: bool,
    ) -> Result<Reradiation, Detail> {
        if !(0.0..=1.0).contains(&quantum_yield) {
            return Err(Detail::Text(format!(
                "dye quantum yield must be in [0, 1], found {quantum_yield}"
            )));
        }
        let min_cell = LAMBDA_RANGE / MAX_CELLS as f32;
        if !(cell_nm.is_finite() && cell_nm >= min_cell) {
            return Err(Detail::Text(format!(
                "dye cell width must be a number of nm ≥ {min_cell} (at most {MAX_CELLS} cells \
                 over {LAMBDA_MIN}–{LAMBDA_MAX} nm), found {cell_nm}"
            )));
        }
        // ceil, forgiving a rounding error when the width divides the range.
        let n = ((LAMBDA_RANGE / cell_nm) - 1e-4).ceil().max(1.0) as usize;
        let mut grid = Reradiation::diagonal_only(diagonal);
        grid.set_grid(LAMBDA_MIN, cell_nm, n);

        let mut a = vec![0.0f64; n];
        let mut e = vec![0.0f64; n];
        let mut w = vec![0.0f64; n];
        let mut mid = vec![0.0f64; n];
        for k in 0..n {
            let (l0, l1) = grid.cell_bounds(k);
            let c = 0.5 * (l0 + l1);
            let av = absorption.eval(c);
            if !(av.is_finite() && (-1e-6..=1.0 + 1e-6).contains(&av)) {
                return Err(Detail::Text(format!(
                    "dye absorption must be a fraction in [0, 1], found {av} at {c} nm"
                )));
            }
            let ev = emission.eval(c);
            if !(ev.is_finite() && ev >= 0.0) {
                return Err(Detail::Text(format!(
                    "dye emission must be finite and non-negative, found {ev} at {c} nm"
                )));
            }
            a[k] = f64::from(av.clamp(0.0, 1.0));
            e[k] = f64::from(ev);
            w[k] = f64::from(l1 - l0);
            mid[k] = f64::from(c);
        }
        if e.iter().all(|&v| v == 0.0) {
            return Err(Detail::Text(format!(
                "dye emission is zero at every cell centre over {LAMBDA_MIN}–{LAMBDA_MAX} nm"
            )));
        }
        // tail[i] = ∫_{cells above i} E = Σ_{o > i} E_o w_o.
        let mut tail = vec![0.0f64; n];
        for i in (0..n.saturating_sub(1)).rev() {
            tail[i] = tail[i + 1] + e[i + 1] * w[i + 1];
        }
        check_stokes_shift(&grid, &a, &e, &w, &tail)?;
        let phi = f64::from(quantum_yield);
        let mut f = vec![0.0f32; n * n];
        for i in 0..n {
            if tail[i] <= 0.0 || a[i] == 0.0 {
                continue;
            }
            let row = phi * a[i] / tail[i];
            for o in i + 1..n {
                let scale = if energy_scaling { mid[i] / mid[o] } else { 1.0 };
                f[i * n + o] = (row * e[o] * scale) as f32;
            }
        }
        grid.set_matrix(f);
        Ok(grid)
    }

    /// A measured matrix from a CSV file (format in the module docs). Returns the counts of
    /// entries set to 0 so the caller can report them. Errors name the file and line.
    pub fn from_csv(path: &Path) -> crate::Result<(Reradiation, ImportReport)> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::file(path, None, format!("cannot read: {e}")))?;
        Self::from_csv_str(&text, &path.display().to_string())
    }

    /// A measured matrix from a file: a bispectral OpenEXR image (recognised by its magic
    /// number, [`exr`]), a Labsphere BFC-450 file (recognised by its first line, [`bfc`])
    /// or CSV. The report says what the import changed.
    pub fn from_file(path: &Path) -> crate::Result<(Reradiation, MatrixReport)> {
        let bytes = std::fs::read(path)
            .map_err(|e| Error::file(path, None, format!("cannot read: {e}")))?;
        if exr::is_exr(path, &bytes) {
            let (r, report) = exr::read(path)?;
            return Ok((r, MatrixReport::Exr(report)));
        }
        let text = String::from_utf8(bytes).map_err(|_| {
            Error::file(
                path,
                None,
                "cannot read: not text (expected a CSV matrix, a BFC file or an OpenEXR image)",
            )
        })?;
        let source = path.display().to_string();
        if bfc::is_bfc(&text) {
            let (r, report) = bfc::parse(&text, &source)?;
            Ok((r, MatrixReport::Bfc(report)))
        } else {
            let (r, report) = import::parse(&text, &source)?;
            Ok((r, MatrixReport::Csv(report)))
        }
    }

    /// The matrix in the CSV format of the module docs: cell centres, the diagonal D at
    /// each centre, F·h above it (what [`Self::from_csv`] reads back, to float rounding).
    /// None for a surface without a grid ([`Self::diagonal_only`]).
    pub fn to_csv(&self, comment: &str) -> Option<String> {
        let n = self.n;
        if n == 0 {
            return None;
        }
        let mut out = String::new();
        for line in comment.lines() {
            out.push_str(&format!("# {line}\n"));
        }
        let centres: Vec<f32> = (0..n).map(|k| self.cell_centre(k)).collect();
        out.push_str("nm");
        for c in &centres {
            out.push_str(&format!(",{c}"));
        }
        out.push('\n');
        for (i, &ci) in centres.iter().enumerate() {
            out.push_str(&format!("{ci}"));
            for o in 0..n {
                let m = match o.cmp(&i) {
                    std::cmp::Ordering::Less => 0.0,
                    std::cmp::Ordering::Equal => self.diagonal.eval(ci),
                    std::cmp::Ordering::Greater => self.f[i * n + o] * self.cell_nm,
                };
                out.push_str(&format!(",{m}"));
            }
            out.push('\n');
        }
        Some(out)
    }

    /// Writes the matrix to `path` as a one-pixel bispectral OpenEXR image ([`exr`]: the
    /// diagonal, F·h for every pair of cell centres, the diagonal's colour as R, G, B),
    /// with `metadata` as `stokes:*` header attributes. An error for a surface without a
    /// grid ([`Self::diagonal_only`]).
    pub fn to_exr(&self, path: &Path, metadata: &[(String, String)]) -> crate::Result<()> {
        exr::write(self, path, metadata)
    }

    /// [`Self::from_csv`] on text; `source` (usually the file name) is the file every error
    /// names.
    pub fn from_csv_str(text: &str, source: &str) -> crate::Result<(Reradiation, ImportReport)> {
        import::parse(text, source)
    }

    /// The same off-diagonal F with another diagonal D (e.g. a scene's reflectance overriding
    /// a measured matrix's diagonal).
    pub fn with_diagonal(mut self, d: Spectrum) -> Reradiation {
        self.diagonal = d;
        self
    }

    /// Sets a grid of `n` cells of width `h` from `start` (no matrix yet).
    fn set_grid(&mut self, start: f32, h: f32, n: usize) {
        self.start = start;
        self.cell_nm = h;
        self.inv_cell = 1.0 / h;
        self.n = n;
        self.lo = start.max(LAMBDA_MIN);
        self.hi = (start + n as f32 * h).min(LAMBDA_MAX).max(self.lo);
    }

    /// Installs F (nm⁻¹, row-major n×n; entries with i ≥ o are ignored) and derives σ_se,
    /// σ_sa and the column CDFs, weighting each cell by its width inside the range.
    fn set_matrix(&mut self, mut f: Vec<f32>) {
        let n = self.n;
        debug_assert_eq!(f.len(), n * n);
        for i in 0..n {
            for o in 0..=i {
                f[i * n + o] = 0.0;
            }
        }
        let w: Vec<f64> = (0..n)
            .map(|k| {
                let (a, b) = self.cell_bounds(k);
                f64::from(b - a)
            })
            .collect();
        let mut sigma_sa = vec![0.0f32; n];
        for i in 0..n {
            let s: f64 = (i + 1..n).map(|o| f64::from(f[i * n + o]) * w[o]).sum();
            sigma_sa[i] = s as f32;
        }
        let mut sigma_se = vec![0.0f32; n];
        let mut cdf = vec![0.0f32; n * n];
        for o in 0..n {
            let weights: Vec<f64> = (0..o).map(|i| f64::from(f[i * n + o]) * w[i]).collect();
            let total: f64 = weights.iter().sum();
            if !(total > 0.0 && w[o] > 0.0) {
                continue;
            }
            sigma_se[o] = total as f32;
            let last = weights.iter().rposition(|&x| x > 0.0).unwrap_or(0);
            let mut acc = 0.0f64;
            for (i, &x) in weights.iter().enumerate() {
                acc += x;
                cdf[o * n + i] = if i >= last { 1.0 } else { (acc / total) as f32 };
            }
        }
        self.fluorescent = sigma_se.iter().any(|&s| s > 0.0);
        self.f = f;
        self.sigma_se = sigma_se;
        self.sigma_sa = sigma_sa;
        self.cdf = cdf;
    }

    /// The index of the cell holding λ, if F may be non-zero there (inside the grid and the
    /// renderer's range).
    #[inline]
    pub fn cell(&self, lambda: f32) -> Option<usize> {
        if !(lambda >= self.lo && lambda < self.hi) {
            return None;
        }
        let k = ((lambda - self.start) * self.inv_cell) as usize;
        Some(k.min(self.n - 1))
    }

    /// The diagonal spectrum as given (before clamping negative values to 0).
    pub fn diagonal(&self) -> &Spectrum {
        &self.diagonal
    }

    /// Number of grid cells (0 for [`Self::diagonal_only`]).
    pub fn cells(&self) -> usize {
        self.n
    }

    /// Cell width h (nm).
    pub fn cell_nm(&self) -> f32 {
        self.cell_nm
    }

    /// Nominal centre of cell `k` (nm): the wavelength a CSV file gives for it.
    pub fn cell_centre(&self, k: usize) -> f32 {
        self.start + (k as f32 + 0.5) * self.cell_nm
    }

    /// Cell `k` clipped to the renderer's range, `[a, b)` in nm (empty when the cell lies
    /// outside it). F is constant over it (the edges are exact up to f32 rounding, where
    /// the cell lookup of [`Self::f`] decides).
    pub fn cell_bounds(&self, k: usize) -> (f32, f32) {
        let a = (self.start + k as f32 * self.cell_nm).clamp(self.lo, self.hi);
        let b = if k + 1 == self.n {
            self.hi
        } else {
            (self.start + (k + 1) as f32 * self.cell_nm).clamp(self.lo, self.hi)
        };
        (a, b)
    }

    /// The diagonal D(λ) (ordinary reflectance), clamped to be non-negative.
    #[inline]
    pub fn d(&self, lambda: f32) -> f32 {
        // The diagonal clamped to be non-negative (NaN gives 0).
        self.diagonal.eval(lambda).nonneg()
    }

    /// D at the four lanes.
    #[inline]
    pub fn d4(&self, lambda: Vec4) -> Vec4 {
        map4(self.diagonal.eval4(lambda), Float::nonneg)
    }

    /// The off-diagonal density F(λi, λo) in nm⁻¹ (0 unless cell(λi) < cell(λo)).
    #[inline]
    pub fn f(&self, lambda_i: f32, lambda_o: f32) -> f32 {
        match (self.cell(lambda_i), self.cell(lambda_o)) {
            (Some(i), Some(o)) => self.f[i * self.n + o],
            _ => 0.0,
        }
    }

    /// In-shifting σ_se(λo) = ∫ F(λi, λo) dλi.
    #[inline]
    pub fn sigma_se(&self, lambda_o: f32) -> f32 {
        self.cell(lambda_o).map_or(0.0, |o| self.sigma_se[o])
    }

    /// Out-shifting σ_sa(λi) = ∫ F(λi, λo) dλo.
    #[inline]
    pub fn sigma_sa(&self, lambda_i: f32) -> f32 {
        self.cell(lambda_i).map_or(0.0, |i| self.sigma_sa[i])
    }

    /// Whether any light is shifted inside the renderer's range (some F > 0).
    pub fn is_fluorescent(&self) -> bool {
        self.fluorescent
    }

    /// The cells whose total re-radiation D + σ_sa exceeds 1 (an energy gain), as
    /// (nominal cell centre in nm, total). D is taken at the centre and σ_sa over the whole
    /// cell row (not clipped to the range), so for a measured matrix the total is the
    /// file's row sum. Empty for [`Self::diagonal_only`], which has no cells.
    pub fn energy_gain_rows(&self) -> Vec<(f32, f32)> {
        self.energy_gain_rows_with(|c, out| f64::from(self.d(c)) + out)
    }

    /// [`Self::energy_gain_rows`] with the total of a row given by `total(centre, σ_sa)`
    /// (a fluorescence map's largest D + s·σ_sa over the surface, [`map`]).
    pub fn energy_gain_rows_with(&self, total: impl Fn(f32, f64) -> f64) -> Vec<(f32, f32)> {
        let n = self.n;
        (0..n)
            .filter_map(|i| {
                let c = self.cell_centre(i);
                let out: f64 = (i + 1..n)
                    .map(|o| f64::from(self.f[i * n + o]))
                    .sum::<f64>()
                    * f64::from(self.cell_nm);
                let total = total(c, out) as f32;
                (total > 1.0 + 1e-5).then_some((c, total))
            })
            .collect()
    }

    /// Shift sampling on a camera path at output wavelength `lambda_o`: keep it with
    /// probability D/(D+σ_se) (`u_choice` below that), else draw λi ∝ F(·, λo): a cell from
    /// the column's CDF with `u_lambda`, and the position inside the (clipped) cell from
    /// what is left of `u_lambda`. `None` when D + σ_se = 0: the lane cannot continue.
    #[inline]
    pub fn sample_input(&self, lambda_o: f32, u_choice: f32, u_lambda: f32) -> Option<ShiftSample> {
        self.sample_input_with(self.d(lambda_o), 1.0, lambda_o, u_choice, u_lambda)
    }

    /// [`Self::sample_input`] for M = d·δ + s·F: the diagonal `d` at λo (≥ 0) given by the
    /// caller, F scaled by the dye strength `s` (a fluorescence map, [`map`]).
    #[inline]
    pub fn sample_input_with(
        &self,
        d: f32,
        s: f32,
        lambda_o: f32,
        u_choice: f32,
        u_lambda: f32,
    ) -> Option<ShiftSample> {
        let column = self.cell(lambda_o);
        let sse = column.map_or(0.0, |o| s * self.sigma_se[o]);
        let total = d + sse;
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let p_keep = d / total;
        let o = match column {
            Some(o) if u_choice >= p_keep && sse > 0.0 => o,
            _ => {
                return Some(ShiftSample {
                    lambda_i: lambda_o,
                    kept: true,
                    pdf: p_keep,
                    value: d,
                })
            }
        };
        let n = self.n;
        let cdf = &self.cdf[o * n..o * n + o];
        let u = u_lambda.clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        // The first cell whose CDF exceeds u: never one of zero weight.
        let i = cdf.partition_point(|&c| c <= u).min(o - 1);
        let below = if i == 0 { 0.0 } else { cdf[i - 1] };
        let frac = ((u - below) / (cdf[i] - below)).clamp(0.0, 1.0);
        let (a, b) = self.cell_bounds(i);
        let mut lambda_i = (a + frac * (b - a)).clamp(a, b);
        // Rounding may put λi on a neighbouring cell's side of the edge: step back inside,
        // so that f and pdf_input at λi agree with this sample.
        for _ in 0..8 {
            match self.cell(lambda_i) {
                Some(k) if k == i => break,
                Some(k) if k < i => lambda_i = lambda_i.next_up(),
                _ => lambda_i = lambda_i.next_down(),
            }
        }
        let value = s * self.f[i * n + o];
        Some(ShiftSample {
            lambda_i,
            kept: false,
            pdf: value / total,
            value,
        })
    }

    /// The pdf with which [`Self::sample_input`]`(lambda_o, ..)` produces this event: for a
    /// kept wavelength (`lambda_i` is then ignored) the discrete probability D/(D+σ_se);
    /// for a shift to `lambda_i` the density F(λi, λo)/(D+σ_se) in nm⁻¹. 0 when D+σ_se = 0.
    #[inline]
    pub fn pdf_input(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        self.pdf_input_with(self.d(lambda_o), 1.0, lambda_i, lambda_o, kept)
    }

    /// [`Self::pdf_input`] for M = d·δ + s·F ([`Self::sample_input_with`]).
    #[inline]
    pub fn pdf_input_with(&self, d: f32, s: f32, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        let total = d + s * self.sigma_se(lambda_o);
        if !(total > 0.0 && total.is_finite()) {
            return 0.0;
        }
        if kept {
            d / total
        } else {
            s * self.f(lambda_i, lambda_o) / total
        }
    }

    /// M for the event: D(λo) if kept (`lambda_i` ignored), F(λi, λo) if shifted.
    #[inline]
    pub fn value(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        self.value_with(self.d(lambda_o), 1.0, lambda_i, lambda_o, kept)
    }

    /// [`Self::value`] for M = d·δ + s·F ([`Self::sample_input_with`]).
    #[inline]
    pub fn value_with(&self, d: f32, s: f32, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        if kept {
            d
        } else {
            s * self.f(lambda_i, lambda_o)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::Tabulated;

    fn assert_traits<T: Send + Sync + Clone + std::fmt::Debug>() {}

    #[test]
    fn types_are_send_sync_clone_debug() {
        assert_traits::<Reradiation>();
        assert_traits::<ShiftSample>();
        assert_traits::<ImportReport>();
    }

    /// A BFC import is clean only when nothing was clamped, dropped or left unmeasured
    /// (the measured files all clamp some entries, so they cannot tell the three apart).
    #[test]
    fn a_bfc_report_is_clean_only_when_nothing_was_left_out() {
        let clean = BfcReport {
            sample: None,
            clamped: ImportReport::default(),
            excitation_dropped: None,
            emission_unmeasured: None,
            emission_dropped: None,
            held_above: None,
        };
        assert!(MatrixReport::Bfc(clean.clone()).is_clean());
        let negative = ImportReport {
            clamped_negative: 1,
            ..ImportReport::default()
        };
        for r in [
            BfcReport {
                clamped: negative,
                ..clean.clone()
            },
            BfcReport {
                excitation_dropped: Some((300.0, 350.0, 6)),
                ..clean.clone()
            },
            BfcReport {
                emission_unmeasured: Some((360.0, 370.0)),
                ..clean.clone()
            },
        ] {
            assert!(!MatrixReport::Bfc(r.clone()).is_clean(), "{r:?}");
        }
    }

    /// A dye must be able to re-emit: some absorption, and at least
    /// [`MIN_REEMITTABLE`] of it below some emission.
    #[test]
    fn a_dye_that_cannot_re_emit_is_rejected() {
        let band = |c: f32, w: f32| Spectrum::narrow_band(c, w).unwrap();
        let boxed = |a: f32, b: f32| {
            Spectrum::Tabulated(
                Tabulated::new(vec![a - 1e-3, a, b, b + 1e-3], vec![0.0, 0.5, 0.5, 0.0]).unwrap(),
            )
        };
        let d = Spectrum::Constant(0.3);
        let dye =
            |a: &Spectrum, e: &Spectrum, qy: f32| Reradiation::from_dye(d.clone(), a, e, qy, 2.0);
        // Accepted: emission above absorption, overlapping bands, a yield of 0 (on purpose).
        assert!(dye(&boxed(420.0, 480.0), &boxed(500.0, 560.0), 0.9)
            .unwrap()
            .is_fluorescent());
        assert!(dye(&band(500.0, 40.0), &band(520.0, 40.0), 0.9).is_ok());
        assert!(dye(&boxed(420.0, 480.0), &boxed(500.0, 560.0), 0.0).is_ok());
        // Rejected: emission entirely below absorption, Gaussian bands overlapping only in
        // their far tails, no absorption in range.
        let cases = [
            (
                boxed(550.0, 650.0),
                boxed(400.0, 500.0),
                "none of the absorbed light",
            ),
            (band(600.0, 20.0).scaled(10.0), band(450.0, 20.0), "only "),
            (band(0.44, 0.02), band(520.0, 30.0), "absorption is zero"),
        ];
        for (a, e, fragment) in cases {
            let Err(err) = dye(&a, &e, 0.9).map_err(|e| e.to_string()) else {
                panic!("accepted {a:?} / {e:?}")
            };
            assert!(err.contains(fragment), "{a:?} / {e:?}: {err}");
        }
        // The share is measured on the absorption: two absorbing cells (of some fifty)
        // below the emission's end pass; absorption of 10⁻⁴ of the band's height there
        // does not.
        let sliver = Spectrum::Tabulated(
            Tabulated::new(vec![498.0, 499.0, 500.0, 600.0], vec![0.0, 0.5, 0.5, 0.5]).unwrap(),
        );
        assert!(dye(&sliver, &boxed(400.0, 503.0), 0.9).is_ok());
        let hair = Spectrum::Tabulated(
            Tabulated::new(
                vec![498.0, 500.0, 501.9, 502.0, 700.0],
                vec![0.0, 5e-5, 5e-5, 0.5, 0.5],
            )
            .unwrap(),
        );
        assert!(dye(&hair, &boxed(400.0, 502.0), 0.9).is_err());
        // The share weighs each cell by its width (2 nm here): one cell [400, 402) at
        // absorption 0.25 below an emission in [402, 404), against 214 cells at 0.5 up to
        // 830 nm, is 0.25·2 / (0.25·2 + 0.5·2·214) = 2.3·10⁻³ and passes; at 0.05 it is
        // 4.7·10⁻⁴ and does not.
        let step = |first: f32| {
            Spectrum::Tabulated(
                Tabulated::new(
                    vec![399.9, 400.0, 402.0, 402.1, 830.0],
                    vec![0.0, first, first, 0.5, 0.5],
                )
                .unwrap(),
            )
        };
        assert!(dye(&step(0.25), &boxed(402.2, 403.8), 0.9).is_ok());
        let err = dye(&step(0.05), &boxed(402.2, 403.8), 0.9).unwrap_err();
        assert!(err.to_string().contains("only 4.7e-4"), "{err}");
    }

    /// A 3-cell matrix whose grid sticks out of the range on both sides.
    fn clipped() -> Reradiation {
        let mut r = Reradiation::diagonal_only(Spectrum::Constant(0.5));
        // Cells [200, 400), [400, 600), [600, 800)... with h = 200 from 200: the first cell
        // is clipped to [360, 400).
        r.set_grid(200.0, 200.0, 4);
        let n = 4;
        let mut f = vec![0.0; n * n];
        f[1] = 0.001; // (0, 1)
        f[n + 3] = 0.002; // (1, 3): cell 3 is [800, 1000) -> [800, 830)
        f[2 * n] = 0.5; // below the diagonal: ignored
        r.set_matrix(f);
        r
    }

    #[test]
    fn cells_are_clipped_to_the_range() {
        let r = clipped();
        assert_eq!(r.cell_bounds(0), (360.0, 400.0));
        assert_eq!(r.cell_bounds(1), (400.0, 600.0));
        assert_eq!(r.cell_bounds(3), (800.0, 830.0));
        assert_eq!(r.cell(359.9), None);
        assert_eq!(r.cell(360.0), Some(0));
        assert_eq!(r.cell(399.99), Some(0));
        assert_eq!(r.cell(400.0), Some(1));
        assert_eq!(r.cell(830.0), None);
        assert_eq!(r.cell(f32::NAN), None);
        // σ_se of cell 1 = 0.001 · 40 nm (clipped width of cell 0), not · 200 nm.
        assert!((r.sigma_se(500.0) - 0.04).abs() < 1e-6);
        assert!((r.sigma_sa(500.0) - 0.002 * 30.0).abs() < 1e-6);
        // The ignored anti-Stokes entry is gone; F is 0 outside the range.
        assert_eq!(r.f(650.0, 700.0), 0.0);
        assert_eq!(r.f(300.0, 500.0), 0.0);
        // Energy rows use the unclipped row: 0.5 + 0.001·200 for the cell centred at 300.
        assert!(r.energy_gain_rows().is_empty());
    }

    #[test]
    fn sampled_wavelengths_stay_in_their_clipped_cell() {
        let r = clipped();
        let mut rng = crate::sampler::Pcg32::new(5, 9);
        for _ in 0..20_000 {
            let s = r
                .sample_input(815.0, rng.next_f32(), rng.next_f32())
                .unwrap();
            if !s.kept {
                assert!((400.0..600.0).contains(&s.lambda_i), "{s:?}");
            }
            let s = r
                .sample_input(450.0, rng.next_f32(), rng.next_f32())
                .unwrap();
            if !s.kept {
                assert!((360.0..400.0).contains(&s.lambda_i), "{s:?}");
            }
        }
        // Extreme random numbers still give a sample inside the cell.
        for u in [0.0, 1.0 - f32::EPSILON, 1.0, 2.0, -1.0] {
            let s = r.sample_input(450.0, 0.99999, u).unwrap();
            assert!(
                !s.kept && (360.0..400.0).contains(&s.lambda_i),
                "{u}: {s:?}"
            );
            assert_eq!(r.cell(s.lambda_i), Some(0));
        }
    }

    #[test]
    fn cell_edges_are_consistent_between_sampling_and_lookup() {
        // A grid whose edges are not exactly representable.
        let mut r = Reradiation::diagonal_only(Spectrum::Constant(0.0));
        let n = 150;
        r.set_grid(LAMBDA_MIN, LAMBDA_RANGE / n as f32, n);
        let mut f = vec![0.0; n * n];
        for i in 0..n {
            for o in i + 1..n {
                f[i * n + o] = 0.01;
            }
        }
        r.set_matrix(f);
        for o in 1..n {
            let (a, b) = r.cell_bounds(o);
            let lo = 0.5 * (a + b);
            let total = r.sigma_se(lo);
            for k in 0..=64 {
                let u = k as f32 / 64.0;
                let s = r.sample_input(lo, 0.5, u).unwrap();
                assert!(!s.kept);
                let i = r.cell(s.lambda_i).unwrap();
                assert!(
                    i < o && s.lambda_i < b,
                    "λi {} not below cell {o}",
                    s.lambda_i
                );
                assert_eq!(s.value, r.f(s.lambda_i, lo));
                assert_eq!(s.pdf, r.pdf_input(s.lambda_i, lo, false));
                assert!((s.value / s.pdf - total).abs() <= 1e-5 * total);
            }
        }
    }

    #[test]
    fn diagonal_tabulated_spectrum_is_accepted() {
        let t = Tabulated::new(vec![400.0, 700.0], vec![0.2, 0.8]).unwrap();
        let r = Reradiation::diagonal_only(Spectrum::Tabulated(t));
        assert!((r.d(550.0) - 0.5).abs() < 1e-6);
        assert_eq!(r.d(380.0), 0.0);
        assert!(r.sample_input(380.0, 0.3, 0.3).is_none());
    }
}
