//! `prism-rgb2spec-opt`: fits the RGB -> spectrum coefficient table of Jakob & Hanika,
//! "A Low-Dimensional Function Space for Efficient Spectral Upsampling" (Computer Graphics
//! Forum 38(2), 2019) for linear sRGB (Rec.709 primaries, D65 white).
//!
//! ```text
//! cargo run --release --bin prism-rgb2spec-opt -- src/spectrum/data/rgb2spec_srgb.bin [--res 64]
//! ```
//!
//! For every table entry (see `prism::spectrum::upsample` for the layout) we find the
//! coefficients `c` of `s(lambda) = S(c0 t^2 + c1 t + c2)` whose colour under the normalised
//! D65 illuminant matches the entry's RGB in CIELAB (as in the paper): the residual is
//! `Lab(XYZ(s)) - Lab(M rgb)`, with `XYZ(s) = int s D65 cmf / int ybar` computed by Simpson's
//! rule with two panels per nm (exact for the product of the piecewise-linear D65 and CMF
//! tables, so only the smooth sigmoid is approximated) from the renderer's own tables in
//! `prism::spectrum::cie`, and `M` the renderer's sRGB -> XYZ matrix. The 3x3 nonlinear system is solved by Levenberg-Marquardt with the analytic
//! Jacobian, in double precision.
//!
//! The problem is well behaved only near a good initial guess, so (as in the paper) the
//! solutions are continued outward from the grey axis, where the answer is known in closed form
//! (`c0 = c1 = 0`): first across the middle-brightness z-slice of each cube, from its grey
//! corner towards the saturated edges, then from that slice up and down each z-column, every
//! solve starting at its already solved neighbour. The columns are independent and run in
//! parallel (rayon).
//!
//! The z = 0 slice (black, whose exact coefficients are infinite) copies slice 1, which lies at
//! z ~ 2e-6, so colours below it are off by less than that. The white entry (also infinite) is
//! never read: see `RgbToSpectrumTable::lookup`.
//!
//! After writing the table, the program measures the round trip through the f32 table and the
//! renderer's own lookup (`RgbToSpectrumTable::lookup`) on a 17^3 grid plus `--check` random
//! colours (default 200000).

use glam::Vec3;
use prism::spectrum::cie;
use prism::spectrum::rgb::SRGB_TO_XYZ;
use prism::spectrum::upsample::{RgbToSpectrumTable, SIGMOID_LAMBDA_HALF, SIGMOID_LAMBDA_MID};
use rayon::prelude::*;
use std::time::Instant;

type V3 = [f64; 3];
type M3 = [[f64; 3]; 3]; // row-major

/// Simpson panels per 1 nm table interval.
const PANELS_PER_NM: usize = 2;
/// Stop when the CIELAB residual norm is below this (Delta E 1976 units).
const TOLERANCE: f64 = 1e-9;
const MAX_ITERATIONS: usize = 200;

/// Colour of sigmoid-polynomial spectra under normalised D65, and its derivatives.
struct Colorimeter {
    /// Normalised wavelength of each quadrature node.
    t: Vec<f64>,
    /// Quadrature weight x D65 x cmf / int(ybar) per node, one vector per XYZ component.
    w: [Vec<f64>; 3],
    white: V3,
    rgb_to_xyz: M3,
}

impl Colorimeter {
    fn new() -> Self {
        let n = (cie::CIE_SAMPLES - 1) * PANELS_PER_NM;
        let h = 1.0 / PANELS_PER_NM as f64;
        let mut t = Vec::with_capacity(n + 1);
        let mut w = [vec![], vec![], vec![]];
        for k in 0..=n {
            let lambda = cie::CIE_LAMBDA_MIN as f64 + k as f64 * h;
            let simpson = if k == 0 || k == n {
                1.0
            } else if k % 2 == 1 {
                4.0
            } else {
                2.0
            } * h
                / 3.0;
            let l32 = lambda as f32;
            let cmf = cie::cie_xyz_bar(l32);
            let illum = cie::d65_normalized(l32) as f64 * simpson / cie::CIE_Y_INTEGRAL as f64;
            t.push((lambda - SIGMOID_LAMBDA_MID as f64) / SIGMOID_LAMBDA_HALF as f64);
            for (c, wc) in w.iter_mut().enumerate() {
                wc.push(illum * cmf[c] as f64);
            }
        }
        let m = SRGB_TO_XYZ;
        let rgb_to_xyz = std::array::from_fn(|r| std::array::from_fn(|c| m.col(c)[r] as f64));
        let white = mat_vec(&rgb_to_xyz, &[1.0; 3]);
        Self {
            t,
            w,
            white,
            rgb_to_xyz,
        }
    }

    /// XYZ of the spectrum with coefficients `c`, and d XYZ / d c (row = XYZ component).
    fn xyz(&self, c: &V3) -> (V3, M3) {
        // Four independent accumulator lanes so the loop pipelines/vectorises.
        const L: usize = 4;
        let mut acc = [[0.0f64; L]; 12];
        let n = self.t.len();
        let full = n / L * L;
        let node = |k: usize, lane: usize, acc: &mut [[f64; L]; 12]| {
            let t = self.t[k];
            let x = (c[0] * t + c[1]) * t + c[2];
            let d = 1.0 / (1.0 + x * x);
            let sq = d.sqrt();
            let s = 0.5 + 0.5 * x * sq;
            let ds = 0.5 * d * sq;
            let basis = [ds * t * t, ds * t, ds];
            for comp in 0..3 {
                let w = self.w[comp][k];
                acc[comp][lane] += s * w;
                for (j, b) in basis.iter().enumerate() {
                    acc[3 + 3 * comp + j][lane] += b * w;
                }
            }
        };
        for base in (0..full).step_by(L) {
            for lane in 0..L {
                node(base + lane, lane, &mut acc);
            }
        }
        for k in full..n {
            node(k, 0, &mut acc);
        }
        let sum = |q: usize| acc[q].iter().sum::<f64>();
        let xyz = [sum(0), sum(1), sum(2)];
        let jac = std::array::from_fn(|r| std::array::from_fn(|j| sum(3 + 3 * r + j)));
        (xyz, jac)
    }

    /// CIELAB (CIE 015) of `xyz` relative to the D65 white, and d Lab / d XYZ.
    fn lab(&self, xyz: &V3) -> (V3, M3) {
        const DELTA: f64 = 6.0 / 29.0;
        let f = |u: f64| {
            if u > DELTA * DELTA * DELTA {
                let r = u.cbrt();
                (r, 1.0 / (3.0 * r * r))
            } else {
                let k = 1.0 / (3.0 * DELTA * DELTA);
                (u * k + 4.0 / 29.0, k)
            }
        };
        let (fx, dx) = f(xyz[0] / self.white[0]);
        let (fy, dy) = f(xyz[1] / self.white[1]);
        let (fz, dz) = f(xyz[2] / self.white[2]);
        let (dx, dy, dz) = (dx / self.white[0], dy / self.white[1], dz / self.white[2]);
        (
            [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)],
            [
                [0.0, 116.0 * dy, 0.0],
                [500.0 * dx, -500.0 * dy, 0.0],
                [0.0, 200.0 * dy, -200.0 * dz],
            ],
        )
    }

    fn target_lab(&self, rgb: &V3) -> V3 {
        self.lab(&mat_vec(&self.rgb_to_xyz, rgb)).0
    }

    /// Residual `Lab(c) - target` and its Jacobian with respect to `c`.
    fn residual(&self, c: &V3, target: &V3) -> (V3, M3) {
        let (xyz, dxyz) = self.xyz(c);
        let (lab, dlab) = self.lab(&xyz);
        let r = std::array::from_fn(|i| lab[i] - target[i]);
        (r, mat_mul(&dlab, &dxyz))
    }

    /// Levenberg-Marquardt from `c`; returns the coefficients and the final Delta E.
    fn fit(&self, rgb: &V3, mut c: V3) -> (V3, f64) {
        let target = self.target_lab(rgb);
        let (mut r, mut jac) = self.residual(&c, &target);
        let mut err = norm2(&r);
        let mut mu = 1e-6;
        for _ in 0..MAX_ITERATIONS {
            if err.sqrt() < TOLERANCE {
                break;
            }
            // Normal equations (J^T J + mu diag(J^T J)) delta = -J^T r.
            let jt = transpose(&jac);
            let a = mat_mul(&jt, &jac);
            let g = mat_vec(&jt, &r);
            let mut improved = false;
            while mu < 1e10 {
                let mut damped = a;
                for (i, row) in damped.iter_mut().enumerate() {
                    row[i] += mu * a[i][i].max(1e-12);
                }
                let step = match solve3(&damped, &g) {
                    Some(s) => s,
                    None => {
                        mu *= 10.0;
                        continue;
                    }
                };
                let trial = [c[0] - step[0], c[1] - step[1], c[2] - step[2]];
                let (tr, tj) = self.residual(&trial, &target);
                let terr = norm2(&tr);
                if terr.is_finite() && terr < err {
                    c = trial;
                    (r, jac, err) = (tr, tj, terr);
                    mu = (mu * 0.1).max(1e-15);
                    improved = true;
                    break;
                }
                mu *= 10.0;
            }
            if !improved {
                break;
            }
        }
        (c, err.sqrt())
    }

    /// Linear sRGB of the spectrum with (f32) coefficients `c`.
    fn rgb_of(&self, c: [f32; 3]) -> V3 {
        if !c[2].is_finite() {
            // Exact black or white from `SigmoidPolynomial::constant`.
            let v = if c[2] > 0.0 { 1.0 } else { 0.0 };
            return [v; 3];
        }
        let c = c.map(|v| v as f64);
        let (xyz, _) = self.xyz(&c);
        solve3(&self.rgb_to_xyz, &xyz).unwrap()
    }
}

fn mat_vec(m: &M3, v: &V3) -> V3 {
    std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

fn mat_mul(a: &M3, b: &M3) -> M3 {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| a[r][k] * b[k][c]).sum()))
}

fn transpose(m: &M3) -> M3 {
    std::array::from_fn(|r| std::array::from_fn(|c| m[c][r]))
}

fn norm2(v: &V3) -> f64 {
    v.iter().map(|x| x * x).sum()
}

/// Gaussian elimination with partial pivoting.
fn solve3(m: &M3, b: &V3) -> Option<V3> {
    let mut a: [[f64; 4]; 3] = std::array::from_fn(|r| [m[r][0], m[r][1], m[r][2], b[r]]);
    for col in 0..3 {
        let p = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[p][col].is_nan() || a[p][col].abs() <= 1e-300 {
            return None;
        }
        a.swap(col, p);
        let pivot = a[col];
        for row in a.iter_mut().skip(col + 1) {
            let f = row[col] / pivot[col];
            for (v, p) in row.iter_mut().zip(pivot).skip(col) {
                *v -= f * p;
            }
        }
    }
    let mut x = [0.0; 3];
    for r in (0..3).rev() {
        let s: f64 = (r + 1..3).map(|k| a[r][k] * x[k]).sum();
        x[r] = (a[r][3] - s) / a[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// `S^-1(v)`: the c2 of the flat spectrum of value v.
fn flat_c2(v: f64) -> f64 {
    (v - 0.5) / (v * (1.0 - v)).sqrt()
}

struct Fitted {
    coeffs: Vec<V3>,
    delta_e: Vec<f64>,
}

/// The RGB of entry (l, k, j, i).
fn entry_rgb(res: usize, l: usize, k: usize, j: usize, i: usize) -> V3 {
    let z = RgbToSpectrumTable::z_node(k, res);
    let x = RgbToSpectrumTable::xy_node(i, res);
    let y = RgbToSpectrumTable::xy_node(j, res);
    let mut rgb = [0.0; 3];
    rgb[l] = z;
    rgb[(l + 1) % 3] = x * z;
    rgb[(l + 2) % 3] = y * z;
    rgb
}

fn fit_table(cm: &Colorimeter, res: usize) -> Fitted {
    let idx = |l, k, j, i| RgbToSpectrumTable::index(res, l, k, j, i) / 3;
    let n = 3 * res * res * res;
    let mut coeffs = vec![[0.0; 3]; n];
    let mut delta_e = vec![0.0; n];
    let k0 = res / 2;
    let top = res - 1;

    // 1. The middle slice of each cube, continued from its grey corner: first along x = 1,
    //    then along each row of constant y (rows in parallel).
    let edges: Vec<Vec<(V3, f64)>> = (0..3)
        .into_par_iter()
        .map(|l| {
            let mut out = vec![(
                [0.0, 0.0, flat_c2(RgbToSpectrumTable::z_node(k0, res))],
                0.0,
            )];
            for j in (0..top).rev() {
                let init = out.last().unwrap().0;
                out.push(cm.fit(&entry_rgb(res, l, k0, j, top), init));
            }
            out.reverse(); // index by j
            out
        })
        .collect();
    let rows: Vec<Vec<(V3, f64)>> = (0..3 * res)
        .into_par_iter()
        .map(|lj| {
            let (l, j) = (lj / res, lj % res);
            let mut out = vec![edges[l][j]];
            for i in (0..top).rev() {
                let init = out.last().unwrap().0;
                out.push(cm.fit(&entry_rgb(res, l, k0, j, i), init));
            }
            out.reverse(); // index by i
            out
        })
        .collect();

    // 2. Every z-column, from the middle slice up to the top and down to slice 1.
    let columns: Vec<Vec<(V3, f64)>> = (0..3 * res * res)
        .into_par_iter()
        .map(|lji| {
            let (l, j, i) = (lji / (res * res), (lji / res) % res, lji % res);
            let mut col = vec![([0.0; 3], 0.0); res];
            col[k0] = rows[l * res + j][i];
            if i == top && j == top {
                // The grey axis: flat spectra, known exactly.
                for (k, e) in col.iter_mut().enumerate().take(top).skip(1) {
                    *e = ([0.0, 0.0, flat_c2(RgbToSpectrumTable::z_node(k, res))], 0.0);
                }
                // White needs c2 = +inf. Lookups never read this entry with weight (exact greys
                // are special-cased and near-white colours go through their complement), so
                // store the finite value of the slice below.
                col[top] = col[top - 1];
            } else {
                for k in k0 + 1..res {
                    col[k] = cm.fit(&entry_rgb(res, l, k, j, i), col[k - 1].0);
                }
                for k in (1..k0).rev() {
                    col[k] = cm.fit(&entry_rgb(res, l, k, j, i), col[k + 1].0);
                }
            }
            col[0] = col[1]; // black: see the module docs
            col
        })
        .collect();
    for l in 0..3 {
        for j in 0..res {
            for i in 0..res {
                let col = &columns[(l * res + j) * res + i];
                for (k, &(c, e)) in col.iter().enumerate() {
                    coeffs[idx(l, k, j, i)] = c;
                    delta_e[idx(l, k, j, i)] = e;
                }
            }
        }
    }
    Fitted { coeffs, delta_e }
}

fn to_table(res: usize, coeffs: &[V3]) -> RgbToSpectrumTable {
    let flat = coeffs.iter().flat_map(|c| c.map(|v| v as f32)).collect();
    RgbToSpectrumTable::new(res, flat).expect("valid table")
}

/// Worst linear-RGB round-trip error of `table` over `colours`, as (error, colour). With
/// `unbounded`, colours are looked up like `RgbUnboundedSpectrum` (at max component 1/2, scaled
/// back) and the error is relative to the largest component.
fn round_trip_error(
    cm: &Colorimeter,
    table: &RgbToSpectrumTable,
    colours: &[V3],
    unbounded: bool,
) -> (f64, V3) {
    colours
        .par_iter()
        .map(|rgb| {
            let max = rgb[0].max(rgb[1]).max(rgb[2]);
            let scale = if unbounded { 2.0 * max } else { 1.0 };
            let v = Vec3::new(rgb[0] as f32, rgb[1] as f32, rgb[2] as f32) / scale as f32;
            let back = cm.rgb_of(table.lookup(v).c).map(|c| c * scale);
            let e = (0..3).map(|c| (back[c] - rgb[c]).abs()).fold(0.0, f64::max);
            (if unbounded { e / max } else { e }, *rgb)
        })
        .reduce(|| (0.0, [0.0; 3]), |a, b| if b.0 > a.0 { b } else { a })
}

/// Deterministic pseudo-random colours in [0, 1)^3 (SplitMix64).
fn random_colours(n: usize, seed: u64) -> Vec<V3> {
    let mut s = seed;
    let mut next = move || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

fn main() {
    let mut out = None;
    let mut res = 64usize;
    let mut checks = 200_000usize;
    let usage = "usage: prism-rgb2spec-opt <out.bin> [--res N] [--check N]";
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut number = |range: std::ops::RangeInclusive<usize>| {
            args.next()
                .and_then(|v| v.parse().ok())
                .filter(|v| range.contains(v))
                .unwrap_or_else(|| panic!("{a} needs an integer in {range:?}"))
        };
        match a.as_str() {
            "--res" => res = number(4..=256),
            "--check" => checks = number(0..=100_000_000),
            "-h" | "--help" => {
                println!("{usage}");
                return;
            }
            _ => out = Some(a),
        }
    }
    let Some(out) = out else {
        eprintln!("{usage}");
        std::process::exit(2);
    };

    let start = Instant::now();
    let cm = Colorimeter::new();
    eprintln!(
        "fitting {} entries (resolution {res}) on {} threads",
        3 * res * res * res,
        rayon::current_num_threads()
    );
    let fitted = fit_table(&cm, res);
    let fit_time = start.elapsed().as_secs_f64();

    // Fit quality at the nodes (slice 0, black, only copies slice 1).
    let mut worst = (0.0, [0.0; 3]);
    let mut over = [0usize; 3];
    for l in 0..3 {
        for k in 1..res {
            for j in 0..res {
                for i in 0..res {
                    let e = fitted.delta_e[RgbToSpectrumTable::index(res, l, k, j, i) / 3];
                    if e > worst.0 {
                        worst = (e, entry_rgb(res, l, k, j, i));
                    }
                    for (o, tol) in over.iter_mut().zip([1e-8, 1e-6, 1e-4]) {
                        *o += (e > tol) as usize;
                    }
                }
            }
        }
    }
    eprintln!(
        "fit: {fit_time:.1} s; max Delta E {:.2e} at rgb {:.4?}; entries above 1e-8 / 1e-6 / 1e-4: {over:?}",
        worst.0, worst.1
    );

    let table = to_table(res, &fitted.coeffs);
    let bytes = table.to_bytes();
    std::fs::write(&out, &bytes).unwrap_or_else(|e| panic!("writing {out}: {e}"));
    eprintln!("wrote {out} ({} bytes)", bytes.len());

    // Round trip through the f32 table and the renderer's lookup, off the nodes.
    if checks > 0 {
        let mut colours = random_colours(checks, 0x5eed);
        let g = 17;
        for b in 0..g {
            for gg in 0..g {
                for r in 0..g {
                    let v = |q: usize| q as f64 / (g - 1) as f64;
                    colours.push([v(r), v(gg), v(b)]);
                }
            }
        }
        let (e, at) = round_trip_error(&cm, &table, &colours, false);
        eprintln!(
            "round trip over {} colours (17^3 grid + random): max abs error {e:.2e} at {at:.4?}",
            colours.len()
        );
        colours.retain(|c| c.iter().any(|&v| v > 0.0));
        let (e, at) = round_trip_error(&cm, &table, &colours, true);
        eprintln!(
            "unbounded (looked up at max 1/2): max error / max component {e:.2e} at {at:.4?}"
        );
    }
    eprintln!("total {:.1} s", start.elapsed().as_secs_f64());
}
