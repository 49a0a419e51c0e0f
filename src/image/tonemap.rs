//! Tone mapping: linear HDR radiance to display values in [0, 1] and 8-bit
//! output ready for PNG.
//!
//! The operators are those of the course path tracer this project descends
//! from (see the report in `shared/seed`): clamping, equalization,
//! equalization + clamping, gamma curve, clamping + gamma curve, plus
//! Reinhard's operator. Every operator first multiplies the input by
//! `2^exposure` ([`ToneMapParams::exposure`], in photographic stops), maps
//! negative values and NaN to 0 and +∞ to the top of the range, and ignores
//! non-finite values when it looks for the image's maximum.
//!
//! Clamp, Equalize and EqualizeClamp apply no display encoding: their output
//! is written to 8 bits as is (as the course renderer did, so they look
//! darker than the gamma operators). Gamma, ClampGamma and Reinhard encode
//! with the power curve `x^(1/gamma)` ([`ToneMapParams::gamma`], 2.2 by
//! default), an approximation of sRGB.

use super::error::ImageError;
use super::Image;
use crate::math::Vec3;
use std::fmt;
use std::str::FromStr;

/// A tone-mapping operator. `v` is a channel value after exposure, `max` the
/// image's largest finite channel value, `V` the clamp threshold
/// ([`ToneMapParams::clamp`]) and `γ` the gamma.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ToneMap {
    /// Clamping: `min(v, 1)`. Everything brighter than 1 saturates; the rest
    /// is unchanged.
    Clamp,
    /// Equalization: `v / max`, a linear map of `[0, max]` onto `[0, 1]` (the
    /// report's definition: divide by the maximum).
    Equalize,
    /// Equalization + clamping: `min(v, V) / V`. Values above `V` saturate,
    /// `[0, V]` is stretched onto `[0, 1]`. With the default `V = 1` this is
    /// [`ToneMap::Clamp`].
    EqualizeClamp,
    /// Gamma curve: `(v / max)^(1/γ)`, equalization followed by the power
    /// curve.
    Gamma,
    /// Clamping + gamma curve: `(min(v, V) / V)^(1/γ)`. The report renders all
    /// its figures with this one (γ = 2.2); it is the default for PNG output.
    ClampGamma,
    /// Reinhard's extended operator on luminance (Reinhard et al. 2002, as
    /// in <https://64.github.io/tonemapping/>): with the luminance
    /// `L = 0.2126 r + 0.7152 g + 0.0722 b` and the white point `Lw`
    /// ([`ToneMapParams::white`], by default the image's largest luminance),
    /// `Ld = L (1 + L / Lw²) / (1 + L)`; the colour is scaled by `Ld / L`,
    /// clipped to 1 per channel, then gamma-encoded. Luminance `Lw` maps to
    /// exactly 1. The report applies the same curve per RGB channel after an
    /// equalization limit of `lmax / 1.5`, which it found oversaturated;
    /// scaling by luminance keeps hues.
    Reinhard,
}

/// Parameters shared by the operators; each uses the ones it needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMapParams {
    /// Display gamma `γ`: encoding is `x^(1/γ)`. Default 2.2.
    pub gamma: f32,
    /// Clamp threshold `V` of EqualizeClamp and ClampGamma. Default 1.
    pub clamp: f32,
    /// Reinhard's white point (the luminance that maps to 1); `None` uses
    /// the image's largest finite luminance.
    pub white: Option<f32>,
    /// Exposure in stops: input is scaled by `2^exposure` first. Default 0.
    pub exposure: f32,
}

impl Default for ToneMapParams {
    fn default() -> Self {
        Self {
            gamma: 2.2,
            clamp: 1.0,
            white: None,
            exposure: 0.0,
        }
    }
}

impl ToneMapParams {
    /// Checks every parameter: gamma, clamp and white must be positive and
    /// finite, exposure finite.
    pub fn validate(&self) -> Result<(), ImageError> {
        let bad = |name: &str, v: f32, what: &str| {
            Err(ImageError::InvalidParameter(format!(
                "tone map {name}: must be {what}, got {v}"
            )))
        };
        if !(self.gamma.is_finite() && self.gamma > 0.0) {
            return bad("gamma", self.gamma, "positive and finite");
        }
        if !(self.clamp.is_finite() && self.clamp > 0.0) {
            return bad("clamp threshold", self.clamp, "positive and finite");
        }
        if let Some(w) = self.white {
            if !(w.is_finite() && w > 0.0) {
                return bad("white point", w, "positive and finite");
            }
        }
        if !self.exposure.is_finite() {
            return bad("exposure", self.exposure, "finite");
        }
        Ok(())
    }
}

/// Rec.709 luminance of linear RGB.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// NaN and negatives → 0; +∞ stays (and saturates later).
#[inline]
fn sanitize(v: f32) -> f32 {
    if v > 0.0 {
        v
    } else {
        0.0
    }
}

impl ToneMap {
    pub const ALL: [ToneMap; 6] = [
        ToneMap::Clamp,
        ToneMap::Equalize,
        ToneMap::EqualizeClamp,
        ToneMap::Gamma,
        ToneMap::ClampGamma,
        ToneMap::Reinhard,
    ];

    /// The name `FromStr` accepts.
    pub fn name(self) -> &'static str {
        match self {
            ToneMap::Clamp => "clamp",
            ToneMap::Equalize => "equalize",
            ToneMap::EqualizeClamp => "equalize-clamp",
            ToneMap::Gamma => "gamma",
            ToneMap::ClampGamma => "clamp-gamma",
            ToneMap::Reinhard => "reinhard",
        }
    }

    /// Maps `img` to display values in `[0, 1]` (already gamma-encoded for
    /// the operators that encode).
    pub fn map(self, img: &Image, params: &ToneMapParams) -> Result<Image, ImageError> {
        params.validate()?;
        let scale = params.exposure.exp2();
        let exposed = img.map(|p| Vec3::new(sanitize(p.x), sanitize(p.y), sanitize(p.z)) * scale);
        let inv_gamma = 1.0 / params.gamma;
        let unit = |v: f32| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        let per_channel =
            |f: &dyn Fn(f32) -> f32| exposed.map(|p| Vec3::new(f(p.x), f(p.y), f(p.z)));
        let max = exposed.max_value();
        // An all-black (or all-infinite) image has no finite maximum: it maps
        // to black rather than dividing by zero.
        let inv_max = if max > 0.0 { 1.0 / max } else { 0.0 };
        let v_th = params.clamp;
        let out = match self {
            ToneMap::Clamp => per_channel(&|v| unit(v)),
            ToneMap::Equalize => per_channel(&|v| unit(v * inv_max)),
            ToneMap::EqualizeClamp => per_channel(&|v| unit(v.min(v_th) / v_th)),
            ToneMap::Gamma => per_channel(&|v| unit(v * inv_max).powf(inv_gamma)),
            ToneMap::ClampGamma => per_channel(&|v| unit(v.min(v_th) / v_th).powf(inv_gamma)),
            ToneMap::Reinhard => {
                let white = params.white.unwrap_or_else(|| {
                    exposed
                        .pixels
                        .iter()
                        .map(|&p| luminance(p))
                        .filter(|l| l.is_finite())
                        .fold(0.0, f32::max)
                });
                let inv_w2 = if white > 0.0 {
                    1.0 / (white * white)
                } else {
                    0.0
                };
                exposed.map(|p| {
                    let l = luminance(p);
                    let s = if l.is_nan() || l <= 0.0 {
                        0.0
                    } else if !l.is_finite() {
                        // Infinite luminance: saturate to white.
                        return Vec3::ONE;
                    } else {
                        let ld = l * (1.0 + l * inv_w2) / (1.0 + l);
                        ld / l
                    };
                    let c = p * s;
                    Vec3::new(
                        unit(c.x).powf(inv_gamma),
                        unit(c.y).powf(inv_gamma),
                        unit(c.z).powf(inv_gamma),
                    )
                })
            }
        };
        Ok(out)
    }

    /// Maps `img` to interleaved 8-bit RGB, row-major from the top:
    /// `round(255 · display value)`.
    pub fn to_rgb8(self, img: &Image, params: &ToneMapParams) -> Result<Vec<u8>, ImageError> {
        let display = self.map(img, params)?;
        Ok(display
            .pixels
            .iter()
            .flat_map(|p| p.to_array())
            .map(quantize8)
            .collect())
    }
}

/// `x` in `[0, 1]` to the nearest of 256 levels (clamped; NaN → 0).
#[inline]
pub fn quantize8(x: f32) -> u8 {
    if x.is_nan() {
        0
    } else {
        (x.clamp(0.0, 1.0) * 255.0).round() as u8
    }
}

impl fmt::Display for ToneMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Error of parsing a tone-map name; lists the valid names.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown tone map `{0}`: expected one of clamp, equalize, equalize-clamp, gamma, clamp-gamma, reinhard")]
pub struct ParseToneMapError(pub String);

impl FromStr for ToneMap {
    type Err = ParseToneMapError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ToneMap::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| ParseToneMapError(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(values: &[f32]) -> Image {
        Image::new(
            values.len() as u32,
            1,
            values.iter().map(|&v| Vec3::splat(v)).collect(),
        )
    }

    fn mapped(t: ToneMap, values: &[f32], p: &ToneMapParams) -> Vec<f32> {
        t.map(&row(values), p)
            .unwrap()
            .pixels
            .iter()
            .map(|p| p.x)
            .collect()
    }

    fn close(a: &[f32], b: &[f32]) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-5, "{a:?} vs {b:?}");
        }
    }

    const V: [f32; 5] = [0.0, 0.25, 1.0, 2.0, 4.0];

    #[test]
    fn clamp_clips_at_one() {
        let p = ToneMapParams::default();
        close(&mapped(ToneMap::Clamp, &V, &p), &[0.0, 0.25, 1.0, 1.0, 1.0]);
    }

    #[test]
    fn equalize_divides_by_max() {
        let p = ToneMapParams::default();
        close(
            &mapped(ToneMap::Equalize, &V, &p),
            &[0.0, 0.0625, 0.25, 0.5, 1.0],
        );
    }

    #[test]
    fn equalize_clamp_stretches_below_threshold() {
        let p = ToneMapParams {
            clamp: 2.0,
            ..Default::default()
        };
        close(
            &mapped(ToneMap::EqualizeClamp, &V, &p),
            &[0.0, 0.125, 0.5, 1.0, 1.0],
        );
    }

    #[test]
    fn gamma_equalizes_then_encodes() {
        let p = ToneMapParams {
            gamma: 2.0,
            ..Default::default()
        };
        close(
            &mapped(ToneMap::Gamma, &V, &p),
            &[0.0, 0.25, 0.5, 0.5f32.sqrt(), 1.0],
        );
    }

    #[test]
    fn clamp_gamma_clamps_then_encodes() {
        let p = ToneMapParams::default();
        let inv = 1.0 / 2.2f32;
        close(
            &mapped(ToneMap::ClampGamma, &V, &p),
            &[0.0, 0.25f32.powf(inv), 1.0, 1.0, 1.0],
        );
    }

    #[test]
    fn reinhard_maps_white_to_one_and_keeps_hue() {
        let p = ToneMapParams {
            gamma: 1.0,
            ..Default::default()
        };
        // Grey: luminance equals the value; white = max luminance = 4.
        let ld = |l: f32| l * (1.0 + l / 16.0) / (1.0 + l);
        close(
            &mapped(ToneMap::Reinhard, &V, &p),
            &[0.0, ld(0.25), ld(1.0), ld(2.0), 1.0],
        );
        // Explicit white point, coloured pixel: hue (channel ratios) kept.
        let p = ToneMapParams {
            gamma: 1.0,
            white: Some(1e6),
            ..Default::default()
        };
        let img = Image::new(1, 1, vec![Vec3::new(0.5, 0.25, 0.0)]);
        let out = ToneMap::Reinhard.map(&img, &p).unwrap().pixels[0];
        let l = luminance(Vec3::new(0.5, 0.25, 0.0));
        let s = (l * (1.0 + l / 1e12) / (1.0 + l)) / l;
        assert!((out.x - 0.5 * s).abs() < 1e-6 && (out.y - 0.25 * s).abs() < 1e-6);
        assert_eq!(out.z, 0.0);
    }

    #[test]
    fn exposure_scales_by_stops() {
        let p = ToneMapParams {
            exposure: 1.0,
            ..Default::default()
        };
        close(&mapped(ToneMap::Clamp, &[0.25, 0.5], &p), &[0.5, 1.0]);
    }

    #[test]
    fn non_finite_and_negative_inputs_are_safe() {
        let p = ToneMapParams::default();
        for t in ToneMap::ALL {
            let img = row(&[f32::NAN, -1.0, f32::INFINITY, 2.0]);
            let out = t.map(&img, &p).unwrap();
            for v in out.pixels.iter().flat_map(|p| p.to_array()) {
                assert!((0.0..=1.0).contains(&v), "{t}: {v}");
            }
            assert_eq!(out.pixels[0], Vec3::ZERO, "{t}");
            assert_eq!(out.pixels[1], Vec3::ZERO, "{t}");
            // Black images do not divide by zero.
            let black = t.map(&row(&[0.0, 0.0]), &p).unwrap();
            assert!(black.pixels.iter().all(|&p| p == Vec3::ZERO), "{t}");
        }
    }

    #[test]
    fn to_rgb8_rounds() {
        let p = ToneMapParams::default();
        let bytes = ToneMap::Clamp.to_rgb8(&row(&[0.5, 2.0]), &p).unwrap();
        assert_eq!(bytes, vec![128, 128, 128, 255, 255, 255]);
        assert_eq!(quantize8(f32::NAN), 0);
    }

    #[test]
    fn parse_names_round_trip_and_errors_list_options() {
        for t in ToneMap::ALL {
            assert_eq!(t.name().parse::<ToneMap>().unwrap(), t);
        }
        let e = "filmic".parse::<ToneMap>().unwrap_err().to_string();
        assert!(e.contains("filmic") && e.contains("clamp-gamma") && e.contains("reinhard"));
    }

    #[test]
    fn invalid_parameters_are_errors() {
        let img = row(&[1.0]);
        for p in [
            ToneMapParams {
                gamma: 0.0,
                ..Default::default()
            },
            ToneMapParams {
                clamp: f32::NAN,
                ..Default::default()
            },
            ToneMapParams {
                white: Some(-1.0),
                ..Default::default()
            },
            ToneMapParams {
                exposure: f32::INFINITY,
                ..Default::default()
            },
        ] {
            let e = ToneMap::Gamma.map(&img, &p).unwrap_err().to_string();
            assert!(e.contains("tone map"), "{e}");
        }
    }
}
