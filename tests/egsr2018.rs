//! The EGSR 2018 paper's scenes (`scenes/egsr2018/`): every variant loads; the generator
//! reproduces the committed files; the medium absorbs at 440 nm and is clear at 550 nm
//! ("note how the volume turns clear"). Methods that must agree on these scenes, and
//! classic tracking's bias on them, are checked in `tests/image_families.rs`.

mod common;
use common::*;
use stokes::scene::Scene;

/// Every scene file of the directory.
const VARIANTS: [&str; 7] = [
    "main",
    "main-d65-no-volume",
    "main-440nm",
    "main-440nm-no-volume",
    "main-550nm",
    "main-550nm-no-volume",
    "teaser",
];

fn path(name: &str) -> std::path::PathBuf {
    root().join(format!("scenes/egsr2018/{name}.toml"))
}

#[test]
fn every_variant_loads_with_its_medium_and_regions() {
    for name in VARIANTS {
        let scene = Scene::load(&path(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let volume = !name.ends_with("no-volume");
        assert_eq!(scene.camera_medium.is_some(), volume, "{name}");
        assert_eq!(scene.has_fluorescent_media(), volume, "{name}");
        let regions: Vec<&str> = scene.regions.iter().map(|r| r.name.as_str()).collect();
        let expect: &[&str] = if name == "teaser" {
            &["postit-pink", "postit-green", "rear-wall"]
        } else {
            &["rear-wall", "left-wall"]
        };
        assert_eq!(regions, expect, "{name}");
    }
    assert_eq!(
        std::fs::read_dir(root().join("scenes/egsr2018"))
            .unwrap()
            .filter(|e| e
                .as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "toml"))
            .count(),
        VARIANTS.len(),
        "a scene file this test does not know"
    );
}

/// The committed scene is what `scenes/tools/egsr2018.py` writes (when python3 is there).
#[test]
fn the_generator_reproduces_the_committed_scenes() {
    if !have("python3") {
        eprintln!("skipped: no python3");
        return;
    }
    let out = scratch("egsr2018-generator");
    let tool = root().join("scenes/tools/egsr2018.py");
    let (ok, _, err) = run(std::process::Command::new("python3")
        .arg(&tool)
        .env("EGSR2018_OUT", &out));
    assert!(ok, "{err}");
    let mut files = 0;
    for dir in ["", "data"] {
        for e in std::fs::read_dir(out.join(dir)).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                continue;
            }
            let name = p.strip_prefix(&out).unwrap();
            let committed = root().join("scenes/egsr2018").join(name);
            let (a, b) = (
                std::fs::read(&p).unwrap(),
                std::fs::read(&committed).unwrap(),
            );
            assert!(
                a == b,
                "{} differs from the generator's output",
                committed.display()
            );
            files += 1;
        }
    }
    assert_eq!(
        files,
        VARIANTS.len() + 3,
        "scene files and generated data files"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// The rear wall's (seen through six units of medium) mean linear sRGB and its standard
/// errors, for `name` rendered at 32×32, 256 spp.
fn rear_wall(name: &str) -> ([f64; 3], [f64; 3]) {
    let mut scene = Scene::load(&path(name)).unwrap_or_else(|e| panic!("{e}"));
    let film = TestRender::at(32, 32)
        .spp(256)
        .seed(3)
        .threads(1)
        .film(&mut scene);
    let wall = scene
        .regions
        .iter()
        .find(|r| r.name == "rear-wall")
        .unwrap();
    region_mean(&film, &wall.pixels(32, 32))
}

/// CIE Z (mostly the light below 480 nm) of linear sRGB, with a bound on its standard
/// error (the channels' errors added in magnitude, since they are correlated).
fn cie_z((m, se): ([f64; 3], [f64; 3])) -> (f64, f64) {
    let row = [0.0193, 0.1192, 0.9505];
    let z = (0..3).map(|c| row[c] * m[c]).sum();
    let e = (0..3).map(|c| row[c] * se[c]).sum();
    (z, e)
}

/// σ̂_t(440 nm) ≈ 0.75 per unit and σ̂_t(550 nm) = 0 (the medium absorbs 380–460 nm): under
/// the 440 nm lamp the rear wall's Z (its blue) is mostly gone with the medium in place
/// (its light crosses about ten units of it; the green glow that replaces it has little
/// Z), while under the 550 nm lamp the wall's green is the same with and without it.
#[test]
fn the_volume_absorbs_at_440nm_and_turns_clear_at_550nm() {
    let (with, _) = cie_z(rear_wall("main-440nm"));
    let (without, _) = cie_z(rear_wall("main-440nm-no-volume"));
    let t440 = with / without;
    let (g_with, se_with) = rear_wall("main-550nm");
    let (g_without, se_without) = rear_wall("main-550nm-no-volume");
    let (a, b) = (g_with[1], g_without[1]);
    let z = (a - b) / se_with[1].hypot(se_without[1]);
    println!(
        "rear wall with/without the medium: 440 nm lamp, CIE Z ratio {t440:.3}; 550 nm lamp, green {a:.5} / {b:.5} = {:.4} (z = {z:.2})",
        a / b
    );
    assert!(
        t440 < 0.35,
        "the medium should absorb at 440 nm: Z ratio {t440}"
    );
    assert!(
        z.abs() < 4.0 && (a / b - 1.0).abs() < 0.05,
        "the medium should be clear at 550 nm: green {a} with it, {b} without (z = {z})"
    );
}

/// The media are the paper's: main σ̂_t(420 nm) = 1 per unit (0.025 × the emission tent's
/// 40-nm sum), non-zero only on 381–459 nm; σ̂_s(550 nm) = 1, non-zero on 511–589 nm; the
/// teaser's σ̂_t(360 nm) = 0.025 × 80 = 2.
#[test]
fn the_media_have_the_papers_coefficients() {
    use glam::Vec4;
    let main = Scene::load(&path("main")).unwrap();
    let m = &main.media[0];
    let st = |l: f32| m.sigma_t_hat(Vec4::splat(l)).x;
    let ss = |l: f32| m.sigma_s_hat(Vec4::splat(l)).x;
    assert!((st(420.0) - 1.0).abs() < 1e-4, "σ̂_t(420) = {}", st(420.0));
    assert!((ss(550.0) - 1.0).abs() < 1e-4, "σ̂_s(550) = {}", ss(550.0));
    for l in [375.0, 380.2, 459.8, 470.0, 550.0, 600.0] {
        assert_eq!(st(l), 0.0, "σ̂_t({l})");
    }
    for l in [381.0, 459.0] {
        assert!(st(l) > 0.0, "σ̂_t({l})");
    }
    for l in [420.0, 510.2, 589.8, 650.0] {
        assert_eq!(ss(l), 0.0, "σ̂_s({l})");
    }
    let teaser = Scene::load(&path("teaser")).unwrap();
    let t = teaser.media[0].sigma_t_hat(Vec4::splat(360.2)).x;
    assert!((t - 2.0).abs() < 1e-3, "teaser σ̂_t(360) = {t}");
}
