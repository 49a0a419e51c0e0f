//! The sRGB transfer function (IEC 61966-2-1), which display-encoded files
//! (8- and 16-bit PPM, PNG, JPEG) are decoded with.

/// The sRGB transfer function's inverse (IEC 61966-2-1): display value in
/// `[0, 1]` to linear.
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB transfer function: linear in `[0, 1]` to display value.
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// [`srgb_to_linear`] of every 8-bit display value.
pub(super) fn srgb_lut() -> [f32; 256] {
    std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0))
}
