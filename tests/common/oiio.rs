//! Image checks through OpenImageIO's command-line tools.
//!
//! [`z_diff`] forms the per-pixel Z image (test − reference)/√(var_test + var_ref) with
//! `oiiotool`, then asks `idiff` whether more than `fail_percent` % of its pixels exceed
//! `z_fail` standard errors, or any exceeds `z_hard`. Thresholds thus follow each pixel's
//! own noise, as measured by the stored variance images. On failure the Z image stays
//! next to the test output as `<test>.zdiff.exr`.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Thresholds of a Z-image check.
#[derive(Debug, Clone, Copy)]
pub struct ZThresholds {
    /// A pixel "fails" beyond this many standard errors.
    pub z_fail: f64,
    /// Allowed share of failing pixels, in percent.
    pub fail_percent: f64,
    /// Any single pixel beyond this fails the check.
    pub z_hard: f64,
}

impl Default for ZThresholds {
    fn default() -> Self {
        ZThresholds {
            z_fail: 4.0,
            fail_percent: 1.0,
            z_hard: 30.0,
        }
    }
}

fn oiiotool(args: &[&str]) -> Result<String, String> {
    let out = Command::new("oiiotool")
        .args(args)
        .output()
        .map_err(|e| format!("cannot run oiiotool (apt-get install openimageio-tools): {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "oiiotool {args:?} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// `oiiotool --stats` of an image, as text.
pub fn stats(img: &Path) -> Result<String, String> {
    oiiotool(&["--stats", "-v", &img.display().to_string()])
}

/// Compares `test` against `reference` using both variance images. `Ok` when idiff passes.
pub fn z_diff(
    test: &Path,
    test_var: &Path,
    reference: &Path,
    ref_var: &Path,
    t: ZThresholds,
) -> Result<(), String> {
    let z: PathBuf = test.with_extension("zdiff.exr");
    let zero: PathBuf = test.with_extension("zero.exr");
    let p = |x: &Path| x.display().to_string();
    oiiotool(&[
        &p(test),
        &p(reference),
        "--sub",
        &p(test_var),
        &p(ref_var),
        "--add",
        "--addc",
        "1e-20",
        "--powc",
        "0.5",
        "--div",
        "-o",
        &p(&z),
    ])?;
    oiiotool(&[&p(&z), "--mulc", "0", "-o", &p(&zero)])?;
    let out = Command::new("idiff")
        .args([
            "-fail",
            &t.z_fail.to_string(),
            "-failpercent",
            &t.fail_percent.to_string(),
            "-hardfail",
            &t.z_hard.to_string(),
            "-warn",
            &t.z_fail.to_string(),
            "-warnpercent",
            &t.fail_percent.to_string(),
            &p(&z),
            &p(&zero),
        ])
        .output()
        .map_err(|e| format!("cannot run idiff (apt-get install openimageio-tools): {e}"))?;
    let _ = std::fs::remove_file(&zero);
    // idiff: 0 pass, 1 warn, 2 fail (and more for errors).
    match out.status.code() {
        Some(0) => {
            let _ = std::fs::remove_file(&z);
            Ok(())
        }
        code => Err(format!(
            "idiff exit {code:?}; Z image kept at {}:\n{}",
            z.display(),
            String::from_utf8_lossy(&out.stdout)
        )),
    }
}
