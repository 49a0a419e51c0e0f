//! PPM: the parser of every variant luz reads (`P2`, `P3`, `P5`, `P6`, with
//! or without `#MAX=`) and the writer of the HDR PPM; the format itself is
//! described in the module docs of [`super`].

use super::srgb::srgb_to_linear;
use super::{ImageError, CHANNELS};
use crate::image::Image;
use crate::location::line_column;
use crate::math::Vec3;
use std::borrow::Cow;
use std::io::Write;
use std::path::Path;

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

/// What a PPM header says about the pixel data after it.
struct Header {
    binary: bool,
    grey: bool,
    width: u64,
    height: u64,
    maxval: u64,
    /// Samples per pixel: 1 for grey, 3 for RGB.
    channels: u64,
    /// Samples in the whole image.
    values: usize,
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
    let h = r.header()?;

    // Each integer i stands for i * scale, then (without #MAX) sRGB decoding.
    let scale = r.max.unwrap_or(1.0) / h.maxval as f64;
    let hdr = r.max.is_some();
    let convert = |i: u64| -> f32 {
        let v = (i as f64 * scale) as f32;
        if hdr {
            v
        } else {
            srgb_to_linear(v)
        }
    };

    let samples = if h.binary {
        r.binary_samples(&h, convert)?
    } else {
        r.ascii_samples(&h, convert)?
    };
    let pixels = if h.grey {
        samples.into_iter().map(Vec3::splat).collect()
    } else {
        samples
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect()
    };
    Ok(Image::new(h.width as u32, h.height as u32, pixels))
}

impl PpmReader<'_> {
    /// The magic number, size and maxval, leaving the reader in the body.
    fn header(&mut self) -> Result<Header, ImageError> {
        let (magic, at) = self.token(|| "magic number".into())?;
        let (binary, grey) = match &*magic {
            "P2" => (false, true),
            "P3" => (false, false),
            "P5" => (true, true),
            "P6" => (true, false),
            _ => {
                return Err(self.error(
                    at,
                    "magic number",
                    format!("expected P2, P3, P5 or P6, found `{magic}`"),
                ))
            }
        };
        let positive = "a positive integer";
        self.skip()?;
        let width_at = self.pos;
        let width = self.int(|| "width".into(), 1, u32::MAX as u64, positive)?;
        let height = self.int(|| "height".into(), 1, u32::MAX as u64, positive)?;
        let maxval_hi = if binary { 65535 } else { u32::MAX as u64 };
        let maxval_expected = if binary {
            "a positive integer up to 65535"
        } else {
            positive
        };
        let maxval = self.int(|| "maxval".into(), 1, maxval_hi, maxval_expected)?;
        self.in_body = true;
        let channels: u64 = if grey { 1 } else { 3 };
        let values = width
            .checked_mul(height)
            .and_then(|n| n.checked_mul(channels))
            .filter(|&n| n <= isize::MAX as u64 / 8)
            .ok_or_else(|| {
                self.error(width_at, "width", format!("{width}x{height} is too large"))
            })? as usize;
        Ok(Header {
            binary,
            grey,
            width,
            height,
            maxval,
            channels,
            values,
        })
    }

    /// The samples of a `P5` or `P6` body, 8 or 16 bits (big-endian) each.
    fn binary_samples(
        &mut self,
        h: &Header,
        convert: impl Fn(u64) -> f32,
    ) -> Result<Vec<f32>, ImageError> {
        let &Header {
            width,
            height,
            maxval,
            channels,
            values,
            grey,
            ..
        } = h;
        // Exactly one whitespace byte separates maxval from the data.
        match self.data.get(self.pos) {
            Some(&b) if is_space(b) => self.pos += 1,
            _ => {
                return Err(self.error(
                    self.pos,
                    "maxval",
                    "expected one whitespace byte before the pixel data",
                ))
            }
        }
        let bytes = if maxval < 256 { 1 } else { 2 };
        let need = values * bytes;
        let body = &self.data[self.pos..];
        if body.len() < need {
            return Err(self.binary_error(
                self.pos,
                "pixel data",
                format!(
                    "truncated: {width}x{height} pixels need {need} bytes, found {}",
                    body.len()
                ),
            ));
        }
        let mut samples = Vec::with_capacity(values);
        for (k, chunk) in body[..need].chunks_exact(bytes).enumerate() {
            let i = if bytes == 1 {
                chunk[0] as u64
            } else {
                u16::from_be_bytes([chunk[0], chunk[1]]) as u64
            };
            if i > maxval {
                let p = k as u64 / channels;
                return Err(self.binary_error(
                    self.pos + k * bytes,
                    &sample_field(p % width, p / width, k as u64 % channels, grey),
                    format!("{i} exceeds maxval {maxval}"),
                ));
            }
            samples.push(convert(i));
        }
        Ok(samples)
    }

    /// The samples of a `P2` or `P3` body, whitespace-separated integers.
    fn ascii_samples(
        &mut self,
        h: &Header,
        convert: impl Fn(u64) -> f32,
    ) -> Result<Vec<f32>, ImageError> {
        let &Header {
            width,
            maxval,
            channels,
            values,
            grey,
            ..
        } = h;
        // Never trust the header for the allocation: grow with the data.
        let mut samples = Vec::with_capacity(values.min(self.data.len() - self.pos));
        let expected = format!("an integer in 0..={maxval}");
        for k in 0..values as u64 {
            let p = k / channels;
            let field = || sample_field(p % width, p / width, k % channels, grey);
            let i = self.int(field, 0, maxval, &expected)?;
            samples.push(convert(i));
        }
        Ok(samples)
    }
}

fn sample_field(x: u64, y: u64, c: u64, grey: bool) -> String {
    if grey {
        format!("pixel ({x}, {y})")
    } else {
        format!("pixel ({x}, {y}) {}", CHANNELS[c as usize])
    }
}

/// Writes `img` as an HDR PPM whose integers span `[0, MAX]` in
/// `resolution` steps, one image row per line.
pub(super) fn write_ppm(out: &mut impl Write, img: &Image, resolution: u32) -> std::io::Result<()> {
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

#[cfg(test)]
mod tests {
    use super::super::fixtures::{hdr_image, temp_dir};
    use super::super::{read, read_texture, srgb_to_linear, write, WriteOptions};
    use crate::image::Image;
    use crate::math::Vec3;

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
}
