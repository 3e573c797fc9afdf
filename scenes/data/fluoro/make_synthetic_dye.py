#!/usr/bin/env python3
"""Writes synthetic_dye_10nm.csv: a SYNTHETIC re-radiation matrix (not measured data).

Run from this folder: python3 make_synthetic_dye.py > synthetic_dye_10nm.csv
The format is described in the header the script writes and in src/fluoro/mod.rs.
"""
import math


def gauss(x, mu, sigma):
    return math.exp(-0.5 * ((x - mu) / sigma) ** 2)


def absorption(l):  # fraction absorbed, in [0, 1]
    return min(1.0, 0.85 * gauss(l, 440.0, 28.0) + 0.25 * gauss(l, 375.0, 15.0))


def emission(l):  # relative emission shape
    return gauss(l, 520.0, 22.0) + 0.35 * gauss(l, 575.0, 45.0)


PHI = 0.8  # quantum yield (fraction of absorbed energy re-emitted)
H = 10.0  # cell width, nm
CENTRES = [365.0 + H * k for k in range(47)]  # cells [360, 370) ... [820, 830)

# Deliberate defects that the importer must set to zero and count:
# (excitation nm, emission nm) -> value
PLANTED = {
    (415.0, 705.0): -0.00031,  # negative (measurement noise)
    (435.0, 785.0): -0.00018,  # negative
    (505.0, 485.0): 0.0012,  # anti-Stokes: emission shorter than excitation
    (525.0, 515.0): 0.0007,  # anti-Stokes
}


def fmt(v):
    s = f"{v:.5f}".rstrip("0").rstrip(".")
    return "0" if s in ("0", "-0") else s


def main():
    n = len(CENTRES)
    e = [emission(c) for c in CENTRES]
    print("# SYNTHETIC re-radiation matrix for testing the stokes importer -- NOT measured data.")
    print("# Made by scenes/data/fluoro/make_synthetic_dye.py from an invented dye:")
    print("#   absorption A(l) = min(1, 0.85 g(l; 440, 28) + 0.25 g(l; 375, 15)),")
    print("#   emission   E(l) = g(l; 520, 22) + 0.35 g(l; 575, 45),  g(l; mu, s) = exp(-(l-mu)^2 / (2 s^2)),")
    print("#   quantum yield 0.8 (energy), diagonal (ordinary reflectance) D(l) = 0.9 (1 - A(l)).")
    print("# Off-diagonal m[i][o] = 0.8 A(c_i) E(c_o) / sum_{o' > i} E(c_o') for o > i, at cell centres c.")
    print("# Four entries are deliberately wrong (two negative, two anti-Stokes: 505->485, 525->515)")
    print("# so that the importer's clamping is exercised.")
    print("#")
    print("# Format: the header is 'nm' then the emission wavelengths; each row is an excitation")
    print("# wavelength then one entry per emission wavelength. Wavelengths are CELL CENTRES (nm),")
    print("# evenly spaced (here 10 nm cells covering 360-830 nm), and the excitation list equals the")
    print("# emission list. Entry m[i][o] = fraction of spectral radiance in excitation cell i")
    print("# re-emitted into emission cell o (dimensionless; the density is F = m / 10 nm).")
    print("# The diagonal m[i][i] is the ordinary reflectance.")
    print("nm," + ",".join(fmt(c) for c in CENTRES))
    for i, ci in enumerate(CENTRES):
        a = absorption(ci)
        tail = sum(e[i + 1:])
        row = []
        for o, co in enumerate(CENTRES):
            if o == i:
                v = 0.9 * (1.0 - a)
            elif o > i and tail > 0.0:
                v = PHI * a * e[o] / tail
            else:
                v = 0.0
            v = PLANTED.get((ci, co), v)
            row.append(fmt(v))
        print(fmt(ci) + "," + ",".join(row))


if __name__ == "__main__":
    main()
