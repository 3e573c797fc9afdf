"""A real client reads stokes' spectral EXR: colour-science (read_spectral_image_Fichet2021,
through OpenImageIO's Python bindings) must find the wavelengths stokes wrote, and its
spectra, integrated against the CIE 1931 observer, must give the RGB channels stokes wrote.

The RGB is computed by stokes from every sample's exact wavelengths, the bins average the
same samples over 5 nm: the two differ only by the observer's variation inside a bin, so
the image means agree to 0.5 % and single pixels to a few percent.

Usage: python spectral_exr.py IMAGE.exr BINS LO HI
"""

import subprocess
import sys
import warnings

import numpy as np

warnings.filterwarnings("ignore")  # colour warns about its optional dependencies
import colour  # noqa: E402
import OpenImageIO as oiio  # noqa: E402
from colour.io import read_spectral_image_Fichet2021  # noqa: E402

path, bins, lo, hi = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


components, spec = read_spectral_image_Fichet2021(path, additional_data=True)
check(spec.is_emissive and not spec.is_polarised and not spec.is_bispectral,
      "colour sees an emissive, unpolarised, not bispectral image")
check(list(components) == ["S0"], f"one component S0 (found {list(components)})")
wavelengths, values = components["S0"]
width = (hi - lo) / bins
centres = lo + (np.arange(bins) + 0.5) * width
check(np.allclose(wavelengths, centres, atol=1e-4),
      f"{bins} wavelengths at the bin centres {centres[0]}..{centres[-1]} nm")
attributes = {a.name: a.value for a in spec.attributes}
check(attributes.get("spectralLayoutVersion") == "1.0", "spectralLayoutVersion 1.0")
check(attributes.get("emissiveUnits") == "W.m^-2.sr^-1", "emissiveUnits W.m^-2.sr^-1")

image = oiio.ImageBuf(path)
names = list(image.spec().channelnames)
pixels = image.get_pixels(oiio.FLOAT)
rgb = pixels[:, :, [names.index(c) for c in "RGB"]]

# The observer averaged over each bin, normalised as stokes normalises: Y = ∫L ȳ / ∫ȳ.
cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
cmfs = cmfs.copy().trim(colour.SpectralShape(360, 830, 1))
lam, cmf = cmfs.wavelengths, cmfs.values
y_integral = float(np.sum((cmf[1:, 1] + cmf[:-1, 1]) / 2))  # trapezoids, 1 nm apart
steps = (np.arange(50) + 0.5) / 50 - 0.5  # midpoints across a bin, in bin widths
binned = np.array([[np.interp(c + steps * width, lam, cmf[:, k]).mean() for k in range(3)]
                   for c in wavelengths])
xyz = np.einsum("hwb,bk->hwk", values, binned) * width / y_integral
to_rgb = colour.models.RGB_COLOURSPACE_sRGB.matrix_XYZ_to_RGB
ours = np.einsum("ij,hwj->hwi", to_rgb, xyz)

mean_rgb, mean_ours = rgb.mean(axis=(0, 1)), ours.mean(axis=(0, 1))
rel = np.abs(mean_ours - mean_rgb) / mean_rgb
# 1 nm bins leave only float rounding and the observer's curvature inside a bin.
mean_tol, pixel_tol = (1e-3, 5e-3) if width <= 1 else (5e-3, 2e-2)
check(bool(np.all(rel < mean_tol)),
      f"image mean: colour's integral {mean_ours} against stokes' RGB {mean_rgb} (rel. {rel.max():.2e})")
bright = rgb.sum(axis=2) > 0.1 * rgb.sum(axis=2).mean()
pixel_rel = np.abs(ours - rgb)[bright] / np.maximum(rgb[bright], 1e-3)
check(float(np.median(pixel_rel)) < pixel_tol,
      f"per pixel: median rel. difference {np.median(pixel_rel):.2e} over {bright.sum()} lit pixels")

info = subprocess.run(["oiiotool", "--info", "-v", path], capture_output=True, text=True).stdout
first = f"S0.{centres[0]:.6f}nm".replace(".", ",").replace(",", ".", 1)
check(first in info and "spectralLayoutVersion" in info,
      f"oiiotool --info -v lists {first} and spectralLayoutVersion")

if failures:
    sys.exit(f"{len(failures)} checks failed")
print("spectral EXR client: all checks passed")
