//! The formats the `image` crate encodes and decodes for luz: OpenEXR and
//! Radiance HDR (linear), PNG and JPEG (display-encoded, sRGB-decoded on
//! read).

use super::srgb::{srgb_lut, srgb_to_linear};
use super::ImageError;
use crate::image::Image;
use crate::math::Vec3;
use image::{ExtendedColorType, ImageEncoder, ImageFormat};
use std::io::{Seek, Write};
use std::path::Path;

/// Decodes `data`, a file in `format`, into linear RGB.
pub(super) fn decode(path: &Path, data: &[u8], format: ImageFormat) -> Result<Image, ImageError> {
    let dynamic =
        image::load(std::io::Cursor::new(data), format).map_err(|e| ImageError::Format {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    let (w, h) = (dynamic.width(), dynamic.height());
    let pixels: Vec<Vec3> = match format {
        ImageFormat::OpenExr | ImageFormat::Hdr => dynamic
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

/// Writes `img` as an RGB f32 OpenEXR file.
pub(super) fn write_exr(out: impl Write + Seek, img: &Image) -> image::ImageResult<()> {
    let bytes: Vec<u8> = img
        .pixels
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(f32::to_ne_bytes)
        .collect();
    image::codecs::openexr::OpenExrEncoder::new(out).write_image(
        &bytes,
        img.width,
        img.height,
        ExtendedColorType::Rgb32F,
    )
}

/// Writes `img` as a Radiance RGBE file.
pub(super) fn write_hdr(out: impl Write, img: &Image) -> image::ImageResult<()> {
    let rgb: Vec<image::Rgb<f32>> = img
        .pixels
        .iter()
        .map(|p| image::Rgb(p.to_array()))
        .collect();
    image::codecs::hdr::HdrEncoder::new(out).encode(&rgb, img.width as usize, img.height as usize)
}

/// Writes 8-bit RGB display values, `width` × `height`, as a PNG file.
pub(super) fn write_png(
    out: impl Write,
    rgb8: &[u8],
    width: u32,
    height: u32,
) -> image::ImageResult<()> {
    image::codecs::png::PngEncoder::new(out).write_image(
        rgb8,
        width,
        height,
        ExtendedColorType::Rgb8,
    )
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{hdr_image, leftovers, temp_dir};
    use super::super::{linear_to_srgb, read, read_texture, srgb_to_linear, write, WriteOptions};
    use crate::image::ToneMap;
    use crate::math::Vec3;

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
}
