use glam::Vec3;

/// Orthonormal basis; local coordinates have the normal along +z (pbrt/Mitsuba convention),
/// so `cos_theta(w) == w.z` in every BSDF.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame around a unit normal (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// Frame with normal `n` whose first tangent follows `dpdu` as closely as possible
    /// (keeps anisotropic/tangent-dependent effects stable across a triangle).
    pub fn from_normal_tangent(n: Vec3, dpdu: Vec3) -> Self {
        let s = dpdu - n * n.dot(dpdu);
        let len = s.length();
        if !(len > 1e-8) || !len.is_finite() {
            return Self::from_normal(n);
        }
        let s = s / len;
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.81).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.dot(f.t)).abs() < 1e-6 && (f.s.dot(f.n)).abs() < 1e-6);
            assert!((f.s.length() - 1.0).abs() < 1e-6 && (f.t.length() - 1.0).abs() < 1e-6);
            let v = Vec3::new(0.2, 0.7, -0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
            assert!((f.to_local(n) - Vec3::Z).length() < 1e-6);
        }
    }
}
