//! Statistics helpers for Monte Carlo tests: a small deterministic RNG, the regularised
//! incomplete gamma function (chi-square p-values), Pearson's chi-square test with pooling of
//! sparse bins, and adaptive Simpson quadrature in 1D and 2D.
#![allow(dead_code)]

/// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
/// Algorithms for Random Number Generation", XSH-RR output). Deterministic, so tests are too.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    const MUL: u64 = 6364136223846793005;

    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MUL).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1) with 24 random bits (every value exactly representable).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() >> 5) as u64;
        let lo = (self.next_u32() >> 6) as u64;
        ((hi << 26) | lo) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }
}

/// ln Gamma(x) for x > 0 by the Lanczos approximation (Lanczos 1964; g = 7, n = 9 coefficient
/// set as tabulated by Godfrey), with the reflection formula below 0.5. ~1e-15 relative.
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x) = Gamma(a, x) / Gamma(a).
/// Series for P when x < a + 1 (Abramowitz & Stegun 6.5.29), else the continued fraction for
/// Q (A&S 6.5.31) evaluated with the modified Lentz method.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    assert!(a > 0.0, "gamma_q: a must be positive");
    if x <= 0.0 {
        return 1.0;
    }
    let log_prefactor = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = x^a e^-x / Gamma(a+1) * sum_n x^n / ((a+1)...(a+n)).
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut ap = a;
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * log_prefactor.exp()).clamp(0.0, 1.0)
    } else {
        // Q(a, x) = x^a e^-x / Gamma(a) * 1 / (x + 1 - a - 1(1-a)/(x + 3 - a - ...)).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (log_prefactor.exp() * h).clamp(0.0, 1.0)
    }
}

/// Upper tail probability of the chi-square distribution with `dof` degrees of freedom.
pub fn chi2_sf(chi2: f64, dof: usize) -> f64 {
    gamma_q(dof as f64 / 2.0, chi2 / 2.0)
}

#[derive(Clone, Debug)]
pub struct Chi2Result {
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Number of cells after pooling.
    pub cells: usize,
}

impl Chi2Result {
    /// Fails the test unless the fit's p-value exceeds `min_p`, naming `what` was tested.
    #[track_caller]
    pub fn assert_fits(&self, min_p: f64, what: impl std::fmt::Display) {
        assert!(
            self.p_value > min_p,
            "{what}: chi2 {:.1}, dof {}, p {:.2e} (needs > {min_p:.0e})",
            self.chi2,
            self.dof,
            self.p_value
        );
    }
}

/// Pearson's chi-square goodness-of-fit test. All cells whose expected count is below
/// `min_expected` are pooled into one cell, which absorbs the next smallest cells while it is
/// itself below `min_expected` (the usual validity rule of the chi-square approximation,
/// Cochran 1954). Observations in a pool of zero expectation make the statistic infinite.
pub fn chi2_test(observed: &[f64], expected: &[f64], min_expected: f64) -> Chi2Result {
    assert_eq!(observed.len(), expected.len());
    let mut idx: Vec<usize> = (0..expected.len()).collect();
    idx.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_obs, mut pool_exp) = (0.0, 0.0);
    let mut chi2 = 0.0;
    let mut cells = 0usize;
    for &i in &idx {
        let (o, e) = (observed[i], expected[i]);
        if !(e > 0.0) && o > 0.0 {
            // Samples where the density says there can be none.
            chi2 = f64::INFINITY;
        }
        if e < min_expected || pool_exp < min_expected {
            pool_obs += o;
            pool_exp += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pool_exp > 0.0 {
        chi2 += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
        cells += 1;
    }
    let dof = cells.saturating_sub(1).max(1);
    let p_value = if chi2.is_finite() {
        chi2_sf(chi2, dof)
    } else {
        0.0
    };
    Chi2Result {
        chi2,
        dof,
        p_value,
        cells,
    }
}

/// Adaptive Simpson quadrature of `f` over [a, b] to absolute tolerance `eps`, refining at
/// least `min_depth` and at most `max_depth` times (Lyness 1969 error estimate
/// |S2 - S1| / 15 with Richardson correction).
pub fn adaptive_simpson(
    f: &mut dyn FnMut(f64) -> f64,
    a: f64,
    b: f64,
    eps: f64,
    min_depth: u32,
    max_depth: u32,
) -> f64 {
    let fa = f(a);
    let fb = f(b);
    let m = 0.5 * (a + b);
    let fm = f(m);
    let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    simpson_rec(f, a, b, fa, fm, fb, whole, eps, 0, min_depth, max_depth)
}

#[allow(clippy::too_many_arguments)]
fn simpson_rec(
    f: &mut dyn FnMut(f64) -> f64,
    a: f64,
    b: f64,
    fa: f64,
    fm: f64,
    fb: f64,
    whole: f64,
    eps: f64,
    depth: u32,
    min_depth: u32,
    max_depth: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
    let (flm, frm) = (f(lm), f(rm));
    let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    let delta = left + right - whole;
    if depth >= max_depth || (depth >= min_depth && delta.abs() <= 15.0 * eps) {
        return left + right + delta / 15.0;
    }
    simpson_rec(
        f,
        a,
        m,
        fa,
        flm,
        fm,
        left,
        0.5 * eps,
        depth + 1,
        min_depth,
        max_depth,
    ) + simpson_rec(
        f,
        m,
        b,
        fm,
        frm,
        fb,
        right,
        0.5 * eps,
        depth + 1,
        min_depth,
        max_depth,
    )
}

/// Nested adaptive Simpson over the rectangle [x0, x1] x [y0, y1] (outer in x, inner in y).
#[allow(clippy::too_many_arguments)]
pub fn adaptive_simpson_2d(
    f: &dyn Fn(f64, f64) -> f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    eps: f64,
    min_depth: u32,
    max_depth: u32,
) -> f64 {
    let inner_eps = eps / (x1 - x0).abs().max(1e-300);
    let mut outer = |x: f64| {
        let mut g = |y: f64| f(x, y);
        adaptive_simpson(&mut g, y0, y1, inner_eps, min_depth, max_depth)
    };
    adaptive_simpson(&mut outer, x0, x1, eps, min_depth, max_depth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_and_chi2_reference_values() {
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        // Chi-square upper tail, 95th percentiles (A&S table 26.8).
        assert!((chi2_sf(3.841_458_820_694_124, 1) - 0.05).abs() < 1e-9);
        assert!((chi2_sf(18.307_038_053_275_146, 10) - 0.05).abs() < 1e-9);
        assert!((chi2_sf(124.342_113_404_047_3, 100) - 0.05).abs() < 1e-9);
        // dof = 2: Q = exp(-x/2).
        assert!((chi2_sf(7.0, 2) - (-3.5f64).exp()).abs() < 1e-12);
    }

    #[test]
    fn assert_fits_passes_a_fit_and_fails_a_mismatch() {
        let expected = vec![1000.0; 10];
        chi2_test(&expected, &expected, 5.0).assert_fits(1e-4, "exact counts");
        let skewed: Vec<f64> = (0..10).map(|i| 820.0 + 40.0 * i as f64).collect();
        let r = chi2_test(&skewed, &expected, 5.0);
        assert!(std::panic::catch_unwind(|| r.assert_fits(1e-4, "skewed counts")).is_err());
    }

    #[test]
    fn pooling_keeps_sparse_cells_together() {
        // 100 sparse cells (expected 0.5 each) plus 3 large ones: one pool of 50 + 3 cells.
        let mut e = vec![0.5; 100];
        e.extend([100.0, 200.0, 300.0]);
        let mut o = vec![0.0; 100];
        o[0] = 50.0;
        o.extend([100.0, 200.0, 300.0]);
        let r = chi2_test(&o, &e, 5.0);
        assert_eq!(r.cells, 4);
        assert!(r.chi2.abs() < 1e-12 && r.dof == 3);
        // A sample where nothing is expected is rejected outright.
        let r = chi2_test(&[1.0, 10.0], &[0.0, 11.0], 5.0);
        assert_eq!(r.p_value, 0.0);
    }

    #[test]
    fn simpson_integrates_a_peak() {
        let f = |x: f64, y: f64| (-((x - 0.3) * (x - 0.3) + (y - 0.6) * (y - 0.6)) / 1e-4).exp();
        let v = adaptive_simpson_2d(&f, 0.0, 1.0, 0.0, 1.0, 1e-10, 3, 20);
        let exact = std::f64::consts::PI * 1e-4;
        assert!((v - exact).abs() < 1e-7 * exact.max(1.0), "{v} vs {exact}");
    }
}
