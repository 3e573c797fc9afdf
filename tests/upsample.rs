//! RGB → spectrum upsampling (`spectrum::upsample`): the colour a spectrum reproduces
//! (CIEDE2000 against the RGB it came from), the bounds of albedo spectra, the unbounded
//! and illuminant uses, the table's determinism and cache file, the SIMD evaluation, and
//! renders of `{ rgb = … }` materials and emitters.

mod common;
use common::*;
use glam::{Vec3, Vec4};
use std::sync::OnceLock;
use stokes::color::{delta_e_2000, linear_srgb_to_xyz, xyz_to_lab, xyz_to_linear_srgb, xyz_to_xy};
use stokes::sampler::Pcg32;
use stokes::simd::{Float, Mask, Spec, F4, F8};
use stokes::spectrum::upsample::{compute_table, table, Table, RES};
use stokes::spectrum::{
    illuminant, reflectance_to_xyz, spectrum_to_xyz, RgbSpectrum, Spectrum, LAMBDA_MIN,
    LAMBDA_RANGE,
};

/// Linear sRGB → its colour as a reflectance under D65, through the spectrum: XYZ
/// relative to D65 (Y = 1 for a perfect white), as the film would see it.
fn reflected_xyz(s: &Spectrum) -> Vec3 {
    let d65 = illuminant("D65").unwrap();
    reflectance_to_xyz(s, &d65) / spectrum_to_xyz(&d65).y
}

/// ΔE₀₀ between `rgb` and its albedo spectrum's colour (Lab white: sRGB's white).
fn round_trip_delta_e(rgb: [f32; 3]) -> f32 {
    let white = linear_srgb_to_xyz(Vec3::ONE);
    let s = Spectrum::Rgb(RgbSpectrum::albedo(rgb));
    let want = xyz_to_lab(linear_srgb_to_xyz(Vec3::from_array(rgb)), white);
    delta_e_2000(xyz_to_lab(reflected_xyz(&s), white), want)
}

/// Max, mean and the worst colour of ΔE over `points`.
fn delta_e_stats(points: &[[f32; 3]]) -> (f32, f32, [f32; 3]) {
    let mut worst = (0.0f32, [0.0; 3]);
    let mut sum = 0.0f64;
    for &p in points {
        let d = round_trip_delta_e(p);
        sum += f64::from(d);
        if d > worst.0 {
            worst = (d, p);
        }
    }
    (worst.0, (sum / points.len() as f64) as f32, worst.1)
}

#[test]
fn rgb_round_trips_through_the_spectrum_within_delta_e() {
    // Interior: 2000 random colours (fixed seed) and the 15³ inner points of a 17³ grid.
    let mut rng = Pcg32::new(2019, 7);
    let mut interior: Vec<[f32; 3]> = (0..2000)
        .map(|_| std::array::from_fn(|_| 0.001 + 0.998 * rng.next_f32()))
        .collect();
    let n = 16;
    let mut boundary = Vec::new();
    for a in 0..=n {
        for b in 0..=n {
            for c in 0..=n {
                let p = [a, b, c].map(|v| v as f32 / n as f32);
                if [a, b, c].iter().any(|&v| v == 0 || v == n) {
                    boundary.push(p);
                } else {
                    interior.push(p);
                }
            }
        }
    }
    // The boundary also densely along the edges of the cube, where the saturated colours
    // are (the primaries and secondaries, and the ramps from black and to white).
    for i in 0..=64 {
        let v = i as f32 / 64.0;
        for p in [
            [v, 0.0, 0.0],
            [0.0, v, 0.0],
            [0.0, 0.0, v],
            [1.0, v, 0.0],
            [v, 1.0, 0.0],
            [0.0, 1.0, v],
            [0.0, v, 1.0],
            [v, 0.0, 1.0],
            [1.0, 0.0, v],
            [1.0, 1.0, v],
            [v, 1.0, 1.0],
            [1.0, v, 1.0],
        ] {
            boundary.push(p);
        }
    }
    // Dark colours, where Lab is most sensitive and b grows fast from node to node.
    let corner = |lo: f32, hi: f32| -> Vec<[f32; 3]> {
        let n = 12;
        (0..(n + 1) * (n + 1) * (n + 1))
            .map(|i| [i % (n + 1), i / (n + 1) % (n + 1), i / (n + 1) / (n + 1)])
            .map(|v| v.map(|v| lo + (hi - lo) * v as f32 / n as f32))
            .collect()
    };
    interior.extend(corner(0.0005, 0.05));
    // Near white, where a blend of the table's nodes falls short (the lookup goes through
    // the complement there): a grid of the corner, and random bright colours, each channel
    // 0.9999 − 0.2u³, so that many have the largest channel within a fraction of a per
    // cent of 1 and another close to it.
    let near_white = corner(0.95, 0.9999);
    interior.extend(&near_white);
    interior
        .extend((0..2000).map(|_| std::array::from_fn(|_| 0.9999 - 0.2 * rng.next_f32().powi(3))));
    let (max_i, mean_i, worst_i) = delta_e_stats(&interior);
    let (max_b, mean_b, worst_b) = delta_e_stats(&boundary);
    eprintln!(
        "interior ({} colours): max ΔE₀₀ {max_i:.4} at {worst_i:?}, mean {mean_i:.4}",
        interior.len()
    );
    eprintln!(
        "boundary ({} colours): max ΔE₀₀ {max_b:.4} at {worst_b:?}, mean {mean_b:.4}",
        boundary.len()
    );
    for p in [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
    ] {
        eprintln!("  {p:?}: ΔE₀₀ {:.4}", round_trip_delta_e(p));
    }
    let (max_w, mean_w, worst_w) = delta_e_stats(&near_white);
    eprintln!("near white [0.95, 0.9999]³: max ΔE₀₀ {max_w:.4} at {worst_w:?}, mean {mean_w:.4}");
    assert!(max_i <= 0.5, "interior: ΔE₀₀ {max_i} at {worst_i:?}");
    assert!(max_b <= 2.0, "boundary: ΔE₀₀ {max_b} at {worst_b:?}");
}

#[test]
fn bright_colours_blend_smoothly_into_their_complement() {
    // Through the band of smallest channels where the lookup turns from the table's own
    // answer to the complement's, at a colour where the two differ most (by about 0.014
    // in 400–700 nm): the spectrum changes as little per step as the colour does.
    let mut prev: Option<RgbSpectrum> = None;
    let mut worst = (0.0f32, 0.0f32);
    for q in 0..=3000 {
        let x = 0.35 + 0.3 * q as f32 / 3000.0;
        let s = RgbSpectrum::albedo([x, 0.9989, 0.9729]);
        if let Some(a) = prev {
            let step = (0..=60)
                .map(|i| 400.0 + 5.0 * i as f32)
                .map(|l| (a.eval(l) - s.eval(l)).abs())
                .fold(0.0, f32::max);
            if step > worst.0 {
                worst = (step, x);
            }
        }
        prev = Some(s);
    }
    eprintln!("largest step {:.5} at red {:.4}", worst.0, worst.1);
    assert!(worst.0 < 0.002, "a step of {} at red {}", worst.0, worst.1);
}

#[test]
fn albedo_spectra_stay_in_the_unit_interval() {
    let mut rng = Pcg32::new(5, 1);
    let mut colours: Vec<[f32; 3]> = (0..300)
        .map(|_| std::array::from_fn(|_| rng.next_f32()))
        .collect();
    let n = 8;
    for a in 0..=n {
        for b in 0..=n {
            for c in 0..=n {
                colours.push([a, b, c].map(|v| v as f32 / n as f32));
            }
        }
    }
    colours.extend([
        [1.0, 1.0, 0.999],
        [1e-6, 0.0, 0.0],
        [0.0, 1e-7, 1e-7],
        [0.999, 1.0, 1.0],
    ]);
    // Out-of-range input is clamped, not extrapolated.
    colours.extend([[1.5, 0.2, 0.1], [-0.3, 0.5, 2.0], [f32::NAN, 0.5, 0.5]]);
    colours.extend([[f32::NAN; 3], [f32::NAN, f32::INFINITY, 0.2]]);
    for rgb in colours {
        let s = RgbSpectrum::albedo(rgb);
        assert!(s.coeffs.iter().all(|c| c.is_finite()), "{rgb:?}: {s:?}");
        for i in 0..=940 {
            let l = LAMBDA_MIN + i as f32 * 0.5;
            let v = s.eval(l);
            assert!((0.0..=1.0).contains(&v), "{rgb:?} at {l} nm: {v}");
        }
        assert!(s.max_value() <= 1.0, "{rgb:?}: max {}", s.max_value());
    }
    // Black and white are exactly 0 and 1.
    let black = RgbSpectrum::albedo([0.0; 3]);
    let white = RgbSpectrum::albedo([1.0; 3]);
    for l in [360.0, 555.0, 829.9] {
        assert_eq!(black.eval(l), 0.0);
        assert_eq!(white.eval(l), 1.0);
    }
}

#[test]
fn grey_nodes_of_the_table_are_nearly_constant() {
    // The fit of a grey node (both ratios 1) is the grey itself, not some metamer.
    let t = table();
    for l in 0..3 {
        for k in [8, 20, 32, 45, 55, 60] {
            let s = RgbSpectrum {
                coeffs: t.node(l, k, RES - 1, RES - 1),
                scale: 1.0,
                illuminant: false,
            };
            let v: Vec<f32> = (0..=47)
                .map(|i| s.eval(LAMBDA_MIN + 10.0 * i as f32))
                .collect();
            let (lo, hi) = v
                .iter()
                .fold((1.0f32, 0.0f32), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(
                hi - lo < 0.01 * hi.max(0.01),
                "block {l} node {k}: {lo}..{hi}"
            );
        }
    }
    // And a lookup just off grey is close to the constant.
    let s = RgbSpectrum::albedo([0.5, 0.5, 0.499]);
    for i in 0..=47 {
        let v = s.eval(LAMBDA_MIN + 10.0 * i as f32);
        assert!((v - 0.5).abs() < 0.01, "{v}");
    }
}

#[test]
fn unbounded_and_illuminant_reproduce_their_rgb() {
    // Unbounded: 2m × the reflectance of rgb/(2m), seen under D65.
    let rgb = [2.0f32, 0.5, 0.3];
    let s = Spectrum::Rgb(RgbSpectrum::unbounded(rgb));
    let back = xyz_to_linear_srgb(reflected_xyz(&s));
    eprintln!("unbounded {rgb:?} → {back}");
    for c in 0..3 {
        assert!(
            (back[c] - rgb[c]).abs() < 0.01 * rgb[0],
            "{back} vs {rgb:?}"
        );
    }
    assert!((s.max_value() - s.eval(700.0)).abs() < 0.5 && s.max_value() > 1.0);

    // Illuminant: [1, 1, 1] is D65 at luminance 1, the white of linear sRGB.
    let white = Spectrum::Rgb(RgbSpectrum::illuminant([1.0; 3]));
    let xyz = spectrum_to_xyz(&white);
    let d65_xy = xyz_to_xy(spectrum_to_xyz(&illuminant("D65").unwrap()));
    eprintln!(
        "illuminant [1, 1, 1]: XYZ {xyz}, xy {} (D65 {d65_xy})",
        xyz_to_xy(xyz)
    );
    assert!((xyz.y - 1.0).abs() < 1e-4, "Y {}", xyz.y);
    assert!((xyz_to_xy(xyz) - d65_xy).abs().max_element() < 1e-5);
    assert!((xyz_to_linear_srgb(xyz) - Vec3::ONE).abs().max_element() < 2e-3);
    // A coloured emitter: its radiance has the RGB it was given.
    let rgb = [3.0f32, 1.0, 0.2];
    let back = xyz_to_linear_srgb(spectrum_to_xyz(&Spectrum::Rgb(RgbSpectrum::illuminant(
        rgb,
    ))));
    eprintln!("illuminant {rgb:?} → {back}");
    for c in 0..3 {
        assert!(
            (back[c] - rgb[c]).abs() < 0.01 * rgb[0],
            "{back} vs {rgb:?}"
        );
    }
    // Nothing is black but black.
    assert_eq!(RgbSpectrum::unbounded([0.0; 3]).eval(500.0), 0.0);
    assert_eq!(RgbSpectrum::illuminant([0.0; 3]).max_value(), 0.0);
}

/// The table fitted afresh, bypassing the memory and disk caches: the cache file's name
/// hashes the fit's settings, not its code, so only a fresh fit shows what the code does.
fn fresh_table() -> &'static Table {
    static FRESH: OnceLock<Table> = OnceLock::new();
    FRESH.get_or_init(|| {
        let t0 = std::time::Instant::now();
        let t = compute_table();
        eprintln!("table computed in {:.2} s", t0.elapsed().as_secs_f64());
        t
    })
}

/// The colour node (l, k, j, i) stands for, written out here rather than taken from the
/// fit: the largest channel l at smoothstep(smoothstep(k/63)), the next two (cyclically)
/// at j/63 and i/63 of it.
fn node_colour(l: usize, k: usize, j: usize, i: usize) -> [f32; 3] {
    let smooth = |x: f64| x * x * (3.0 - 2.0 * x);
    let n = (RES - 1) as f64;
    let b = smooth(smooth(k as f64 / n));
    let mut rgb = [0.0f32; 3];
    rgb[l] = b as f32;
    rgb[(l + 1) % 3] = (b * j as f64 / n) as f32;
    rgb[(l + 2) % 3] = (b * i as f64 / n) as f32;
    rgb
}

#[test]
fn every_fitted_node_reproduces_its_colour() {
    // A fresh fit, node by node: the spectrum of each node's own coefficients (no
    // interpolation) has the node's colour, integrated here at 1 nm, not on the fit's
    // 5 nm grid. Nodes on the faces of the cube (a ratio 0 or 1) included; the darkest
    // scale nodes are left out, where ΔE of a colour with b < 1e-4 says nothing.
    let t = fresh_table();
    let white = linear_srgb_to_xyz(Vec3::ONE);
    let mut worst = (0.0f32, (0, 0, 0, 0));
    let mut count = 0;
    for l in 0..3 {
        for k in [6, 12, 13, 24, 40, 55, 62, RES - 1] {
            for j in [0, 1, 17, 40, 62, RES - 1] {
                for i in [0, 5, 31, 63] {
                    let s = Spectrum::Rgb(RgbSpectrum {
                        coeffs: t.node(l, k, j, i),
                        scale: 1.0,
                        illuminant: false,
                    });
                    let rgb = node_colour(l, k, j, i);
                    let want = xyz_to_lab(linear_srgb_to_xyz(Vec3::from_array(rgb)), white);
                    let d = delta_e_2000(xyz_to_lab(reflected_xyz(&s), white), want);
                    count += 1;
                    if d > worst.0 || d.is_nan() {
                        worst = (d, (l, k, j, i));
                    }
                }
            }
        }
    }
    let (l, k, j, i) = worst.1;
    eprintln!(
        "{count} nodes: max ΔE₀₀ {:.4} at node {:?} (rgb {:?})",
        worst.0,
        worst.1,
        node_colour(l, k, j, i)
    );
    assert!(worst.0 <= 0.3, "node {:?}: ΔE₀₀ {}", worst.1, worst.0);
}

#[test]
fn the_cached_table_is_a_fresh_fit() {
    // The table renders use (memory, else the disk cache, else computed) is the one the
    // current code fits. A stale cache file fails here: bump `VERSION` in
    // `spectrum/upsample.rs` whenever the fit changes.
    assert!(
        *table() == *fresh_table(),
        "the cached RGB table differs from a fresh fit (stale cache at {:?}?)",
        stokes::spectrum::upsample::cache_path()
    );
}

#[test]
fn the_table_is_deterministic_and_its_file_round_trips() {
    let a = fresh_table().clone();
    let b = compute_table();
    let bytes = a.to_bytes();
    assert!(bytes == b.to_bytes(), "two computations differ");

    let dir = scratch("upsample-table");
    let path = dir.join("nested/table.bin");
    a.write(&path).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), bytes);
    assert!(Table::read(&path).unwrap() == a);
    // Only the file: no temporary left behind.
    assert_eq!(std::fs::read_dir(dir.join("nested")).unwrap().count(), 1);
    // A damaged file is refused (and then recomputed by the caller), never trusted.
    assert!(Table::from_bytes(&bytes[..bytes.len() - 1]).is_none());
    assert!(Table::from_bytes(&bytes[8..]).is_none());
    assert!(Table::from_bytes(&[]).is_none());
    let mut flipped = bytes.clone();
    flipped[1000] ^= 0x10;
    assert!(Table::from_bytes(&flipped).is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_binary_caches_the_table_and_survives_a_bad_cache() {
    let dir = scratch("upsample-cache");
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        enclosure(
            "type = \"diffuse\"\nreflectance = { rgb = [0.8, 0.3, 0.1] }",
            "{ rgb = [1, 0.9, 0.8] }",
            8,
            "",
        ),
    )
    .unwrap();
    let render = |cache: &std::path::Path| {
        let (ok, _, err) = run(stokes().env("STOKES_CACHE_DIR", cache).args([
            "render",
            &s(&scene),
            "-o",
            &s(&dir.join("out.exr")),
            "--spp",
            "1",
        ]));
        assert!(ok, "{err}");
    };
    let cache = dir.join("cache");
    render(&cache);
    let files: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let written = Table::read(&files[0]).expect("a valid table file");
    // A cut file is recomputed and rewritten whole.
    let len = std::fs::metadata(&files[0]).unwrap().len();
    std::fs::write(
        &files[0],
        &std::fs::read(&files[0]).unwrap()[..len as usize / 2],
    )
    .unwrap();
    render(&cache);
    assert!(Table::read(&files[0]).unwrap() == written);
    // A cache "directory" that is a file: the table stays in memory, the render works.
    let not_a_dir = dir.join("file");
    std::fs::write(&not_a_dir, "x").unwrap();
    render(&not_a_dir.join("sub"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The rgb spectra the SIMD tests evaluate.
fn kinds() -> Vec<RgbSpectrum> {
    vec![
        RgbSpectrum::albedo([0.8, 0.2, 0.1]),
        RgbSpectrum::albedo([0.05, 0.9, 0.95]),
        RgbSpectrum::unbounded([2.0, 0.5, 0.3]),
        RgbSpectrum::illuminant([1.0, 0.7, 3.0]),
    ]
}

fn check_width<F: Float>(s: &RgbSpectrum, rng: &mut Pcg32) {
    let lambda: Spec<F> = Spec(std::array::from_fn(|_| {
        F::from_fn(|_| LAMBDA_MIN + LAMBDA_RANGE * rng.next_f32())
    }));
    let m = F::Mask::from_fn(|i| i != 1);
    let w = Spectrum::Rgb(*s).eval_w(&lambda, m);
    for k in 0..4 {
        for i in 0..F::WIDTH {
            let l = lambda[k].get(i);
            let want = if m.get(i) { s.eval(l) } else { 0.0 };
            assert_eq!(
                w[k].get(i).to_bits(),
                want.to_bits(),
                "{s:?} at {l}: lane {i}"
            );
        }
    }
    // eval4 too.
    let l4 = Vec4::from_array(std::array::from_fn(|k| lambda[k].get(0)));
    let four = s.eval4(l4);
    for k in 0..4 {
        assert_eq!(four[k].to_bits(), s.eval(l4[k]).to_bits());
    }
}

#[test]
fn eval_w_and_eval4_match_eval_bit_for_bit() {
    let mut rng = Pcg32::new(11, 3);
    for s in kinds() {
        for _ in 0..200 {
            check_width::<f32>(&s, &mut rng);
            check_width::<F4>(&s, &mut rng);
            check_width::<F8>(&s, &mut rng);
        }
    }
}

/// Pixels well inside the sphere of [`enclosure`] at 32×32.
fn sphere_pixels() -> Vec<usize> {
    let r_px = (1.0f32 / (1.8f32 * 1.8 - 1.0).sqrt()) / (30f32.to_radians().tan()) * 16.0;
    (0..32 * 32)
        .filter(|i| {
            let (x, y) = ((i % 32) as f32 + 0.5 - 16.0, (i / 32) as f32 + 0.5 - 16.0);
            (x * x + y * y).sqrt() < 0.8 * r_px
        })
        .collect()
}

fn render_sphere(reflectance: &str, radiance: &str) -> ([f64; 3], [f64; 3]) {
    let material = format!("type = \"diffuse\"\nreflectance = {reflectance}");
    let mut scene = scene_from(&enclosure(&material, radiance, 32, ""));
    let film = TestRender::at(32, 32).spp(64).seed(4).film(&mut scene);
    region_mean(&film, &sphere_pixels())
}

#[test]
fn rgb_materials_and_emitters_render_their_colour() {
    // A grey rgb is the constant: the same image as `reflectance = 0.5`, within noise.
    let grey = render_sphere("{ rgb = [0.5, 0.5, 0.5] }", "1.0");
    let half = render_sphere("0.5", "1.0");
    eprintln!("grey rgb {:?}, constant 0.5 {:?}", grey.0, half.0);
    assert_agree("rgb grey vs 0.5", grey, half, 4.0);
    // Just off grey goes through the table: nearly the constant.
    let near_grey = render_sphere("{ rgb = [0.5, 0.5, 0.499] }", "1.0");
    eprintln!("rgb [0.5, 0.5, 0.499]: {:?}", near_grey.0);
    let want = white_rgb().map(|v| 0.5 * v);
    for (got, want) in near_grey.0.iter().zip(want) {
        assert!((got - want).abs() < 0.005 * want, "{near_grey:?}");
    }

    // A coloured albedo in a D65 enclosure reflects the spectrum's colour exactly, and
    // that is its own linear sRGB × D65's luminance to within the fit.
    let d65 = Spectrum::Scaled(Box::new(illuminant("D65").unwrap()), 0.01);
    let y = f64::from(spectrum_to_xyz(&d65).y);
    let rgb = [0.8f32, 0.3, 0.1];
    let exact = xyz_to_linear_srgb(reflectance_to_xyz(
        &Spectrum::Rgb(RgbSpectrum::albedo(rgb)),
        &d65,
    ));
    let red = render_sphere(
        "{ rgb = [0.8, 0.3, 0.1] }",
        "{ illuminant = \"D65\", scale = 0.01 }",
    );
    eprintln!(
        "rgb {rgb:?} under D65: {:?} (exact {exact}, nominal × Y {:?})",
        red.0,
        rgb.map(|v| f64::from(v) * y)
    );
    assert_agree(
        "rgb albedo",
        red,
        (exact.to_array().map(f64::from), [0.0; 3]),
        4.0,
    );
    for c in 0..3 {
        assert!(
            (f64::from(exact[c]) - f64::from(rgb[c]) * y).abs() < 0.005 * y,
            "{exact}"
        );
    }

    // An rgb emitter seen in a white sphere: [1, 1, 1] is linear sRGB white, a coloured one
    // its colour (radiance: the illuminant use).
    for rgb in [[1.0f32, 1.0, 1.0], [2.0, 0.5, 0.25]] {
        let got = render_sphere("1.0", &format!("{{ rgb = {rgb:?} }}"));
        let exact = xyz_to_linear_srgb(spectrum_to_xyz(&Spectrum::Rgb(RgbSpectrum::illuminant(
            rgb,
        ))));
        eprintln!("rgb emitter {rgb:?}: {:?} (exact {exact})", got.0);
        assert_agree(
            "rgb emitter",
            got,
            (exact.to_array().map(f64::from), [0.0; 3]),
            4.0,
        );
        for c in 0..3 {
            assert!(
                (exact[c] - rgb[c]).abs() < 0.005 * rgb[0],
                "{exact} vs {rgb:?}"
            );
        }
    }
}
