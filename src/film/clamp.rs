//! Firefly clamps, as Cycles' Clamp Direct and Clamp Indirect (Light Paths panel): a sample's
//! direct and indirect light are each limited to a maximum luminance before the film adds them.
//!
//! Clamping trades bias for variance: energy above the limit is simply lost. Both limits are 0
//! (off) by default, so Prism stays unbiased unless asked.
//!
//! Two differences from Cycles, both deliberate:
//! - The limit is on luminance (CIE Y, the Y of the film's XYZ), and the whole contribution is
//!   scaled, so its hue is kept. Cycles limits the sum of |R| + |G| + |B|, which is about 3x the
//!   luminance for white light: Cycles' clamp 10 corresponds to about 3.3 here.
//! - The limit applies to the sums of a sample's direct and indirect contributions, not to each
//!   contribution separately (Cycles clamps each light sample and emission hit): a clamped pixel
//!   is then provably at most `direct + indirect`, the bound the tests check.

use glam::Vec3;

/// Per-sample luminance limits; 0 = no limit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleClamp {
    /// Light that reached the camera after at most one scattering event.
    pub direct: f32,
    /// Light that scattered two or more times.
    pub indirect: f32,
}

impl SampleClamp {
    /// Validated limits (each finite and >= 0).
    pub fn new(direct: f32, indirect: f32) -> Result<Self, String> {
        for (name, v) in [("clamp_direct", direct), ("clamp_indirect", indirect)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{name} must be a number >= 0 (0 = off), got {v}"));
            }
        }
        Ok(SampleClamp { direct, indirect })
    }

    pub fn is_off(&self) -> bool {
        self.direct == 0.0 && self.indirect == 0.0
    }

    /// The clamped sum of one sample's direct and indirect XYZ.
    #[inline]
    pub fn apply(&self, direct: Vec3, indirect: Vec3) -> Vec3 {
        limit_luminance(direct, self.direct) + limit_luminance(indirect, self.indirect)
    }
}

/// `xyz` scaled so that its luminance (Y) is at most `limit` (0 = unchanged). Non-finite input
/// stays non-finite, so the film still sees and discards it.
#[inline]
fn limit_luminance(xyz: Vec3, limit: f32) -> Vec3 {
    if limit > 0.0 && xyz.y > limit {
        xyz * (limit / xyz.y)
    } else {
        xyz
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_luminance_and_keeps_chromaticity() {
        let c = SampleClamp::new(1.0, 10.0).unwrap();
        let d = Vec3::new(3.0, 4.0, 5.0);
        let i = Vec3::new(20.0, 40.0, 10.0);
        let out_d = limit_luminance(d, c.direct);
        let out_i = limit_luminance(i, c.indirect);
        assert!((out_d.y - 1.0).abs() < 1e-6 && (out_i.y - 10.0).abs() < 1e-5);
        // Chromaticity (x, y) unchanged.
        let chroma = |v: Vec3| (v.x / (v.x + v.y + v.z), v.y / (v.x + v.y + v.z));
        for (a, b) in [(d, out_d), (i, out_i)] {
            let (ca, cb) = (chroma(a), chroma(b));
            assert!((ca.0 - cb.0).abs() < 1e-6 && (ca.1 - cb.1).abs() < 1e-6);
        }
        assert_eq!(c.apply(d, i), out_d + out_i);
        // Below the limit, and with the limit off: unchanged.
        assert_eq!(
            limit_luminance(Vec3::new(0.1, 0.2, 0.3), 1.0),
            Vec3::new(0.1, 0.2, 0.3)
        );
        assert_eq!(limit_luminance(i, 0.0), i);
        assert!(SampleClamp::default().is_off());
        assert!(!limit_luminance(Vec3::splat(f32::NAN), 1.0).is_finite());
        assert!(!limit_luminance(Vec3::splat(f32::INFINITY), 1.0).is_finite());
        assert!(SampleClamp::new(-1.0, 0.0).is_err() && SampleClamp::new(0.0, f32::NAN).is_err());
    }
}
