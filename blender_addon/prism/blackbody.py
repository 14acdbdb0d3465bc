# SPDX-License-Identifier: MIT
"""Linear Rec.709 colour of a black body, scaled to luminance 1: what Blender's Blackbody node
and light Temperature give (its `temperature_color` in 5.0), for Blenders and node setups
where Blender does not compute it for us.

Planck's law integrated against the CIE 1931 2-degree observer in the multi-lobe Gaussian fit
of Wyman, Sloan and Shirley 2013 ("Simple Analytic Approximations to the CIE XYZ Color
Matching Functions", JCGT 2(2), eq. 2-4), then XYZ -> linear Rec.709 (D65). Negative channels
are clamped to 0 and temperatures held to 800-12000 K, as Blender does.
"""

import math

# (weight, mean nm, sigma below the mean, sigma above) per lobe.
_X = ((1.056, 599.8, 37.9, 31.0), (0.362, 442.0, 16.0, 26.7), (-0.065, 501.1, 20.4, 26.2))
_Y = ((0.821, 568.8, 46.9, 40.5), (0.286, 530.9, 16.3, 31.1))
_Z = ((1.217, 437.0, 11.8, 36.0), (0.681, 459.0, 26.0, 13.8))


def _lobes(lam, lobes):
    total = 0.0
    for w, mu, s_lo, s_hi in lobes:
        t = (lam - mu) / (s_lo if lam < mu else s_hi)
        total += w * math.exp(-0.5 * t * t)
    return total


def blackbody_rgb(kelvin):
    """(r, g, b) of a black body at `kelvin`, luminance 1."""
    t = min(max(float(kelvin), 800.0), 12000.0)
    x = y = z = 0.0
    for lam in range(360, 831):
        m = lam * 1e-9
        planck = 1.0 / (m ** 5 * (math.exp(1.438776877e-2 / (m * t)) - 1.0))
        x += planck * _lobes(lam, _X)
        y += planck * _lobes(lam, _Y)
        z += planck * _lobes(lam, _Z)
    r = 3.2404542 * x - 1.5371385 * y - 0.4985314 * z
    g = -0.9692660 * x + 1.8760108 * y + 0.0415560 * z
    b = 0.0556434 * x - 0.2040259 * y + 1.0572252 * z
    r, g, b = max(r, 0.0), max(g, 0.0), max(b, 0.0)
    lum = 0.2126 * r + 0.7152 * g + 0.0722 * b
    return (r / lum, g / lum, b / lum)
