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
}
