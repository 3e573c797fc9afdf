#!/usr/bin/env python3
"""stokes' rough coat against Mitsuba 3's roughplastic in a white furnace.

A plate under a rough clear coat (eta 1.5, GGX alpha 0.2) over a Lambertian base of
albedo rho, seen at theta degrees through a 2-degree field of view inside a uniform
environment of radiance 1: each pixel is the coated surface's directional albedo at
theta, with no noise from the scene. stokes renders it as a plate inside an emitting
box, Mitsuba 3 (`scalar_rgb`, `roughplastic` with `nonlinear`, `constant` emitter) as a
rectangle under the sky; both at the same spp. stokes' image is divided by its render
of the bare furnace (the linear-sRGB colour of a constant spectrum of 1), so both print
the albedo itself.

Where the models are the same (rho = 0: the coat's GGX reflection alone) the two agree
up to the masking term (Mitsuba: separable G1*G1, stokes: height-correlated). With a
base they differ in one place on purpose: the coat's internal reflectance r, which
stokes scales to reciprocity (so that a white base under a clear rough coat keeps all
the energy) and Mitsuba keeps single-scattering (about 15 % lower at alpha 0.2). The
last column is what a white base returns: 1 for stokes.

    python3 benches/mitsuba/coat_furnace.py --spp 4096

Needs `pip install mitsuba` and a release build of stokes. Not part of the tests.
"""

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

from materials import read_rgb  # the EXR reader of the materials comparison

ROOT = Path(__file__).resolve().parents[2]
ALPHA = 0.2
ETA = 1.5


def stokes_scene(rho, theta, plate=True):
    t = math.radians(theta)
    x, y = 3.0 * math.sin(t), 3.0 * math.cos(t)
    body = f"""[camera]
position = [{x}, {y}, 0]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov = 2
resolution = [8, 8]

[materials.plate]
type = "coated"
ior = {ETA}
roughness = {ALPHA}
base = {{ type = "diffuse", reflectance = {rho} }}

[[shapes]]
type = "box"
min = [-10, -10, -10]
max = [10, 10, 10]
emission = {{ radiance = 1.0, two_sided = true }}
"""
    if plate:
        body += """
[[shapes]]
type = "quad"
origin = [-5, 0, -5]
edge_u = [0, 0, 10]
edge_v = [10, 0, 0]
material = "plate"
"""
    return body


def mean_rgb(path):
    px = read_rgb(path)
    return [sum(v[c] for v in px.values()) / len(px) for c in range(3)]


def stokes_albedo(rho, theta, spp, tmp, white):
    scene = tmp / f"s_{rho}_{theta}.toml"
    scene.write_text(stokes_scene(rho, theta))
    out = tmp / f"s_{rho}_{theta}.exr"
    subprocess.run([str(ROOT / "target/release/stokes"), "render", str(scene), "--spp", str(spp),
                    "-o", str(out)], check=True, capture_output=True)
    m = mean_rgb(out)
    return sum(a / b for a, b in zip(m, white)) / 3


def stokes_white(spp, tmp):
    scene = tmp / "white.toml"
    scene.write_text(stokes_scene(0.0, 0.0, plate=False))
    out = tmp / "white.exr"
    subprocess.run([str(ROOT / "target/release/stokes"), "render", str(scene), "--spp", "16",
                    "-o", str(out)], check=True, capture_output=True)
    return mean_rgb(out)


def mitsuba_albedo(rho, theta, spp):
    import mitsuba as mi
    T = mi.ScalarTransform4f
    t = math.radians(theta)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
        "sensor": {
            "type": "perspective", "fov": 2,
            "to_world": T().look_at(origin=[3 * math.sin(t), 3 * math.cos(t), 0],
                                    target=[0, 0, 0], up=[0, 0, 1]),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": 8, "height": 8, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
        },
        # Mitsuba's rectangle spans [-1, 1]² in xy facing +z: turn it to face +y.
        "plate": {"type": "rectangle",
                  "to_world": T().rotate([1, 0, 0], -90).scale(5),
                  "bsdf": {"type": "roughplastic", "distribution": "ggx", "alpha": ALPHA,
                           "int_ior": ETA, "ext_ior": 1.0, "nonlinear": True,
                           "diffuse_reflectance": {"type": "rgb", "value": rho}}},
    })
    img = mi.render(scene, seed=1)
    vals = list(mi.TensorXf(img).array)
    return sum(vals) / len(vals)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--spp", type=int, default=4096)
    args = p.parse_args()
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Warn)
    rhos = [0.0, 0.5, 0.8, 1.0]
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        white = stokes_white(args.spp, tmp)
        print(f"rough coat eta {ETA}, alpha {ALPHA}; mitsuba {mi.__version__} scalar_rgb; "
              f"{args.spp} spp, 64 pixels")
        print("theta  " + "  ".join(f"{'rho ' + str(r):>22}" for r in rhos))
        print("       " + "  ".join(f"{'stokes  mitsuba  ratio':>22}" for _ in rhos))
        for theta in [0, 45, 70]:
            row = []
            for rho in rhos:
                s = stokes_albedo(rho, theta, args.spp, tmp, white)
                m = mitsuba_albedo(rho, theta, args.spp)
                row.append(f"{s:7.4f} {m:7.4f} {s / m:6.3f}")
            print(f"{theta:>4}°  " + "  ".join(f"{c:>22}" for c in row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
