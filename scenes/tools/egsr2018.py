#!/usr/bin/env python3
"""Writes scenes/egsr2018/: the scene of Mojzík, Fichet and Wilkie, "Handling Fluorescence in
a Uni-directional Spectral Path Tracer" (EGSR 2018), in every lighting variant its figures
use, with the geometry, re-radiation matrices and spectra it needs.

    python3 scenes/tools/egsr2018.py

Standard library only; the output is deterministic (rerunning rewrites the same bytes). The
scene's description (camera, box, tile grid, lamp, medium) is in scenes/egsr2018/README.md,
which this script does not write.
"""

import math
import os

# EGSR2018_OUT writes elsewhere (the tests compare its output with the committed files).
ROOT = os.environ.get("EGSR2018_OUT") or os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "egsr2018"
)
DATA = os.path.join(ROOT, "data")

# Tile grid: a point with wall coordinates (u, v) in [0, 1]^2 lies on a grid line when
# frac(4u) or frac(4v) is outside [LINE, 1 - LINE).
LINE = 0.0375


def write(path, text):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(text)


def tent(lam, centre, width):
    return max(0.0, 1.0 - abs(lam - centre) / width)


def fmt(x):
    """Compact, exact enough, deterministic."""
    if x == 0.0:
        return "0"
    return f"{x:.6g}"


# ------------------------------------------------------------------------------------------
# The medium's re-radiation matrix: M(li -> lo) = d0 * min(tent_a(li), tent_e(lo)) for lo > li
# on a 1 nm grid (cell centres at whole nm), as the paper's implementation sets it up.
# ------------------------------------------------------------------------------------------


def medium_csv(path, first, last, d0, absorption, emission, title):
    lams = list(range(first, last + 1))
    out = [
        f"# {title}",
        f"# M(li -> lo) = {d0} * min(tent(li; {absorption[0]}, {absorption[1]}), "
        f"tent(lo; {emission[0]}, {emission[1]})) for lo > li, else 0;",
        "# tent(l; c, w) = max(0, 1 - |l - c| / w). Entries are fractions per 1 nm cell; the",
        "# medium's `scale` turns them into coefficients per scene unit. Written by",
        "# scenes/tools/egsr2018.py.",
        "nm," + ",".join(str(l) for l in lams),
    ]
    for li in lams:
        row = []
        for lo in lams:
            m = d0 * min(tent(li, *absorption), tent(lo, *emission)) if lo > li else 0.0
            row.append(fmt(m))
        out.append(str(li) + "," + ",".join(row))
    write(path, "\n".join(out) + "\n")


# ------------------------------------------------------------------------------------------
# Geometry
# ------------------------------------------------------------------------------------------


def intervals():
    """The wall parameter [0, 1] cut into line and tile intervals: (a, b, is_line)."""
    cuts = []
    for k in range(4):
        lo, hi = k / 4, (k + 1) / 4
        a, b = lo + LINE / 4, hi - LINE / 4
        cuts.append((lo, a, True))
        cuts.append((a, b, False))
        cuts.append((b, hi, True))
    # Merge the two halves of each interior line.
    merged = []
    for c in cuts:
        if merged and merged[-1][2] and c[2]:
            merged[-1] = (merged[-1][0], c[1], True)
        else:
            merged.append(c)
    return merged


# Walls of the cube [-1, 1]^3 open towards the camera (y = +1): (name, origin, edge_u, edge_v).
WALLS = [
    ("rear", (-1, -1, -1), (2, 0, 0), (0, 0, 2)),
    ("floor", (-1, -1, -1), (2, 0, 0), (0, 2, 0)),
    ("ceiling", (-1, -1, 1), (2, 0, 0), (0, 2, 0)),
    ("left", (1, -1, -1), (0, 2, 0), (0, 0, 2)),  # x = +1, image left
    ("right", (-1, -1, -1), (0, 2, 0), (0, 0, 2)),  # x = -1, image right
]


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def mul(a, s):
    return tuple(x * s for x in a)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def inward(origin, eu, ev):
    """(eu, ev) ordered so that eu x ev points into the box (towards the origin)."""
    centre = add(origin, add(mul(eu, 0.5), mul(ev, 0.5)))
    if dot(cross(eu, ev), mul(centre, -1)) > 0:
        return eu, ev
    return ev, eu


def walls_obj(path):
    """Every wall as two objects, `<wall>_tiles` and `<wall>_lines`, facing into the box."""
    lines = ["# The tiled walls of the EGSR 2018 box. Written by scenes/tools/egsr2018.py."]
    nv = 0
    for name, origin, eu, ev in WALLS:
        for kind, want_line in (("tiles", False), ("lines", True)):
            lines.append(f"o {name}_{kind}")
            for ua, ub, ul in intervals():
                for va, vb, vl in intervals():
                    if (ul or vl) != want_line:
                        continue
                    corners = [(ua, va), (ub, va), (ub, vb), (ua, vb)]
                    pts = [add(origin, add(mul(eu, u), mul(ev, v))) for u, v in corners]
                    if inward(origin, eu, ev) != (eu, ev):
                        pts = pts[::-1]
                    for p in pts:
                        lines.append("v " + " ".join(fmt(round(c, 9)) for c in p))
                    lines.append(f"f {nv + 1} {nv + 2} {nv + 3}")
                    lines.append(f"f {nv + 1} {nv + 3} {nv + 4}")
                    nv += 4
    write(path, "\n".join(lines) + "\n")


# ------------------------------------------------------------------------------------------
# Scene files
# ------------------------------------------------------------------------------------------

HEADER = """# {title}
# The scene of Mojzík, Fichet and Wilkie, "Handling Fluorescence in a Uni-directional
# Spectral Path Tracer" (EGSR 2018), as its own implementation sets it up
# (scenes/egsr2018/README.md). Written by scenes/tools/egsr2018.py: edit that, not this.
"""

CAMERA = """
[camera]                      # pinhole at (0, 5, 0) looking along -y; +z up, -x image right
position = [0, 5, 0]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov = 27.97
resolution = [256, 256]
{medium_line}
[render]
spp = 256
max_depth = 8                 # the paper's 8 path segments
seed = 0
"""

LAMPS = {
    # The paper's lamp: 1.0 per nm on 300-700 nm (the renderer's range starts at 360).
    "uv-visible": '{ wavelengths = [300, 700], values = [1, 1] }',
    "d65": '{ illuminant = "D65", scale = 0.01 }',
    # Narrow triangles of 20 nm base, peak 10 (the same energy as 50 nm of the lamp above).
    "440nm": '{ wavelengths = [430, 440, 450], values = [0, 10, 0] }',
    "550nm": '{ wavelengths = [540, 550, 560], values = [0, 10, 0] }',
}

MEDIA = {
    # (file, first and last cell centre, d0, absorption (c, w), emission (c, w))
    "420-550": ("medium-420-550.csv", 380, 590, 0.025, (420, 40), (550, 40)),
    "360-620": ("medium-360-620.csv", 360, 700, 0.025, (360, 40), (620, 80)),
}


def medium_block(key):
    file, first, last, d0, (ca, wa), (ce, we) = MEDIA[key]
    return f"""
[media.fluorescent]           # purely fluorescent (no absorption, no elastic scattering),
sigma_a = 0                   # isotropic, filling all space; absorbs {ca} +- {wa} nm, emits {ce} +- {we} nm
sigma_s = 0
matrix = {{ file = "data/{file}", scale = 1.0 }}
"""


def quad(origin, eu, ev, material, extra=""):
    o = ", ".join(fmt(c) for c in origin)
    u = ", ".join(fmt(c) for c in eu)
    v = ", ".join(fmt(c) for c in ev)
    return f"""
[[shapes]]
type = "quad"
origin = [{o}]
edge_u = [{u}]
edge_v = [{v}]
material = "{material}"{extra}
"""


def lamp(half, z, spectrum):
    """A one-sided emitter facing -z, [-half, half]^2 at height z, in a white housing
    (its four sides up to the ceiling; the top is behind the ceiling)."""
    out = quad(
        (-half, -half, z),
        (0, 2 * half, 0),
        (2 * half, 0, 0),
        "housing",
        f'\nemission = {{ radiance = {spectrum}, two_sided = false }}',
    )
    h = round(1.0 - z, 6)
    sides = [
        ((-half, -half, z), (2 * half, 0, 0), (0, 0, h)),  # y = -half, facing -y
        ((half, half, z), (-2 * half, 0, 0), (0, 0, h)),  # y = +half, facing +y
        ((half, -half, z), (0, 2 * half, 0), (0, 0, h)),  # x = +half, facing +x
        ((-half, half, z), (0, -2 * half, 0), (0, 0, h)),  # x = -half, facing -x
    ]
    for o, eu, ev in sides:
        out += quad(o, eu, ev, "housing")
    return out


def tiled_box():
    out = """
[spectra]
tile_white = 1.0
line_white = 0.7
"""
    for name in ["5R_4_14", "5R_6_8", "5PB_4_12", "5PB_6_8", "5Y_7_12", "5Y_8_8"]:
        out += f'munsell_{name} = {{ csv = "data/munsell.csv", column = "{name}" }}\n'
    out += 'macbeth_white = { csv = "data/macbeth.csv", column = "white" }\n'
    looks = {
        "rear": ("tile_white", "line_white"),
        "floor": ("tile_white", "line_white"),
        "left": ("munsell_5R_4_14", "munsell_5R_6_8"),
        "right": ("munsell_5PB_4_12", "munsell_5PB_6_8"),
        "ceiling": ("munsell_5Y_7_12", "munsell_5Y_8_8"),
    }
    for wall, (tile, line) in looks.items():
        for kind, spec in (("tiles", tile), ("lines", line)):
            out += f"""
[materials.{wall}_{kind}]
type = "diffuse"
reflectance = "{spec}"
"""
    out += """
[materials.housing]
type = "diffuse"
reflectance = "macbeth_white"
"""
    for wall in looks:
        for kind in ("tiles", "lines"):
            out += f"""
[[shapes]]
type = "obj"
file = "data/walls.obj"
object = "{wall}_{kind}"
material = "{wall}_{kind}"
"""
    return out


def plain_box():
    out = """
[spectra]
"""
    for name in ["white", "red", "blue", "yellow"]:
        out += f'macbeth_{name} = {{ csv = "data/macbeth.csv", column = "{name}" }}\n'
    for name in ["white", "red", "blue", "yellow"]:
        out += f"""
[materials.{name}]
type = "diffuse"
reflectance = "macbeth_{name}"
"""
    out += """
[materials.housing]
type = "diffuse"
reflectance = "macbeth_white"
"""
    looks = {"rear": "white", "floor": "white", "ceiling": "yellow", "left": "red", "right": "blue"}
    for name, origin, eu, ev in WALLS:
        eu, ev = inward(origin, eu, ev)
        out += quad(origin, eu, ev, looks[name])
    return out


# Sticky-note ("post-it") materials: the project's own dye model fitted by eye to the
# reflectance (diagonal), excitation (row sums) and emission (column sums) of the
# measured BFC-450 matrices of 3M's pink and green notes (shared/egsr2018/*.BFC, which stay
# outside the repository). F = QY * A(li) * E(lo) / int_{l > li} E, so QY * A is the
# measured excitation.
POSTITS = """
[materials.postit_pink]       # fitted to 3M's fluorescent pink note (measured BFC-450 matrix)
type = "fluorescent_diffuse"
reflectance = { wavelengths = [360, 400, 440, 480, 520, 560, 580, 600, 620, 660, 830], values = [0.67, 0.74, 0.68, 0.46, 0.28, 0.25, 0.36, 0.65, 0.87, 0.94, 0.95] }
dye = { absorption = { wavelengths = [360, 400, 440, 480, 520, 560, 580, 600, 620, 640], values = [0.05, 0.025, 0.07, 0.25, 0.37, 0.45, 0.36, 0.11, 0.04, 0] }, emission = { wavelengths = [550, 570, 590, 610, 630, 660, 700, 760, 830], values = [0, 0.2, 0.7, 1.0, 0.8, 0.45, 0.15, 0.05, 0] }, quantum_yield = 0.8 }

[materials.postit_green]      # fitted to 3M's fluorescent green note (measured BFC-450 matrix)
type = "fluorescent_diffuse"
reflectance = { wavelengths = [360, 380, 420, 460, 480, 500, 520, 540, 580, 620, 680, 720, 780, 830], values = [0.21, 0.21, 0.10, 0.08, 0.13, 0.37, 0.71, 0.78, 0.69, 0.63, 0.65, 0.80, 0.90, 0.90] }
dye = { absorption = { wavelengths = [360, 400, 440, 460, 480, 500, 520, 540], values = [0.15, 0.14, 0.2, 0.25, 0.25, 0.15, 0.025, 0] }, emission = { wavelengths = [470, 490, 510, 520, 540, 560, 580, 620, 700, 780, 830], values = [0, 0.2, 0.8, 1.0, 0.8, 0.4, 0.2, 0.06, 0.04, 0.04, 0] }, quantum_yield = 0.8 }

[[shapes]]
type = "sphere"
center = [-0.5, 0.34, -0.6]
radius = 0.4
smooth = true
material = "postit_pink"

[[shapes]]
type = "sphere"
center = [0.3, -0.32, -0.4]
radius = 0.6
smooth = true
material = "postit_green"
"""

# Regions of interest at 256 x 256 (pixel rectangles; min inclusive, max exclusive).
MAIN_REGIONS = """
[[region]]  # the rear wall's centre, seen through six units of the medium
name = "rear-wall"
min = [86, 102]
max = [170, 170]

[[region]]  # the left (red) wall beside the opening, where the medium glows in front of it
name = "left-wall"
min = [4, 60]
max = [40, 196]
"""

TEASER_REGIONS = """
[[region]]  # inside the pink sticky-note sphere's silhouette
name = "postit-pink"
min = [160, 172]
max = [206, 216]

[[region]]  # inside the green sticky-note sphere's silhouette
name = "postit-green"
min = [70, 138]
max = [128, 194]

[[region]]  # the rear wall above the spheres, seen through six units of the medium
name = "rear-wall"
min = [104, 78]
max = [152, 110]
"""


def scene(title, box, lamp_block, medium, regions):
    text = HEADER.format(title=title)
    text += CAMERA.format(medium_line='medium = "fluorescent"\n' if medium else "")
    text += box
    if medium:
        text += medium_block(medium)
    text += lamp_block
    text += regions
    return text


VARIANTS = [
    # (file, title, box, lamp spectrum, lamp half-size and height, medium, regions)
    ("main.toml", "Main scene: the tiled box filled with a medium absorbing 420 nm and emitting 550 nm, lamp 300-700 nm", "tiled", "uv-visible", (0.4, 0.99), "420-550", MAIN_REGIONS),
    ("main-d65-no-volume.toml", "Results: the tiled box under D65, without the medium", "tiled", "d65", (0.4, 0.99), None, MAIN_REGIONS),
    ("main-440nm.toml", "Results: the tiled box under a 440 nm lamp, with the medium (absorbs 420, emits 550)", "tiled", "440nm", (0.4, 0.99), "420-550", MAIN_REGIONS),
    ("main-440nm-no-volume.toml", "Results: the tiled box under a 440 nm lamp, without the medium", "tiled", "440nm", (0.4, 0.99), None, MAIN_REGIONS),
    ("main-550nm.toml", "Results: the tiled box under a 550 nm lamp, with the medium (which is transparent at 550 nm)", "tiled", "550nm", (0.4, 0.99), "420-550", MAIN_REGIONS),
    ("main-550nm-no-volume.toml", "Results: the tiled box under a 550 nm lamp, without the medium", "tiled", "550nm", (0.4, 0.99), None, MAIN_REGIONS),
    ("teaser.toml", "Teaser: sticky-note spheres in a plain box filled with a medium absorbing 360 nm and emitting 620 nm", "plain", "uv-visible", (0.3, 0.999), "360-620", TEASER_REGIONS),
]


def main():
    walls_obj(os.path.join(DATA, "walls.obj"))
    for key, (file, first, last, d0, a, e) in MEDIA.items():
        medium_csv(
            os.path.join(DATA, file), first, last, d0, a, e,
            f"The EGSR 2018 medium re-radiation matrix ({key}), cell centres {first}-{last} nm",
        )
    for file, title, box, spectrum, (half, z), medium, regions in VARIANTS:
        body = tiled_box() if box == "tiled" else plain_box()
        if box == "plain":
            body += POSTITS
        write(os.path.join(ROOT, file), scene(title, body, lamp(half, z, LAMPS[spectrum]), medium, regions))


if __name__ == "__main__":
    main()
