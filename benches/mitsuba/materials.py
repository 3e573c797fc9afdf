#!/usr/bin/env python3
"""stokes against Mitsuba 3 on rough conductors, a rough dielectric and coated diffuses.

The measured Cornell box without its boxes, with six spheres (one UV-sphere OBJ this
script writes, so both renderers trace the same triangles, flat-shaded): rough gold
(GGX alpha 0.2), smooth silver, rough copper (alpha 0.05), rough glass (eta 1.5,
alpha 0.2), the box's green paint under a clear coat (stokes `coated`, Mitsuba
`plastic` with `nonlinear`) and its red paint under a rough coat (alpha 0.2; Mitsuba
`roughplastic` with `nonlinear`: the same model except for the coat's internal
reflectance r, which stokes scales to reciprocity, 0.584 at eta 1.5, alpha 0.2, and
Mitsuba keeps single-scattering, 0.496, so that stokes' red paint (rho about 0.6-0.7
in the red) is expected 8-11 % brighter in its diffuse part) and a black base under the
same rough coat (the coat's GGX reflection alone: the same model but for the masking). Metals use the measured eta + ik both renderers read from the same tables
(stokes: data/metals/, Mitsuba: its data/ior/*.spd). Both render the same resolution and
spp, unbounded depth with Russian roulette; the script prints the mean linear-sRGB
value per channel of the whole image and of each sphere's box of pixels, for both, and
the ratio stokes / Mitsuba with stokes' standard error (from its variance image).

    python3 benches/mitsuba/materials.py --res 128 --spp 1024 --out /tmp/materials

Needs `pip install mitsuba` (scalar_spectral) and a release build of stokes
(target/release/stokes). Not part of the tests.
"""

import argparse
import math
import os
import subprocess
import sys
from pathlib import Path

import cbox  # spectrum(), read_csv_columns()

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "scenes" / "data" / "cornell-box"

# name, centre, radius, stokes material, Mitsuba bsdf
SPHERES = [
    ("gold", (170, 100, 200), 100, 'type = "conductor"\nmetal = "Au"\nroughness = 0.2',
     {"type": "roughconductor", "material": "Au", "distribution": "ggx", "alpha": 0.2}),
    ("glass", (390, 100, 330), 100, 'type = "dielectric"\nior = 1.5\nroughness = 0.2',
     {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.2,
      "int_ior": 1.5, "ext_ior": 1.0}),
    ("silver", (420, 70, 110), 70, 'type = "conductor"\nmetal = "Ag"',
     {"type": "conductor", "material": "Ag"}),
    ("copper", (150, 300, 400), 70, 'type = "conductor"\nmetal = "Cu"\nroughness = 0.05',
     {"type": "roughconductor", "material": "Cu", "distribution": "ggx", "alpha": 0.05}),
    # A clear coat (index 1.5) over the box's green paint: Mitsuba's `plastic` with
    # nonlinear internal scattering is the same layer model (diffuse_reflectance is
    # filled in from the green column below).
    ("plastic", (280, 60, 80), 60,
     'type = "coated"\nior = 1.5\nbase = { type = "diffuse", reflectance = "green" }',
     {"type": "plastic", "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": True, "_paint": "green"}),
    ("roughplastic", (430, 330, 300), 60,
     'type = "coated"\nior = 1.5\nroughness = 0.2\nbase = { type = "diffuse", reflectance = "red" }',
     {"type": "roughplastic", "distribution": "ggx", "alpha": 0.2, "int_ior": 1.5,
      "ext_ior": 1.0, "nonlinear": True, "_paint": "red"}),
    # The same rough coat over black: only the coat's own GGX reflection, where the two
    # models are the same but for the masking term.
    ("roughcoat", (120, 400, 250), 50,
     'type = "coated"\nior = 1.5\nroughness = 0.2\nbase = { type = "diffuse", reflectance = 0 }',
     {"type": "roughplastic", "distribution": "ggx", "alpha": 0.2, "int_ior": 1.5,
      "ext_ior": 1.0, "nonlinear": True, "diffuse_reflectance": 0.0}),
]
WALLS = [("floor", "white"), ("ceiling", "white"), ("back", "white"),
         ("redwall", "red"), ("greenwall", "green")]


def write_sphere_obj(path, stacks=32, slices=64):
    """A unit UV sphere, faces wound outwards (counter-clockwise seen from outside)."""
    v = [(0.0, 1.0, 0.0)]
    for i in range(1, stacks):
        t = math.pi * i / stacks
        for j in range(slices):
            p = 2 * math.pi * j / slices
            v.append((math.sin(t) * math.cos(p), math.cos(t), math.sin(t) * math.sin(p)))
    v.append((0.0, -1.0, 0.0))
    ring = lambda i, j: 1 + (i - 1) * slices + (j % slices)
    f = [(0, ring(1, j + 1), ring(1, j)) for j in range(slices)]
    for i in range(1, stacks - 1):
        for j in range(slices):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)
            f += [(a, b, d), (a, d, c)]
    s = len(v) - 1
    f += [(s, ring(stacks - 1, j), ring(stacks - 1, j + 1)) for j in range(slices)]
    with open(path, "w") as out:
        out.writelines(f"v {x:.7f} {y:.7f} {z:.7f}\n" for x, y, z in v)
        out.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f)


def stokes_scene(out, res):
    lines = [f"""[camera]
position = [278, 273, -800]
look_at = [278, 273, 0]
up = [0, 1, 0]
fov = 39.3077
resolution = [{res}, {res}]

[spectra]
white = {{ csv = "{DATA}/reflectance.csv", column = "white" }}
red = {{ csv = "{DATA}/reflectance.csv", column = "red" }}
green = {{ csv = "{DATA}/reflectance.csv", column = "green" }}
luminaire = {{ csv = "{DATA}/light.csv", column = "radiance" }}

[materials.white]
type = "diffuse"
reflectance = "white"
[materials.red]
type = "diffuse"
reflectance = "red"
[materials.green]
type = "diffuse"
reflectance = "green"
[materials.luminaire]
type = "diffuse"
reflectance = 0.78
"""]
    for name, _, _, mat, _ in SPHERES:
        lines.append(f"[materials.{name}]\n{mat}\n")
    for wall, mat in WALLS:
        lines.append(f'[[shapes]]\ntype = "obj"\nfile = "{DATA}/cbox_{wall}.obj"\nmaterial = "{mat}"\n')
    lines.append(f'[[shapes]]\ntype = "obj"\nfile = "{DATA}/cbox_luminaire.obj"\n'
                 'translate = [0, -0.5, 0]\nmaterial = "luminaire"\n'
                 'emission = { radiance = "luminaire" }\n')
    for name, c, r, _, _ in SPHERES:
        lines.append(f'[[shapes]]\ntype = "obj"\nfile = "{out}/sphere.obj"\nmaterial = "{name}"\n'
                     f"scale = {r}\ntranslate = [{c[0]}, {c[1]}, {c[2]}]\n")
    path = out / "materials.toml"
    path.write_text("\n".join(lines))
    return path


def mitsuba_scene(out, res, spp):
    import mitsuba as mi
    T = mi.ScalarTransform4f
    refl = cbox.read_csv_columns(DATA / "reflectance.csv")
    light = cbox.read_csv_columns(DATA / "light.csv")
    # stokes' diffuse is two-sided: so are these (only the inside is seen anyway).
    diffuse = lambda n: {"type": "twosided", "bsdf": {
        "type": "diffuse", "reflectance": cbox.spectrum(zip(refl["nm"], refl[n]))}}
    obj = lambda f, bsdf, **kw: {"type": "obj", "filename": str(f), "bsdf": bsdf,
                                 "face_normals": True, **kw}
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective", "fov": 39.3077, "fov_axis": "y",
            "near_clip": 10.0, "far_clip": 2800.0,
            "to_world": T().look_at(origin=[278, 273, -800], target=[278, 273, 0], up=[0, 1, 0]),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": res, "height": res,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        },
        "luminaire": obj(DATA / "cbox_luminaire.obj",
                         diffuse_flat(0.78), to_world=T().translate([0, -0.5, 0]),
                         emitter={"type": "area",
                                  "radiance": cbox.spectrum(zip(light["nm"], light["radiance"]))}),
    }
    for wall, mat in WALLS:
        d[wall] = obj(DATA / f"cbox_{wall}.obj", diffuse(mat))
    for name, c, r, _, bsdf in SPHERES:
        if "_paint" in bsdf:
            bsdf = dict(bsdf)
            paint = bsdf.pop("_paint")
            bsdf["diffuse_reflectance"] = cbox.spectrum(zip(refl["nm"], refl[paint]))
        # Metals are two-sided in stokes; only the outside is visible here.
        d[name] = obj(out / "sphere.obj", bsdf, to_world=T().translate(list(c)).scale(r))
    return d


def diffuse_flat(v):
    return {"type": "diffuse", "reflectance": cbox.spectrum([(360.0, v), (830.0, v)])}


def regions(res):
    """Pixel boxes around each sphere (from a projection of its bounding sphere)."""
    out = {"image": (0, 0, res, res)}
    f = 1 / math.tan(math.radians(39.3077) / 2)
    for name, c, r, _, _ in SPHERES:
        z = c[2] + 800
        # The camera looks down +z; image x runs towards -x in the scene (Mitsuba's and
        # stokes' look_at with up +y: right-handed, +x to the left of the image).
        px = lambda x: (0.5 - 0.5 * f * (x - 278) / z) * res
        py = lambda y: (0.5 - 0.5 * f * (y - 273) / z) * res
        x0, x1 = sorted((px(c[0] - r * 0.7), px(c[0] + r * 0.7)))
        y0, y1 = sorted((py(c[1] - r * 0.7), py(c[1] + r * 0.7)))
        out[name] = (int(x0), int(y0), int(math.ceil(x1)), int(math.ceil(y1)))
    return out


def read_rgb(path):
    """{(x, y): [R, G, B]} of an EXR, read with Mitsuba's Bitmap (no numpy needed)."""
    import mitsuba as mi
    b = mi.Bitmap(str(path))
    names = [b.struct_()[k].name for k in range(b.channel_count())]
    t = mi.TensorXf(b)
    h, w, c = t.shape
    flat = list(t.array)
    idx = [names.index(n) for n in ("R", "G", "B")]
    return {(x, y): [flat[(y * w + x) * c + k] for k in idx] for y in range(h) for x in range(w)}


def box_mean(px, box):
    x0, y0, x1, y1 = box
    vals = [px[(x, y)] for y in range(y0, y1) for x in range(x0, x1)]
    return [sum(v[c] for v in vals) / len(vals) for c in range(3)], len(vals)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--res", type=int, default=128)
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    p.add_argument("--out", type=Path, default=Path("/tmp/materials"))
    args = p.parse_args()
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    write_sphere_obj(out / "sphere.obj")
    scene = stokes_scene(out, args.res)
    stokes_exr = out / "stokes.exr"
    subprocess.run([str(ROOT / "target/release/stokes"), "render", str(scene), "--spp",
                    str(args.spp), "--threads", str(args.threads), "--variance", "-o",
                    str(stokes_exr)], check=True)

    import drjit as dr
    import mitsuba as mi
    mi.set_variant("scalar_spectral")
    mi.set_log_level(mi.LogLevel.Warn)
    dr.set_thread_count(args.threads)
    img = mi.render(mi.load_dict(mitsuba_scene(out, args.res, args.spp)), seed=1)
    mitsuba_exr = out / "mitsuba.exr"
    mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(mitsuba_exr))

    s, m = read_rgb(stokes_exr), read_rgb(mitsuba_exr)
    var = read_rgb(out / "stokes.variance.exr")
    print(f"mitsuba {mi.__version__} scalar_spectral; {args.res}² {args.spp} spp; images in {out}")
    print(f"{'region':<8} {'pixels':>6}  {'stokes R G B':>30}  {'mitsuba R G B':>30}  stokes/mitsuba (± 1 se of stokes)")
    for name, box in regions(args.res).items():
        (sm, n), (mm, _) = box_mean(s, box), box_mean(m, box)
        vm, _ = box_mean(var, box)
        se = [math.sqrt(v / n) for v in vm]  # variance of each pixel's mean, averaged
        ratio = "  ".join(f"{a / b:.4f} ± {e / b:.4f}" for a, b, e in zip(sm, mm, se))
        fmt = lambda v: " ".join(f"{x:9.5f}" for x in v)
        print(f"{name:<8} {n:>6}  {fmt(sm):>30}  {fmt(mm):>30}  {ratio}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
