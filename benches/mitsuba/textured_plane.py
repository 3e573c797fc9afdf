#!/usr/bin/env python3
"""stokes against Mitsuba 3 on a textured diffuse plane under a constant sky and a point
light: both upsample the texture's sRGB with the same model (Jakob and Hanika 2019),
each from its own coefficient table, so the image means should agree within about 1 %.

The texture (written here, an 8-bit sRGB PNG of concentric coloured squares) is the same
under flips and transposition, so the two renderers' texture-coordinate conventions
cannot matter. The plane is 2 x 2, seen from straight above; the sky is RGB (0.5, 0.5,
0.5) as an illuminant (D65), the point light 1 W/sr/nm (a constant spectrum) 1 unit
above the centre. The script prints the mean linear sRGB of both images and the ratio
with stokes' standard error (from its variance image), and the RMS of the per-pixel
difference beside stokes' own per-pixel noise (equal if the images agree pixel by pixel
and Mitsuba's noise is like stokes').

    /work/venvs/mitsuba/bin/python benches/mitsuba/textured_plane.py --res 64 --spp 1024

Needs `pip install mitsuba` (scalar_spectral) and a release build of stokes
(target/release/stokes). Not part of the tests.
"""

import argparse
import struct
import subprocess
import zlib
from pathlib import Path

import mitsuba as mi
import numpy as np

ROOT = Path(__file__).resolve().parents[2]

COLOURS = [(200, 40, 30), (40, 170, 60), (50, 70, 200), (230, 220, 200), (220, 180, 40)]


def write_png(path, n):
    """n x n concentric squares of COLOURS (sRGB bytes), 8 texels per band."""
    def px(x, y):
        band = int(max(abs(x + 0.5 - n / 2), abs(y + 0.5 - n / 2)) // 8)
        return COLOURS[band % len(COLOURS)]
    raw = b"".join(b"\0" + bytes(c for x in range(n) for c in px(x, y)) for y in range(n))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", n, n, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def stokes_scene(out, res):
    return f"""
[camera]
position = [0, 3, 0]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov = 40
resolution = [{res}, {res}]

[materials.paper]
type = "diffuse"
reflectance = {{ texture = "{out / 'squares.png'}", wrap = "clamp" }}

[[shapes]]
type = "quad"
origin = [1, 0, -1]
edge_u = [-2, 0, 0]
edge_v = [0, 0, 2]
material = "paper"

[[lights]]
type = "environment"
radiance = {{ rgb = [0.5, 0.5, 0.5] }}

[[lights]]
type = "point"
position = [0, 1, 0]
intensity = 1
"""


def mitsuba_render(out, res, spp):
    mi.set_variant("scalar_spectral")
    T = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective", "fov": 40, "fov_axis": "y",
            "to_world": T().look_at(origin=[0, 3, 0], target=[0, 0, 0], up=[0, 0, 1]),
            "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "plane": {
            "type": "rectangle",
            "to_world": T().rotate([1, 0, 0], -90),
            "bsdf": {"type": "diffuse", "reflectance": {
                "type": "bitmap", "filename": str(out / "squares.png"),
                "filter_type": "bilinear", "wrap_mode": "clamp"}},
        },
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}},
        "lamp": {"type": "point", "position": [0, 1, 0],
                 "intensity": {"type": "uniform", "value": 1.0}},
    })
    return np.array(mi.render(scene))[:, :, :3]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--out", type=Path, default=Path("/tmp/stokes-textured-plane"))
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    write_png(a.out / "squares.png", 64)
    (a.out / "plane.toml").write_text(stokes_scene(a.out, a.res))
    exr = a.out / "stokes.exr"
    subprocess.run([str(ROOT / "target/release/stokes"), "render", str(a.out / "plane.toml"),
                    "-o", str(exr), "--spp", str(a.spp), "--variance"], check=True)
    mi.set_variant("scalar_spectral")
    s = np.array(mi.Bitmap(str(exr)))[:, :, :3]
    var = np.array(mi.Bitmap(str(exr).replace(".exr", ".variance.exr")))[:, :, :3]
    m = mitsuba_render(a.out, a.res, a.spp)
    n = s.shape[0] * s.shape[1]
    for c, name in enumerate("RGB"):
        ms, mm = s[:, :, c].mean(), m[:, :, c].mean()
        se = np.sqrt(var[:, :, c].sum()) / n
        print(f"{name}: stokes {ms:.5f} ± {se:.5f}, Mitsuba {mm:.5f}, ratio {ms / mm:.4f}")
    # Pixel by pixel: the RMS of the difference against that of stokes' own noise.
    d = np.sqrt(((s - m) ** 2).mean())
    noise = np.sqrt(var.mean())
    print(f"per pixel: RMS difference {d:.5f}, stokes' RMS standard error {noise:.5f}")


if __name__ == "__main__":
    main()
