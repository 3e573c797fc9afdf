//! `stokes figure`: panels land where the layout says with the sRGB values the formula
//! gives, the difference row is white where a panel equals the reference and red or blue
//! where it is above or below, the error table holds the errors computed by hand (over
//! the image and a scene's regions), and bad input fails with one line and no file.

mod common;

use common::{run, scratch, stokes};
use std::path::{Path, PathBuf};
use stokes::output::write_exr;
use stokes::tools::figure::{Figure, Made, Panel, Rect, BLUE, CSV_HEADER, RED};

const W: u32 = 16;
const H: u32 = 8;

/// Writes a W×H EXR of `f(x, y)` with `spp` in its header (if given).
fn exr(dir: &Path, name: &str, spp: Option<u32>, f: impl Fn(u32, u32) -> [f32; 3]) -> PathBuf {
    let path = dir.join(name);
    let px: Vec<[f32; 3]> = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect();
    let meta: Vec<(String, String)> = spp
        .map(|n| ("spp".into(), n.to_string()))
        .into_iter()
        .collect();
    write_exr(&path, W, H, &px, &meta).unwrap();
    path
}

/// A constant grey EXR.
fn grey(dir: &Path, name: &str, v: f32) -> PathBuf {
    exr(dir, name, None, |_, _| [v; 3])
}

/// A figure of `panels` into `dir/strip.png`, without reference or options.
fn figure(dir: &Path, panels: &[(&str, &Path)]) -> Figure {
    Figure {
        panels: panels
            .iter()
            .map(|(label, file)| Panel {
                label: label.to_string(),
                file: file.to_path_buf(),
            })
            .collect(),
        output: dir.join("strip.png"),
        reference: None,
        scene: None,
        diff: false,
        diff_scale: None,
        exposure: 0.0,
        zoom: 1,
        title: None,
        table: None,
        csv: None,
    }
}

/// An 8-bit RGB PNG read back: width, height, pixels.
struct Png {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

impl Png {
    fn read(path: &Path) -> Png {
        let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut rgb = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut rgb).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        rgb.truncate(info.buffer_size());
        Png {
            width: info.width,
            height: info.height,
            rgb,
        }
    }

    fn at(&self, x: u32, y: u32) -> [u8; 3] {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Every pixel of `r`.
    fn pixels(&self, r: &Rect) -> Vec<[u8; 3]> {
        (r.y..r.y + r.height)
            .flat_map(|y| (r.x..r.x + r.width).map(move |x| (x, y)))
            .map(|(x, y)| self.at(x, y))
            .collect()
    }
}

/// The 8-bit sRGB encoding of a linear value in [0, 1], from the sRGB formula.
fn srgb8(linear: f64) -> u8 {
    let e = if linear <= 0.0031308 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0).round() as u8
}

/// Checks that `r` is filled with `colour` and framed by background (white) on all four
/// sides: the panel is exactly there, no larger and no smaller.
fn assert_panel(png: &Png, r: &Rect, colour: [u8; 3], what: &str) {
    assert!(
        png.pixels(r).iter().all(|&p| p == colour),
        "{what}: expected {colour:?} over {r:?}, found {:?}",
        png.pixels(r)[0]
    );
    let around = [
        Rect {
            x: r.x - 1,
            y: r.y,
            width: 1,
            height: r.height,
        },
        Rect {
            x: r.x + r.width,
            y: r.y,
            width: 1,
            height: r.height,
        },
        Rect {
            x: r.x,
            y: r.y - 1,
            width: r.width,
            height: 1,
        },
    ];
    for edge in around {
        assert!(
            png.pixels(&edge).iter().all(|&p| p == [255; 3]),
            "{what}: expected background around {r:?}, found {:?} at {edge:?}",
            png.pixels(&edge)
        );
    }
}

/// Whether any pixel of the `height` rows under `r` is dark (a label is drawn there).
fn text_under(png: &Png, r: &Rect, height: u32) -> bool {
    let band = Rect {
        x: r.x.saturating_sub(20),
        y: r.y + r.height + 1,
        width: r.width + 40,
        height,
    };
    png.pixels(&band).iter().any(|p| p.iter().all(|&c| c < 128))
}

#[test]
fn panels_are_tone_mapped_in_place_with_labels() {
    let dir = scratch("figure-strip");
    let a = grey(&dir, "a.exr", 0.5);
    let b = exr(&dir, "b.exr", None, |_, _| [0.04, 0.25, 2.0]);
    assert_eq!(srgb8(0.5), 188, "the sRGB formula itself");
    let fig = figure(&dir, &[("A", &a), ("mono max, 16 spp", &b)]);
    let made: Made = fig.make().unwrap();
    let png = Png::read(&fig.output);
    assert_eq!(
        (png.width, png.height),
        (made.layout.width, made.layout.height)
    );
    let [pa, pb] = made.layout.panels[..] else {
        panic!("expected two panels, found {:?}", made.layout.panels)
    };
    assert!(
        pa.x + pa.width < pb.x,
        "left to right, apart: {pa:?} {pb:?}"
    );
    assert_eq!((pa.width, pa.height), (W, H));
    assert!(pb.x + pb.width <= png.width && pb.y + pb.height <= png.height);
    assert_panel(&png, &pa, [188; 3], "A");
    assert_panel(&png, &pb, [srgb8(0.04), srgb8(0.25), 255], "B");
    assert!(
        text_under(&png, &pa, 24) && text_under(&png, &pb, 24),
        "labels"
    );
    assert!(made.table.is_none() && made.markdown.is_none());

    // One stop up, twice as large, with a title: 0.25 becomes 0.5.
    let mut fig = fig;
    fig.exposure = 1.0;
    fig.zoom = 2;
    fig.title = Some("Title".into());
    let made = fig.make().unwrap();
    let png = Png::read(&fig.output);
    let pb = made.layout.panels[1];
    assert_eq!((pb.width, pb.height), (2 * W, 2 * H));
    assert!(pb.y > 30, "room for the title: {pb:?}");
    assert_panel(&png, &pb, [srgb8(0.08), 188, 255], "B at +1 EV");

    // The command line draws the same strip.
    let out = dir.join("cli.png");
    let (ok, _, err) = run(stokes().args([
        "figure".as_ref(),
        format!("A={}", a.display()).as_ref(),
        format!("mono max, 16 spp={}", b.display()).as_ref(),
        "--exposure".as_ref(),
        "1".as_ref(),
        "--zoom".as_ref(),
        "2".as_ref(),
        "--title".as_ref(),
        "Title".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]));
    assert!(ok, "{err}");
    let cli = Png::read(&out);
    assert_eq!(
        (cli.width, cli.height, &cli.rgb),
        (png.width, png.height, &png.rgb)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn difference_row_is_white_where_equal_red_above_blue_below() {
    let dir = scratch("figure-diff");
    let r = exr(&dir, "ref.exr", Some(1024), |_, _| [0.5; 3]);
    let same = grey(&dir, "same.exr", 0.5);
    let above = grey(&dir, "above.exr", 0.7);
    let below = grey(&dir, "below.exr", 0.3);
    // One firefly in 512 differences: above the 99th percentile, so not the scale.
    let firefly = exr(&dir, "firefly.exr", None, |x, y| {
        [if (x, y) == (3, 2) { 10.0 } else { 0.5 }; 3]
    });
    let mut fig = figure(
        &dir,
        &[
            ("same", &same),
            ("above", &above),
            ("below", &below),
            ("firefly", &firefly),
        ],
    );
    fig.reference = Some(r.clone());
    fig.diff = true;
    let made = fig.make().unwrap();
    let png = Png::read(&fig.output);
    // The reference is appended, with its spp, and has no difference panel.
    assert_eq!(made.layout.panels.len(), 5);
    assert_panel(&png, &made.layout.panels[4], [188; 3], "reference");
    assert!(made.layout.diffs[4].is_none());
    // |difference| is 0 or 0.2 but for the firefly: its 99th percentile is 0.2.
    let scale = made.diff_scale.unwrap();
    assert!((scale - 0.2).abs() < 1e-6, "scale {scale}");
    let diff = |i: usize| made.layout.diffs[i].unwrap_or_else(|| panic!("no diff panel {i}"));
    assert_panel(&png, &diff(0), [255; 3], "same − reference");
    let red = png.at(diff(1).x, diff(1).y);
    let blue = png.at(diff(2).x, diff(2).y);
    assert!(
        red[0] > red[1] + 100 && red[0] > red[2] + 100,
        "above: {red:?}"
    );
    assert!(
        blue[2] > blue[0] + 100 && blue[2] > blue[1] + 50,
        "below: {blue:?}"
    );
    assert_panel(&png, &diff(1), red, "above − reference");
    assert_panel(&png, &diff(2), blue, "below − reference");
    let f = diff(3);
    assert_eq!(png.at(f.x + 3, f.y + 2), RED, "the firefly, saturated");
    assert_eq!(png.at(f.x + 4, f.y + 2), [255; 3], "beside the firefly");
    for i in 0..4 {
        assert!(
            diff(i).y >= made.layout.panels[i].y + H + 16,
            "row 2 under row 1"
        );
        assert!(text_under(&png, &diff(i), 24), "diff label {i}");
    }
    // The colour bar: red at the top, white in the middle, blue at the bottom.
    let bar = made.layout.colour_bar.unwrap();
    let (top, mid, bottom) = (
        png.at(bar.x + 2, bar.y),
        png.at(bar.x + 2, bar.y + bar.height / 2),
        png.at(bar.x + 2, bar.y + bar.height - 1),
    );
    assert!(
        top[0] > top[2] + 100 && bottom[2] > bottom[0] + 100,
        "{top:?} {bottom:?}"
    );
    assert!(mid.iter().all(|&c| c > 240), "{mid:?}");

    // At the scale, the map's ends; at twice the scale, halfway to white.
    assert_eq!((red, blue), (RED, BLUE));
    fig.diff_scale = Some(0.4);
    let made = fig.make().unwrap();
    let png = Png::read(&fig.output);
    let d = made.layout.diffs[1].unwrap();
    let pale = png.at(d.x, d.y);
    for c in 0..3 {
        let halfway = (255.0 + RED[c] as f64) / 2.0;
        assert!((pale[c] as f64 - halfway).abs() <= 1.0, "{pale:?}");
    }
    assert!(made.diff_scale == Some(0.4));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scene at twice the images' resolution with one region: its left half-height
/// quarter, which becomes the 8×4 pixels at the top left of a 16×8 image.
const SCENE: &str = r#"
[camera]
position = [0, 0, -2.5]
look_at = [0, 0, 0]
fov = 60
resolution = [32, 16]

[materials.grey]
type = "diffuse"
reflectance = 0.5

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "grey"
emission = { radiance = "D65", scale = 1 }

[[region]]
name = "corner"
min = [0, 0]
max = [16, 8]
"#;

#[test]
fn error_table_holds_the_errors_by_hand_over_image_and_regions() {
    let dir = scratch("figure-table");
    let value = |x: u32, y: u32| 0.1 + 0.05 * ((x + 3 * y) % 7) as f32;
    let r = exr(&dir, "ref.exr", Some(4096), |x, y| [value(x, y), 0.5, 1.0]);
    let same = exr(&dir, "same.exr", Some(16), |x, y| [value(x, y), 0.5, 1.0]);
    // Off by 0.1 everywhere but in the corner region, where it is exact.
    let corner = |x: u32, y: u32| x < 8 && y < 4;
    let off = exr(&dir, "off.exr", Some(64), |x, y| {
        let d = if corner(x, y) { 0.0 } else { 0.1 };
        [value(x, y) + d, 0.5 + d, 1.0 + d]
    });
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let mut fig = figure(&dir, &[("same, 16 spp", &same), ("off | by 0.1", &off)]);
    fig.reference = Some(r.clone());
    fig.table = Some(dir.join("errors.md"));
    fig.csv = Some(dir.join("errors.csv"));
    fig.scene = Some(scene.clone());
    let made = fig.make().unwrap();
    let t = made.table.as_ref().unwrap();
    assert_eq!(
        t.regions,
        [("image".to_string(), 128), ("corner".to_string(), 32)]
    );
    assert_eq!(t.rows.len(), 2, "the appended reference has no row");
    assert_eq!((t.rows[0].spp, t.rows[1].spp), (Some(16), Some(64)));
    for e in &t.rows[0].errors {
        assert_eq!((e.rmse, e.relmse), (0.0, 0.0));
    }
    // By hand: over the image, 96 of 128 pixels are off by 0.1 in every channel.
    let (mut se, mut rel, mut n) = (0.0f64, 0.0f64, 0);
    for y in 0..H {
        for x in 0..W {
            for rc in [value(x, y) as f64, 0.5, 1.0] {
                let d: f64 = if corner(x, y) { 0.0 } else { 0.1 };
                se += d * d;
                rel += d * d / (rc * rc + 0.01);
                n += 1;
            }
        }
    }
    let (rmse, relmse) = ((se / n as f64).sqrt(), rel / n as f64);
    assert!((rmse - (0.75f64 * 0.01).sqrt()).abs() < 1e-12);
    let [image, corner_errors] = t.rows[1].errors[..] else {
        panic!("expected two regions")
    };
    assert!((image.rmse - rmse).abs() < 1e-6, "{} vs {rmse}", image.rmse);
    assert!(
        (image.relmse - relmse).abs() < 1e-5 * relmse,
        "{} vs {relmse}",
        image.relmse
    );
    assert!(corner_errors.rmse < 1e-7 && corner_errors.relmse < 1e-12);

    // The same figure as CSV, markdown and on stdout.
    let csv = std::fs::read_to_string(dir.join("errors.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 4, "{csv}");
    assert!(
        rows[0].starts_with("\"same, 16 spp\","),
        "quoted: {}",
        rows[0]
    );
    assert!(rows[1].contains(",16,,corner,32,0,0"), "{}", rows[1]);
    let f: Vec<&str> = rows[2].split(',').collect();
    assert_eq!(&f[2..6], ["64", "", "image", "128"]);
    let (csv_rmse, csv_relmse): (f64, f64) = (f[6].parse().unwrap(), f[7].parse().unwrap());
    assert_eq!(
        (csv_rmse, csv_relmse),
        (image.rmse, image.relmse),
        "full precision"
    );
    assert!(rows[3].contains(",corner,32,"), "{}", rows[3]);
    let md = std::fs::read_to_string(dir.join("errors.md")).unwrap();
    assert_eq!(Some(&md), made.markdown.as_ref());
    assert!(md.contains("4096 spp"), "{md}");
    assert!(md.contains("| corner RMSE | corner relMSE |"), "{md}");
    assert!(md.contains("| off \\| by 0.1 | 64 | – |"), "{md}");
    assert!(md.contains(&format!("{:.3e}", image.rmse)), "{md}");
    // The scene's camera is 32x16, the images 16x8: the same aspect, no warning.
    assert!(made.warnings.is_empty(), "{:?}", made.warnings);

    std::fs::remove_file(dir.join("errors.md")).unwrap();
    let (ok, stdout, err) = run(stokes()
        .arg("figure")
        .arg(format!("same, 16 spp={}", same.display()))
        .arg(format!("off | by 0.1={}", off.display()))
        .arg("--reference")
        .arg(&r)
        .arg("--scene")
        .arg(&scene)
        .arg("--table")
        .arg(dir.join("errors.md"))
        .arg("-o")
        .arg(dir.join("cli.png")));
    assert!(ok, "{err}");
    assert_eq!(stdout, md);
    assert_eq!(std::fs::read_to_string(dir.join("errors.md")).unwrap(), md);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs `stokes figure ARGS` in `dir`; it must fail with one `error:` line, no panic,
/// and leave `dir` as it was (no strip, no table, no temporary file). Returns the line.
fn fails_cleanly(dir: &Path, args: &[&str]) -> String {
    let before = listing(dir);
    let out = stokes()
        .current_dir(dir)
        .arg("figure")
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.code(),
        Some(1),
        "figure {args:?} should fail: {err}"
    );
    assert!(!err.contains("panicked"), "panic: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "one line: {err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    assert_eq!(listing(dir), before, "figure {args:?} left files behind");
    lines[0].to_string()
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn bad_input_is_one_line_and_writes_nothing() {
    let dir = scratch("figure-bad");
    grey(&dir, "a.exr", 0.5);
    grey(&dir, "ref.exr", 0.5);
    let small = dir.join("small.exr");
    write_exr(&small, 8, 8, &[[0.5; 3]; 64], &[]).unwrap();
    std::fs::write(dir.join("text.exr"), "not an image").unwrap();
    // An EXR with one channel, Y, and no R, G or B.
    {
        use exr::prelude::*;
        let y = AnyChannel::new("Y", FlatSamples::F32(vec![0.5; 64]));
        let layer = Layer::new(
            (8, 8),
            LayerAttributes::named(""),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(vec![y].into()),
        );
        Image::from_layer(layer)
            .write()
            .to_file(dir.join("luma.exr"))
            .unwrap();
    }
    std::fs::write(dir.join("scene.toml"), "[camera\n").unwrap();
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["A=a.exr", "B=small.exr", "-o", "s.png"],
            &["small.exr is 8x8", "a.exr is 16x8", "same size"],
        ),
        (
            &["A=a.exr", "--reference", "small.exr", "-o", "s.png"],
            &["--reference small.exr is 8x8", "a.exr is 16x8"],
        ),
        (
            &["A=a.exr", "B=missing.exr", "-o", "s.png"],
            &["missing.exr does not exist", "panel \"B\""],
        ),
        (
            &["A=a.exr", "--reference", "missing.exr", "-o", "s.png"],
            &["missing.exr does not exist", "--reference"],
        ),
        (
            &["A=a.exr", "--diff", "-o", "s.png"],
            &["--diff: expected --reference"],
        ),
        (
            &["A=a.exr", "--table", "t.md", "-o", "s.png"],
            &["--table: expected --reference"],
        ),
        (
            &[
                "A=a.exr",
                "--reference",
                "ref.exr",
                "--diff-scale",
                "0.1",
                "-o",
                "s.png",
            ],
            &["--diff-scale: expected --diff"],
        ),
        (
            &[
                "A=a.exr",
                "--reference",
                "ref.exr",
                "--diff",
                "--diff-scale",
                "0",
                "-o",
                "s.png",
            ],
            &["--diff-scale", "positive"],
        ),
        (
            &["a.exr", "-o", "s.png"],
            &["panel \"a.exr\"", "LABEL=FILE.exr"],
        ),
        (
            &["A=a.png", "-o", "s.png"],
            &["panel \"A=a.png\"", "ending in .exr"],
        ),
        (
            &["A=text.exr", "-o", "s.png"],
            &["text.exr", "cannot read EXR"],
        ),
        (
            &["A=luma.exr", "-o", "s.png"],
            &["luma.exr has no R, G and B channels"],
        ),
        (&["A=a.exr", "-o", "s.exr"], &["-o s.exr", "ending in .png"]),
        (&["A=a.exr", "--zoom", "0", "-o", "s.png"], &["--zoom"]),
        (
            &[
                "A=a.exr",
                "--reference",
                "ref.exr",
                "--table",
                "s.png",
                "-o",
                "s.png",
            ],
            &["--table s.png", "the file -o writes"],
        ),
        // Outputs are checked before any input is read.
        (
            &["A=missing.exr", "-o", "a.exr/s.png"],
            &["-o a.exr/s.png", "found a file"],
        ),
        (
            &[
                "A=a.exr",
                "--reference",
                "ref.exr",
                "--scene",
                "scene.toml",
                "-o",
                "s.png",
            ],
            &["scene.toml:1:"],
        ),
    ];
    for (args, fragments) in cases {
        let line = fails_cleanly(&dir, args);
        for f in *fragments {
            assert!(
                line.contains(f),
                "figure {args:?}: expected {f:?} in {line}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
