//! Bad scenes give one clear message naming the file and the key or line, exit non-zero,
//! never panic, and leave no output file.

mod common;
use common::*;

const GOOD: &str = r#"
[camera]
position = [0, 0, -3]
look_at = [0, 0, 0]
fov = 40
resolution = [8, 8]

[materials.white]
type = "diffuse"
reflectance = 0.5

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
stacks = 8
material = "white"

[[shapes]]
type = "quad"
origin = [-1, 2, -1]
edge_u = [2, 0, 0]
edge_v = [0, 0, 2]
emission = { radiance = 1.0 }
"#;

/// Renders `scene_text` (written to `name`) and returns (success, stderr, output exists).
fn render_text(name: &str, scene_text: &str, extra: &[&str]) -> (bool, String, bool) {
    let dir = scratch(name);
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(&scene, scene_text).unwrap();
    let out = dir.join("out.exr");
    let (ok, _, err) = run(stokes()
        .args(["render", &s(&scene), "-o", &s(&out), "--spp", "1"])
        .args(extra));
    (ok, err, out.exists())
}

fn expect_error(name: &str, scene_text: &str, fragments: &[&str]) {
    let (ok, err, out) = render_text(name, scene_text, &[]);
    assert!(!ok, "{name}: a bad scene rendered");
    assert!(!out, "{name}: an output file was written");
    assert!(
        !err.contains("panicked") && !err.contains("RUST_BACKTRACE"),
        "{name}: panic: {err}"
    );
    assert_eq!(
        err.trim().lines().count(),
        1,
        "{name}: expected one line, got {err}"
    );
    for f in fragments {
        assert!(err.contains(f), "{name}: message lacks {f:?}: {err}");
    }
}

#[test]
fn a_good_scene_renders() {
    let (ok, err, out) = render_text("good", GOOD, &[]);
    assert!(ok && out, "{err}");
}

#[test]
fn missing_scene_file() {
    let (ok, _, err) =
        run(stokes().args(["render", "/nonexistent/scene.toml", "-o", "/tmp/never.exr"]));
    assert!(!ok);
    assert!(
        err.contains("/nonexistent/scene.toml") && err.contains("cannot read"),
        "{err}"
    );
}

#[test]
fn unknown_key_names_key_and_line() {
    let bad = GOOD.replace("fov = 40", "fov = 40\nzoom = 2");
    expect_error(
        "unknown",
        &bad,
        &["unknown.toml:6:1:", "unknown field `zoom`"],
    );
}

#[test]
fn toml_syntax_error_names_the_line() {
    let bad = GOOD.replace("radius = 1", "radius = = 1");
    expect_error("syntax", &bad, &["syntax.toml:15:"]);
}

#[test]
fn wrong_type_names_the_key() {
    let bad = GOOD.replace("radius = 1", "radius = \"big\"");
    expect_error("wrongtype", &bad, &["wrongtype.toml", "radius"]);
}

#[test]
fn negative_radiance() {
    let bad = GOOD.replace("radiance = 1.0", "radiance = -1.0");
    expect_error(
        "negative",
        &bad,
        &[
            "negative.toml",
            "shapes[1].emission.radiance",
            "non-negative radiance",
        ],
    );
}

#[test]
fn reflectance_above_one() {
    let bad = GOOD.replace("reflectance = 0.5", "reflectance = 1.5");
    expect_error(
        "albedo",
        &bad,
        &["albedo.toml", "materials.white.reflectance", "[0, 1]"],
    );
}

#[test]
fn malformed_spectra() {
    let unsorted = GOOD.replace(
        "reflectance = 0.5",
        "reflectance = { wavelengths = [400, 600, 500], values = [0.1, 0.2, 0.3] }",
    );
    expect_error(
        "unsorted",
        &unsorted,
        &["unsorted.toml", "materials.white.reflectance", "increasing"],
    );
    let two_kinds = GOOD.replace(
        "reflectance = 0.5",
        "reflectance = { constant = 0.5, blackbody = 3000 }",
    );
    expect_error(
        "twokinds",
        &two_kinds,
        &["materials.white.reflectance", "exactly one of"],
    );
    let unknown_name = GOOD.replace("reflectance = 0.5", "reflectance = \"chartreuse\"");
    expect_error(
        "noname",
        &unknown_name,
        &["materials.white.reflectance", "chartreuse"],
    );
}

#[test]
fn malformed_csv_names_file_and_line() {
    let dir = scratch("csvdir");
    std::fs::write(
        dir.join("refl.csv"),
        "nm,value\n400,0.1\n500,zero\n600,0.3\n",
    )
    .unwrap();
    let scene = dir.join("csv.toml");
    std::fs::write(
        &scene,
        GOOD.replace("reflectance = 0.5", "reflectance = { csv = \"refl.csv\" }"),
    )
    .unwrap();
    let out = dir.join("out.exr");
    let (ok, _, err) = run(stokes().args(["render", &s(&scene), "-o", &s(&out)]));
    assert!(!ok && !out.exists());
    assert!(err.contains("refl.csv:3"), "{err}");
}

#[test]
fn missing_and_malformed_obj() {
    let dir = scratch("objdir");
    let text = GOOD.replace(
        "type = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nstacks = 8",
        "type = \"obj\"\nfile = \"mesh.obj\"",
    );
    let scene = dir.join("obj.toml");
    std::fs::write(&scene, &text).unwrap();
    let out = dir.join("out.exr");
    let (ok, _, err) = run(stokes().args(["render", &s(&scene), "-o", &s(&out)]));
    assert!(!ok && !out.exists());
    assert!(
        err.contains("mesh.obj") && err.contains("shapes[0].file"),
        "{err}"
    );
    std::fs::write(dir.join("mesh.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
    let (ok, _, err) = run(stokes().args(["render", &s(&scene), "-o", &s(&out)]));
    assert!(!ok && !out.exists());
    assert!(
        err.contains("mesh.obj:4") && err.contains("out of range"),
        "{err}"
    );
}

#[test]
fn unknown_material_and_shape_type() {
    let bad = GOOD.replace("material = \"white\"", "material = \"grey\"");
    expect_error("nomat", &bad, &["shapes[0].material", "grey", "white"]);
    let bad = GOOD.replace("type = \"sphere\"", "type = \"torus\"");
    expect_error("torus", &bad, &["shapes[0].type", "torus"]);
}

#[test]
fn bad_command_line_values() {
    let (ok, err, _) = render_text("badres", GOOD, &["--res", "0x5"]);
    assert!(!ok, "{err}");
    assert!(err.contains("--res"), "{err}");
}
