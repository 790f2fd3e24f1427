//! Luminance for expected values, written here apart from the crate's `color::luminance`: the
//! Rec. 709 / sRGB weights of Y (ITU-R BT.709-6, item 3.2), in f64.

use glam::DVec3;

/// Y = 0.2126 R + 0.7152 G + 0.0722 B of linear Rec. 709 RGB.
pub fn luminance(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}
