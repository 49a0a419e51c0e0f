//! Reading and writing images.
//!
//! # Formats
//!
//! | format | read | write | values |
//! |---|---|---|---|
//! | OpenEXR (`.exr`) | yes | yes, RGB f32 | linear, exact |
//! | Radiance (`.hdr`) | yes | yes, RGBE | linear, 8-bit shared-exponent mantissa (≈ 0.4 % of the pixel's largest channel) |
//! | HDR PPM (`.ppm`, ascii `P3` with a `#MAX=` comment) | yes | yes | linear, `value = integer * MAX / maxval` |
//! | PPM without `#MAX` (`P2`, `P3`, `P5`, `P6`, 8 or 16 bit) | yes | no | display-encoded: sRGB-decoded to linear |
//! | PNG (`.png`) | yes | yes, 8-bit tone-mapped | sRGB-decoded to linear on read |
//! | JPEG | yes | no | sRGB-decoded to linear on read |
//!
//! Readers recognise the format by its magic bytes, not by the file name.
//! Writers pick the format by the (case-insensitive) extension.
//!
//! # The HDR PPM of the course renderer
//!
//! ```text
//! P3
//! #MAX=48.5
//! # any other comments
//! 640 480
//! 10000000
//! r g b r g b ...
//! ```
//!
//! A plain ascii PPM whose header carries a comment `#MAX=<float>` (spaces
//! after `#` allowed): each integer `i` in `0..=maxval` stands for the linear
//! value `i * MAX / maxval`. luz writes `MAX` as the image's largest value
//! (1 for a black image) and `maxval` = [`WriteOptions::ppm_resolution`]
//! (10 000 000 by default: a step of `MAX * 1e-7`, about f32 precision near
//! `MAX`), one image row per line.
//!
//! # Policies
//!
//! - **Non-finite values** are an error, both when reading (a NaN or ∞ in a
//!   file) and when writing any format: luz's film never produces them (it
//!   drops non-finite samples), so one reaching an image is a bug upstream
//!   that must not be hidden by silently rewriting it.
//! - **Negative values** are written to EXR as they are; Radiance HDR and PPM
//!   cannot represent them, so writing them there is an error; PNG tone
//!   mapping maps them to black.
//! - **Writes are atomic**: the data goes to a hidden temporary file in the
//!   destination's directory (`.<name>.luz-tmp-<pid>-<n>`), which is flushed,
//!   synced and then renamed over the destination. A failed write removes the
//!   temporary; an interrupted one can leave only that hidden temporary,
//!   never a partial file under the requested name.
//! - Alpha channels are ignored; grey images are read as grey RGB.

mod atomic;
mod codecs;
mod ppm;
mod srgb;

pub use super::error::ImageError;
pub(crate) use atomic::write_atomic;
pub use ppm::parse_ppm;
pub use srgb::{linear_to_srgb, srgb_to_linear};

use super::tonemap::{ToneMap, ToneMapParams};
use super::Image;
use atomic::directory_of;
use image::ImageFormat;
use std::path::Path;

const CHANNELS: [&str; 3] = ["red", "green", "blue"];
const READ_FORMATS: &str = "OpenEXR, Radiance HDR, PPM (P2/P3/P5/P6, #MAX= HDR), PNG, JPEG";
const TEXTURE_FORMATS: &str = "PPM, PNG, JPEG";
const WRITE_EXTENSIONS: &str = ".exr, .hdr, .ppm, .png";

/// Options for [`write()`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WriteOptions {
    /// Tone mapping for PNG output (HDR formats store linear values).
    pub tonemap: ToneMap,
    pub params: ToneMapParams,
    /// `maxval` of written HDR PPM files: integers in `0..=ppm_resolution`
    /// span `[0, MAX]`.
    pub ppm_resolution: u32,
}

impl Default for WriteOptions {
    fn default() -> Self {
        Self {
            tonemap: ToneMap::ClampGamma,
            params: ToneMapParams::default(),
            ppm_resolution: 10_000_000,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Exr,
    Hdr,
    Ppm,
    Png,
    Jpeg,
}

fn sniff(data: &[u8]) -> Option<Kind> {
    if data.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        Some(Kind::Exr)
    } else if data.starts_with(b"#?") {
        Some(Kind::Hdr)
    } else if data.starts_with(b"\x89PNG") {
        Some(Kind::Png)
    } else if data.starts_with(&[0xff, 0xd8, 0xff]) {
        Some(Kind::Jpeg)
    } else if data.len() >= 2 && data[0] == b'P' && data[1].is_ascii_digit() {
        Some(Kind::Ppm)
    } else {
        None
    }
}

/// The bytes of an input image, which must be a regular file (a FIFO would
/// block the read for ever).
fn read_bytes(path: &Path) -> Result<Vec<u8>, ImageError> {
    crate::location::read_regular_file(path).map_err(|source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads any supported image into linear RGB (see the module docs for how
/// each format maps to linear values). Non-finite values are an error.
pub fn read(path: &Path) -> Result<Image, ImageError> {
    let data = read_bytes(path)?;
    let kind = sniff(&data).ok_or_else(|| ImageError::Unsupported {
        path: path.to_path_buf(),
        message: "not a recognised image file".into(),
        supported: READ_FORMATS,
    })?;
    let img = decode(path, &data, kind)?;
    check_values(
        path,
        &img,
        |v| !v.is_finite(),
        "files must hold finite values",
    )?;
    Ok(img)
}

/// Reads a texture: PPM, PNG or JPEG, as linear RGB in `[0, 1]` (display
/// encoded files are sRGB-decoded; an HDR PPM is linear already and must not
/// exceed 1, since a texture is an albedo).
pub fn read_texture(path: &Path) -> Result<Image, ImageError> {
    let data = read_bytes(path)?;
    let kind = match sniff(&data) {
        Some(k @ (Kind::Ppm | Kind::Png | Kind::Jpeg)) => k,
        Some(_) => {
            return Err(ImageError::Unsupported {
                path: path.to_path_buf(),
                message: "HDR images cannot be textures".into(),
                supported: TEXTURE_FORMATS,
            })
        }
        None => {
            return Err(ImageError::Unsupported {
                path: path.to_path_buf(),
                message: "not a recognised texture file".into(),
                supported: TEXTURE_FORMATS,
            })
        }
    };
    let img = decode(path, &data, kind)?;
    check_values(
        path,
        &img,
        |v| !(0.0..=1.0).contains(&v),
        "texture values are albedos and must lie in [0, 1]",
    )?;
    Ok(img)
}

fn decode(path: &Path, data: &[u8], kind: Kind) -> Result<Image, ImageError> {
    let format = match kind {
        Kind::Ppm => return parse_ppm(data, path),
        Kind::Exr => ImageFormat::OpenExr,
        Kind::Hdr => ImageFormat::Hdr,
        Kind::Png => ImageFormat::Png,
        Kind::Jpeg => ImageFormat::Jpeg,
    };
    codecs::decode(path, data, format)
}

/// An error at the first value of `img` that is `bad`, if any.
fn check_values(
    path: &Path,
    img: &Image,
    bad: impl Fn(f32) -> bool,
    reason: &'static str,
) -> Result<(), ImageError> {
    match img.first_where(bad) {
        None => Ok(()),
        Some((x, y, c)) => Err(ImageError::BadValue {
            path: path.to_path_buf(),
            x,
            y,
            channel: CHANNELS[c],
            value: img.get(x, y)[c],
            reason,
        }),
    }
}

/// Checks that `path` names a format `write` can produce and a directory
/// that exists, so a caller can refuse it before spending time on a render.
pub fn check_output_path(path: &Path) -> Result<(), ImageError> {
    output_kind(path)?;
    let dir = directory_of(path);
    if !dir.is_dir() {
        return Err(ImageError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("the directory {} does not exist", dir.display()),
            ),
        });
    }
    Ok(())
}

fn output_kind(path: &Path) -> Result<Kind, ImageError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    Ok(match ext.as_str() {
        "exr" => Kind::Exr,
        "hdr" => Kind::Hdr,
        "ppm" => Kind::Ppm,
        "png" => Kind::Png,
        _ => {
            return Err(ImageError::Unsupported {
                path: path.to_path_buf(),
                message: if ext.is_empty() {
                    "no file extension to choose an output format".into()
                } else {
                    format!("cannot write `.{ext}` files")
                },
                supported: WRITE_EXTENSIONS,
            })
        }
    })
}

/// Writes `img` to `path` atomically, in the format its extension names
/// (`.exr`, `.hdr`, `.ppm` as HDR PPM, `.png` tone-mapped with
/// `options.tonemap`). See the module docs for the value policies.
pub fn write(path: &Path, img: &Image, options: &WriteOptions) -> Result<(), ImageError> {
    let kind = output_kind(path)?;
    check_writable(path, img, kind, options)?;
    // Tone map before touching the file system, so bad parameters leave
    // nothing behind.
    let png = if kind == Kind::Png {
        Some(options.tonemap.to_rgb8(img, &options.params)?)
    } else {
        None
    };
    let format_error = |e: image::ImageError| ImageError::Format {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    write_atomic(path, |out| match kind {
        Kind::Exr => codecs::write_exr(out, img).map_err(format_error),
        Kind::Hdr => codecs::write_hdr(out, img).map_err(format_error),
        Kind::Png => codecs::write_png(
            out,
            png.as_deref().unwrap_or_default(),
            img.width,
            img.height,
        )
        .map_err(format_error),
        Kind::Ppm => {
            ppm::write_ppm(out, img, options.ppm_resolution).map_err(|source| ImageError::Io {
                path: path.to_path_buf(),
                source,
            })
        }
        Kind::Jpeg => unreachable!("JPEG is never chosen for writing"),
    })
}

/// Refuses, before any file is touched, an image `write` cannot store as
/// `kind`: empty, inconsistent, non-finite, or (in formats without them)
/// negative, and a PPM resolution of 0.
fn check_writable(
    path: &Path,
    img: &Image,
    kind: Kind,
    options: &WriteOptions,
) -> Result<(), ImageError> {
    if img.width == 0 || img.height == 0 {
        return Err(ImageError::Format {
            path: path.to_path_buf(),
            message: format!("cannot write an empty {}x{} image", img.width, img.height),
        });
    }
    if img.pixels.len() != img.width as usize * img.height as usize {
        return Err(ImageError::Format {
            path: path.to_path_buf(),
            message: format!(
                "{}x{} image holds {} pixels",
                img.width,
                img.height,
                img.pixels.len()
            ),
        });
    }
    check_values(
        path,
        img,
        |v| !v.is_finite(),
        "non-finite values cannot be written",
    )?;
    if matches!(kind, Kind::Hdr | Kind::Ppm) {
        check_values(
            path,
            img,
            |v| v < 0.0,
            "negative values cannot be stored in this format (use .exr)",
        )?;
    }
    if kind == Kind::Ppm && options.ppm_resolution == 0 {
        return Err(ImageError::InvalidParameter(
            "PPM resolution (maxval) must be at least 1".into(),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod fixtures {
    use crate::image::Image;
    use crate::math::Vec3;
    use std::path::{Path, PathBuf};

    pub fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("luz-image-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A deterministic HDR test image with a wide range of values.
    pub fn hdr_image() -> Image {
        let (w, h) = (7u32, 5u32);
        let pixels = (0..w * h)
            .map(|i| {
                let t = i as f32;
                Vec3::new(
                    t * 0.37,
                    (t * 1.3).sin().abs() * 5.0,
                    1e-3 * (t + 1.0).powi(2),
                )
            })
            .collect();
        Image::new(w, h, pixels)
    }

    pub fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("luz-tmp"))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::fixtures::{hdr_image, temp_dir};
    use super::*;
    use crate::math::Vec3;

    #[test]
    fn textures_reject_hdr_files_and_values_above_one() {
        let dir = temp_dir("tex-bad");
        let exr = dir.join("t.exr");
        write(&exr, &hdr_image(), &WriteOptions::default()).unwrap();
        let e = read_texture(&exr).unwrap_err().to_string();
        assert!(e.contains("t.exr") && e.contains("PPM, PNG, JPEG"), "{e}");
        let ppm = dir.join("t.ppm");
        std::fs::write(&ppm, "P3\n#MAX=2\n1 1\n10\n10 0 0\n").unwrap();
        let e = read_texture(&ppm).unwrap_err().to_string();
        assert!(
            e.contains("t.ppm") && e.contains("red") && e.contains("[0, 1]"),
            "{e}"
        );
    }

    #[test]
    fn corrupt_and_unknown_files_are_errors_naming_the_file() {
        let dir = temp_dir("corrupt");
        let img = hdr_image();
        for ext in ["exr", "hdr", "png"] {
            let path = dir.join(format!("c.{ext}"));
            write(&path, &img, &WriteOptions::default()).unwrap();
            let bytes = std::fs::read(&path).unwrap();
            std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
            let e = read(&path).unwrap_err().to_string();
            assert!(e.contains(&format!("c.{ext}")), "{e}");
        }
        let path = dir.join("x.bin");
        std::fs::write(&path, b"hello").unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.contains("x.bin") && e.contains("PNG"), "{e}");
        let e = read(&dir.join("absent.exr")).unwrap_err().to_string();
        assert!(e.contains("absent.exr"), "{e}");
    }

    #[test]
    fn non_finite_values_are_rejected_on_read_and_write() {
        let dir = temp_dir("nan");
        // An EXR holding a NaN (written by the image crate directly).
        let path = dir.join("nan.exr");
        let buf =
            image::Rgb32FImage::from_raw(2, 1, vec![0.0, 1.0, 2.0, 3.0, f32::NAN, 5.0]).unwrap();
        image::DynamicImage::ImageRgb32F(buf).save(&path).unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.contains("nan.exr: pixel (1, 0) green is NaN"), "{e}");
        let mut img = hdr_image();
        img.set(2, 1, Vec3::new(0.0, 0.0, f32::INFINITY));
        for ext in ["exr", "hdr", "ppm", "png"] {
            let path = dir.join(format!("out.{ext}"));
            let e = write(&path, &img, &WriteOptions::default())
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!("out.{ext}: pixel (2, 1) blue is inf")),
                "{e}"
            );
            assert!(!path.exists());
        }
    }

    #[test]
    fn negative_values_rejected_where_unrepresentable() {
        let dir = temp_dir("neg");
        let img = Image::new(1, 1, vec![Vec3::new(0.0, -1.0, 0.0)]);
        for ext in ["hdr", "ppm"] {
            let path = dir.join(format!("n.{ext}"));
            let e = write(&path, &img, &WriteOptions::default())
                .unwrap_err()
                .to_string();
            assert!(e.contains("negative"), "{e}");
            assert!(!path.exists());
        }
        write(&dir.join("n.png"), &img, &WriteOptions::default()).unwrap();
    }

    #[test]
    fn unknown_extension_names_path_and_supported_ones() {
        let dir = temp_dir("ext");
        let img = hdr_image();
        let e = write(&dir.join("a.tiff"), &img, &WriteOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("a.tiff") && e.contains(".tiff") && e.contains(".exr, .hdr, .ppm, .png"),
            "{e}"
        );
        let e = write(&dir.join("noext"), &img, &WriteOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("noext") && e.contains(".png"), "{e}");
        assert!(std::fs::read_dir(&dir).unwrap().next().is_none());
    }

    #[test]
    fn empty_image_cannot_be_written() {
        let dir = temp_dir("empty");
        let e = write(
            &dir.join("e.exr"),
            &Image::new(0, 0, vec![]),
            &WriteOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("e.exr") && e.contains("empty"), "{e}");
    }
}
