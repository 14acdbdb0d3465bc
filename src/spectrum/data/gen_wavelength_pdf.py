#!/usr/bin/env python3
"""Generate `wavelength_pdf.rs`: the shape of the `rgb` wavelength density (`WavelengthPdf::Rgb`)
as log-density knots, fitted to the renderer's four-member hero-wavelength rule.

The renderer does not run this; its output is committed. To regenerate (about a minute):

    python3 -m venv /tmp/wpdfenv && /tmp/wpdfenv/bin/pip install numpy scipy
    /tmp/wpdfenv/bin/python src/spectrum/data/gen_wavelength_pdf.py src/spectrum/data/wavelength_pdf.rs

What is fitted. A path carries N = 4 wavelengths, lambda_k = P^-1(u + k/N) (mod 1) for one
uniform u (`SampledWavelengths::sample_hero`): one member in each N-quantile of the density p.
Linear Rec.709 channel c of a pixel is estimated by (1/N) sum_k f(lambda_k) c_bar(lambda_k) /
p(lambda_k), f a spectrum the path picked up (D65 x reflectances, for Blender's RGB colours
upsampled by the sigmoid-polynomial model of Jakob & Hanika 2019). Its variance over u is the
colour noise the wavelengths alone add. The density that minimises the variance of ONE
wavelength (p ~ sqrt(sum_c (f c_bar / int f c_bar)^2), Cauchy-Schwarz) is not the one that
minimises the four-member rule's: that depends on how the N-quantiles split each channel's
integral, which a pointwise formula does not see.

So p = 0.4 x the luminance bell (`visible_wavelength_pdf`; the floor keeps any wavelength at
0.4 of the bell's density, so a narrow-band light is never a firefly source) + 0.6 x q, with
log q piecewise linear on 25 knots over 360-830 nm, and the knots minimise

    sum over spectra f, channels c of Var_u[estimate_c] / (mean_c^2 + 0.05 max_c' mean_c'^2)

(relative variance per channel, with a floor so that a channel a colour hardly has does not
dominate; the benchmark's relMSE weighs channels the same way) over reflectances of white, a
Cornell red and green, skin, marble and a jade green, each once and squared (two bounces),
under D65. Powell's method from the single-wavelength optimum. On 40 random RGB reflectances
and 20 products of two (not fitted), the four-member variance is a median 0.31x / 0.41x that of
the single-wavelength optimum mixed the same way (the worst colour 1.2x / 1.5x), the
single-wavelength variance 1.04x.
"""

import re
import sys

import numpy as np
from scipy.optimize import least_squares, minimize

HERE = __file__.rsplit("/", 1)[0]
N_MEMBERS = 4
KNOTS = 25
BELL_SHARE = 0.4
VIS_CENTER, VIS_K = 538.0, 0.0072  # sampled.rs: the luminance bell


def table(src, name, n):
    m = re.search(r"pub const %s: \[f32; %d\] = \[(.*?)\];" % (name, n), src, re.S)
    return np.array([float(x) for x in m.group(1).replace("\n", " ").split(",") if x.strip()])


def main(out_path):
    src = open(HERE + "/cie_data.rs").read()
    lam = np.arange(360.0, 831.0)
    xyz = np.vstack([table(src, n, 471) for n in ("CIE_X", "CIE_Y", "CIE_Z")])
    d65 = table(src, "CIE_D65", 471)
    to_rgb = table(src, "XYZ_TO_SRGB", 9).reshape(3, 3).T  # stored column-major
    centres = np.arange(360, 830) + 0.5
    cmf = np.stack([np.interp(centres, lam, row) for row in to_rgb @ xyz], 1)
    white = cmf * np.interp(centres, lam, d65)[:, None]  # D65 x c_bar per 1-nm bin

    def sigmoid_spectrum(c):
        t = (centres - 360.0) / 470.0
        x = (c[0] * t + c[1]) * t + c[2]
        return 0.5 + x / (2.0 * np.sqrt(1.0 + x * x))

    def reflectance(rgb):
        unit = white / white[:, 1].sum()
        fit = least_squares(lambda c: (sigmoid_spectrum(c)[:, None] * unit).sum(0) - rgb, [0, 0, 0])
        return sigmoid_spectrum(fit.x)

    colours = [(0.8, 0.8, 0.8), (0.63, 0.065, 0.05), (0.14, 0.45, 0.09), (0.85, 0.55, 0.45),
               (0.83, 0.79, 0.75), (0.3, 0.6, 0.35)]
    spectra = []
    for rgb in colours:
        f = reflectance(np.array(rgb))
        spectra += [f, f * f]

    bell = VIS_K / np.cosh(VIS_K * (centres - VIS_CENTER)) ** 2
    bell /= bell.sum()
    u = (np.arange(4096) + 0.5) / 4096 / N_MEMBERS

    def rule_variance(p, f):
        cdf = np.concatenate([[0.0], np.cumsum(p)])
        est = 0.0
        for k in range(N_MEMBERS):
            i = np.clip(np.searchsorted(cdf, u + k / N_MEMBERS, side="right") - 1, 0, len(p) - 1)
            est = est + f[i, None] * white[i] / p[i, None] / N_MEMBERS
        mean, var = est.mean(0), est.var(0)
        return (var / (mean**2 + 0.05 * mean.max() ** 2)).sum()

    knots = np.linspace(360.0, 830.0, KNOTS)

    def density(theta):
        q = np.exp(np.interp(centres, knots, np.maximum(theta, -40.0)))
        return BELL_SHARE * bell + (1.0 - BELL_SHARE) * q / q.sum()

    # Start from the single-wavelength optimum for the first spectrum (grey, as fitted):
    # sqrt(sum_c (f D65 c_bar / int f D65 c_bar)^2). Powell's result depends on the start (the
    # objective has many shallow minima of about the same value), so this is kept as it was.
    f = spectra[0][:, None] * white
    single = np.sqrt(((f / f.sum(0)) ** 2).sum(1))
    theta0 = np.interp(knots, centres, np.log(single + 1e-30))
    fit = minimize(lambda t: sum(rule_variance(density(t), f) for f in spectra), theta0,
                   method="Powell", options={"maxiter": 4000, "xtol": 1e-3, "ftol": 1e-5})
    theta = np.maximum(fit.x, -40.0)
    theta -= theta.max()
    print("objective %.4f (single-wavelength optimum %.4f)" % (
        fit.fun, sum(rule_variance(density(theta0), f) for f in spectra)))
    with open(out_path, "w") as out:
        out.write("// @generated by src/spectrum/data/gen_wavelength_pdf.py; do not edit by hand.\n")
        out.write("// log q at %d knots evenly spaced over 360-830 nm (shifted to max 0); the `rgb`\n" % KNOTS)
        out.write("// wavelength density is %.1f x the luminance bell + %.1f x q normalised.\n\n" % (BELL_SHARE, 1 - BELL_SHARE))
        out.write("pub const RGB_PDF_BELL_SHARE: f32 = %.1f;\n\n" % BELL_SHARE)
        out.write("#[rustfmt::skip]\npub const RGB_PDF_LOG_KNOTS: [f32; %d] = [\n" % KNOTS)
        for i in range(0, KNOTS, 5):
            out.write("    " + " ".join("%.4f," % v for v in theta[i:i + 5]) + "\n")
        out.write("];\n")


if __name__ == "__main__":
    main(sys.argv[1])
