//! Render parts: a film saved as an OpenEXR file that any viewer shows as
//! the mean image, and that also carries what is needed to continue or merge
//! it exactly.
//!
//! # File layout
//!
//! One scan-line layer:
//!
//! - `R`, `G`, `B` (f32): the mean radiance, what viewers display;
//! - `luz.sum.{R,G,B}.{hi,lo}` and `luz.sumsq.{R,G,B}.{hi,lo}` (u32): the
//!   bits of the f64 per-pixel sums of samples and of their squares, high
//!   and low words. EXR has no f64 channels; storing the bits keeps the sums
//!   exact, so a resumed render continues the very same running sums and a
//!   merge adds the sums the renders computed.
//!
//! and these header attributes (text, since EXR has no 64-bit integers):
//!
//! | attribute | value |
//! |---|---|
//! | `luz:version` | the luz version that rendered it |
//! | `luz:sceneHash` | [`scene_hash`] of the scene, 16 hex digits |
//! | `luz:seed` | the render's seed |
//! | `luz:spp` | the samples per pixel of the whole render this is part of |
//! | `luz:samples` | the sample indices held, as ranges `A..B`, comma separated |
//! | `luz:backend` | the intersection backend |
//! | `luz:nonFinite` | samples dropped as not finite |
//!
//! The resolution is the EXR data window.

pub use super::scene_hash::scene_hash;
use crate::image::io::write_atomic;
use crate::image::ImageError;
use crate::render::film::check_resolution;
use crate::render::Film;
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image as ExrImage, Layer,
    LayerAttributes, ReadChannels, ReadLayers, SmallVec, Text, WritableImage,
};
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// What a part is a part of, and which samples it holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartMeta {
    pub version: String,
    pub scene_hash: u64,
    pub seed: u64,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// Sample indices held: sorted, disjoint, none empty.
    pub ranges: Vec<Range<u32>>,
    pub backend: String,
}

impl PartMeta {
    pub fn sample_count(&self) -> u64 {
        self.ranges.iter().map(|r| r.len() as u64).sum()
    }
}

/// A property in which two films differ that parts of one render share:
/// the attribute that stores it, and its two values.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mismatch {
    pub attribute: &'static str,
    pub ours: String,
    pub theirs: String,
}

/// The first property (resolution, scene hash, seed, backend, luz version)
/// that shows `theirs` (of resolution `their_size`) is not part of the
/// render `ours` (of `our_size`) is, if any.
pub fn first_mismatch(
    (ours, our_size): (&PartMeta, (u32, u32)),
    (theirs, their_size): (&PartMeta, (u32, u32)),
) -> Option<Mismatch> {
    let size = |(w, h): (u32, u32)| format!("{w}x{h}");
    let hash = |h: u64| format!("{h:016x}");
    [
        ("dataWindow", size(our_size), size(their_size)),
        (SCENE_HASH, hash(ours.scene_hash), hash(theirs.scene_hash)),
        (SEED, ours.seed.to_string(), theirs.seed.to_string()),
        (BACKEND, ours.backend.clone(), theirs.backend.clone()),
        (VERSION, ours.version.clone(), theirs.version.clone()),
    ]
    .into_iter()
    .find(|(_, a, b)| a != b)
    .map(|(attribute, ours, theirs)| Mismatch {
        attribute,
        ours,
        theirs,
    })
}

#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub meta: PartMeta,
    pub film: Film,
}

#[derive(Debug, thiserror::Error)]
pub enum PartError {
    #[error(transparent)]
    Image(#[from] ImageError),
    /// A file that is not a luz render part, or a damaged one.
    #[error("{}: {field}: {message}", path.display())]
    Invalid {
        path: PathBuf,
        field: String,
        message: String,
    },
}

const VERSION: &str = "luz:version";
const SCENE_HASH: &str = "luz:sceneHash";
const SEED: &str = "luz:seed";
const SPP: &str = "luz:spp";
const SAMPLES: &str = "luz:samples";
const BACKEND: &str = "luz:backend";
const NON_FINITE: &str = "luz:nonFinite";
const RGB: [&str; 3] = ["R", "G", "B"];

/// Formats sample ranges as `luz:samples` stores them: `0..64,128..192`.
pub fn format_ranges(ranges: &[Range<u32>]) -> String {
    let parts: Vec<String> = ranges
        .iter()
        .map(|r| format!("{}..{}", r.start, r.end))
        .collect();
    parts.join(",")
}

/// Parses one range `A..B` with `A < B`.
pub fn parse_range(s: &str) -> Result<Range<u32>, String> {
    let bad = || format!("expected a sample range A..B such as 0..64, found `{s}`");
    let (a, b) = s.trim().split_once("..").ok_or_else(bad)?;
    let (a, b): (u32, u32) = (a.parse().map_err(|_| bad())?, b.parse().map_err(|_| bad())?);
    if a >= b {
        return Err(format!(
            "sample range {a}..{b} is empty (A must be below B)"
        ));
    }
    Ok(a..b)
}

fn split_bits(v: f64) -> (u32, u32) {
    let bits = v.to_bits();
    ((bits >> 32) as u32, bits as u32)
}

fn join_bits(hi: u32, lo: u32) -> f64 {
    f64::from_bits(((hi as u64) << 32) | lo as u64)
}

/// Writes the part `meta` describes, holding `film`, to `path` atomically
/// (see the module docs for the layout).
pub fn write(path: &Path, meta: &PartMeta, film: &Film) -> Result<(), PartError> {
    let mean = film.image();
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in RGB.iter().enumerate() {
        let values = mean.pixels.iter().map(|p| p[c]).collect();
        channels.push(AnyChannel::new(*name, FlatSamples::F32(values)));
        for (kind, sums) in [("sum", &film.sum), ("sumsq", &film.sum_sq)] {
            let (hi, lo): (Vec<u32>, Vec<u32>) = sums.iter().map(|s| split_bits(s[c])).unzip();
            channels.push(AnyChannel::new(
                format!("luz.{kind}.{name}.hi").as_str(),
                FlatSamples::U32(hi),
            ));
            channels.push(AnyChannel::new(
                format!("luz.{kind}.{name}.lo").as_str(),
                FlatSamples::U32(lo),
            ));
        }
    }
    let text = |s: &str| AttributeValue::Text(Text::from(s));
    let attributes = LayerAttributes {
        other: HashMap::from([
            (Text::from(VERSION), text(&meta.version)),
            (
                Text::from(SCENE_HASH),
                text(&format!("{:016x}", meta.scene_hash)),
            ),
            (Text::from(SEED), text(&meta.seed.to_string())),
            (Text::from(SPP), text(&meta.spp.to_string())),
            (Text::from(SAMPLES), text(&format_ranges(&meta.ranges))),
            (Text::from(BACKEND), text(&meta.backend)),
            (Text::from(NON_FINITE), text(&film.non_finite.to_string())),
        ]),
        ..LayerAttributes::default()
    };
    let layer = Layer::new(
        (film.width as usize, film.height as usize),
        attributes,
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(channels),
    );
    write_atomic(path, |out| {
        ExrImage::from_layer(layer)
            .write()
            .to_buffered(out)
            .map_err(|e| ImageError::Format {
                path: path.to_path_buf(),
                message: e.to_string(),
            })
    })?;
    Ok(())
}

/// Reads a part that [`write`] wrote, checking every field.
pub fn read(path: &Path) -> Result<Part, PartError> {
    let invalid = |field: &str, message: String| PartError::Invalid {
        path: path.to_path_buf(),
        field: field.to_string(),
        message,
    };
    let data = std::fs::read(path).map_err(|source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(data))
        .map_err(|e| invalid("file", format!("not a readable OpenEXR file ({e})")))?;
    let layer = image.layer_data;
    let attr = |name: &str| -> Result<String, PartError> {
        match layer.attributes.other.get(&Text::from(name)) {
            Some(AttributeValue::Text(t)) => Ok(t.to_string()),
            Some(_) => Err(invalid(name, "is not a text attribute".into())),
            None => Err(invalid(
                name,
                "missing: not a render part written by luz".into(),
            )),
        }
    };
    let number = |name: &str| -> Result<u64, PartError> {
        let s = attr(name)?;
        s.parse()
            .map_err(|_| invalid(name, format!("expected an unsigned integer, found `{s}`")))
    };
    let version = attr(VERSION)?;
    let hash_text = attr(SCENE_HASH)?;
    let scene_hash = u64::from_str_radix(&hash_text, 16).map_err(|_| {
        invalid(
            SCENE_HASH,
            format!("expected hex digits, found `{hash_text}`"),
        )
    })?;
    let seed = number(SEED)?;
    let spp =
        u32::try_from(number(SPP)?).map_err(|_| invalid(SPP, "does not fit in 32 bits".into()))?;
    let ranges_text = attr(SAMPLES)?;
    let mut ranges = Vec::new();
    for r in ranges_text.split(',') {
        ranges.push(parse_range(r).map_err(|m| invalid(SAMPLES, m))?);
    }
    if ranges.windows(2).any(|w| w[0].end > w[1].start) {
        return Err(invalid(
            SAMPLES,
            format!("ranges `{ranges_text}` are not sorted and disjoint"),
        ));
    }
    let backend = attr(BACKEND)?;
    let non_finite = number(NON_FINITE)?;

    let (width, height) = (layer.size.width(), layer.size.height());
    check_resolution(width as u32, height as u32).map_err(|m| invalid("dataWindow", m))?;
    let n = width * height;
    let channel = |name: &str| -> Result<&Vec<u32>, PartError> {
        let found = layer.channel_data.list.iter().find(|c| c.name == *name);
        match found.map(|c| &c.sample_data) {
            Some(FlatSamples::U32(v)) if v.len() == n => Ok(v),
            Some(_) => Err(invalid(name, "expected a u32 channel".into())),
            None => Err(invalid(name, "channel missing".into())),
        }
    };
    let mut film = Film::new(width as u32, height as u32);
    for (c, name) in RGB.iter().enumerate() {
        for (kind, sums) in [("sum", &mut film.sum), ("sumsq", &mut film.sum_sq)] {
            let hi = channel(&format!("luz.{kind}.{name}.hi"))?;
            let lo = channel(&format!("luz.{kind}.{name}.lo"))?;
            for (i, s) in sums.iter_mut().enumerate() {
                let v = join_bits(hi[i], lo[i]);
                if !v.is_finite() {
                    return Err(invalid(
                        &format!("luz.{kind}.{name}"),
                        format!(
                            "pixel ({}, {}) holds {v}, not a finite sum",
                            i % width,
                            i / width
                        ),
                    ));
                }
                s[c] = v;
            }
        }
    }
    let meta = PartMeta {
        version,
        scene_hash,
        seed,
        spp,
        ranges,
        backend,
    };
    film.samples = meta.sample_count();
    film.non_finite = non_finite;
    Ok(Part { meta, film })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_survive_a_round_trip_bit_for_bit() {
        let mut film = Film::new(3, 2);
        for (i, (s, q)) in film.sum.iter_mut().zip(&mut film.sum_sq).enumerate() {
            *s = [0.1 * i as f64, 1.0 / 3.0, 1e30];
            *q = [f64::MIN_POSITIVE, 2.0f64.sqrt(), 1e300];
        }
        film.samples = 7;
        film.non_finite = 3;
        let part = Part {
            meta: PartMeta {
                version: "0.1.0".into(),
                scene_hash: 0xfedc_ba98_7654_3210,
                seed: u64::MAX,
                spp: 9,
                ranges: vec![1..3, 4..9],
                backend: "rust".into(),
            },
            film,
        };
        let dir = std::env::temp_dir().join(format!("luz-part-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.exr");
        write(&path, &part.meta, &part.film).unwrap();
        assert_eq!(read(&path).unwrap(), part);
        // Any EXR reader sees the mean image.
        let mean = crate::image::read(&path).unwrap();
        assert_eq!(mean, part.film.image());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn ranges_parse_and_refuse_empty_or_malformed() {
        assert_eq!(parse_range("3..17"), Ok(3..17));
        for bad in ["5..5", "6..2", "1-2", "..4", "a..b", "-1..3"] {
            assert!(parse_range(bad).is_err(), "{bad}");
        }
        assert_eq!(format_ranges(&[0..4, 8..9]), "0..4,8..9");
    }
}
