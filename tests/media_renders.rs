//! Participating media in renders: the three tracking methods agree where they must,
//! single scattering in a thin fluorescent slab matches a numerical quadrature (and
//! classic tracking measurably misses it), and extreme media stay finite.

mod common;
use common::*;
use glam::Vec4;
use stokes::integrator::render::Film;
use stokes::integrator::{radiance, PathOptions, PathStats};
use stokes::medium::Tracking;
use stokes::method::{Method, Shifting, Spectral};
use stokes::sampler::{LazyStream, Streams};
use stokes::scene::Scene;

fn render_with(
    scene: &mut Scene,
    res: u32,
    spp: u32,
    seed: u64,
    spectral: Spectral,
    tracking: Tracking,
    max_depth: i32,
) -> Film {
    let method = Method {
        spectral,
        tracking: Some(tracking),
        ..Method::default()
    };
    TestRender::at(res, res)
        .spp(spp)
        .seed(seed)
        .max_depth(max_depth)
        .method(method)
        .film(scene)
}

#[test]
fn the_default_tracking_depends_on_the_scene() {
    // Classic where no medium fluoresces (unbiased and cheapest there), fluorescence-aware
    // where one does; a tracking asked for is kept.
    let plain = scene_from(&room_with_medium("sigma_s = 0.5", None));
    let dyed = scene_from(&room_with_medium(
        "sigma_s = 0.1\ndye = { absorption = { narrow_band = 440, fwhm = 40 }, emission = { narrow_band = 520, fwhm = 40 }, quantum_yield = 0.9 }",
        None,
    ));
    let open = Method::default();
    assert_eq!(open.resolve(&plain).tracking, Tracking::Classic);
    assert_eq!(open.resolve(&dyed).tracking, Tracking::FluoAware);
    let max = Method {
        tracking: Some(Tracking::Max),
        ..open
    };
    assert_eq!(max.resolve(&plain).tracking, Tracking::Max);
    assert_eq!(max.resolve(&dyed).tracking, Tracking::Max);
}

/// A box of medium `medium` (TOML body of [media.m]) in a grey room under a quad light.
fn room_with_medium(medium: &str, boundary_material: Option<&str>) -> String {
    let (mat_def, mat_ref) = match boundary_material {
        Some(m) => (
            format!("[materials.boundary]\n{m}\n"),
            "material = \"boundary\"\n".to_string(),
        ),
        None => (String::new(), String::new()),
    };
    format!(
        r#"
[camera]
position = [0, 1, -3.5]
look_at = [0, 0.8, 0]
fov = 45
resolution = [24, 24]

[media.m]
{medium}

[materials.grey]
type = "diffuse"
reflectance = {{ wavelengths = [360, 500, 600, 830], values = [0.6, 0.4, 0.7, 0.5] }}
{mat_def}
[[shapes]]
type = "box"
min = [-2, 0, -4]
max = [2, 3, 2]
material = "grey"

[[shapes]]
type = "box"
min = [-0.7, 0.01, -0.7]
max = [0.7, 1.5, 0.7]
interior = "m"
{mat_ref}
[[shapes]]
type = "quad"
origin = [-0.5, 2.99, -0.5]
edge_u = [1, 0, 0]
edge_v = [0, 0, 1]
emission = {{ radiance = "D65", scale = 0.3 }}
"#
    )
}

const SCATTERING: &str = r#"sigma_a = { wavelengths = [360, 830], values = [0.1, 0.4] }
sigma_s = { wavelengths = [360, 550, 830], values = [1.5, 0.8, 0.3] }
g = 0.3"#;

#[test]
fn tracking_methods_and_lane_counts_agree_in_a_non_fluorescent_medium() {
    for boundary in [None, Some("type = \"dielectric\"\nior = 1.33")] {
        let mut scene = scene_from(&room_with_medium(SCATTERING, boundary));
        let runs = [
            (
                "classic",
                render_with(
                    &mut scene,
                    24,
                    128,
                    1,
                    Spectral::Hwss,
                    Tracking::Classic,
                    -1,
                ),
            ),
            (
                "max",
                render_with(&mut scene, 24, 128, 2, Spectral::Hwss, Tracking::Max, -1),
            ),
            (
                "fluo-aware",
                render_with(
                    &mut scene,
                    24,
                    128,
                    3,
                    Spectral::Hwss,
                    Tracking::FluoAware,
                    -1,
                ),
            ),
            (
                "mono classic",
                render_with(
                    &mut scene,
                    24,
                    512,
                    4,
                    Spectral::Mono,
                    Tracking::Classic,
                    -1,
                ),
            ),
        ];
        // The medium block's image region and the whole image.
        let block: Vec<usize> = (0..24 * 24usize)
            .filter(|i| (i % 24).abs_diff(12) < 5 && (i / 24) >= 10 && (i / 24) < 20)
            .collect();
        let regions = [("block", block), ("image", all_pixels(&runs[0].1))];
        assert_all_agree(&format!("{boundary:?}"), &runs, &regions, 4.0);
    }
}

#[test]
fn a_dense_medium_darkens_and_the_medium_is_seen() {
    // The test above could pass with media ignored; this one cannot: a dense absorbing
    // block is much darker than the empty room there.
    let absorbing = "sigma_a = 8.0\nsigma_s = 0.0";
    let mut with = scene_from(&room_with_medium(absorbing, None));
    let mut without = scene_from(&room_with_medium("sigma_a = 0.0\nsigma_s = 0.0", None));
    let a = render_with(&mut with, 24, 32, 1, Spectral::Hwss, Tracking::Classic, -1);
    let b = render_with(
        &mut without,
        24,
        32,
        1,
        Spectral::Hwss,
        Tracking::Classic,
        -1,
    );
    let block: Vec<usize> = (0..24 * 24usize)
        .filter(|i| (i % 24).abs_diff(12) < 4 && (i / 24) >= 12 && (i / 24) < 18)
        .collect();
    let (ma, _) = region_mean(&a, &block);
    let (mb, _) = region_mean(&b, &block);
    assert!(
        ma[1] < 0.3 * mb[1],
        "dense block {} vs empty {}",
        ma[1],
        mb[1]
    );
}

/// A wide, thin slab of exclusively fluorescent medium (thickness `d`, σ_dye peak
/// `sigma_peak`) inside a black box whose walls emit a 440 nm band from both sides.
fn slab_scene(d: f32, sigma_peak: f32) -> String {
    format!(
        r#"
[camera]
position = [0, 0, -5]
look_at = [0, 0, 0]
fov = 10
resolution = [8, 8]

[media.dye]
dye = {{ absorption = {{ wavelengths = [400, 440, 480], values = [0, 1, 0] }}, concentration = {sigma_peak}, emission = {{ wavelengths = [490, 520, 560], values = [0, 1, 0] }}, quantum_yield = 0.9, cell_nm = 1 }}

[[shapes]]
type = "box"
min = [-40, -40, {z0}]
max = [40, 40, {z1}]
interior = "dye"

[[shapes]]
type = "box"
min = [-60, -60, -60]
max = [60, 60, 60]
emission = {{ radiance = {{ narrow_band = 440, fwhm = 16 }}, scale = 50, two_sided = true }}
"#,
        z0 = -d / 2.0,
        z1 = d / 2.0
    )
}

/// E₂(x) = ∫₀¹ e^{−x/μ} dμ by the midpoint rule.
fn e2(x: f64) -> f64 {
    let n = 400;
    (0..n)
        .map(|i| (-(x) / ((i as f64 + 0.5) / n as f64)).exp())
        .sum::<f64>()
        / n as f64
}

/// Single scattering seen through the slab at λo: the background L(λo) plus
/// ∫₀^d ∫ F(λi, λo) L(λi) ½[E₂(σ(λi) z) + E₂(σ(λi)(d − z))] dλi dz, with σ̂_t(λo) = 0.
fn quadrature(scene: &Scene, lambda_o: f32, d: f64) -> f64 {
    let med = &scene.media[0];
    let light = stokes::spectrum::Spectrum::NarrowBand {
        centre: 440.0,
        fwhm: 16.0,
    };
    let (nz, h) = (64, 0.25f32);
    let mut total = 0.0;
    let mut li = 400.0 + h / 2.0;
    while li < 480.0 {
        let lam = Vec4::splat(li);
        let sigma = med.sigma_t_hat(lam).x as f64;
        let f = med.shift_value(li, lambda_o, false) as f64;
        let l_in = 50.0 * light.eval(li) as f64;
        if f > 0.0 && l_in > 0.0 {
            let mut zi = 0.0;
            for k in 0..nz {
                let z = (k as f64 + 0.5) / nz as f64 * d;
                zi += 0.5 * (e2(sigma * z) + e2(sigma * (d - z))) * d / nz as f64;
            }
            total += f * l_in * zi * h as f64;
        }
        li += h;
    }
    50.0 * light.eval(lambda_o) as f64 + total
}

fn estimate(scene: &Scene, lambda_o: f32, tracking: Tracking, n: u64) -> (f64, f64) {
    let ray = scene.camera.ray(4.0, 4.0);
    let opts = PathOptions {
        method: Method {
            spectral: Spectral::Mono,
            ..Method::default()
        }
        .with_tracking(tracking),
        max_depth: 2,
    };
    let (mut s, mut q) = (0.0f64, 0.0f64);
    let mut stats = PathStats::default();
    for i in 0..n {
        let rng = Streams::for_sample(17, lambda_o as u64, i);
        let shift = LazyStream::new(17, lambda_o as u64, i);
        let v = radiance(
            scene,
            ray,
            Vec4::splat(lambda_o),
            &opts,
            rng,
            shift,
            &mut stats,
        )
        .x as f64;
        assert!(v.is_finite());
        s += v;
        q += v * v;
    }
    let m = s / n as f64;
    (m, ((q / n as f64 - m * m) / (n as f64 - 1.0)).sqrt())
}

#[test]
fn single_scattering_in_a_thin_fluorescent_slab_matches_quadrature_and_classic_is_biased() {
    let d = 0.1;
    let scene = scene_from(&slab_scene(d as f32, 3.0));
    for lambda_o in [510.0f32, 525.0] {
        let want = quadrature(&scene, lambda_o, d);
        assert!(want > 0.0);
        for tracking in [Tracking::Max, Tracking::FluoAware] {
            let (m, se) = estimate(&scene, lambda_o, tracking, 200_000);
            let z = (m - want) / se;
            eprintln!(
                "λo {lambda_o} {tracking:?}: {m:.5} ± {se:.5} vs quadrature {want:.5}, z = {z:.2}"
            );
            assert!(
                z.abs() < 4.0,
                "{tracking:?} at {lambda_o} nm: {m} vs {want} (z = {z:.2})"
            );
        }
        let (m, se) = estimate(&scene, lambda_o, Tracking::Classic, 200_000);
        let z = (m - want) / se.max(1e-9);
        eprintln!("λo {lambda_o} Classic: {m:.5} ± {se:.5} vs quadrature {want:.5}, z = {z:.2}");
        assert!(
            z < -5.0,
            "classic tracking should miss the re-emission: z = {z:.2}"
        );
    }
}

#[test]
fn extreme_media_stay_finite() {
    for (d, sigma) in [(0.1f32, 1000.0f32), (0.1, 1e-3), (2.0, 50.0)] {
        // σ̂_t d = 100, σ̂_t d = 1e-4, and a thick slab; all three methods, both modes.
        let mut scene = scene_from(&slab_scene(d, sigma));
        for tracking in [Tracking::Classic, Tracking::Max, Tracking::FluoAware] {
            for spectral in [Spectral::Hwss, Spectral::Mono] {
                let f = render_with(&mut scene, 8, 16, 5, spectral, tracking, -1);
                let worst = f
                    .mean()
                    .iter()
                    .flat_map(|p| p.iter().copied())
                    .fold(0.0f32, |a, v| a.max(v.abs()));
                assert!(
                    worst.is_finite() && worst < 1e4,
                    "{d} {sigma} {tracking:?} {spectral:?}: {worst}"
                );
            }
        }
    }
    // A scattering medium where σ̂_s > σ̂_t in the emission band (dye plus elastic scattering).
    let mut scene = scene_from(&room_with_medium(
        "sigma_s = 0.5\ndye = { absorption = { narrow_band = 450, fwhm = 40, scale = 40 }, emission = { narrow_band = 530, fwhm = 30 }, quantum_yield = 0.9 }",
        None,
    ));
    for tracking in [Tracking::Classic, Tracking::Max, Tracking::FluoAware] {
        let f = render_with(&mut scene, 12, 16, 6, Spectral::Hwss, tracking, -1);
        assert!(f.mean().iter().all(|p| p.iter().all(|v| v.is_finite())));
    }
}

/// The camera and a white emitting quad 3 units ahead, both inside a large box of the
/// medium `ink` (`sigma_a` its absorption, a spectrum).
fn ink_room(sigma_a: &str) -> String {
    format!(
        r#"
[camera]
position = [0, 0, -2]
look_at = [0, 0, 0]
fov = 10
resolution = [8, 8]
medium = "ink"

[media.ink]
sigma_a = {sigma_a}

[[shapes]]
type = "box"
min = [-10, -10, -10]
max = [10, 10, 10]
interior = "ink"

[[shapes]]
type = "quad"
origin = [1, -1, 1]
edge_u = [-2, 0, 0]
edge_v = [0, 2, 0]
emission = {{ radiance = 1.0 }}
"#
    )
}

#[test]
fn camera_and_light_inside_an_absorbing_medium() {
    // Camera and an emitting quad both inside a large absorbing box: the quad is seen with
    // radiance L·e^{−σ_a D}, D the distance along the central ray.
    let text = ink_room("0.4");
    let text = text.as_str();
    let mut scene = scene_from(text);
    // Classic tracking in a purely absorbing medium is an analogue estimator (a collision
    // ends the path), so the comparison is a Z-test.
    let film = render_with(
        &mut scene,
        8,
        1024,
        1,
        Spectral::Hwss,
        Tracking::Classic,
        -1,
    );
    let centre: Vec<usize> = (0..64usize)
        .filter(|i| (i % 8).abs_diff(4) < 2 && (i / 8).abs_diff(4) < 2)
        .collect();
    let got = region_mean(&film, &centre);
    let white = stokes::color::xyz_to_linear_srgb(stokes::spectrum::spectrum_to_xyz(
        &stokes::spectrum::Spectrum::Constant(1.0),
    ));
    // The central pixels see the quad at distances 3 to 3.0001 (10° field of view).
    let want = white * (-0.4f32 * 3.0).exp();
    assert_agree(
        "camera in ink",
        got,
        (want.to_array().map(|v| v as f64), [0.0; 3]),
        4.0,
    );
    assert!(
        got.1[1] < 0.03 * want[1] as f64,
        "too noisy to decide: {:?}",
        got.1
    );
    // Without the camera's medium the quad is seen unattenuated: the test can fail.
    let mut outside = scene_from(&text.replace("medium = \"ink\"\n", ""));
    let f2 = render_with(
        &mut outside,
        8,
        64,
        1,
        Spectral::Hwss,
        Tracking::Classic,
        -1,
    );
    assert!(region_mean(&f2, &centre).0[1] > 1.5 * want[1] as f64);
}

#[test]
fn lanes_and_shiftings_agree_in_a_fluorescent_medium() {
    // A scattering medium with a dye: HWSS (both shiftings) and mono, under max and
    // fluorescence-aware tracking, estimate the same image.
    let dyed = "sigma_s = 0.3\ng = 0.2\ndye = { absorption = { wavelengths = [360, 420, 470, 520], values = [0.5, 1, 0.6, 0] }, concentration = 1.5, emission = { wavelengths = [480, 520, 560, 640], values = [0, 1, 0.6, 0] }, quantum_yield = 0.9 }";
    let mut scene = scene_from(&room_with_medium(dyed, None));
    let run = |scene: &mut Scene, spp, seed, spectral, shifting, tracking| {
        let method = Method {
            spectral,
            shifting,
            tracking: Some(tracking),
            ..Method::default()
        };
        TestRender::at(24, 24)
            .spp(spp)
            .seed(seed)
            .method(method)
            .film(scene)
    };
    let runs = [
        (
            "hwss independent fluo-aware",
            run(
                &mut scene,
                128,
                1,
                Spectral::Hwss,
                Shifting::Independent,
                Tracking::FluoAware,
            ),
        ),
        (
            "hwss constant fluo-aware",
            run(
                &mut scene,
                128,
                2,
                Spectral::Hwss,
                Shifting::Constant,
                Tracking::FluoAware,
            ),
        ),
        (
            "hwss independent max",
            run(
                &mut scene,
                128,
                3,
                Spectral::Hwss,
                Shifting::Independent,
                Tracking::Max,
            ),
        ),
        (
            "mono fluo-aware",
            run(
                &mut scene,
                512,
                4,
                Spectral::Mono,
                Shifting::Independent,
                Tracking::FluoAware,
            ),
        ),
    ];
    let block: Vec<usize> = (0..24 * 24usize)
        .filter(|i| (i % 24).abs_diff(12) < 5 && (i / 24) >= 10 && (i / 24) < 20)
        .collect();
    let regions = [("block", block), ("image", all_pixels(&runs[0].1))];
    assert_all_agree("fluorescent medium", &runs, &regions, 4.0);
}

/// In a scene with media, shadow rays are traced segment by segment and pass only
/// index-matched (null) boundaries: an opaque plate between a floor and the only light
/// leaves the floor below it black at depth 2 (direct light only), while a medium box
/// (which the shadow rays of the lit floor beside the plate cross) keeps the media code
/// path in use. With every shadow ray let through opaque surfaces, the floor under the
/// plate would be lit as brightly as the rest.
#[test]
fn shadow_rays_in_media_scenes_stop_at_opaque_surfaces() {
    let mut scene = scene_from(
        r#"
[camera]
position = [0, 0.4, -2.5]
look_at = [0, 0, 0]
fov = 50
resolution = [24, 24]

[media.haze]
sigma_a = 0.05
sigma_s = 0.2

[materials.grey]
type = "diffuse"
reflectance = 0.5

[[shapes]]
type = "quad"
origin = [-3, 0, -3]
edge_u = [0, 0, 6]
edge_v = [6, 0, 0]
material = "grey"

[[shapes]]
type = "quad"
origin = [-0.6, 1, -0.6]
edge_u = [1.2, 0, 0]
edge_v = [0, 0, 1.2]
material = "grey"

[[shapes]]
type = "box"
min = [-3, 0.01, 0.8]
max = [3, 0.6, 2.5]
interior = "haze"

[[shapes]]
type = "quad"
origin = [-0.1, 2, -0.1]
edge_u = [0.2, 0, 0]
edge_v = [0, 0, 0.2]
emission = { radiance = "D65", scale = 20 }
"#,
    );
    assert!(scene.has_media());
    let film = TestRender::at(24, 24).spp(16).max_depth(2).film(&mut scene);
    let mean = film.mean();
    let lum = |i: usize| mean[i].iter().sum::<f32>();
    // The floor straight below the plate (image centre, below the horizon of the plate)
    // and the floor in front of it, outside the plate's shadow.
    let (w, h) = (24, 24);
    let shadowed: Vec<usize> = (11..14)
        .flat_map(|y| (10..14).map(move |x| y * w + x))
        .collect();
    let lit: Vec<usize> = (21..h)
        .flat_map(|y| (2..6).map(move |x| y * w + x))
        .collect();
    let dark = shadowed.iter().map(|&i| lum(i)).fold(0.0, f32::max);
    let bright = lit.iter().map(|&i| lum(i)).sum::<f32>() / lit.len() as f32;
    eprintln!("under the plate: max {dark}; beside it: mean {bright}");
    assert!(
        bright > 0.05,
        "the floor beside the plate is lit ({bright})"
    );
    assert_eq!(dark, 0.0, "no direct light through the opaque plate");
}

/// A medium's matrix file with a diagonal (a surface's measurement, say) loads, and the
/// scene warns that the diagonal is not used, naming the key and the file; a clean file
/// gives no warning.
#[test]
fn a_medium_matrix_with_a_diagonal_is_loaded_with_a_warning() {
    let dir = scratch("medium-matrix-diagonal");
    std::fs::create_dir_all(&dir).unwrap();
    // The slab scene with its dye replaced by the matrix `file`.
    let scene_text = |file: &str| {
        slab_scene(1.0, 1.0)
            .lines()
            .map(|l| match l.starts_with("dye = ") {
                true => format!("matrix = {{ file = \"{file}\", scale = 2.0 }}"),
                false => l.to_string(),
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    std::fs::write(
        dir.join("with.csv"),
        "nm,420,470,520\n420,0.3,0.2,0.1\n470,0,0,0.3\n520,0,0,0\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("clean.csv"),
        "nm,420,470,520\n420,0,0.2,0.1\n470,0,0,0.3\n520,0,0,0\n",
    )
    .unwrap();
    let load = |file: &str| {
        Scene::from_str(&scene_text(file), &dir.join("scene.toml"))
            .unwrap_or_else(|e| panic!("{e}"))
    };
    let warned = load("with.csv");
    assert!(warned.has_fluorescent_media());
    // The row sum at 420 nm, 0.2 + 0.1, times the scale 2 per unit.
    let st = warned.media[0].sigma_t_hat(glam::Vec4::splat(420.0)).x;
    assert!((st - 0.6).abs() < 1e-6, "σ̂_t(420) = {st}");
    assert_eq!(warned.warnings.len(), 1, "{:?}", warned.warnings);
    let w = &warned.warnings[0];
    assert!(
        w.contains("media.dye.matrix") && w.contains("with.csv") && w.contains("diagonal"),
        "{w}"
    );
    assert!(load("clean.csv").warnings.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_rgb_medium_attenuates_by_its_upsampled_spectrum() {
    // Where a medium takes a constant it takes an RGB too (upsampled unbounded: a
    // coefficient may exceed 1). Camera and a white emitter inside an absorbing box whose
    // σ_a(λ) is the upsampled colour: the quad is seen with ∫ e^{−σ_a(λ) D} x̄(λ) dλ, D = 3.
    use stokes::spectrum::{RgbSpectrum, Spectrum};
    let rgb = [0.2f32, 0.5, 1.2];
    let text = ink_room(&format!("{{ rgb = [{}, {}, {}] }}", rgb[0], rgb[1], rgb[2]));
    let sigma = Spectrum::Rgb(RgbSpectrum::unbounded(rgb));
    let transmittance = |s: &Spectrum| {
        Spectrum::combine(s, &Spectrum::Constant(3.0), |a, d| (-a * d).exp()).unwrap()
    };
    let expected = |s: &Spectrum| {
        stokes::color::xyz_to_linear_srgb(stokes::spectrum::spectrum_to_xyz(&transmittance(s)))
            .to_array()
            .map(f64::from)
    };
    let want = expected(&sigma);
    // The test can tell: a grey medium of the colour's luminance, or the colour read as an
    // albedo (channels capped at 1), would fail it by a wide margin.
    let grey = expected(&Spectrum::Constant(
        0.2126 * 0.2 + 0.7152 * 0.5 + 0.0722 * 1.2,
    ));
    let capped = expected(&Spectrum::Rgb(RgbSpectrum::albedo([0.2, 0.5, 1.0])));
    let centre: Vec<usize> = (0..64usize)
        .filter(|i| (i % 8).abs_diff(4) < 2 && (i / 8).abs_diff(4) < 2)
        .collect();
    for spectral in [Spectral::Hwss, Spectral::Mono] {
        let mut scene = scene_from(&text);
        let film = render_with(&mut scene, 8, 16384, 3, spectral, Tracking::Classic, -1);
        let got = region_mean(&film, &centre);
        assert_agree(
            &format!("rgb ink, {spectral:?}"),
            got,
            (want, [0.0; 3]),
            4.0,
        );
        for other in [grey, capped] {
            let z = (0..3)
                .map(|c| (got.0[c] - other[c]).abs() / got.1[c])
                .fold(0.0, f64::max);
            assert!(
                z > 8.0,
                "too noisy to tell {want:?} from {other:?}: {got:?}"
            );
        }
    }
}

/// Light seen through a scattering slab: forward scattering (g = 0.8) lets much more of it
/// through towards the camera than back scattering (g = −0.8), with next-event estimation
/// and phase sampling alike. Catches a phase function evaluated or sampled about the
/// wrong direction, which an isotropic medium cannot show.
#[test]
fn forward_scattering_lets_more_light_through_a_slab_than_back_scattering() {
    let slab = |g: f32| {
        format!(
            r#"
[camera]
position = [0, 0, -5]
look_at = [0, 0, 0]
fov = 12
resolution = [12, 12]

[media.fog]
sigma_s = 3.0
g = {g}

[[shapes]]
type = "box"
min = [-20, -20, -0.5]
max = [20, 20, 0.5]
interior = "fog"

[[shapes]]
type = "quad"
origin = [-1, 1, 2]
edge_u = [2, 0, 0]
edge_v = [0, -2, 0]
emission = {{ radiance = 1.0 }}
"#
        )
    };
    let mean = |g: f32| {
        let mut scene = scene_from(&slab(g));
        let film = render_with(&mut scene, 12, 64, 5, Spectral::Hwss, Tracking::Classic, -1);
        let all: Vec<usize> = (0..144).collect();
        region_mean(&film, &all).0[1]
    };
    let (forward, backward) = (mean(0.8), mean(-0.8));
    assert!(
        forward > 2.0 * backward && backward > 0.0,
        "g = 0.8 lets {forward} through, g = -0.8 {backward}"
    );
}
