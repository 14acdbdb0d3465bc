/// Piecewise-constant discrete distribution over `n` items, sampled by inverting its CDF
/// (binary search, or a guide table for hot small tables). Used to pick lights in proportion
/// to their power, texels of an environment map, offsets of the pixel filter.
#[derive(Clone, Debug, Default)]
pub struct DiscreteDistribution {
    /// cdf[i] = sum of weights of items < i, normalised; len n + 1.
    cdf: Vec<f32>,
    pmf: Vec<f32>,
    /// Optional guide table (Chen & Asau 1974, "On generating random variates from an
    /// empirical distribution"): guide[k] is the item that u = k / n falls in, so the item of
    /// any u in [k / n, (k + 1) / n) is found by a short forward scan from guide[k] instead of
    /// a binary search. Empty: binary search. Either way the same item is chosen.
    guide: Vec<u32>,
}

impl DiscreteDistribution {
    /// Negative and non-finite weights count as 0. If all are 0, the distribution is uniform.
    pub fn new(weights: &[f32]) -> Self {
        let clean: Vec<f64> = weights
            .iter()
            .map(|&w| {
                if w.is_finite() && w > 0.0 {
                    w as f64
                } else {
                    0.0
                }
            })
            .collect();
        let total: f64 = clean.iter().sum();
        let n = clean.len();
        let pmf: Vec<f32> = if total > 0.0 {
            clean.iter().map(|&w| (w / total) as f32).collect()
        } else {
            vec![1.0 / n.max(1) as f32; n]
        };
        let mut cdf = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for (i, &w) in clean.iter().enumerate() {
            acc += if total > 0.0 {
                w / total
            } else {
                1.0 / n as f64
            };
            cdf.push(if i + 1 == n { 1.0 } else { acc as f32 });
        }
        DiscreteDistribution {
            cdf,
            pmf,
            guide: Vec::new(),
        }
    }

    /// Adds a guide table of `len()` entries (one u32 per item): sampling then costs O(1) on
    /// average (the pixel filter samples twice per camera ray).
    pub fn with_guide_table(mut self) -> Self {
        let n = self.pmf.len();
        self.guide = (0..n)
            .map(|k| self.search(k as f32 / n as f32) as u32)
            .collect();
        self
    }

    /// First item i with cdf[i + 1] > u (skipping zero-probability items), at most n - 1.
    #[inline]
    fn search(&self, u: f32) -> usize {
        let n = self.pmf.len();
        self.cdf[1..].partition_point(|&c| c <= u).min(n - 1)
    }

    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf.get(i).copied().unwrap_or(0.0)
    }

    /// Returns (index, probability, u remapped to [0,1) within the chosen item for reuse).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let n = self.pmf.len();
        let i = if self.guide.is_empty() {
            self.search(u)
        } else {
            // u is about k / n or above: its item is guide[k] or a few after. (Rounding of
            // u * n can put u just below k / n: step back where cdf[i] > u.)
            let k = ((u * n as f32) as usize).min(n - 1);
            let mut i = self.guide[k] as usize;
            while i > 0 && self.cdf[i] > u {
                i -= 1;
            }
            while i + 1 < n && self.cdf[i + 1] <= u {
                i += 1;
            }
            i
        };
        let (lo, hi) = (self.cdf[i], self.cdf[i + 1]);
        let u_remapped = if hi > lo {
            ((u - lo) / (hi - lo)).clamp(0.0, 0.999_999_94)
        } else {
            0.0
        };
        (i, self.pmf[i], u_remapped)
    }
}

/// A tabulated 1D density on [0, 1) sampled in O(1) without branches: the inverse of its CDF
/// at `M` uniform steps of u, interpolated linearly. x(u) is monotone (stratified u stay
/// stratified) and the density it samples is, exactly, piecewise constant between
/// consecutive knots: p(x) = 1 / (M (x_{m+1} - x_m)) on [x_m, x_{m+1}), the source density
/// averaged over each knot interval. [`Self::pdf`] returns that density, so estimates that
/// divide by it stay unbiased. For the hot per-camera-sample tables (wavelengths, pixel
/// filter), whose [`DiscreteDistribution`] guide-table search was 4-8% of a render in
/// mispredicted branches.
#[derive(Clone, Debug)]
pub struct InverseCdf {
    /// x_m = F^-1(m / M), m = 0..=M; x_0 = 0, x_M = 1.
    knots: Vec<f32>,
    /// For x-bucket j (of M): the first knot interval that reaches into [j / M, (j + 1) / M).
    first_interval: Vec<u32>,
}

impl InverseCdf {
    /// Knot intervals of `resolution` steps of u, over the density that is constant on each of
    /// `weights`' bins (uniform bins of [0, 1)); weights as [`DiscreteDistribution::new`].
    pub fn new(weights: &[f32], resolution: usize) -> Self {
        let bins = DiscreteDistribution::new(weights).with_guide_table();
        let n = bins.len() as f32;
        let m = resolution.max(1);
        let mut knots: Vec<f32> = (0..=m)
            .map(|k| {
                if k == m {
                    return 1.0;
                }
                let (i, _, within) = bins.sample(k as f32 / m as f32);
                ((i as f32 + within) / n).min(1.0)
            })
            .collect();
        // Rounding must not make x(u) decrease.
        for k in 1..knots.len() {
            knots[k] = knots[k].max(knots[k - 1]);
        }
        let mut first_interval = Vec::with_capacity(m);
        let mut interval = 0usize;
        for j in 0..m {
            let x = j as f32 / m as f32;
            while interval + 1 < m && knots[interval + 1] <= x {
                interval += 1;
            }
            first_interval.push(interval as u32);
        }
        InverseCdf {
            knots,
            first_interval,
        }
    }

    /// (x, p(x)) for u in [0, 1).
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32) {
        let m = self.knots.len() - 1;
        let t = u.clamp(0.0, 1.0) * m as f32;
        let k = (t as usize).min(m - 1);
        let (x0, x1) = (self.knots[k], self.knots[k + 1]);
        let width = x1 - x0;
        let x = (x0 + (t - k as f32) * width).min(x1);
        (x, 1.0 / (m as f32 * width).max(f32::MIN_POSITIVE))
    }

    /// The density of [`Self::sample`] at x (0 outside [0, 1]).
    pub fn pdf(&self, x: f32) -> f32 {
        if !(0.0..=1.0).contains(&x) {
            return 0.0;
        }
        let m = self.knots.len() - 1;
        let mut k = self.first_interval[((x * m as f32) as usize).min(m - 1)] as usize;
        while k + 1 < m && self.knots[k + 1] <= x {
            k += 1;
        }
        let width = self.knots[k + 1] - self.knots[k];
        if width > 0.0 {
            1.0 / (m as f32 * width)
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The guide table picks exactly the item the binary search picks, for every u (also at
    /// the boundaries and through zero-probability items).
    #[test]
    fn guide_table_matches_binary_search() {
        let weights: Vec<f32> = (0..97)
            .map(|i| {
                if i % 7 == 3 {
                    0.0
                } else {
                    ((i * 37) % 11) as f32 + 0.1
                }
            })
            .collect();
        let plain = DiscreteDistribution::new(&weights);
        let guided = plain.clone().with_guide_table();
        for k in 0..100_000u32 {
            let u = (k as f32 / 100_000.0).min(0.999_999_94);
            assert_eq!(plain.sample(u), guided.sample(u), "u = {u}");
        }
        for i in 0..=97 {
            let u = plain.cdf[i].min(0.999_999_94);
            assert_eq!(plain.sample(u), guided.sample(u), "cdf[{i}] = {u}");
        }
    }

    #[test]
    fn samples_in_proportion() {
        let d = DiscreteDistribution::new(&[1.0, 0.0, 3.0, f32::NAN]);
        let mut counts = [0usize; 4];
        let n = 100_000;
        for k in 0..n {
            let (i, p, ur) = d.sample((k as f32 + 0.5) / n as f32);
            assert!((0.0..1.0).contains(&ur));
            assert_eq!(p, d.pmf(i));
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        assert_eq!(counts[3], 0);
        assert!((counts[0] as f32 / n as f32 - 0.25).abs() < 1e-3);
        assert!((counts[2] as f32 / n as f32 - 0.75).abs() < 1e-3);
        let u = DiscreteDistribution::new(&[0.0, 0.0]);
        assert_eq!(u.pmf(0), 0.5);
    }

    /// x(u) is monotone, the density integrates to 1, follows the source density, and is the
    /// density returned with each sample. (That it is the density of the samples is checked by
    /// chi-square through its users: tests/pixel_filter.rs, tests/spectrum_roundtrip.rs.)
    #[test]
    fn inverse_cdf_samples_its_own_density() {
        let weights: Vec<f32> = (0..200)
            .map(|i| {
                let x = (i as f32 + 0.5) / 200.0;
                (-30.0 * (x - 0.3) * (x - 0.3)).exp() + 0.02
            })
            .collect();
        let d = InverseCdf::new(&weights, 256);
        let mut last = 0.0;
        let steps = 100_000;
        let mut integral = 0.0;
        for k in 0..steps {
            let (x, p) = d.sample((k as f32 + 0.5) / steps as f32);
            assert!(x >= last && (0.0..=1.0).contains(&x), "{x} after {last}");
            assert!((p - d.pdf(x)).abs() <= 1e-3 * p, "{p} vs {}", d.pdf(x));
            last = x;
            integral += d.pdf((k as f32 + 0.5) / steps as f32) / steps as f32;
        }
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
        // Close to the source density where it is smooth.
        let total: f32 = weights.iter().sum::<f32>() / 200.0;
        for x in [0.1f32, 0.3, 0.5, 0.9] {
            let source = weights[(x * 200.0) as usize] / total;
            assert!(
                (d.pdf(x) / source - 1.0).abs() < 0.05,
                "{x}: {} vs {source}",
                d.pdf(x)
            );
        }
    }
}
