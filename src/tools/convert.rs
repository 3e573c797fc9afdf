//! `stokes convert-bispectral`: a measured re-radiation matrix (BFC, CSV or bispectral
//! EXR) written in the project's CSV format (`fluoro` module docs), so that a measured
//! file can be read, diffed and edited as text, with what its import changed in the
//! header; or as a bispectral OpenEXR image (`fluoro::exr`) for other spectral tools.

use crate::error::{Detail, Error};
use crate::fluoro::{MatrixReport, Reradiation};
use crate::output::{check_outputs, write_atomically};
use crate::Result;
use std::path::Path;

/// The formats `convert-bispectral` writes, by the output's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Csv,
    Exr,
}

/// Converts `input` to `output`, a CSV or bispectral EXR file by its extension; returns
/// what the import changed.
pub fn convert_bispectral(input: &Path, output: &Path) -> Result<MatrixReport> {
    let ext = output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let format = match ext.as_deref() {
        Some("csv") => Format::Csv,
        Some("exr") => Format::Exr,
        _ => return Err(Error::option(
            &format!("-o {}", output.display()),
            Detail::expected(
                "a file name ending in .csv or .exr (a CSV matrix or a bispectral OpenEXR image)",
                format!("{:?}", output.file_name().unwrap_or_default()),
            ),
        )),
    };
    check_outputs(&[("-o", output)])?;
    let (rr, report) = Reradiation::from_file(input)?;
    let no_grid = || Error::file(input, None, "no re-radiation grid in the file");
    if rr.cells() == 0 {
        return Err(no_grid());
    }
    match format {
        Format::Csv => {
            let comment = format!(
                "re-radiation matrix converted by stokes convert-bispectral from {}\nimport: {report}",
                input.display()
            );
            let text = rr.to_csv(&comment).ok_or_else(no_grid)?;
            write_atomically(output, |tmp| {
                std::fs::write(tmp, text).map_err(|e| Detail::from(format!("cannot write: {e}")))
            })?;
        }
        Format::Exr => {
            let metadata = [
                ("source".to_string(), input.display().to_string()),
                ("import".to_string(), report.to_string()),
            ];
            rr.to_exr(output, &metadata)?;
        }
    }
    Ok(report)
}
