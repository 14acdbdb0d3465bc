//! Thin-film interference: a transparent film of thickness `d` and IOR `n_f` on a dielectric
//! (soap bubbles, anti-reflection coatings, oil on water). Blender's Principled Thin Film,
//! glTF's `KHR_materials_iridescence`.
//!
//! A spectral renderer can compute it exactly per wavelength, where an RGB renderer has to
//! average it over each channel's band (Cycles: Belcour & Barla 2017, in XYZ). The reflected
//! amplitude of the three-layer stack (ambient 1 / film 2 / substrate 3) is the Airy sum of
//! the multiply-reflected waves (Born & Wolf, "Principles of Optics", sec. 1.6.4, eq. 58;
//! Hecht, "Optics", sec. 9.7):
//!
//! ```text
//! r = (r12 + r23 e^{i delta}) / (1 + r12 r23 e^{i delta}),   delta = 4 pi n2 d cos(theta2) / lambda
//! R = (|r_s|^2 + |r_p|^2) / 2                                  (unpolarised light)
//! ```
//!
//! with the Fresnel amplitude coefficients of each interface for s and p polarisation and
//! complex cosines from Snell's law, so that total internal reflection inside the film or at
//! the substrate (an evanescent wave) is handled by the same formula. The film absorbs
//! nothing: the transmitted fraction is `1 - R`.

use crate::math::PI;

/// A thin film's thickness (nanometres) and IOR.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinFilm {
    pub thickness_nm: f32,
    pub ior: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Complex {
    re: f64,
    im: f64,
}

impl Complex {
    const fn real(re: f64) -> Complex {
        Complex { re, im: 0.0 }
    }
    fn add(self, o: Complex) -> Complex {
        Complex {
            re: self.re + o.re,
            im: self.im + o.im,
        }
    }
    fn sub(self, o: Complex) -> Complex {
        Complex {
            re: self.re - o.re,
            im: self.im - o.im,
        }
    }
    fn mul(self, o: Complex) -> Complex {
        Complex {
            re: self.re * o.re - self.im * o.im,
            im: self.re * o.im + self.im * o.re,
        }
    }
    fn scale(self, k: f64) -> Complex {
        Complex {
            re: self.re * k,
            im: self.im * k,
        }
    }
    fn div(self, o: Complex) -> Complex {
        let d = o.re * o.re + o.im * o.im;
        Complex {
            re: (self.re * o.re + self.im * o.im) / d,
            im: (self.im * o.re - self.re * o.im) / d,
        }
    }
    fn norm_sqr(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    /// The principal square root (non-negative real part; for a negative real argument,
    /// positive imaginary part: the evanescent wave that decays into the medium).
    fn sqrt(self) -> Complex {
        let r = self.norm_sqr().sqrt();
        let re = ((r + self.re) * 0.5).max(0.0).sqrt();
        let im = ((r - self.re) * 0.5).max(0.0).sqrt();
        Complex {
            re,
            im: if self.im < 0.0 { -im } else { im },
        }
    }
    /// e^{i phi}.
    fn cis(phi: f64) -> Complex {
        Complex {
            re: phi.cos(),
            im: phi.sin(),
        }
    }
}

/// Fresnel amplitude reflection coefficients (s, p) from a medium of (complex) IOR `n_i` and
/// cosine `cos_i` into one of `n_t`, `cos_t` (Born & Wolf sec. 1.5.2, eqs. 20a/21a; cosines
/// complex past the critical angle, IOR and cosine complex in an absorbing medium, sec. 14.2).
fn amplitudes(n_i: Complex, cos_i: Complex, n_t: Complex, cos_t: Complex) -> (Complex, Complex) {
    let a = n_i.mul(cos_i);
    let b = n_t.mul(cos_t);
    let r_s = a.sub(b).div(a.add(b));
    let c = n_t.mul(cos_i);
    let d = n_i.mul(cos_t);
    let r_p = c.sub(d).div(c.add(d));
    (r_s, r_p)
}

impl ThinFilm {
    /// Reflectance of the film-coated interface for light arriving with cosine `cos_i` to the
    /// (outward) normal, at wavelength `lambda_nm`. `eta` is the substrate's IOR relative to
    /// the outside, as in `fresnel_dielectric`, and the film lies on the outside of the
    /// interface (its IOR relative to the outside). A negative `cos_i` is light from inside the
    /// substrate. Returns a value in [0, 1]; 1 for degenerate input.
    pub fn reflectance(&self, cos_i: f32, eta: f32, lambda_nm: f32) -> f32 {
        if !(eta > 0.0) || !eta.is_finite() || cos_i.is_nan() || !(self.ior > 0.0) {
            return 1.0;
        }
        // IORs of the incident medium and the far medium, the incident one first.
        let (n1, n3) = if cos_i >= 0.0 {
            (1.0f64, eta as f64)
        } else {
            (eta as f64, 1.0f64)
        };
        self.airy(n1, cos_i.abs(), Complex::real(n3), lambda_nm)
    }

    /// Reflectance of the film on a conductor of complex IOR `n + i k` (relative to the
    /// outside, where the light arrives with cosine `cos_i` > 0): the same Airy sum with the
    /// absorbing substrate's complex amplitudes (Born & Wolf sec. 14.4.1; the wave entering
    /// the metal is evanescent, so nothing comes back from beyond the interface). Metals under
    /// an oxide or oil film: Blender's Principled Thin Film on the metallic part.
    pub fn reflectance_conductor(&self, cos_i: f32, n: f32, k: f32, lambda_nm: f32) -> f32 {
        let valid = n > 0.0 && n.is_finite() && k >= 0.0 && k.is_finite();
        if !valid || cos_i.is_nan() || !(self.ior > 0.0) {
            return 1.0;
        }
        let n3 = Complex {
            re: n as f64,
            im: k as f64,
        };
        self.airy(1.0, cos_i.max(0.0), n3, lambda_nm)
    }

    /// The Airy sum for light from a medium of IOR `n1` at cosine `cos_1` through the film onto
    /// a substrate of complex IOR `n3`.
    fn airy(&self, n1: f64, cos_1: f32, n3: Complex, lambda_nm: f32) -> f32 {
        let n2 = self.ior as f64;
        let c1 = (cos_1 as f64).min(1.0);
        let sin2_1 = 1.0 - c1 * c1;
        // Snell: n1 sin1 = n2 sin2 = n3 sin3, cos = sqrt(1 - sin^2), complex past the
        // critical angle and in an absorbing medium.
        let cos_in = |n: Complex| {
            let ratio = Complex::real(n1).div(n);
            Complex::real(1.0)
                .sub(ratio.mul(ratio).scale(sin2_1))
                .sqrt()
        };
        let n2c = Complex::real(n2);
        let (c1, c2, c3) = (Complex::real(c1), cos_in(n2c), cos_in(n3));
        let (r12_s, r12_p) = amplitudes(Complex::real(n1), c1, n2c, c2);
        let (r23_s, r23_p) = amplitudes(n2c, c2, n3, c3);
        // Round-trip phase through the film (complex when the wave in it is evanescent).
        let k = 4.0 * PI as f64 * n2 * self.thickness_nm.max(0.0) as f64 / lambda_nm as f64;
        let phase = c2.scale(k);
        // e^{i phase} for complex phase = e^{-Im} (cos Re + i sin Re).
        let e = Complex::cis(phase.re).scale((-phase.im).exp());
        let airy = |r12: Complex, r23: Complex| {
            let num = r12.add(r23.mul(e));
            let den = Complex::real(1.0).add(r12.mul(r23).mul(e));
            num.div(den).norm_sqr()
        };
        let r = 0.5 * (airy(r12_s, r23_s) + airy(r12_p, r23_p));
        if r.is_finite() {
            r.clamp(0.0, 1.0) as f32
        } else {
            1.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::fresnel_dielectric;

    /// Normal incidence against the closed form (Hecht eq. 9.101 with real coefficients):
    /// R = (r12^2 + r23^2 + 2 r12 r23 cos delta) / (1 + r12^2 r23^2 + 2 r12 r23 cos delta).
    #[test]
    fn normal_incidence_matches_the_closed_form() {
        let film = ThinFilm {
            thickness_nm: 380.0,
            ior: 1.33,
        };
        let n3 = 1.5f64;
        for lambda in [380.0f32, 450.0, 532.0, 600.0, 700.0, 780.0] {
            let r12 = (1.0 - 1.33) / (1.0 + 1.33);
            let r23 = (1.33 - n3) / (1.33 + n3);
            let delta = 4.0 * std::f64::consts::PI * 1.33 * 380.0 / lambda as f64;
            let c = 2.0 * r12 * r23 * delta.cos();
            let want = (r12 * r12 + r23 * r23 + c) / (1.0 + r12 * r12 * r23 * r23 + c);
            let got = film.reflectance(1.0, 1.5, lambda) as f64;
            assert!((got - want).abs() < 1e-5, "{lambda} nm: {got} vs {want}");
        }
    }

    /// A quarter-wave coating of IOR sqrt(n) reflects nothing at its design wavelength (the
    /// principle of anti-reflection coatings) and more elsewhere.
    #[test]
    fn quarter_wave_coating_cancels_reflection() {
        let n = 1.9f32;
        let film = ThinFilm {
            thickness_nm: 550.0 / (4.0 * n.sqrt()),
            ior: n.sqrt(),
        };
        assert!(film.reflectance(1.0, n, 550.0) < 1e-6);
        assert!(film.reflectance(1.0, n, 400.0) > 0.01);
    }

    /// No film (thickness 0, or a film of the substrate's IOR, or of the outside's) is the
    /// plain dielectric Fresnel at every angle and from both sides, total internal reflection
    /// included.
    #[test]
    fn vanishing_films_give_plain_fresnel() {
        for cos in [1.0f32, 0.8, 0.4, 0.1, -1.0, -0.9, -0.75, -0.5, -0.2] {
            let plain = fresnel_dielectric(cos, 1.5);
            for film in [
                ThinFilm {
                    thickness_nm: 0.0,
                    ior: 1.33,
                },
                ThinFilm {
                    thickness_nm: 300.0,
                    ior: 1.5,
                },
                ThinFilm {
                    thickness_nm: 300.0,
                    ior: 1.0,
                },
            ] {
                let r = film.reflectance(cos, 1.5, 500.0);
                assert!(
                    (r - plain).abs() < 1e-5,
                    "{film:?} cos {cos}: {r} vs {plain}"
                );
            }
        }
    }

    /// The unpolarised Fresnel reflectance of a bare conductor (Born & Wolf sec. 14.2), by the
    /// classic closed form.
    fn conductor_fresnel(cos: f32, n: f32, k: f32) -> f32 {
        let (c2, s2) = (cos * cos, 1.0 - cos * cos);
        let a = n * n - k * k - s2;
        let t = (a * a + 4.0 * n * n * k * k).sqrt();
        let a2b2 = t;
        let a_ = (0.5 * (t + a)).sqrt();
        let rs = (a2b2 + c2 - 2.0 * a_ * cos) / (a2b2 + c2 + 2.0 * a_ * cos);
        let rp = rs * (a2b2 * c2 + s2 * s2 - 2.0 * a_ * cos * s2)
            / (a2b2 * c2 + s2 * s2 + 2.0 * a_ * cos * s2);
        0.5 * (rs + rp)
    }

    /// On a conductor, a vanishing film (thickness 0, or a film of the outside's IOR) leaves
    /// the metal's own Fresnel reflectance; k = 0 is the dielectric case.
    #[test]
    fn vanishing_films_on_a_conductor_give_its_fresnel() {
        // Gold at 550 nm (n 0.43, k 2.46) and aluminium-like (1.2, 7.0).
        for (n, k) in [(0.43f32, 2.46f32), (1.2, 7.0), (2.9, 3.1)] {
            for cos in [1.0f32, 0.8, 0.5, 0.2, 0.05] {
                let plain = conductor_fresnel(cos, n, k);
                for film in [
                    ThinFilm {
                        thickness_nm: 0.0,
                        ior: 1.4,
                    },
                    ThinFilm {
                        thickness_nm: 250.0,
                        ior: 1.0,
                    },
                ] {
                    let r = film.reflectance_conductor(cos, n, k, 550.0);
                    assert!(
                        (r - plain).abs() < 1e-5,
                        "n {n} k {k} cos {cos} {film:?}: {r} vs {plain}"
                    );
                }
            }
        }
        let film = ThinFilm {
            thickness_nm: 300.0,
            ior: 1.33,
        };
        for cos in [1.0f32, 0.6, 0.1] {
            let (a, b) = (
                film.reflectance_conductor(cos, 1.5, 0.0, 520.0),
                film.reflectance(cos, 1.5, 520.0),
            );
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
    }

    /// A film on a metal shifts the phase and colours the reflection: across thicknesses the
    /// reflectance stays in [0, 1], goes below the bare metal's (destructive interference) and
    /// above it, and the metal's absorption keeps it from reaching 0.
    #[test]
    fn film_on_a_metal_interferes_and_stays_bounded() {
        let (n, k) = (0.43f32, 2.46f32);
        let bare = conductor_fresnel(1.0, n, k);
        let (mut lo, mut hi) = (1.0f32, 0.0f32);
        for d in 1..200 {
            let film = ThinFilm {
                thickness_nm: d as f32 * 4.0,
                ior: 1.5,
            };
            for cos in [1.0f32, 0.5, 0.05] {
                let r = film.reflectance_conductor(cos, n, k, 550.0);
                assert!((0.0..=1.0).contains(&r), "{r}");
            }
            let r = film.reflectance_conductor(1.0, n, k, 550.0);
            lo = lo.min(r);
            hi = hi.max(r);
        }
        assert!(
            lo < bare - 0.1 && hi > bare && lo > 0.05,
            "{lo} {bare} {hi}"
        );
    }

    /// A film denser than both sides (a soap film in air) can totally reflect inside itself
    /// only past the outside's critical angle; the result stays in [0, 1] at every angle and
    /// thickness, and oscillates with the thickness (interference).
    #[test]
    fn soap_film_is_bounded_and_iridescent() {
        let mut lo = 1.0f32;
        let mut hi = 0.0f32;
        for d in 0..200 {
            let film = ThinFilm {
                thickness_nm: d as f32 * 5.0,
                ior: 1.33,
            };
            for cos in [1.0f32, 0.5, 0.05, -0.6] {
                let r = film.reflectance(cos, 1.0, 550.0);
                assert!((0.0..=1.0).contains(&r), "{r}");
                if cos == 1.0 && d > 0 {
                    lo = lo.min(r);
                    hi = hi.max(r);
                }
            }
        }
        // Fringes: from ~0 (destructive) to 4 r^2 / (1 + r^2)^2 ~ 0.077 (constructive).
        assert!(lo < 1e-4 && (hi - 0.0767).abs() < 2e-3, "{lo} {hi}");
    }
}
