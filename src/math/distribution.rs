/// Piecewise-constant discrete distribution over `n` items, sampled by inverting its CDF
/// (binary search). Used to pick lights in proportion to their power.
#[derive(Clone, Debug, Default)]
pub struct DiscreteDistribution {
    /// cdf[i] = sum of weights of items < i, normalised; len n + 1.
    cdf: Vec<f32>,
    pmf: Vec<f32>,
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
        DiscreteDistribution { cdf, pmf }
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
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let n = self.pmf.len();
        // First i with cdf[i + 1] > u, skipping zero-probability items.
        let i = self.cdf[1..].partition_point(|&c| c <= u).min(n - 1);
        let (lo, hi) = (self.cdf[i], self.cdf[i + 1]);
        let u_remapped = if hi > lo {
            ((u - lo) / (hi - lo)).clamp(0.0, 0.999_999_94)
        } else {
            0.0
        };
        (i, self.pmf[i], u_remapped)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
