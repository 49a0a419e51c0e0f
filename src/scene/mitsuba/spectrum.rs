//! Spectra to linear sRGB as Mitsuba 3's RGB variants do it
//! (`spectrum_list_to_srgb` and `Properties::texture` in its src/core): the
//! piecewise-linear spectrum is integrated against the CIE 1931 matching
//! functions at 1000 points, times D65 for reflectances, and the XYZ result
//! turned into linear sRGB.

use super::cie;
use crate::math::Rgb;

/// What a spectrum describes: it decides the illuminant and the clamping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Use {
    /// An albedo: lit by D65, clamped to [0, 1].
    Reflectance,
    /// Emitted radiance or intensity: no illuminant, only negatives clamped.
    Emission,
    /// A conductor's η or k: grey when uniform, like an albedo, but
    /// unbounded.
    Index,
}

/// A uniform spectrum of value `v`: an albedo is grey; an emitter is the
/// (slightly purple) colour a flat spectrum has in sRGB, whose white is D65.
pub(super) fn uniform(v: f64, use_: Use) -> Rgb {
    match use_ {
        Use::Reflectance | Use::Index => Rgb::splat(v as f32),
        Use::Emission => (xyz_to_srgb([1.0; 3]) * v).as_vec3a(),
    }
}

/// Wavelength:value pairs (in nm, ascending) to RGB; `None` when the
/// wavelengths do not ascend or the lists are empty.
pub(super) fn to_rgb(wavelengths: &[f64], values: &[f64], use_: Use) -> Option<Rgb> {
    let n = wavelengths.len();
    if n == 0 || n != values.len() || wavelengths.windows(2).any(|w| w[1] <= w[0]) {
        return None;
    }
    let steps = 1000;
    let mut xyz = [0.0f64; 3];
    for i in 0..steps {
        let w = cie::MIN + (i as f64 / (steps - 1) as f64) * (cie::MAX - cie::MIN);
        if w < wavelengths[0] || w > wavelengths[n - 1] {
            continue;
        }
        let k = wavelengths
            .partition_point(|&x| x <= w)
            .clamp(1, n.max(2) - 1)
            - 1;
        let v = if n == 1 {
            values[0]
        } else {
            let (w0, w1) = (wavelengths[k], wavelengths[k + 1]);
            ((w - w1) * values[k] + (w0 - w) * values[k + 1]) / (w0 - w1)
        };
        let weight = match use_ {
            Use::Reflectance | Use::Index => d65(w),
            Use::Emission => 1.0,
        };
        let cmf = cie1931(w);
        for c in 0..3 {
            xyz[c] += cmf[c] * v * weight;
        }
    }
    // Mitsuba's MI_CIE_Y_NORMALIZATION: a unit spectrum has luminance 1.
    let scale = (cie::MAX - cie::MIN) / 106.750_259_399_414_06 / steps as f64;
    let rgb = xyz_to_srgb(xyz.map(|c| c * scale));
    let rgb = match use_ {
        Use::Reflectance => rgb.clamp(glam::DVec3::ZERO, glam::DVec3::ONE),
        Use::Emission | Use::Index => rgb.max(glam::DVec3::ZERO),
    };
    Some(rgb.as_vec3a())
}

/// Table lookup with linear interpolation, zero outside 360–830 nm.
fn lerp_table(table: &[f32], w: f64) -> f64 {
    if !(cie::MIN..=cie::MAX).contains(&w) {
        return 0.0;
    }
    let t = (w - cie::MIN) * ((cie::SAMPLES - 1) as f64 / (cie::MAX - cie::MIN));
    let i0 = (t as usize).min(cie::SAMPLES - 2);
    let w1 = t - i0 as f64;
    (1.0 - w1) * table[i0] as f64 + w1 * table[i0 + 1] as f64
}

fn cie1931(w: f64) -> [f64; 3] {
    let n = cie::SAMPLES;
    [0, 1, 2].map(|c| lerp_table(&cie::XYZ[c * n..(c + 1) * n], w))
}

/// Normalised so that D65 has luminance 1 (MI_CIE_D65_NORMALIZATION).
fn d65(w: f64) -> f64 {
    lerp_table(&cie::D65, w) / 98.997_417_518_762_55
}

fn xyz_to_srgb([x, y, z]: [f64; 3]) -> glam::DVec3 {
    glam::DVec3::new(
        3.240479 * x - 1.537150 * y - 0.498535 * z,
        -0.969256 * x + 1.875991 * y + 0.041556 * z,
        0.055648 * x - 0.204043 * y + 1.057311 * z,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_reflectance_is_grey_and_a_flat_emitter_is_not() {
        let w: Vec<f64> = (0..=10).map(|i| 360.0 + 47.0 * i as f64).collect();
        let grey = to_rgb(&w, &[0.5; 11], Use::Reflectance).unwrap();
        assert!(
            (grey - Rgb::splat(0.5)).abs().max_element() < 0.01,
            "{grey}"
        );
        let light = to_rgb(&w, &[1.0; 11], Use::Emission).unwrap();
        let flat = uniform(1.0, Use::Emission);
        assert!(
            (light - flat).abs().max_element() < 0.01,
            "{light} vs {flat}"
        );
        assert!(flat.x > flat.z, "{flat}");
    }

    #[test]
    fn descending_wavelengths_are_refused() {
        assert!(to_rgb(&[500.0, 400.0], &[1.0, 1.0], Use::Emission).is_none());
        assert!(to_rgb(&[], &[], Use::Emission).is_none());
    }
}
