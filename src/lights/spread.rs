//! Blender's area light Spread: emission narrowed to a cone around the emitter's normal, as a
//! soft box with a grid of slats in front of it.
//!
//! The model is Blender's (D10594, as Cycles evaluates it): the fraction of a slatted box's
//! opening seen at angle `a` from the normal is proportional to tan(h) - tan(a) for a < h, with
//! h half the spread angle, so the radiance is L f(a), f(a) = max(tan h - tan a, 0) N. The
//! constant N keeps the emitted power that of the Lambertian emitter of radiance L:
//! power / (L A) = 2 pi N int_0^h (tan h - tan a) cos a sin a da = pi N (tan h - h), so
//! N = 1 / (tan h - h) (and 3 / h^3, its limit, for small h where the difference cancels).
//! Light selection (by power) and sampling (by area) are therefore unchanged; only the
//! radiance a direction receives is.

/// The emission profile of a spread below 180 degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    tan_half: f32,
    normalize: f32,
}

impl Spread {
    /// The profile of a full spread angle `spread` (radians); `None` at pi and above (the
    /// Lambertian emitter, f = 1).
    pub fn new(spread: f32) -> Option<Spread> {
        if !(spread < std::f32::consts::PI - 1e-6) {
            return None;
        }
        let half = (0.5 * spread).max(0.0);
        let tan_half = half.tan();
        let normalize = if half > 0.05 {
            1.0 / (tan_half - half)
        } else {
            // tan h - h = h^3 / 3 + O(h^5): the difference loses all precision in f32.
            3.0 / half.max(1e-6).powi(3)
        };
        Some(Spread {
            tan_half,
            normalize,
        })
    }

    /// The factor f on the radiance emitted at angle acos(`cos_a`) from the normal.
    pub fn attenuation(&self, cos_a: f32) -> f32 {
        let cos_a = cos_a.abs().min(1.0);
        if cos_a <= 0.0 {
            return 0.0;
        }
        let tan_a = (1.0 - cos_a * cos_a).max(0.0).sqrt() / cos_a;
        ((self.tan_half - tan_a) * self.normalize).max(0.0)
    }

    /// Cosine of the half angle beyond which nothing is emitted (for the light tree's bounds).
    pub fn cos_cutoff(&self) -> f32 {
        1.0 / (1.0 + self.tan_half * self.tan_half).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::Spread;

    /// The emitted power is the Lambertian emitter's: int f(a) cos a dw over the hemisphere
    /// = pi, for wide, narrow and very narrow spreads.
    #[test]
    fn spread_keeps_the_power() {
        for degrees in [150.0f64, 90.0, 45.0, 10.0, 4.0] {
            let s = Spread::new((degrees as f32).to_radians()).unwrap();
            let n = 200_000;
            let h = std::f64::consts::FRAC_PI_2 / n as f64;
            let integral: f64 = (0..n)
                .map(|i| {
                    let a = (i as f64 + 0.5) * h;
                    s.attenuation(a.cos() as f32) as f64 * a.cos() * a.sin()
                })
                .sum::<f64>()
                * h
                * 2.0
                * std::f64::consts::PI;
            assert!(
                (integral / std::f64::consts::PI - 1.0).abs() < 2e-3,
                "{degrees} degrees: {integral}"
            );
        }
        assert!(Spread::new(std::f32::consts::PI).is_none());
    }

    /// Nothing outside the cone; on the axis, the factor that keeps the power.
    #[test]
    fn spread_is_a_cone() {
        let s = Spread::new(60f32.to_radians()).unwrap();
        assert_eq!(s.attenuation(31f32.to_radians().cos()), 0.0);
        assert!(s.attenuation(29f32.to_radians().cos()) > 0.0);
        let h = 30f32.to_radians();
        assert!((s.attenuation(1.0) - h.tan() / (h.tan() - h)).abs() < 1e-4);
        assert!((s.cos_cutoff() - h.cos()).abs() < 1e-6);
    }
}
