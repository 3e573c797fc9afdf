#!/usr/bin/env python3
"""Renders the eight measured bispectral materials of ../shared/data/bispectral/ as a
swatch chart, under D65 and under a 365 nm UV lamp, into docs/results/: a PNG, and a
spectral EXR (47 bins of 10 nm, OpenEXR spectral layout) at a quarter of the size.

Top row of each pair: the measured matrix (reflection and re-emission); the row below
it: the same file's diagonal only (ordinary reflectance, no fluorescence), so that what
fluorescence adds shows side by side. Columns, left to right:

    CIBA12     Ciba white plastic #12 (optical brightener)
    CIPLAW10   Ciba white plastic #10
    HERPICER   Hercules pigment, cerise
    HERPIORA   Hercules pigment, orange
    IXCRLALE   Crayola "laser lemon" index card
    PHP8HP1C   HP 870cxi cyan on HP paper
    POLGREE    Labsphere green
    TEXTYELL   a textile yellow

The matrices are read in place (they stay in ../shared); the diagonal-only versions are
written to a temporary directory via `stokes convert-bispectral`. Run from the repository
root after `cargo build --release`:

    python3 benches/bfc_swatches.py [--spp 256]
"""

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = (ROOT / ".." / "shared" / "data" / "bispectral").resolve()
NAMES = ["CIBA12", "CIPLAW10", "HERPICER", "HERPIORA", "IXCRLALE", "PHP8HP1C", "POLGREE", "TEXTYELL"]

D65 = """
[[shapes]]
type = "quad"                          # a large D65 panel in front, above the camera
origin = [-12, 6, -10]
edge_u = [24, 0, 0]
edge_v = [0, 0, 6]
emission = { radiance = "D65", scale = 0.2 }
"""

UV = """
[[shapes]]
type = "quad"                          # a 365 nm lamp in front, above the camera
origin = [-12, 6, -10]
edge_u = [24, 0, 0]
edge_v = [0, 0, 6]
emission = { radiance = { narrow_band = 365, fwhm = 10 }, scale = 4000 }

[[shapes]]
type = "quad"                          # a dim D65 fill
origin = [-12, -6, -10]
edge_u = [0, 0, 6]
edge_v = [24, 0, 0]
emission = { radiance = "D65", scale = 0.02 }
"""


def scene(matrices, diagonals, light):
    out = ["""[camera]
position = [0, 0, -24]
look_at = [0, 0, 0]
fov = 22
resolution = [768, 240]

[render]
spp = 256

[materials.backdrop]
type = "diffuse"
reflectance = 0.05

[[shapes]]
type = "quad"
origin = [-20, -10, 0.01]
edge_u = [0, 20, 0]
edge_v = [40, 0, 0]
material = "backdrop"
"""]
    for k, name in enumerate(NAMES):
        x = 7.0 - 2.0 * k  # the camera looks along +z: +x is on the left of the image
        for row, (path, y) in enumerate([(matrices[name], 0.2), (diagonals[name], -2.0)]):
            mat = f"{name.lower()}_{row}"
            out.append(f"""
[materials.{mat}]
type = "fluorescent_diffuse"
matrix = "{path}"

[[shapes]]
type = "quad"
origin = [{x - 0.9 + 1.8}, {y}, 0]
edge_u = [0, 1.8, 0]
edge_v = [-1.8, 0, 0]
material = "{mat}"
""")
    out.append(light)
    return "".join(out)


def diagonal_only(src_csv, dst_csv):
    lines = src_csv.read_text().splitlines()
    body = [l for l in lines if not l.startswith("#")]
    header, rows = body[0], body[1:]
    out = ["# the diagonal (ordinary reflectance) of " + src_csv.name + " only", header]
    for i, row in enumerate(rows):
        f = row.split(",")
        out.append(",".join(f[:1] + [v if o == i else "0" for o, v in enumerate(f[1:])]))
    dst_csv.write_text("\n".join(out) + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--bins", type=int, default=47, help="spectral bins over 360-830 nm")
    args = p.parse_args()
    stokes = ROOT / "target" / "release" / "stokes"
    results = ROOT / "docs" / "results"
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        matrices, diagonals = {}, {}
        for name in NAMES:
            bfc = DATA / f"{name}.BFC"
            csv = tmp / f"{name}.csv"
            subprocess.run([str(stokes), "convert-bispectral", str(bfc), "-o", str(csv)],
                           check=True, capture_output=True)
            diagonal_only(csv, tmp / f"{name}_diagonal.csv")
            matrices[name] = bfc
            diagonals[name] = tmp / f"{name}_diagonal.csv"
        for tag, light in [("d65", D65), ("uv365", UV)]:
            s = tmp / f"bfc-swatches-{tag}.toml"
            s.write_text(scene(matrices, diagonals, light))
            exr = tmp / f"bfc-swatches-{tag}.exr"
            r = subprocess.run([str(stokes), "render", str(s), "--spp", str(args.spp), "-o", str(exr),
                                "--png"], check=True, capture_output=True, text=True)
            print(r.stderr.strip().splitlines()[-1])
            shutil.copy(exr.with_suffix(".png"), results / f"bfc-swatches-{tag}.png")
            print(f"wrote docs/results/bfc-swatches-{tag}.png")
            spectral = results / f"bfc-swatches-{tag}-spectral.exr"
            r = subprocess.run([str(stokes), "render", str(s), "--spp", str(args.spp), "--res", "192x60",
                                "--spectral-bins", str(args.bins), "-o", str(spectral)],
                               check=True, capture_output=True, text=True)
            print(r.stderr.strip().splitlines()[-1])
            print(f"wrote {spectral.relative_to(ROOT)} ({spectral.stat().st_size / 1e6:.1f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
