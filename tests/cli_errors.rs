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

/// The files left in `dir` (recursively), for "nothing was written" checks.
fn files_in(dir: &std::path::Path) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(files_in(&p));
        } else {
            out.push(s(&p));
        }
    }
    out.sort();
    out
}

/// Every output path (image, PNG, variance, stats JSON) is checked before rendering: a
/// path that cannot be written fails at once, naming the option and the path, and
/// nothing is written (no partial outputs, no probe files, no directories).
#[test]
fn unwritable_outputs_fail_before_rendering() {
    let dir = scratch("outputs");
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, GOOD).unwrap();
    let sub = dir.join("a-directory");
    std::fs::create_dir(&sub).unwrap();
    let ok_out = dir.join("new/dirs/img.exr");
    let (d, f) = (s(&sub), s(&scene));
    let cases: Vec<(Vec<String>, [&str; 2])> = vec![
        (vec!["-o".into(), d.clone()], ["-o", "found a directory"]),
        (
            vec!["-o".into(), format!("{d}/")],
            ["-o", "expected a file name"],
        ),
        (
            vec!["-o".into(), format!("{f}/img.exr")],
            ["scene.toml, found a file", "-o"],
        ),
        (
            vec!["-o".into(), s(&ok_out), "--stats-json".into(), d.clone()],
            ["--stats-json", "found a directory"],
        ),
        (
            vec!["-o".into(), s(&dir.join("x.png")), "--png".into()],
            ["-o", "a file name ending in .exr"],
        ),
        (
            vec![
                "-o".into(),
                s(&dir.join("x.exr")),
                "--png".into(),
                "--stats-json".into(),
                s(&dir.join("x.png")),
            ],
            ["--stats-json", "the file --png writes"],
        ),
        (
            vec![
                "-o".into(),
                s(&ok_out),
                "--stats-json".into(),
                s(&dir.join("new/dirs/img.variance.exr")),
                "--variance".into(),
            ],
            ["--stats-json", "the file --variance writes"],
        ),
    ];
    for (args, fragments) in cases {
        let (ok, _, err) = run(stokes()
            .args(["render", &f, "--spp", "1", "--res", "8x8"])
            .args(&args));
        assert!(!ok, "{args:?}: rendered");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(!err.contains("pass 1"), "{args:?}: rendered first: {err}");
        for fr in fragments {
            assert!(err.contains(fr), "{args:?}: lacks {fr:?}: {err}");
        }
        assert_eq!(files_in(&dir), vec![f.clone()], "{args:?}: left files");
        assert!(!dir.join("new").exists(), "{args:?}: created directories");
    }
    // The same outputs in a writable place are written (directories created).
    let (ok, _, err) = run(stokes()
        .args([
            "render",
            &f,
            "--spp",
            "1",
            "--res",
            "8x8",
            "-o",
            &s(&ok_out),
        ])
        .args([
            "--png",
            "--variance",
            "--stats-json",
            &s(&dir.join("s.json")),
        ]));
    assert!(ok, "{err}");
    for p in [
        "new/dirs/img.exr",
        "new/dirs/img.png",
        "new/dirs/img.variance.exr",
        "s.json",
    ] {
        assert!(dir.join(p).exists(), "{p} missing");
    }
}

/// `stokes reference -o`, `stokes converge --out` and `stokes merge -o` check their
/// outputs before the work too.
#[test]
fn unwritable_outputs_of_reference_converge_and_merge() {
    let dir = scratch("outputs2");
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, GOOD).unwrap();
    let f = s(&scene);
    let reference = dir.join("ref.exr");
    let (ok, _, err) = run(stokes().args(["reference", &f, "--spp", "2", "-o", &s(&reference)]));
    assert!(ok, "{err}");
    let sub = dir.join("taken");
    std::fs::create_dir_all(sub.join("convergence.csv")).unwrap();
    std::fs::create_dir_all(sub.join("m.variance.exr")).unwrap();
    let before = files_in(&dir);
    let r = s(&reference);
    let cases: Vec<(Vec<String>, [&str; 2])> = vec![
        (
            vec![
                "reference".into(),
                f.clone(),
                "--spp".into(),
                "1".into(),
                "-o".into(),
                s(&sub),
            ],
            ["-o", "found a directory"],
        ),
        (
            vec![
                "reference".into(),
                f.clone(),
                "--spp".into(),
                "1".into(),
                "-o".into(),
                format!("{f}/r.exr"),
            ],
            ["-o", "found a file"],
        ),
        (
            vec![
                "converge".into(),
                f.clone(),
                "--reference".into(),
                r.clone(),
                "--budget".into(),
                "0.1".into(),
                "--out".into(),
                s(&sub),
            ],
            [
                "--out",
                "convergence.csv: expected a file to write, found a directory",
            ],
        ),
        (
            vec![
                "converge".into(),
                f.clone(),
                "--reference".into(),
                r.clone(),
                "--budget".into(),
                "0.1".into(),
                "--out".into(),
                f.clone(),
            ],
            ["--out", "found a file"],
        ),
        (
            vec!["merge".into(), r.clone(), "-o".into(), s(&sub)],
            ["-o", "found a directory"],
        ),
        (
            vec![
                "merge".into(),
                r.clone(),
                "-o".into(),
                s(&sub.join("m.exr")),
                "--variance".into(),
            ],
            ["--variance", "m.variance.exr: expected a file to write"],
        ),
    ];
    for (args, fragments) in cases {
        let (ok, _, err) = run(stokes().args(&args));
        assert!(!ok, "{args:?}: succeeded");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(
            !err.contains("pass 1") && !err.contains("[1/"),
            "{args:?}: worked first: {err}"
        );
        for fr in fragments {
            assert!(err.contains(fr), "{args:?}: lacks {fr:?}: {err}");
        }
        assert_eq!(files_in(&dir), before, "{args:?}: left files");
    }
}

#[test]
fn bad_spectral_bins_name_the_option() {
    for (extra, fragments) in [
        (
            &["--spectral-bins", "0"][..],
            &["--spectral-bins", "1 to 470 bins", "found 0"][..],
        ),
        (
            &["--spectral-bins", "8", "--spectral-range", "300:830"],
            &["--spectral-range", "inside 360:830", "found 300:830"],
        ),
        (
            &["--spectral-bins", "8", "--spectral-range", "400-700"],
            &["--spectral-range", "LO:HI"],
        ),
        (&["--spectral-range", "400:700"], &["--spectral-bins"]),
    ] {
        let (ok, err, out) = render_text("spectral-bins", GOOD, extra);
        assert!(!ok && !out, "{extra:?} rendered");
        assert!(!err.contains("panicked"), "{err}");
        for f in fragments {
            assert!(err.contains(f), "{extra:?}: message lacks {f:?}: {err}");
        }
    }
    // And a good one writes the layout's channels beside R, G, B.
    let dir = scratch("spectral-bins-good");
    let scene = dir.join("good.toml");
    std::fs::write(&scene, GOOD).unwrap();
    let out = dir.join("out.exr");
    let (ok, _, err) = run(stokes().args([
        "render",
        &s(&scene),
        "-o",
        &s(&out),
        "--spp",
        "2",
        "--spectral-bins",
        "4",
        "--spectral-range",
        "400:800",
        "--variance",
    ]));
    assert!(ok, "{err}");
    for path in [out.clone(), stokes::output::variance_path(&out)] {
        let names: Vec<String> = stokes::output::Channels::read(&path)
            .unwrap()
            .planes
            .into_iter()
            .map(|p| p.name)
            .collect();
        assert_eq!(
            names,
            [
                "B",
                "G",
                "R",
                "S0.450,000000nm",
                "S0.550,000000nm",
                "S0.650,000000nm",
                "S0.750,000000nm"
            ],
            "{}",
            path.display()
        );
    }
}
