//! Packets against single rays, and wavelength-split paths at dispersive refractions
//! against lane dropping.
//!
//! Width 1 (single rays) and width 4 (packets) are one estimator, written once over the
//! lane width, with every path drawing its own random numbers and every operation the
//! same IEEE arithmetic in every lane: they give the same image bit for bit, but where
//! Embree's packet kernel, given a coherent packet of camera rays, reports the
//! neighbouring triangle for a ray that hits an edge exactly (a few pixels in 10,000 are
//! allowed; the rest must then pass a Z-test).
//!
//! Every width also hands the path the barycentrics of its hits as single rays do (0 for
//! misses), for smooth shading.

mod common;
use common::*;
use glam::Vec4;
use stokes::integrator::render::Film;
use stokes::integrator::trace::{SampleId, Tracer, Width};
use stokes::integrator::{radiance, PathOptions, PathStats};
use stokes::medium::tracking::Tracking;
use stokes::method::{Axis, Dispersion, Layout, Method, Rays};
use stokes::sampler::{LazyStream, Streams};
use stokes::scene::Scene;
use stokes::simd::{F4, F8};
use stokes::spectrum::{SampledWavelengths, Wavelengths};

fn opts(w: u32, h: u32, spp: u32, rays: Rays, dispersion: Dispersion) -> TestRender {
    TestRender::at(w, h)
        .spp(spp)
        .seed(11)
        .rays(rays)
        .dispersion(dispersion)
}

/// How many pixels differ between two films, after checking the sample counts match.
fn differing_pixels(a: &Film, b: &Film) -> usize {
    assert_eq!((a.width, a.height, a.spp), (b.width, b.height, b.spp));
    a.mean()
        .iter()
        .zip(b.mean())
        .filter(|(x, y)| **x != *y)
        .count()
}

/// Renders `scene` in every ray mode and layout and checks the images are the same
/// estimate.
fn modes_agree(name: &str, scene: &mut Scene, w: u32, h: u32, spp: u32, dispersion: Dispersion) {
    let single = opts(w, h, spp, Rays::Single, dispersion).film(scene);
    let (m, _) = region_mean(&single, &all_pixels(&single));
    assert!(m.iter().sum::<f64>() > 1e-4, "{name}: the image is black");
    for rays in [Rays::Packet, Rays::Packet8, Rays::Lockstep] {
        for layout in Layout::VALUES {
            let film = opts(w, h, spp, rays, dispersion)
                .layout(*layout)
                .film(scene);
            let diff = differing_pixels(&single, &film);
            let mode = format!("{} {}", rays.name(), layout.name());
            eprintln!("{name}: {mode} vs single: {diff} pixels differ");
            assert!(
                diff * 10_000 <= 3 * (w * h) as usize,
                "{name}: {mode} differs from single rays in {diff} of {} pixels",
                w * h
            );
            let all = all_pixels(&film);
            assert_agree(
                &format!("{name}: {mode} vs single"),
                region_mean(&film, &all),
                region_mean(&single, &all),
                4.0,
            );
        }
    }
}

#[test]
fn packet_and_single_rays_give_the_same_image() {
    // No media: shadow rays go out in packets. Odd sizes: quads stick out of the image.
    modes_agree(
        "cornell-box",
        &mut scene_file("cornell-box.toml"),
        37,
        29,
        4,
        Dispersion::Drop,
    );
    modes_agree(
        "fluorescent-surfaces",
        &mut scene_file("fluorescent-surfaces.toml"),
        32,
        32,
        4,
        Dispersion::Drop,
    );
    // Media: distance sampling, null boundaries, shadow rays through media.
    modes_agree(
        "fluorescent-volume-440nm",
        &mut scene_file("fluorescent-volume-440nm.toml"),
        24,
        24,
        4,
        Dispersion::Drop,
    );
    modes_agree(
        "fluorescent-slab",
        &mut scene_file("fluorescent-slab.toml"),
        24,
        24,
        4,
        Dispersion::Drop,
    );
    // Rough conductors and a dispersive rough dielectric (per-lane pdfs, no splits).
    modes_agree(
        "metals-and-glass",
        &mut scene_file("metals-and-glass.toml"),
        24,
        24,
        8,
        Dispersion::Drop,
    );
    // Smooth shading normals, coated fluorescent surfaces (the coat's choice before the
    // shift), rough gold and glass.
    modes_agree(
        "product-shot",
        &mut scene_file("product-shot.toml"),
        24,
        24,
        8,
        Dispersion::Drop,
    );
    // Point, spot, directional and environment lights: delta lights' MIS, shadow rays to
    // beyond the scene, escaping rays.
    modes_agree(
        "product-shot-spot",
        &mut scene_file("product-shot-spot.toml"),
        24,
        24,
        8,
        Dispersion::Drop,
    );
    // Textures (per-lane texture coordinates), an environment map and a fluorescence map.
    modes_agree(
        "textured-print",
        &mut scene_file("textured-print.toml"),
        24,
        24,
        8,
        Dispersion::Drop,
    );
    // Splits: children wait for a free lane.
    for d in [Dispersion::Drop, Dispersion::Split] {
        modes_agree(
            &format!("prism ({})", d.name()),
            &mut scene_file("prism.toml"),
            32,
            32,
            64,
            d,
        );
    }
}

/// The path options of the scenes below.
fn path_opts(dispersion: Dispersion) -> PathOptions {
    PathOptions {
        method: Method {
            dispersion,
            ..Method::default()
        }
        .with_tracking(Tracking::FluoAware),
        max_depth: -1,
    }
}

/// The seed of the samples below.
const SEED: u64 = 5;

/// The inputs of pixel sample `i` (sample index 0 of pixel i) of the scene's camera, as
/// the tracer makes them: ray, wavelengths and streams.
fn sample_inputs(scene: &Scene, i: u64) -> (stokes::accel::Ray, Vec4, Streams<f32>, LazyStream) {
    let w = scene.camera.width as u64;
    let (x, y) = (i % w, i / w);
    let mut rng = Streams::for_sample(SEED, i, 0);
    let [jx, jy] = rng.next_2d();
    let ray = scene.camera.ray(x as f32 + jx, y as f32 + jy);
    let lambda = SampledWavelengths::hwss_with(Wavelengths::default(), rng.next_f32()).lambda;
    (ray, lambda, rng, LazyStream::new(SEED, i, 0))
}

/// The scenes of the lane tests: lanes on different materials, in and out of a medium,
/// split at a dispersive refraction.
fn divergent_scenes() -> Vec<(&'static str, Scene, Dispersion)> {
    let mut out = vec![
        (
            "cornell-box",
            scene_file("cornell-box.toml"),
            Dispersion::Drop,
        ),
        (
            "dispersive furnace",
            scene_from(&furnace_slab("{ cauchy = [1.5, 30000] }")),
            Dispersion::Split,
        ),
        (
            "fluorescent volume",
            scene_file("fluorescent-volume-440nm.toml"),
            Dispersion::Split,
        ),
        (
            "fluorescent surfaces",
            scene_file("fluorescent-surfaces.toml"),
            Dispersion::Drop,
        ),
    ];
    for (_, scene, _) in &mut out {
        scene.set_resolution(16, 16);
    }
    out
}

#[test]
fn masked_lanes_never_contribute_and_a_lone_lane_equals_the_single_ray_path() {
    for (name, scene, dispersion) in divergent_scenes() {
        let po = path_opts(dispersion);
        let mut stats = PathStats::default();
        let n = 256u32;
        // The single-ray answers, path by path.
        let want: Vec<Vec4> = (0..n as u64)
            .map(|i| {
                let (ray, lambda, rng, shift) = sample_inputs(&scene, i);
                radiance(&scene, ray, lambda, &po, rng, shift, &mut stats)
            })
            .collect();
        let live = want.iter().filter(|v| **v != Vec4::ZERO).count();
        assert!(
            live > 16,
            "{name}: {live} paths saw light: the test shows little"
        );
        // Packets whose lanes may only use the lanes of `usable` (one live lane, random
        // holes, full), refilled as paths end or only when all have ended.
        // Packets whose lanes may only use the lanes of `usable` (one live lane, random
        // holes, full), refilled as paths end or only when all have ended; 4 and 8 wide.
        let patterns: [(usize, u32); 9] = [
            (4, 0b0001),
            (4, 0b0100),
            (4, 0b1010),
            (4, 0b1101),
            (4, 0b1111),
            (8, 0b0000_0001),
            (8, 0b1001_0110),
            (8, 0b1110_1111),
            (8, 0xff),
        ];
        for (width, usable) in patterns {
            for lockstep in [false, true] {
                let (results, lambdas, occupancy, ..) = match width {
                    4 => run_packets::<F4>(&scene, &po, usable, lockstep, true, n),
                    _ => run_packets::<F8>(&scene, &po, usable, lockstep, true, n),
                };
                let what = format!("{name}, {width} lanes {usable:b}, lockstep {lockstep}");
                for k in 0..n as usize {
                    assert!(
                        results[k].to_array().map(f32::to_bits)
                            == want[k].to_array().map(f32::to_bits),
                        "{what}: path {k} gives {} in a packet, {} alone",
                        results[k],
                        want[k]
                    );
                    let (_, lambda, _, _) = sample_inputs(&scene, k as u64);
                    assert_eq!(lambdas[k], lambda, "{what}: path {k}'s wavelengths");
                }
                assert_eq!(
                    results[n as usize],
                    Vec4::ZERO,
                    "{what}: an empty lane wrote a result"
                );
                let lanes = usable.count_ones() as f64 / width as f64;
                assert!(
                    occupancy <= lanes + 1e-9,
                    "{what}: lanes outside the pattern were used"
                );
            }
        }
    }
}

/// Runs pixel samples 0..n (sample index 0 of pixels 0..n) through a tracer of width `F`
/// that may use only the lanes of `usable`: the results and wavelengths per sample (plus
/// a sentinel slot that nothing may write), the lane occupancy, and the busy shares of the
/// steps inside a medium and of the steps that traced camera rays; `sort`: lanes gathered
/// into groups ([`Tracer::sort`]).
fn run_packets<F: Width>(
    scene: &Scene,
    po: &PathOptions,
    usable: u32,
    lockstep: bool,
    sort: bool,
    n: u32,
) -> (Vec<Vec4>, Vec<Vec4>, f64, f64, f64) {
    let mut tracer = Tracer::<F>::default();
    tracer.usable = usable;
    tracer.lockstep = lockstep;
    tracer.sort = sort;
    let (results, lambdas, _) = trace_samples(&mut tracer, scene, po, n);
    let occupancy = tracer.lanes_used as f64 / tracer.lanes_total as f64;
    let medium = tracer.medium_lanes_used as f64 / tracer.medium_lanes_total as f64;
    let camera = tracer.camera_lanes_used as f64 / tracer.camera_lanes_total as f64;
    (results, lambdas, occupancy, medium, camera)
}

/// Which busy share a gathering must raise: the medium's steps, or the camera's.
#[derive(Clone, Copy)]
enum Share {
    Medium,
    Camera,
}

/// Sorting on and off must give the same bits for every sample of `file` at widths 4 and
/// 8, and sorting must raise the busy share `share` by more than `rise`.
fn gathering_changes_no_result_and_raises(file: &str, share: Share, rise: f64) {
    let mut scene = scene_file(file);
    scene.set_resolution(32, 32);
    let po = path_opts(Dispersion::Drop);
    let n = 1024;
    for width in [4, 8] {
        let run = |sort| {
            let (results, lambdas, _, medium, camera) = match width {
                4 => run_packets::<F4>(&scene, &po, u32::MAX, false, sort, n),
                _ => run_packets::<F8>(&scene, &po, u32::MAX, false, sort, n),
            };
            let busy = match share {
                Share::Medium => medium,
                Share::Camera => camera,
            };
            (results, lambdas, busy)
        };
        let ((a, la, apart), (b, lb, together)) = (run(false), run(true));
        let bits = |v: &[Vec4]| {
            v.iter()
                .map(|x| x.to_array().map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(
            bits(&a),
            bits(&b),
            "{file}, width {width}: sorting changed a result"
        );
        assert_eq!(
            la, lb,
            "{file}, width {width}: sorting changed a wavelength"
        );
        let what = match share {
            Share::Medium => "medium",
            Share::Camera => "camera",
        };
        assert!(
            together > apart + rise,
            "{file}, width {width}: {what} lanes {together:.3} busy gathered, {apart:.3} not"
        );
        eprintln!("{file}, width {width}: {what} lanes busy {apart:.3} → {together:.3}");
    }
}

/// Gathering the paths inside a medium into the same groups moves paths between lanes
/// but changes no bit of any sample, and it must fill the medium's steps: their share of
/// busy lanes rises by more than 0.2 at widths 4 and 8 (measured 0.32 → 0.83 and
/// 0.20 → 0.63 in the volume, 0.49 → 0.94 and 0.39 → 0.86 in the slab).
#[test]
fn gathering_the_paths_in_media_changes_no_result_and_fills_the_lanes() {
    for file in ["fluorescent-volume-440nm.toml", "fluorescent-slab.toml"] {
        gathering_changes_no_result_and_raises(file, Share::Medium, 0.2);
    }
}

/// Gathering the free lanes before the refill, so that the paths about to leave the
/// camera fill whole groups, moves paths between lanes but changes no bit of any sample,
/// and the camera rays go to Embree in fuller packets: the busy share of the steps that
/// trace camera rays rises by more than 0.3 at widths 4 and 8 (measured 0.45 → 0.94 and
/// 0.37 → 0.85 in the Cornell box, 0.36 → 0.91 and 0.28 → 0.82 on the sphere, 0.40 →
/// 0.91 and 0.31 → 0.81 in the fluorescent volume, where the medium's paths are gathered
/// too).
#[test]
fn gathering_the_camera_paths_changes_no_result_and_fills_the_camera_packets() {
    for file in [
        "cornell-box.toml",
        "sphere-100k.toml",
        "fluorescent-volume-440nm.toml",
    ] {
        gathering_changes_no_result_and_raises(file, Share::Camera, 0.3);
    }
}

/// Tracing the groups' closest-hit rays as streams ahead of their step (the camera rays
/// of the groups that start together as one coherent stream, the other groups' rays as
/// one incoherent stream) changes no sample at widths 4 and 8, with either stream alone
/// or both: each stream hands each group the hits its own packet query would find.
/// Embree answers a stream with its widest packet kernel (8 lanes under AVX2, 16 under
/// AVX-512), not the 4-wide one, so the two are different kernels and the test does not
/// demand the same bits everywhere: at most one sample in 200 may differ (a ray through
/// an edge that two kernels give to different triangles; none differs on an AMD EPYC
/// Zen 3, AVX2, nor under the SSE2, SSE4.2 and AVX kernels). A stream that handed hits to
/// the wrong lanes or groups changes most samples. The wavelengths are drawn before any
/// ray is traced and must match exactly. Most rays go through the streams: the camera
/// rays of all but the rounds that start a single group (at 32², measured 882–924 of
/// 1024 at width 4 and 478–672 at width 8), and the bounce rays of all but the rounds
/// that bounce a single group.
#[cfg(embree3)]
#[test]
fn rays_in_streams_change_no_result() {
    for file in [
        "cornell-box.toml",
        "fluorescent-surfaces.toml",
        "fluorescent-volume-440nm.toml",
    ] {
        let mut scene = scene_file(file);
        scene.set_resolution(32, 32);
        let po = path_opts(Dispersion::Drop);
        let n = 1024u32;
        for width in [4, 8] {
            let run = |cameras, bounces| {
                fn with<F: Width>(cameras: bool, bounces: bool) -> Tracer<F> {
                    let mut tracer = Tracer::default();
                    tracer.stream_cameras = cameras;
                    tracer.stream_bounces = bounces;
                    tracer.log = Some(Box::default());
                    tracer
                }
                match width {
                    4 => trace_samples(&mut with::<F4>(cameras, bounces), &scene, &po, n),
                    _ => trace_samples(&mut with::<F8>(cameras, bounces), &scene, &po, n),
                }
            };
            let bits = |v: &[Vec4]| {
                v.iter()
                    .map(|x| x.to_array().map(f32::to_bits))
                    .collect::<Vec<_>>()
            };
            let (a, la, none) = run(false, false);
            assert_eq!(
                (none.0, none.1),
                (0, 0),
                "{file}, width {width}: rays streamed with streams off"
            );
            let a = bits(&a);
            for (cameras, bounces) in [(true, false), (false, true), (true, true)] {
                let (b, lb, (camera, bounce, traced)) = run(cameras, bounces);
                let what = format!("{file}, width {width}, cameras {cameras}, bounces {bounces}");
                let b = bits(&b);
                let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
                assert!(
                    differ * 200 <= n as usize,
                    "{what}: the streams changed {differ} of {n} samples"
                );
                assert_eq!(la, lb, "{what}: the streams changed a wavelength");
                match cameras {
                    true => assert!(
                        camera as f64 > 0.3 * n as f64 && camera <= n as u64,
                        "{what}: {camera} of {n} camera rays streamed"
                    ),
                    false => assert_eq!(camera, 0, "{what}: camera rays streamed"),
                }
                match bounces {
                    true => assert!(
                        bounce as f64 > 0.6 * traced as f64 && bounce <= traced,
                        "{what}: {bounce} of {traced} bounce rays streamed"
                    ),
                    false => assert_eq!(bounce, 0, "{what}: bounce rays streamed"),
                }
                eprintln!(
                    "{what}: {camera} of {n} camera rays and {bounce} of {traced} bounce rays \
                     streamed, {differ} samples differ"
                );
            }
        }
    }
}

/// Pixel samples 0..n (sample index 0 of pixels 0..n) through `tracer`: the results and
/// wavelengths per sample (plus a sentinel slot that nothing may write), how many
/// camera and bounce rays went through the streams, and how many bounce rays it traced
/// (if it logs its rays).
fn trace_samples<F: Width>(
    tracer: &mut Tracer<F>,
    scene: &Scene,
    po: &PathOptions,
    n: u32,
) -> (Vec<Vec4>, Vec<Vec4>, (u64, u64, u64)) {
    let mut results = vec![Vec4::ZERO; n as usize + 1];
    let mut lambdas = vec![Vec4::ZERO; n as usize + 1];
    let w = scene.camera.width;
    let mut work = (0..n).map(|i| SampleId {
        x: i % w,
        y: i / w,
        index: 0,
        slot: i,
    });
    let mut stats = PathStats::default();
    let (r, l) = (&mut results, &mut lambdas);
    if scene.has_media() {
        tracer.run::<true>(scene, po, SEED, &mut work, r, l, &mut stats);
    } else {
        tracer.run::<false>(scene, po, SEED, &mut work, r, l, &mut stats);
    }
    let bounces = tracer.log.as_ref().map_or(0, |log| log.bounce.len() as u64);
    let streamed = (
        tracer.camera_rays_streamed,
        tracer.bounce_rays_streamed,
        bounces,
    );
    (results, lambdas, streamed)
}

/// A glass slab of index `ior` in a white furnace (a box emitting 1 inwards). A lossless
/// dielectric in a uniform enclosure leaves the radiance unchanged at every wavelength;
/// a slab traps no light (its faces are parallel or perpendicular), so unbounded paths
/// end. (A faceted sphere does trap light in total internal reflection, which a depth
/// limit then cuts: a bias that is not the estimator's.)
fn furnace_slab(ior: &str) -> String {
    format!(
        r#"
[camera]
position = [1.2, 0.8, -1.8]
look_at = [0, 0, 0]
fov = 50
resolution = [16, 16]

[materials.glass]
type = "dielectric"
ior = {ior}

[[shapes]]
type = "box"
min = [-3, -3, -3]
max = [3, 3, 3]
emission = {{ radiance = 1.0, two_sided = true }}

[[shapes]]
type = "box"
min = [-1, -1, -0.2]
max = [1, 1, 0.2]
material = "glass"
"#
    )
}

#[test]
fn split_paths_in_a_dispersive_furnace_return_the_emitted_radiance() {
    let expected = stokes::color::xyz_to_linear_srgb(stokes::spectrum::spectrum_to_xyz(
        &stokes::spectrum::Spectrum::Constant(1.0),
    ));
    let dispersive = furnace_slab("{ cauchy = [1.5, 30000] }");
    let runs: Vec<(&str, Film)> = [
        ("split", dispersive.as_str(), Dispersion::Split, 4096),
        ("drop", dispersive.as_str(), Dispersion::Drop, 4096),
        (
            "non-dispersive",
            &furnace_slab("1.6"),
            Dispersion::Split,
            4096,
        ),
    ]
    .into_iter()
    .map(|(name, text, d, spp)| {
        let mut scene = scene_from(text);
        (name, opts(16, 16, spp, Rays::Packet, d).film(&mut scene))
    })
    .collect();
    let all = all_pixels(&runs[0].1);
    for (name, film) in &runs {
        let (m, se) = region_mean(film, &all);
        eprintln!("furnace {name}: {m:?} ± {se:?}, expected {expected}");
        for c in 0..3 {
            // The HWSS estimate of a constant spectrum sits within 0.1 % of the tabulated
            // integral; 0.3 % leaves room for that and the noise.
            let rel = (m[c] - expected[c] as f64) / expected[c] as f64;
            assert!(
                rel.abs() < 0.003,
                "{name}: channel {c}: {} vs {}",
                m[c],
                expected[c]
            );
        }
    }
    let (_, se_split) = region_mean(&runs[0].1, &all);
    let (_, se_drop) = region_mean(&runs[1].1, &all);
    assert!(
        se_split[0] < 0.001 * expected[0] as f64,
        "too noisy to decide"
    );
    assert!(
        se_split[0] < se_drop[0] / 2.0,
        "split is not less noisy than drop: {se_split:?} vs {se_drop:?}"
    );
    assert_all_agree("furnace", &runs, &[("image", all)], 4.0);
}

/// Vertical strips across the prism's spectrum (the pixels where the screen is lit).
fn spectrum_strips(film: &Film, strips: usize) -> Vec<(String, Vec<usize>)> {
    let mean = film.mean();
    let w = film.width as usize;
    let lit: Vec<usize> = (0..mean.len())
        .filter(|&i| mean[i].iter().sum::<f32>() > 0.02)
        .collect();
    let (x0, x1) = lit
        .iter()
        .fold((w, 0), |(a, b), &i| (a.min(i % w), b.max(i % w)));
    assert!(
        x1 > x0 + strips,
        "the spectrum is not on screen ({x0}..{x1})"
    );
    (0..strips)
        .map(|s| {
            let a = x0 + (x1 + 1 - x0) * s / strips;
            let b = x0 + (x1 + 1 - x0) * (s + 1) / strips;
            let px = (0..mean.len())
                .filter(|i| (a..b).contains(&(i % w)))
                .collect();
            (format!("strip {s} (x {a}..{b})"), px)
        })
        .collect()
}

/// The prism scene with a wider slit and a taller lamp, so that a test-sized render finds
/// the light often enough to tell a few per cent.
fn wide_prism() -> Scene {
    let text = std::fs::read_to_string(root().join("scenes/prism.toml")).unwrap();
    let wide = text
        .replace("origin = [-60, -2, -10]", "origin = [-60, -8, -10]")
        .replace("edge_u = [0, 4, 0]", "edge_u = [0, 16, 0]")
        .replace("origin = [-20, 0.5, -40]", "origin = [-20, 2, -40]")
        .replace("edge_u = [0, 19.5, 0]", "edge_u = [0, 18, 0]");
    assert_ne!(text, wide, "scenes/prism.toml changed: update wide_prism()");
    scene_from(&wide)
}

#[test]
fn split_agrees_with_lane_dropping_on_the_prism_and_is_less_noisy() {
    let mut scene = wide_prism();
    let (w, h, spp) = (32, 32, 2048);
    let drop = opts(w, h, spp, Rays::Packet, Dispersion::Drop).film(&mut scene);
    let split = opts(w, h, spp, Rays::Packet, Dispersion::Split).film(&mut scene);
    let mut strips = spectrum_strips(&split, 4);
    strips.push(("image".into(), all_pixels(&split)));
    assert_all_agree(
        "prism",
        &[("drop", drop.clone()), ("split", split.clone())],
        &strips
            .iter()
            .map(|(n, px)| (n.as_str(), px.clone()))
            .collect::<Vec<_>>(),
        4.0,
    );
    let (m, se) = region_mean(&split, &all_pixels(&split));
    for c in 0..3 {
        assert!(se[c] < 0.05 * m[c], "too noisy to decide (channel {c})");
    }
    // Colour noise: the summed variance of the mean over the image.
    let noise = |f: &Film| -> f64 {
        let v = f.variance_of_mean();
        v.iter()
            .map(|p| p.iter().map(|&x| x as f64).sum::<f64>())
            .sum()
    };
    let (nd, ns) = (noise(&drop), noise(&split));
    eprintln!(
        "variance at {spp} spp: drop {nd:.4e}, split {ns:.4e} ({:.2}x)",
        nd / ns
    );
    assert!(
        ns < nd / 2.0,
        "split is not less noisy than drop at equal spp: {ns} vs {nd}"
    );
}

/// The render's counters: every thread's rays are counted (depth 1 traces exactly one
/// camera ray per sample), every thread count and mode the same rays, and the packet-lane
/// occupancy is a share: 1 where every packet is full (depth 1 on an even-sized image),
/// below 1 but well above ¼ once paths end at different depths, absent for single rays.
#[test]
fn ray_counts_add_up_over_threads_and_modes_and_occupancy_is_a_share() {
    use stokes::integrator::render::render;
    let mut scene = scene_file("cornell-box.toml");
    scene.set_resolution(16, 16);
    let run = |scene: &Scene, rays: Rays, threads: usize, depth: i32| {
        let o = opts(16, 16, 4, rays, Dispersion::Split)
            .threads(threads)
            .max_depth(depth)
            .opts;
        render(scene, &o, &|| {}).unwrap().stats
    };
    for threads in [1, 2] {
        let first = run(&scene, Rays::Single, threads, 1);
        assert_eq!(first.rays, 16 * 16 * 4, "{threads} threads, depth 1");
        assert_eq!(first.occupancy(), None);
        assert_eq!(
            run(&scene, Rays::Packet, threads, 1).occupancy(),
            Some(1.0),
            "{threads} threads: full packets at depth 1"
        );
    }
    // Thread counts run the same arithmetic: the same rays, exactly. Packets and single
    // rays may part at an edge hit that Embree's packet kernel resolves to the
    // neighbouring triangle (see the module docs), so across modes the counts agree to 1 %.
    let single = run(&scene, Rays::Single, 1, -1);
    assert!(single.rays > 3 * 16 * 16 * 4, "{} rays", single.rays);
    assert_eq!(run(&scene, Rays::Single, 2, -1).rays, single.rays);
    let packet = run(&scene, Rays::Packet, 1, -1);
    assert_eq!(run(&scene, Rays::Packet, 2, -1).rays, packet.rays);
    let rel = (packet.rays as f64 / single.rays as f64 - 1.0).abs();
    assert!(
        rel < 0.01,
        "packet {} against single {} rays",
        packet.rays,
        single.rays
    );
    let o = packet.occupancy().unwrap();
    assert!(o > 0.5 && o < 1.0, "occupancy {o}");
    assert_eq!(packet.medium_occupancy(), None, "a scene without media");
}

/// A render reports how busy its packets' medium steps ran, summed over threads: absent
/// for single rays, and high in packet modes, since the paths inside the medium are
/// gathered (without gathering, width 4 runs about a third busy here, width 8 a fifth).
#[test]
fn a_render_reports_how_busy_the_medium_steps_ran() {
    use stokes::integrator::render::render;
    let mut scene = scene_file("fluorescent-volume-440nm.toml");
    scene.set_resolution(32, 32);
    for threads in [1, 2] {
        let run = |rays: Rays| {
            let o = opts(32, 32, 8, rays, Dispersion::Split)
                .threads(threads)
                .opts;
            render(&scene, &o, &|| {}).unwrap().stats
        };
        assert_eq!(run(Rays::Single).medium_occupancy(), None);
        for (rays, least) in [(Rays::Packet, 0.7), (Rays::Packet8, 0.5)] {
            let stats = run(rays);
            let o = stats.medium_occupancy().unwrap();
            eprintln!("{threads} threads, {rays:?}: medium lanes {o:.3} busy");
            assert!(o > least && o <= 1.0, "{threads} threads, {rays:?}: {o}");
            assert!(stats.medium_lanes_total > 0);
        }
    }
}

/// Every width reports the barycentrics of its hits (Embree's `u`, `v`) as single rays
/// do, and 0 for misses and inactive lanes.
#[test]
fn hits_carry_barycentrics_at_every_width() {
    use glam::Vec3;
    use stokes::accel::{set_flush_denormals, Coherence};
    use stokes::simd::{Mask, V3};
    set_flush_denormals();
    let scene = Scene::load(&root().join("scenes/cornell-box.toml")).unwrap();
    let org = scene.camera.position;
    // Directions fanning out from the camera: most hit the box, some leave through its
    // open front.
    let (lo, hi) = scene.bounds;
    let (ahead, size) = ((lo + hi) / 2.0 - org, (hi - lo).length());
    let dir = |k: usize| {
        let a = k as f32 * 0.618_034;
        let off = Vec3::new((a * 7.0).sin(), (a * 3.0).cos(), (a * 5.0).sin());
        ahead + off * size * 0.2
    };
    fn check<F: Width>(scene: &Scene, org: Vec3, dir: &dyn Fn(usize) -> Vec3) -> (usize, usize) {
        let (mut hits, mut misses) = (0, 0);
        for base in (0..2000).step_by(F::WIDTH) {
            // Every seventh lane inactive.
            let active = F::Mask::from_fn(|k| (base + k) % 7 != 3);
            let d = V3::<F>::from_fn(|k| dir(base + k));
            let o = V3::<F>::from_fn(|_| org);
            let h = F::intersect(
                &scene.accel,
                &o,
                &d,
                F::splat(f32::INFINITY),
                active,
                Coherence::Incoherent,
            );
            for k in 0..F::WIDTH {
                let one = f32::intersect(
                    &scene.accel,
                    &org.into(),
                    &dir(base + k).into(),
                    f32::INFINITY,
                    active.get(k),
                    Coherence::Incoherent,
                );
                assert_eq!(h.valid.get(k), one.valid, "ray {}", base + k);
                let (u, v) = (h.u.get(k), h.v.get(k));
                if !one.valid {
                    assert_eq!((u, v), (0.0, 0.0), "ray {}", base + k);
                    misses += 1;
                    continue;
                }
                hits += 1;
                assert_eq!((h.geom[k], h.prim[k]), (one.geom[0], one.prim[0]));
                assert!(
                    (u - one.u).abs() < 1e-4 && (v - one.v).abs() < 1e-4,
                    "ray {}: {u} {v} against {} {}",
                    base + k,
                    one.u,
                    one.v
                );
                assert!(u >= 0.0 && v >= 0.0 && u + v <= 1.0 + 1e-6, "{u} {v}");
            }
        }
        (hits, misses)
    }
    let (hits, misses) = check::<f32>(&scene, org, &dir);
    assert!(hits > 1000 && misses > 285, "{hits} hits, {misses} misses");
    let spread = (0..2000).filter(|&k| {
        let h = f32::intersect(
            &scene.accel,
            &org.into(),
            &dir(k).into(),
            f32::INFINITY,
            true,
            Coherence::Incoherent,
        );
        h.valid && h.u > 0.01 && h.v > 0.01
    });
    assert!(spread.count() > 500, "barycentrics away from the corners");
    check::<F4>(&scene, org, &dir);
    check::<F8>(&scene, org, &dir);
}

/// `stokes bench limit` replays a render's rays by kind: the log must hold one camera ray
/// per pixel sample, each from the camera, and as many rays in all as the render counts,
/// in every mode (and none but camera rays when paths end at their first hit).
#[test]
fn the_ray_log_sorts_every_traced_ray_by_kind() {
    use stokes::integrator::render::{render, trace_rays};
    let mut scene = scene_file("cornell-box.toml");
    scene.set_resolution(16, 16);
    let samples = 16 * 16 * 4;
    for rays in [Rays::Single, Rays::Packet, Rays::Packet8, Rays::Lockstep] {
        for depth in [1, -1] {
            let o = opts(16, 16, 4, rays, Dispersion::Drop)
                .threads(1)
                .max_depth(depth)
                .opts;
            let log = trace_rays(&scene, &o, 0, 4);
            let what = format!("{rays:?}, depth {depth}");
            assert_eq!(log.camera.len(), samples, "{what}: camera rays");
            let eye = scene.camera.position;
            assert!(log.camera.iter().all(|r| r.org == eye), "{what}");
            let logged = log.camera.len() + log.bounce.len() + log.shadow.len();
            assert!(log.segment.is_empty(), "{what}: no media, no segments");
            let traced = render(&scene, &o, &|| {}).unwrap().stats.rays;
            assert_eq!(logged as u64, traced, "{what}: logged against traced rays");
            if depth == 1 {
                assert_eq!(logged, samples, "{what}: only camera rays");
            } else {
                assert!(
                    log.bounce.len() > samples && log.shadow.len() > samples,
                    "{what}"
                );
            }
        }
    }
}

/// `stokes bench limit` reports its fraction twice: from the median render and the fastest
/// replays, and from each render paired with replays timed right after it. The pairs must
/// give finite, positive, ordered quartiles, and the JSON must carry them. No bound ties
/// the two fractions together: they are timings, and a loaded host (or a slow Embree ISA)
/// moves them apart by 4× (seen in CI under `isa=avx`).
#[test]
fn the_embree_limit_pairs_each_render_with_its_replays() {
    use stokes::tools::bench_limit::{bench_limit, LimitOptions};
    let mut scene = scene_file("cornell-box.toml");
    scene.set_resolution(16, 16);
    let render = opts(16, 16, 1, Rays::Packet, Dispersion::Drop)
        .threads(1)
        .max_depth(3)
        .opts;
    let o = LimitOptions {
        render,
        seconds: 0.5,
        repetitions: 5,
    };
    let r = bench_limit(&scene, &o, &mut |_| {}).unwrap();
    let kinds: Vec<_> = r.kinds.iter().map(|k| k.kind).collect();
    assert_eq!(kinds, ["camera", "bounce", "shadow"]);
    let p = r.fraction_paired;
    assert!(
        p.q1.is_finite() && p.q1 > 0.0 && p.q1 <= p.median && p.median <= p.q3 && p.q3.is_finite(),
        "{p:?}"
    );
    let json = serde_json::to_value(&r).unwrap();
    assert!(json["fraction_paired"]["q3"].is_number(), "{json}");
}
