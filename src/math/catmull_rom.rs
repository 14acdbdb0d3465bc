//! Catmull-Rom splines over non-uniformly spaced nodes: interpolation weights, integration,
//! inversion of a monotonic spline and sampling of a 2D tabulated density (one dimension
//! interpolated, the other sampled). Used by the BSSRDF profile table.
//!
//! Each segment [x1, x2] is a cubic Hermite curve whose end derivatives are the centred
//! differences (f2 - f0) / (x2 - x0) and (f3 - f1) / (x3 - x1) (Catmull & Rom 1974), falling
//! back to the one-sided difference (f2 - f1) / (x2 - x1) at the ends of the table. With
//! t = (x - x1) / (x2 - x1) and derivatives scaled by the segment width (d1, d2):
//! f(t) = h00 f1 + h01 f2 + h10 d1 + h11 d2, where
//! h00 = 2t^3 - 3t^2 + 1, h01 = -2t^3 + 3t^2, h10 = t^3 - 2t^2 + t, h11 = t^3 - t^2.

/// Index `i` of the segment [nodes[i], nodes[i+1]] that contains `x` (clamped to the table).
fn find_segment(nodes: &[f32], x: f32) -> usize {
    // First node strictly greater than x, minus one.
    let p = nodes.partition_point(|&n| n <= x);
    p.saturating_sub(1).min(nodes.len().saturating_sub(2))
}

/// Four spline weights for evaluating at `x`: the value is `sum_k w[k] * f[offset + k]`
/// (entries whose index falls outside the table have weight 0). `None` outside the nodes.
pub fn catmull_rom_weights(nodes: &[f32], x: f32) -> Option<(isize, [f32; 4])> {
    let n = nodes.len();
    if n < 2 || !(x >= nodes[0] && x <= nodes[n - 1]) {
        return None;
    }
    Some(catmull_rom_weights_in(nodes, x, find_segment(nodes, x)))
}

/// `catmull_rom_weights` for an `x` inside the nodes whose segment `i` the caller knows (a
/// table with a closed-form node spacing finds it without the search).
pub fn catmull_rom_weights_in(nodes: &[f32], x: f32, i: usize) -> (isize, [f32; 4]) {
    let n = nodes.len();
    let (x1, x2) = (nodes[i], nodes[i + 1]);
    let width = x2 - x1;
    let t = if width > 0.0 { (x - x1) / width } else { 0.0 };
    let (t2, t3) = (t * t, t * t * t);
    let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
    let h01 = -2.0 * t3 + 3.0 * t2;
    let h10 = t3 - 2.0 * t2 + t;
    let h11 = t3 - t2;
    let mut w = [0.0f32, h00, h01, 0.0];
    // d1 = (f2 - f0) * width / (x2 - x0), or f2 - f1 at the table's start.
    if i > 0 {
        let s = width / (x2 - nodes[i - 1]);
        w[0] -= h10 * s;
        w[2] += h10 * s;
    } else {
        w[1] -= h10;
        w[2] += h10;
    }
    // d2 = (f3 - f1) * width / (x3 - x1), or f2 - f1 at the table's end.
    if i + 2 < n {
        let s = width / (nodes[i + 2] - x1);
        w[1] -= h11 * s;
        w[3] += h11 * s;
    } else {
        w[1] -= h11;
        w[2] += h11;
    }
    (i as isize - 1, w)
}

/// Evaluates the spline through (nodes, values) at `x` (0 outside the nodes).
pub fn catmull_rom_eval(nodes: &[f32], values: &[f32], x: f32) -> f32 {
    let Some((offset, w)) = catmull_rom_weights(nodes, x) else {
        return 0.0;
    };
    let mut v = 0.0;
    for (k, wk) in w.iter().enumerate() {
        let idx = offset + k as isize;
        if *wk != 0.0 && idx >= 0 && (idx as usize) < values.len() {
            v += wk * values[idx as usize];
        }
    }
    v
}

/// Scaled end derivatives (d1, d2) of segment i of the spline through (x, f).
fn segment_derivatives(x: &[f32], f: &[f32], i: usize) -> (f32, f32) {
    let width = x[i + 1] - x[i];
    let d1 = if i > 0 {
        (f[i + 1] - f[i - 1]) * width / (x[i + 1] - x[i - 1])
    } else {
        f[i + 1] - f[i]
    };
    let d2 = if i + 2 < x.len() {
        (f[i + 2] - f[i]) * width / (x[i + 2] - x[i])
    } else {
        f[i + 1] - f[i]
    };
    (d1, d2)
}

/// Integral of the spline over [x[0], x[n-1]]; `cdf[i]` receives the integral up to x[i].
/// Exact for the cubic: over one segment, width * ((f1 + f2) / 2 + (d1 - d2) / 12).
pub fn integrate_catmull_rom(x: &[f32], f: &[f32], cdf: &mut [f32]) -> f32 {
    let mut sum = 0.0f64;
    if let Some(c) = cdf.first_mut() {
        *c = 0.0;
    }
    for i in 0..x.len().saturating_sub(1) {
        let (d1, d2) = segment_derivatives(x, f, i);
        let width = (x[i + 1] - x[i]) as f64;
        sum += width * ((f[i] + f[i + 1]) as f64 * 0.5 + (d1 - d2) as f64 / 12.0);
        cdf[i + 1] = sum as f32;
    }
    sum as f32
}

/// Value and integral from the segment start (in units of t, not x) of one Hermite segment.
#[inline]
fn hermite_value_integral(t: f32, f1: f32, f2: f32, d1: f32, d2: f32) -> (f32, f32) {
    let (t2, t3, t4) = (t * t, t * t * t, t * t * t * t);
    let value = (2.0 * t3 - 3.0 * t2 + 1.0) * f1
        + (-2.0 * t3 + 3.0 * t2) * f2
        + (t3 - 2.0 * t2 + t) * d1
        + (t3 - t2) * d2;
    let integral = (0.5 * t4 - t3 + t) * f1
        + (-0.5 * t4 + t3) * f2
        + (0.25 * t4 - 2.0 / 3.0 * t3 + 0.5 * t2) * d1
        + (0.25 * t4 - t3 / 3.0) * d2;
    (value, integral)
}

/// Solves `g(t) = target` for t in [0, 1] where g is increasing with derivative `dg`: Newton
/// steps, falling back to bisection whenever a step leaves the bracket.
fn newton_bisection(mut g: impl FnMut(f32) -> (f32, f32), target: f32, t0: f32) -> f32 {
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    let mut t = t0.clamp(0.0, 1.0);
    for _ in 0..60 {
        let (value, slope) = g(t);
        let err = value - target;
        if err.abs() < 1e-5 * target.abs().max(1e-6) {
            break;
        }
        if err < 0.0 {
            lo = t;
        } else {
            hi = t;
        }
        if hi - lo < 1e-6 {
            break;
        }
        let next = t - err / slope;
        t = if next > lo && next < hi && next.is_finite() {
            next
        } else {
            0.5 * (lo + hi)
        };
    }
    t
}

/// The `x` where the monotonically increasing spline through (x, f) takes the value `y`
/// (clamped to the ends of the table).
pub fn invert_catmull_rom(x: &[f32], f: &[f32], y: f32) -> f32 {
    let n = x.len();
    if !(y > f[0]) {
        return x[0];
    }
    if !(y < f[n - 1]) {
        return x[n - 1];
    }
    let i = find_segment(f, y);
    let (d1, d2) = segment_derivatives(x, f, i);
    let (f1, f2) = (f[i], f[i + 1]);
    let t = newton_bisection(
        |t| {
            let (t2, t3) = (t * t, t * t * t);
            let v = (2.0 * t3 - 3.0 * t2 + 1.0) * f1
                + (-2.0 * t3 + 3.0 * t2) * f2
                + (t3 - 2.0 * t2 + t) * d1
                + (t3 - t2) * d2;
            let dv = (6.0 * t2 - 6.0 * t) * f1
                + (-6.0 * t2 + 6.0 * t) * f2
                + (3.0 * t2 - 4.0 * t + 1.0) * d1
                + (3.0 * t2 - 2.0 * t) * d2;
            (v, dv)
        },
        y,
        (y - f1) / (f2 - f1),
    );
    x[i] + t * (x[i + 1] - x[i])
}

/// A 2D table `values[i * nodes2.len() + j]` over (nodes1 x nodes2) with per-row running
/// integrals `cdf` (from `integrate_catmull_rom`). Interpolates the rows at `alpha` (first
/// dimension) and samples the second dimension in proportion to the interpolated spline.
/// Returns (sample, spline value there, density = value / integral), or None if the
/// interpolated row integrates to zero or alpha is outside the table.
pub fn sample_catmull_rom_2d(
    nodes1: &[f32],
    nodes2: &[f32],
    values: &[f32],
    cdf: &[f32],
    alpha: f32,
    u: f32,
) -> Option<(f32, f32, f32)> {
    let (offset, w) = catmull_rom_weights(nodes1, alpha)?;
    let n2 = nodes2.len();
    let row = |table: &[f32], j: usize| -> f32 {
        let mut v = 0.0;
        for (k, wk) in w.iter().enumerate() {
            let r = offset + k as isize;
            if *wk != 0.0 && r >= 0 && (r as usize) < nodes1.len() {
                v += wk * table[r as usize * n2 + j];
            }
        }
        v
    };
    let total = row(cdf, n2 - 1);
    if !(total > 0.0) {
        return None;
    }
    let target = u * total;
    // Last node whose interpolated running integral is <= target.
    let mut lo = 0usize;
    let mut hi = n2 - 1;
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if row(cdf, mid) <= target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let i = lo;
    let (x1, x2) = (nodes2[i], nodes2[i + 1]);
    let width = x2 - x1;
    let (f0, f1, f2) = (
        if i > 0 { row(values, i - 1) } else { 0.0 },
        row(values, i),
        row(values, i + 1),
    );
    let f3 = if i + 2 < n2 { row(values, i + 2) } else { 0.0 };
    let d1 = if i > 0 {
        (f2 - f0) * width / (x2 - nodes2[i - 1])
    } else {
        f2 - f1
    };
    let d2 = if i + 2 < n2 {
        (f3 - f1) * width / (nodes2[i + 2] - x1)
    } else {
        f2 - f1
    };
    // Remaining mass to place inside the segment, in units of t (the segment's integral over t
    // is its integral over x divided by the width).
    let rest = (target - row(cdf, i)) / width;
    let seg_total = (row(cdf, i + 1) - row(cdf, i)) / width;
    let guess = if seg_total > 0.0 {
        rest / seg_total
    } else {
        0.5
    };
    let t = newton_bisection(
        |t| {
            let (v, int) = hermite_value_integral(t, f1, f2, d1, d2);
            (int, v)
        },
        rest,
        guess,
    );
    let (value, _) = hermite_value_integral(t, f1, f2, d1, d2);
    Some((x1 + t * width, value, value / total))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_reproduce_cubic_inside_and_nodes() {
        let x: Vec<f32> = (0..10).map(|i| (i as f32 * 0.3).powf(1.3)).collect();
        let f: Vec<f32> = x.iter().map(|&v| 2.0 * v + 1.0).collect();
        // Nodes are reproduced exactly, linear functions everywhere.
        for &xv in &[0.0, 0.05, 0.7, 1.9, x[9]] {
            let v = catmull_rom_eval(&x, &f, xv);
            assert!((v - (2.0 * xv + 1.0)).abs() < 1e-4, "{xv}: {v}");
        }
        assert_eq!(catmull_rom_eval(&x, &f, -0.1), 0.0);
    }

    #[test]
    fn integral_and_inverse() {
        let x: Vec<f32> = (0..40).map(|i| i as f32 * 0.1).collect();
        let f: Vec<f32> = x.iter().map(|&v| v * v).collect();
        let mut cdf = vec![0.0; 40];
        let total = integrate_catmull_rom(&x, &f, &mut cdf);
        let exact = 3.9f32.powi(3) / 3.0;
        assert!((total - exact).abs() < 2e-3 * exact, "{total} vs {exact}");
        let xi = invert_catmull_rom(&x, &f, 2.0);
        assert!((xi - 2.0f32.sqrt()).abs() < 1e-3, "{xi}");
    }

    #[test]
    fn sample_2d_inverts_the_row_cdf() {
        let n1: Vec<f32> = vec![0.0, 0.5, 1.0];
        let n2: Vec<f32> = (0..20).map(|i| i as f32 * 0.1).collect();
        let mut values = Vec::new();
        let mut cdf = vec![0.0; 60];
        for (r, a) in n1.iter().enumerate() {
            let row: Vec<f32> = n2.iter().map(|&x| 1.0 + a * x).collect();
            integrate_catmull_rom(&n2, &row, &mut cdf[r * 20..(r + 1) * 20]);
            values.extend(row);
        }
        // Row alpha = 0 is constant: uniform sampling over [0, 1.9].
        let (x, v, pdf) = sample_catmull_rom_2d(&n1, &n2, &values, &cdf, 0.0, 0.25).unwrap();
        assert!((x - 0.475).abs() < 1e-4, "{x}");
        assert!((v - 1.0).abs() < 1e-5 && (pdf - 1.0 / 1.9).abs() < 1e-4);
    }
}
