//! `stokes convert-bispectral`: a measured re-radiation matrix (BFC or CSV) written in the
//! project's CSV format (`fluoro` module docs), so that a measured file can be read,
//! diffed and edited as text, with what its import changed in the header.

use crate::error::{Detail, Error};
use crate::fluoro::{MatrixReport, Reradiation};
use crate::output::{check_outputs, write_atomically};
use crate::Result;
use std::path::Path;

/// Converts `input` to the CSV file `output`; returns what the import changed.
pub fn convert_bispectral(input: &Path, output: &Path) -> Result<MatrixReport> {
    let is_csv = output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    if !is_csv {
        return Err(Error::option(
            &format!("-o {}", output.display()),
            Detail::expected(
                "a file name ending in .csv (bispectral EXR output is not written yet)",
                format!("{:?}", output.file_name().unwrap_or_default()),
            ),
        ));
    }
    check_outputs(&[("-o", output)])?;
    let (rr, report) = Reradiation::from_file(input)?;
    let comment = format!(
        "re-radiation matrix converted by stokes convert-bispectral from {}\nimport: {report}",
        input.display()
    );
    let text = rr
        .to_csv(&comment)
        .ok_or_else(|| Error::file(input, None, "no re-radiation grid in the file"))?;
    write_atomically(output, |tmp| {
        std::fs::write(tmp, text).map_err(|e| Detail::from(format!("cannot write: {e}")))
    })?;
    Ok(report)
}
