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

pub use super::error::ImageError;
use super::tonemap::{ToneMap, ToneMapParams};
use super::Image;
use crate::location::line_column;
use crate::math::Vec3;
use image::{ExtendedColorType, ImageEncoder, ImageFormat};
use std::borrow::Cow;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

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
    let dynamic =
        image::load(std::io::Cursor::new(data), format).map_err(|e| ImageError::Format {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    let (w, h) = (dynamic.width(), dynamic.height());
    let pixels: Vec<Vec3> = match kind {
        Kind::Exr | Kind::Hdr => dynamic
            .into_rgb32f()
            .pixels()
            .map(|p| Vec3::from(p.0))
            .collect(),
        _ => {
            let ct = dynamic.color();
            if ct.bytes_per_pixel() / ct.channel_count() == 1 {
                let lut = srgb_lut();
                dynamic
                    .into_rgb8()
                    .pixels()
                    .map(|p| Vec3::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]))
                    .collect()
            } else {
                dynamic
                    .into_rgb32f()
                    .pixels()
                    .map(|p| {
                        Vec3::new(
                            srgb_to_linear(p[0]),
                            srgb_to_linear(p[1]),
                            srgb_to_linear(p[2]),
                        )
                    })
                    .collect()
            }
        }
    };
    Ok(Image::new(w, h, pixels))
}

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

fn srgb_lut() -> [f32; 256] {
    std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0))
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

// ---------------------------------------------------------------- PPM read

struct PpmReader<'a> {
    path: &'a Path,
    data: &'a [u8],
    pos: usize,
    /// `#MAX=` value, if the header had one.
    max: Option<f64>,
    in_body: bool,
}

fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c)
}

impl<'a> PpmReader<'a> {
    /// An error at byte `offset` of the text, reported as line and column.
    fn error(&self, offset: usize, field: &str, message: impl Into<String>) -> ImageError {
        let (line, column) = line_column(self.data, offset);
        ImageError::Parse {
            path: self.path.to_path_buf(),
            line,
            column,
            field: field.to_string(),
            message: message.into(),
        }
    }

    /// An error at byte `offset` of binary pixel data.
    fn binary_error(&self, offset: usize, field: &str, message: impl Into<String>) -> ImageError {
        ImageError::BinaryParse {
            path: self.path.to_path_buf(),
            offset,
            field: field.to_string(),
            message: message.into(),
        }
    }

    /// Skips whitespace and comments, picking up `#MAX=` from comments.
    fn skip(&mut self) -> Result<(), ImageError> {
        while self.pos < self.data.len() {
            let b = self.data[self.pos];
            if is_space(b) {
                self.pos += 1;
            } else if b == b'#' {
                let start = self.pos + 1;
                let end = self.data[start..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(self.data.len(), |n| start + n);
                let text = String::from_utf8_lossy(&self.data[start..end]);
                if let Some(value) = text.trim().strip_prefix("MAX=") {
                    self.max_comment(self.pos, value.trim())?;
                }
                self.pos = end;
            } else {
                break;
            }
        }
        Ok(())
    }

    /// Takes the value of a `#MAX=` comment that starts at byte `at`.
    fn max_comment(&mut self, at: usize, value: &str) -> Result<(), ImageError> {
        if self.in_body {
            return Err(self.error(at, "MAX", "must come before the pixel data"));
        }
        if self.max.is_some() {
            return Err(self.error(at, "MAX", "given more than once"));
        }
        match value.parse::<f64>() {
            Ok(m) if m.is_finite() && m > 0.0 && m <= f32::MAX as f64 => {
                self.max = Some(m);
                Ok(())
            }
            _ => Err(self.error(
                at,
                "MAX",
                format!("expected a positive finite number, found `{value}`"),
            )),
        }
    }

    /// The next whitespace-delimited token and its offset. `field` names
    /// it in an error; it is a closure so that the pixel values of a large
    /// ASCII file do not each format a name no error needs.
    fn token(&mut self, field: impl Fn() -> String) -> Result<(Cow<'a, str>, usize), ImageError> {
        self.skip()?;
        let start = self.pos;
        while self.pos < self.data.len()
            && !is_space(self.data[self.pos])
            && self.data[self.pos] != b'#'
        {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(self.error(self.pos, &field(), "unexpected end of file"));
        }
        let data: &'a [u8] = self.data;
        Ok((String::from_utf8_lossy(&data[start..self.pos]), start))
    }

    /// An integer in `lo..=hi`.
    fn int(
        &mut self,
        field: impl Fn() -> String,
        lo: u64,
        hi: u64,
        expected: &str,
    ) -> Result<u64, ImageError> {
        let (tok, at) = self.token(&field)?;
        match tok.parse::<u64>() {
            Ok(v) if (lo..=hi).contains(&v) => Ok(v),
            _ => Err(self.error(at, &field(), format!("expected {expected}, found `{tok}`"))),
        }
    }
}

/// Parses the contents of a PPM file (`P2`, `P3`, `P5`, `P6`, with or
/// without `#MAX=`); `path` names it in errors. The header's size is never
/// trusted for an allocation before the data is there.
pub fn parse_ppm(data: &[u8], path: &Path) -> Result<Image, ImageError> {
    let mut r = PpmReader {
        path,
        data,
        pos: 0,
        max: None,
        in_body: false,
    };
    let (magic, at) = r.token(|| "magic number".into())?;
    let (binary, grey) = match &*magic {
        "P2" => (false, true),
        "P3" => (false, false),
        "P5" => (true, true),
        "P6" => (true, false),
        _ => {
            return Err(r.error(
                at,
                "magic number",
                format!("expected P2, P3, P5 or P6, found `{magic}`"),
            ))
        }
    };
    let positive = "a positive integer";
    r.skip()?;
    let width_at = r.pos;
    let width = r.int(|| "width".into(), 1, u32::MAX as u64, positive)?;
    let height = r.int(|| "height".into(), 1, u32::MAX as u64, positive)?;
    let maxval_hi = if binary { 65535 } else { u32::MAX as u64 };
    let maxval_expected = if binary {
        "a positive integer up to 65535"
    } else {
        positive
    };
    let maxval = r.int(|| "maxval".into(), 1, maxval_hi, maxval_expected)?;
    r.in_body = true;
    let channels: u64 = if grey { 1 } else { 3 };
    let values = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .filter(|&n| n <= isize::MAX as u64 / 8)
        .ok_or_else(|| r.error(width_at, "width", format!("{width}x{height} is too large")))?
        as usize;

    // Each integer i stands for i * scale, then (without #MAX) sRGB decoding.
    let scale = r.max.unwrap_or(1.0) / maxval as f64;
    let hdr = r.max.is_some();
    let convert = |i: u64| -> f32 {
        let v = (i as f64 * scale) as f32;
        if hdr {
            v
        } else {
            srgb_to_linear(v)
        }
    };

    let mut samples: Vec<f32> = Vec::new();
    if binary {
        // Exactly one whitespace byte separates maxval from the data.
        match data.get(r.pos) {
            Some(&b) if is_space(b) => r.pos += 1,
            _ => {
                return Err(r.error(
                    r.pos,
                    "maxval",
                    "expected one whitespace byte before the pixel data",
                ))
            }
        }
        let bytes = if maxval < 256 { 1 } else { 2 };
        let need = values * bytes;
        let body = &data[r.pos..];
        if body.len() < need {
            return Err(r.binary_error(
                r.pos,
                "pixel data",
                format!(
                    "truncated: {width}x{height} pixels need {need} bytes, found {}",
                    body.len()
                ),
            ));
        }
        samples.reserve_exact(values);
        for (k, chunk) in body[..need].chunks_exact(bytes).enumerate() {
            let i = if bytes == 1 {
                chunk[0] as u64
            } else {
                u16::from_be_bytes([chunk[0], chunk[1]]) as u64
            };
            if i > maxval {
                let p = k as u64 / channels;
                return Err(r.binary_error(
                    r.pos + k * bytes,
                    &sample_field(p % width, p / width, k as u64 % channels, grey),
                    format!("{i} exceeds maxval {maxval}"),
                ));
            }
            samples.push(convert(i));
        }
    } else {
        // Never trust the header for the allocation: grow with the data.
        samples.reserve(values.min(data.len() - r.pos));
        let expected = format!("an integer in 0..={maxval}");
        for k in 0..values as u64 {
            let p = k / channels;
            let field = || sample_field(p % width, p / width, k % channels, grey);
            let i = r.int(field, 0, maxval, &expected)?;
            samples.push(convert(i));
        }
    }
    let pixels = if grey {
        samples.into_iter().map(Vec3::splat).collect()
    } else {
        samples
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect()
    };
    Ok(Image::new(width as u32, height as u32, pixels))
}

fn sample_field(x: u64, y: u64, c: u64, grey: bool) -> String {
    if grey {
        format!("pixel ({x}, {y})")
    } else {
        format!("pixel ({x}, {y}) {}", CHANNELS[c as usize])
    }
}

// ------------------------------------------------------------------ write

/// The directory a file `path` lies in (`.` for a bare file name).
fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
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
        Kind::Exr => {
            let bytes: Vec<u8> = img
                .pixels
                .iter()
                .flat_map(|p| p.to_array())
                .flat_map(f32::to_ne_bytes)
                .collect();
            image::codecs::openexr::OpenExrEncoder::new(out)
                .write_image(&bytes, img.width, img.height, ExtendedColorType::Rgb32F)
                .map_err(format_error)
        }
        Kind::Hdr => {
            let rgb: Vec<image::Rgb<f32>> = img
                .pixels
                .iter()
                .map(|p| image::Rgb(p.to_array()))
                .collect();
            image::codecs::hdr::HdrEncoder::new(out)
                .encode(&rgb, img.width as usize, img.height as usize)
                .map_err(format_error)
        }
        Kind::Png => image::codecs::png::PngEncoder::new(out)
            .write_image(
                png.as_deref().unwrap_or_default(),
                img.width,
                img.height,
                ExtendedColorType::Rgb8,
            )
            .map_err(format_error),
        Kind::Ppm => write_ppm(out, img, options.ppm_resolution).map_err(|source| ImageError::Io {
            path: path.to_path_buf(),
            source,
        }),
        Kind::Jpeg => unreachable!("JPEG is never chosen for writing"),
    })
}

fn write_ppm(out: &mut impl Write, img: &Image, resolution: u32) -> std::io::Result<()> {
    let max = img.max_value();
    let max = if max > 0.0 { max } else { 1.0 };
    writeln!(out, "P3")?;
    writeln!(out, "#MAX={max}")?;
    writeln!(out, "# luz HDR PPM: value = integer * MAX / {resolution}")?;
    writeln!(out, "{} {}", img.width, img.height)?;
    writeln!(out, "{resolution}")?;
    let k = resolution as f64 / max as f64;
    let mut line = String::new();
    for row in img.pixels.chunks_exact(img.width as usize) {
        line.clear();
        for (j, v) in row.iter().flat_map(|p| p.to_array()).enumerate() {
            let i = ((v as f64 * k).round() as u64).min(resolution as u64);
            if j > 0 {
                line.push(' ');
            }
            use std::fmt::Write as _;
            let _ = write!(line, "{i}");
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
    }
    Ok(())
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Runs `body` on a buffered temporary file next to `path`, then syncs and
/// renames it to `path`. On any failure the temporary is removed.
pub(crate) fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    let io_error = |source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    };
    let name = path.file_name().ok_or_else(|| ImageError::Format {
        path: path.to_path_buf(),
        message: "not a file name".into(),
    })?;
    let dir = directory_of(path);
    let temp = dir.join(format!(
        ".{}.luz-tmp-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let file = File::options()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(io_error)?;
    let result = (|| {
        let mut out = BufWriter::new(file);
        body(&mut out)?;
        let file = out.into_inner().map_err(|e| io_error(e.into_error()))?;
        file.sync_all().map_err(io_error)?;
        drop(file);
        std::fs::rename(&temp, path).map_err(io_error)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("luz-image-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A deterministic HDR test image with a wide range of values.
    fn hdr_image() -> Image {
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

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("luz-tmp"))
            .collect()
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = temp_dir("exr");
        let path = dir.join("a.exr");
        let mut img = hdr_image();
        img.pixels[3] = Vec3::new(-0.5, 1e-30, 3e5); // negatives survive EXR
        write(&path, &img, &WriteOptions::default()).unwrap();
        assert_eq!(read(&path).unwrap(), img);
        assert!(leftovers(&dir).is_empty());
    }

    #[test]
    fn hdr_round_trip_within_rgbe_precision() {
        let dir = temp_dir("hdr");
        let path = dir.join("a.HDR");
        let img = hdr_image();
        write(&path, &img, &WriteOptions::default()).unwrap();
        let back = read(&path).unwrap();
        assert_eq!((back.width, back.height), (img.width, img.height));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            let m = a.max_element();
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= m / 128.0, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn ppm_round_trip_within_resolution() {
        let dir = temp_dir("ppm");
        let path = dir.join("a.ppm");
        let img = hdr_image();
        write(&path, &img, &WriteOptions::default()).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with(&format!("P3\n#MAX={}\n", img.max_value())));
        let back = read(&path).unwrap();
        let step = img.max_value() / 1e7;
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= step + a[c] * 1e-7, "{a} vs {b}");
            }
        }
        // A black image writes MAX=1 and reads back black.
        let black = Image::filled(2, 1, Vec3::ZERO);
        write(&path, &black, &WriteOptions::default()).unwrap();
        assert_eq!(read(&path).unwrap(), black);
    }

    #[test]
    fn png_round_trip_within_one_level_after_tonemap() {
        let dir = temp_dir("png");
        let path = dir.join("a.png");
        let img = hdr_image();
        for t in ToneMap::ALL {
            let options = WriteOptions {
                tonemap: t,
                ..Default::default()
            };
            write(&path, &img, &options).unwrap();
            let expected = t.map(&img, &options.params).unwrap();
            // Raw 8-bit values are the tone mapper's, to the nearest level.
            let raw = image::open(&path).unwrap().into_rgb8();
            for (p, e) in raw.pixels().zip(&expected.pixels) {
                for c in 0..3 {
                    assert!((p[c] as f32 / 255.0 - e[c]).abs() <= 0.5 / 255.0 + 1e-6);
                }
            }
            // `read` decodes sRGB: re-encoding gives the display values back.
            let back = read(&path).unwrap();
            for (b, e) in back.pixels.iter().zip(&expected.pixels) {
                for c in 0..3 {
                    assert!((linear_to_srgb(b[c]) - e[c]).abs() <= 1.0 / 255.0, "{t}");
                }
            }
        }
    }

    #[test]
    fn reads_hand_written_hdr_ppm() {
        let dir = temp_dir("ppm-max");
        let path = dir.join("course.ppm");
        std::fs::write(
            &path,
            "P3\n#MAX=48\n# forest.ppm\n2 2\n# a comment\n1000\n\
             0 0 0  1000 500 250\n 10 20 30\n1 2 3\n",
        )
        .unwrap();
        let img = read(&path).unwrap();
        assert_eq!((img.width, img.height), (2, 2));
        assert_eq!(img.get(0, 0), Vec3::ZERO);
        assert_eq!(img.get(1, 0), Vec3::new(48.0, 24.0, 12.0));
        assert_eq!(img.get(0, 1), Vec3::new(0.48, 0.96, 1.44));
        assert_eq!(img.get(1, 1), Vec3::new(0.048, 0.096, 0.144));
        // Spaces after `#` are allowed too.
        std::fs::write(&path, "P3\n# MAX=2.5\n1 1\n10\n10 5 0\n").unwrap();
        assert_eq!(read(&path).unwrap().pixels[0], Vec3::new(2.5, 1.25, 0.0));
    }

    #[test]
    fn reads_ldr_ppm_variants_with_srgb_decoding() {
        let dir = temp_dir("ppm-ldr");
        let path = dir.join("t.ppm");
        let mut p6 = b"P6\n# texture\n2 1\n255\n".to_vec();
        p6.extend([0, 255, 128, 255, 0, 10]);
        std::fs::write(&path, &p6).unwrap();
        for img in [read(&path).unwrap(), read_texture(&path).unwrap()] {
            assert_eq!(
                img.get(0, 0),
                Vec3::new(0.0, 1.0, srgb_to_linear(128.0 / 255.0))
            );
            assert_eq!(
                img.get(1, 0),
                Vec3::new(1.0, 0.0, srgb_to_linear(10.0 / 255.0))
            );
        }
        // 16-bit, big-endian.
        let mut p6 = b"P6 1 1 65535 ".to_vec();
        p6.extend([0xff, 0xff, 0x00, 0x00, 0x80, 0x00]);
        std::fs::write(&path, &p6).unwrap();
        let img = read(&path).unwrap();
        assert_eq!(img.pixels[0].x, 1.0);
        assert_eq!(img.pixels[0].y, 0.0);
        assert!((img.pixels[0].z - srgb_to_linear(32768.0 / 65535.0)).abs() < 1e-6);
        // Ascii P3 and grey P2.
        std::fs::write(&path, "P3\n1 1\n255\n255 0 255\n").unwrap();
        assert_eq!(read(&path).unwrap().pixels[0], Vec3::new(1.0, 0.0, 1.0));
        std::fs::write(&path, "P2 2 1 4 4 0").unwrap();
        assert_eq!(read(&path).unwrap().pixels, vec![Vec3::ONE, Vec3::ZERO]);
    }

    #[test]
    fn reads_png_and_jpeg_textures() {
        let dir = temp_dir("tex");
        let png = dir.join("t.png");
        let rgb = image::RgbImage::from_raw(2, 1, vec![255, 0, 128, 0, 0, 0]).unwrap();
        rgb.save(&png).unwrap();
        let img = read_texture(&png).unwrap();
        assert_eq!(
            img.get(0, 0),
            Vec3::new(1.0, 0.0, srgb_to_linear(128.0 / 255.0))
        );
        let jpg = dir.join("t.jpg");
        image::RgbImage::from_pixel(8, 8, image::Rgb([200, 200, 200]))
            .save(&jpg)
            .unwrap();
        let img = read_texture(&jpg).unwrap();
        let expected = srgb_to_linear(200.0 / 255.0);
        assert!(img.pixels.iter().all(|p| (p.x - expected).abs() < 0.02));
        // 16-bit PNG.
        let png16 = dir.join("t16.png");
        image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(1, 1, vec![65535u16, 0, 0])
            .unwrap()
            .save(&png16)
            .unwrap();
        assert_eq!(read(&png16).unwrap().pixels[0], Vec3::new(1.0, 0.0, 0.0));
    }

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

    fn ppm_error(name: &str, contents: &[u8]) -> String {
        let dir = temp_dir("ppm-err");
        let path = dir.join(format!("{name}.ppm"));
        std::fs::write(&path, contents).unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.contains(&format!("{name}.ppm")), "{e}");
        e
    }

    #[test]
    fn ppm_errors_name_file_line_and_field() {
        let e = ppm_error("maxval", b"P3\n2 2\nabc\n");
        assert!(
            e.ends_with("maxval.ppm:3:1: maxval: expected a positive integer, found `abc`"),
            "{e}"
        );
        let e = ppm_error("magic", b"P7\n1 1\n");
        assert!(
            e.contains("magic.ppm:1:1: magic number: expected P2, P3, P5 or P6, found `P7`"),
            "{e}"
        );
        let e = ppm_error("width", b"P3\n0 2\n255\n");
        assert!(
            e.contains("width.ppm:2:1: width: expected a positive integer, found `0`"),
            "{e}"
        );
        let e = ppm_error("max", b"P3\n#MAX=nan\n1 1\n255\n0 0 0\n");
        assert!(
            e.contains("max.ppm:2:1: MAX: expected a positive finite number, found `nan`"),
            "{e}"
        );
        let e = ppm_error("max-neg", b"P3\n#MAX=-3\n1 1\n255\n0 0 0\n");
        assert!(e.contains("max-neg.ppm:2:1: MAX:"), "{e}");
        let e = ppm_error("value", b"P3\n2 1\n255\n0 0 0\n0 256 0\n");
        assert!(
            e.contains(
                "value.ppm:5:3: pixel (1, 0) green: expected an integer in 0..=255, found `256`"
            ),
            "{e}"
        );
        let e = ppm_error("negative", b"P3\n1 1\n255\n0 -1 0\n");
        assert!(e.contains("negative.ppm:4:3: pixel (0, 0) green:"), "{e}");
        let e = ppm_error("late-max", b"P3\n1 1\n255\n0 0\n#MAX=3\n0\n");
        assert!(
            e.contains("late-max.ppm:5:1: MAX: must come before the pixel data"),
            "{e}"
        );
        let e = ppm_error("empty", b"P3\n");
        assert!(
            e.contains("empty.ppm:2:1: width: unexpected end of file"),
            "{e}"
        );
    }

    #[test]
    fn truncated_and_oversized_ppm_are_errors() {
        let e = ppm_error("trunc-ascii", b"P3\n2 2\n255\n1 2 3\n4 5");
        assert!(
            e.contains("trunc-ascii.ppm:5:4: pixel (1, 0) blue: unexpected end of file"),
            "{e}"
        );
        let mut p6 = b"P6\n2 2\n255\n".to_vec();
        p6.extend([0u8; 11]);
        let e = ppm_error("trunc-bin", &p6);
        assert!(
            e.contains(
                "trunc-bin.ppm: byte 11: pixel data: truncated: 2x2 pixels need 12 bytes, found 11"
            ),
            "{e}"
        );
        // A huge header on a tiny file must not allocate or panic.
        let e = ppm_error("huge", b"P6\n4000000000 4000000000\n255\n\0\0\0");
        assert!(e.contains("huge.ppm"), "{e}");
        let e = ppm_error("huge-ascii", b"P3\n4000000000 4000000000\n255\n0 0 0");
        assert!(
            e.contains("huge-ascii.ppm:2:1: width: 4000000000x4000000000 is too large"),
            "{e}"
        );
        let e = ppm_error("p6-maxval", b"P6 1 1 70000 \0\0\0\0\0\0");
        assert!(
            e.contains("p6-maxval.ppm:1:8: maxval: expected a positive integer up to 65535"),
            "{e}"
        );
        let mut p6 = b"P6 1 1 100 ".to_vec();
        p6.extend([0, 101, 0]);
        let e = ppm_error("p6-value", &p6);
        assert!(
            e.contains("pixel (0, 0) green: 101 exceeds maxval 100"),
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
    fn atomic_write_replaces_and_leaves_no_temporaries() {
        let dir = temp_dir("atomic");
        let path = dir.join("out.png");
        std::fs::write(&path, b"old").unwrap();
        write(&path, &hdr_image(), &WriteOptions::default()).unwrap();
        assert!(std::fs::read(&path).unwrap().starts_with(b"\x89PNG"));
        assert_eq!(leftovers(&dir), Vec::<String>::new());
        // A failing write (bad tone-map parameter) leaves the old file alone.
        let bad = WriteOptions {
            params: ToneMapParams {
                gamma: -1.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let before = std::fs::read(&path).unwrap();
        assert!(write(&path, &hdr_image(), &bad).is_err());
        assert_eq!(std::fs::read(&path).unwrap(), before);
        // A failure while encoding removes the temporary and writes nothing.
        let missing = dir.join("fresh.ppm");
        let r = write_atomic(&missing, |out| {
            out.write_all(b"P3\n").unwrap();
            Err(ImageError::InvalidParameter("simulated failure".into()))
        });
        assert!(r.is_err());
        assert!(!missing.exists());
        assert_eq!(leftovers(&dir), Vec::<String>::new());
        // A missing directory: an error naming the file, nothing written.
        let e = write(
            &dir.join("no/such/dir/x.exr"),
            &hdr_image(),
            &WriteOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("x.exr"), "{e}");
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
