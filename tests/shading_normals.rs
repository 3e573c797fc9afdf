//! Shading normals through the renderer: a smooth-shaded low-poly sphere in a white
//! furnace returns the emitted radiance; light never leaks through the back of a surface
//! whose shading normals lean over its edge; a mesh's file normals pointing inwards shade
//! like outward ones.

mod common;
use common::*;

/// A white diffuse sphere of `stacks` rings (`smooth` shading or not) in a box whose
/// walls emit 1 on both sides.
fn furnace(stacks: u32, smooth: bool) -> String {
    enclosure(
        "type = \"diffuse\"\nreflectance = 1.0",
        "1.0",
        stacks,
        &format!("smooth = {smooth}"),
    )
}

#[test]
fn smooth_low_poly_sphere_in_a_white_furnace_returns_the_emitted_radiance() {
    let want = white_rgb();
    for stacks in [12u32, 24] {
        let mut scene = scene_from(&furnace(stacks, true));
        let film = TestRender::at(16, 16).spp(2048).seed(4).film(&mut scene);
        let (m, se) = region_mean(&film, &all_pixels(&film));
        eprintln!("{stacks} stacks, smooth: {m:?} ± {se:?}");
        for c in 0..3 {
            let r = m[c] / want[c];
            assert!(se[c] / want[c] < 1.5e-3, "too few samples to decide");
            assert!(
                (r - 1.0).abs() < 5e-3,
                "{stacks} stacks, channel {c}: {r} of the emitted radiance"
            );
        }
    }
}

/// A 4 × 4 quad at y = 0 facing +y whose vertex normals lean 60° towards +x, seen from
/// above; a light below it faces up at its back.
fn leaning_quad(dir: &std::path::Path, normal_sign: f32) -> String {
    let (s, c) = (60f32.to_radians().sin(), 60f32.to_radians().cos());
    let n = format!("vn {} {} 0", normal_sign * s, normal_sign * c);
    let obj = format!(
        "v -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\n{n}\nf 1//1 3//1 2//1\nf 1//1 4//1 3//1\n"
    );
    std::fs::write(dir.join("quad.obj"), obj).unwrap();
    r#"
[camera]
position = [0, 3, -0.5]
look_at = [0, 0, 0]
fov = 50
resolution = [16, 16]

[materials.white]
type = "diffuse"
reflectance = 0.8

[[shapes]]
type = "obj"
file = "quad.obj"
material = "white"

[[shapes]]
type = "quad"
origin = [-1, -1, -1]
edge_u = [0, 0, 2]
edge_v = [2, 0, 0]
emission = { radiance = 10.0 }
"#
    .to_string()
}

#[test]
fn no_light_leaks_through_the_back_of_a_shaded_surface() {
    let dir = scratch("shading-leak");
    for sign in [1.0f32, -1.0] {
        let text = leaning_quad(&dir, sign);
        let path = dir.join("leak.toml");
        std::fs::write(&path, &text).unwrap();
        let mut scene = stokes::scene::Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            scene.geometries[0].shading_normal(0, 0.3, 0.3).is_some(),
            "the quad should carry its file's normals"
        );
        let film = TestRender::at(16, 16).spp(256).seed(2).film(&mut scene);
        let (m, _) = region_mean(&film, &all_pixels(&film));
        // The light faces up at the quad's back; the camera sees only the front.
        assert_eq!(
            m, [0.0; 3],
            "normals × {sign}: light leaked through the back: {m:?}"
        );
    }
}

#[test]
fn inward_file_normals_shade_like_outward_ones() {
    // The same leaning normals, once pointing out of the front and once negated (a file
    // whose normals point into the surface): turned to the geometric side, the images agree.
    let dir = scratch("shading-inward");
    // A light beside the quad, above it, facing it (edge_u × edge_v points to −x).
    let text = leaning_quad(&dir, 1.0).replace(
        "origin = [-1, -1, -1]\nedge_u = [0, 0, 2]\nedge_v = [2, 0, 0]",
        "origin = [3, 0.5, -1]\nedge_u = [0, 0, 2]\nedge_v = [0, 2, 0]",
    );
    let render = |sign: f32, seed: u64| {
        leaning_quad(&dir, sign);
        let path = dir.join("lit.toml");
        std::fs::write(&path, &text).unwrap();
        let mut scene = stokes::scene::Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        TestRender::at(16, 16).spp(512).seed(seed).film(&mut scene)
    };
    let (a, b) = (render(1.0, 5), render(-1.0, 6));
    let all = all_pixels(&a);
    let (ma, mb) = (region_mean(&a, &all), region_mean(&b, &all));
    assert!(
        ma.0[1] > 1e-3,
        "the quad should be lit from the side: {ma:?}"
    );
    assert_agree("outward vs inward file normals", ma, mb, 4.0);
}

/// A 4 × 4 gold plate at y = 0 (an OBJ quad with texture coordinates whose u runs along
/// +x, or along +z when `u_along_z`) with GGX widths `roughness`, seen from straight above;
/// a small light above, offset along +x from the mirror direction.
fn brushed_plate(dir: &std::path::Path, u_along_z: bool, roughness: &str) -> stokes::scene::Scene {
    let vt = match u_along_z {
        false => "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n",
        true => "vt 0 0\nvt 0 1\nvt 1 1\nvt 1 0\n",
    };
    let obj = format!("v -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\n{vt}f 1/1 3/3 2/2\nf 1/1 4/4 3/3\n");
    std::fs::write(dir.join("plate.obj"), obj).unwrap();
    let text = format!(
        r#"
[camera]
position = [0, 4, 0.001]
look_at = [0, 0, 0]
fov = 20
resolution = [16, 16]

[materials.gold]
type = "conductor"
metal = "Au"
roughness = {roughness}

[[shapes]]
type = "obj"
file = "plate.obj"
material = "gold"

[[shapes]]
type = "quad"
origin = [1.2, 3, -0.2]
edge_u = [0.4, 0, 0]
edge_v = [0, 0, 0.4]
emission = {{ radiance = 50.0 }}
"#
    );
    let path = dir.join("brushed.toml");
    std::fs::write(&path, text).unwrap();
    stokes::scene::Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn anisotropic_roughness_follows_the_texture_u_direction() {
    let dir = scratch("shading-brushed");
    let mean = |u_along_z: bool, roughness: &str, seed: u64| {
        let mut scene = brushed_plate(&dir, u_along_z, roughness);
        assert!(scene.geometries[0].tangent(0).is_some());
        let film = TestRender::at(16, 16).spp(256).seed(seed).film(&mut scene);
        region_mean(&film, &all_pixels(&film))
    };
    // Narrow along u, wide along v: the light off to +x is caught when v runs along x.
    let (along_x, along_z) = (mean(false, "[0.05, 0.5]", 1), mean(true, "[0.05, 0.5]", 2));
    eprintln!("u along x: {along_x:?}; u along z: {along_z:?}");
    assert!(
        along_z.0[0] > 2.0 * along_x.0[0],
        "the wide axis should follow v: {along_z:?} vs {along_x:?}"
    );
    // Isotropic roughness does not care which way u runs.
    let (a, b) = (mean(false, "0.3", 3), mean(true, "0.3", 4));
    assert_agree("isotropic, u along x vs z", a, b, 4.0);
}
