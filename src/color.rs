//! Colour conventions shared by every layer: Rec.709 luminance of linear RGB, and the sRGB
//! transfer functions (IEC 61966-2-1) between 8-bit codes and linear values.

use glam::Vec3;

/// Rec.709 luminance of linear RGB.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The sRGB electro-optical transfer function: encoded value in [0, 1] → linear.
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Maps a linear value to an 8-bit sRGB code:
/// `x = clamp(linear, 0, 1)` (NaN → 0), then the sRGB OETF
/// `12.92·x` for `x ≤ 0.0031308`, else `1.055·x^(1/2.4) − 0.055`,
/// then `round(255·v)`.
pub fn linear_to_srgb8(linear: f32) -> u8 {
    let x = if linear.is_nan() {
        0.0
    } else {
        f64::from(linear.clamp(0.0, 1.0))
    };
    let v = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    // v ∈ [0, 1], so the rounded value fits in u8.
    (v * 255.0).round() as u8
}
