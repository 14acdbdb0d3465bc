//! Linear Rec.709/sRGB <-> CIE XYZ (D65 white) and the sRGB transfer function.
use glam::{Mat3, Vec3};

// Rec.709 primaries with D65 white (IEC 61966-2-1), columns are the primaries' XYZ.
const SRGB_TO_XYZ: Mat3 = Mat3::from_cols_array(&[
    0.412_456_4, 0.212_672_9, 0.019_333_9, 0.357_576_1, 0.715_152_2, 0.119_192, 0.180_437_5,
    0.072_175, 0.950_304_1,
]);

pub fn linear_srgb_to_xyz(rgb: Vec3) -> Vec3 {
    SRGB_TO_XYZ * rgb
}

pub fn xyz_to_linear_srgb(xyz: Vec3) -> Vec3 {
    SRGB_TO_XYZ.inverse() * xyz
}

/// sRGB electro-optical transfer function (decode 8-bit texture values to linear).
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}
