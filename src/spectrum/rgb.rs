//! Linear Rec.709/sRGB <-> CIE XYZ (D65 white) and the sRGB transfer function.
//!
//! The matrices use the Rec.709 primaries (ITU-R BT.709) and the white point of the tabulated
//! CIE D65 integrated against the tabulated CIE 1931 observer (`cie::D65_WHITE_XYZ`,
//! xy = 0.31273, 0.32902), rather than the rounded xy = (0.3127, 0.3290) of IEC 61966-2-1.
//! The entries differ from the IEC matrix by < 2e-4, and in exchange the normalised D65
//! illuminant maps to RGB (1, 1, 1) exactly and flat reflectances map exactly to greys, which
//! keeps the spectral round trip (`upsample`) consistent with the film's XYZ -> RGB.
use super::cie;
use glam::{Mat3, Vec3};

/// Linear sRGB -> XYZ; the columns are the XYZ of the primaries (Y of white = 1).
pub const SRGB_TO_XYZ: Mat3 = Mat3::from_cols_array(&cie::SRGB_TO_XYZ_COLS);
/// XYZ -> linear sRGB, the inverse of [`SRGB_TO_XYZ`].
pub const XYZ_TO_SRGB: Mat3 = Mat3::from_cols_array(&cie::XYZ_TO_SRGB_COLS);

#[inline]
pub fn linear_srgb_to_xyz(rgb: Vec3) -> Vec3 {
    SRGB_TO_XYZ * rgb
}

#[inline]
pub fn xyz_to_linear_srgb(xyz: Vec3) -> Vec3 {
    XYZ_TO_SRGB * xyz
}

/// Rec.709 luminance of linear RGB (Blender's colour -> float weights in its default
/// scene-linear space).
#[inline]
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// sRGB electro-optical transfer function (decode 8-bit texture values to linear).
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Inverse of [`srgb_to_linear`] (encode linear values for display).
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrices_are_inverse_and_white_is_d65() {
        let id = SRGB_TO_XYZ * XYZ_TO_SRGB;
        assert!(id.abs_diff_eq(Mat3::IDENTITY, 1e-6), "{id}");
        let w = linear_srgb_to_xyz(Vec3::ONE);
        assert!((w - cie::D65_WHITE_XYZ).abs().max_element() < 1e-6, "{w}");
        assert!(
            (xyz_to_linear_srgb(cie::D65_WHITE_XYZ) - Vec3::ONE)
                .abs()
                .max_element()
                < 1e-6
        );
        // Close to the IEC 61966-2-1 matrix.
        let iec = Mat3::from_cols_array(&[
            0.412_456_4,
            0.212_672_9,
            0.019_333_9,
            0.357_576_1,
            0.715_152_2,
            0.119_192,
            0.180_437_5,
            0.072_175,
            0.950_304_1,
        ]);
        assert!(SRGB_TO_XYZ.abs_diff_eq(iec, 2e-4));
        // Luminance row sums to 1; primaries have the Rec.709 chromaticities.
        let r = SRGB_TO_XYZ.x_axis;
        assert!((r.x / r.element_sum() - 0.64).abs() < 1e-6);
        assert!((r.y / r.element_sum() - 0.33).abs() < 1e-6);
    }

    #[test]
    fn transfer_function_roundtrip() {
        for i in 0..=100 {
            let v = i as f32 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(v)) - v).abs() < 1e-5);
        }
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
    }
}
