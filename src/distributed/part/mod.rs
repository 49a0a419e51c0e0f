//! Render parts: a film saved as an OpenEXR file that any viewer shows as
//! the mean image, and that also carries what is needed to continue or merge
//! it exactly, and to tell whether it is still what luz wrote.
//!
//! # File layout
//!
//! One uncompressed scan-line layer:
//!
//! - `R`, `G`, `B` (f32): the mean radiance, what viewers display;
//! - `stderr.R`, `stderr.G`, `stderr.B` (f32): the standard error of each
//!   pixel's mean (the sample standard deviation over √n), so that a viewer
//!   shows where the image is still noisy;
//! - `luz.sum.{R,G,B}.{hi,lo}` and `luz.sumsq.{R,G,B}.{hi,lo}` (u32): the
//!   bits of the f64 per-pixel sums of samples and of their squares, high
//!   and low words. EXR has no f64 channels; storing the bits keeps the sums
//!   exact, so a resumed render continues the very same running sums and a
//!   merge adds the sums the renders computed;
//! - in an adaptive part only, `luz.count`, `luz.goal` and `luz.met` (u32):
//!   each pixel's sample count, the count it renders on to before its next
//!   decision, and whether it met the noise threshold at its last decision
//!   (see [`crate::render::adaptive`]).
//!
//! and these header attributes (text, since EXR has no 64-bit integers),
//! written in this order, so that two renders of one part are the same
//! bytes:
//!
//! | attribute | value |
//! |---|---|
//! | `luz:version` | the luz version that rendered it |
//! | `luz:sceneHash` | [`scene_hash`] of the scene, 16 hex digits |
//! | `luz:seed` | the render's seed |
//! | `luz:spp` | the samples per pixel of the whole render this is part of |
//! | `luz:samples` | the sample indices held, as ranges `A..B`, comma separated |
//! | `luz:sampling` | `uniform`, `noise-threshold E MIN..MAX` or `adaptive SPP` ([`Sampling`]) |
//! | `luz:sampleTotal` | the samples of all pixels together |
//! | `luz:backend` | the intersection backend ([`BackendKind`] name: `rust`, `embree`) |
//! | `luz:nonFinite` | samples dropped as not finite |
//! | `luz:checksum` | xxh3-64 of all of the above, the resolution, the sample count and the sums, 16 hex digits |
//!
//! The resolution is the EXR data window.
//!
//! # Integrity
//!
//! [`read`] refuses a part that is not what luz wrote, before merge or
//! resume can add it to anything:
//!
//! - **Header first.** Only the header is parsed at first; its data window
//!   must be within luz's limits ([`check_resolution`](crate::render::film::check_resolution)) and its channels
//!   (uncompressed, as luz writes them) must fit in the file. A header
//!   claiming 16000×16000 pixels in a file of a few kilobytes is refused
//!   before anything is allocated for its pixels.
//! - **Checksum.** `luz:checksum` is xxh3-64 ([`xxhash_rust::xxh3`]) of a
//!   tag, the other luz attributes' texts in the order of the table (name
//!   and value, each followed by a zero byte), width, height and sample
//!   count (little-endian), then the bits of every sum and then every sum of
//!   squares, pixel by pixel in R, G, B order (little-endian u64), and in an
//!   adaptive part every count, every goal (little-endian u32) and every
//!   met flag (a byte). It guards
//!   against damage and careless edits, not against forgery (anyone can
//!   recompute it), so a fast non-cryptographic hash is the right tool: a
//!   random change goes unseen with probability 2⁻⁶⁴, ample for that job,
//!   and 64 bits print as 16 hex digits like `luz:sceneHash`. xxh3-128
//!   would cost the same time but buy nothing against either threat. For a
//!   1024×1024 part (48 MiB of sums) it takes 6–11 ms, a few percent of
//!   reading or writing the file.
//! - **Plausible sums**, which catch corruption even where someone
//!   recomputed the checksum: radiance is never negative, so no sum may be
//!   negative or non-finite, and per pixel and channel the Cauchy–Schwarz
//!   inequality `sum² ≤ n·sumsq` holds for the `n` samples (dropped
//!   non-finite ones count as zeros, which keep it). Rounding of `n` f64
//!   additions moves either side by a relative `n·ε/2` at most (ε =
//!   `f64::EPSILON`), so the test allows a relative `4·n·ε`; a flipped bit of
//!   a sum's exponent or top mantissa bits breaks it by far more.

mod attributes;
mod channels;
mod checksum;
mod layout;
mod ordered;
mod plausible;
mod ranges;
mod records;
#[cfg(test)]
mod tests;

pub use super::scene_hash::scene_hash;
pub use plausible::{SumKind, SumProblem};
pub use ranges::{format_ranges, parse_range};

use crate::accel::BackendKind;
use crate::image::io::write_atomic;
use crate::image::ImageError;
use crate::render::{Film, Sampling};
use attributes::{
    attribute_texts, layer_attributes, parse_attributes, ParsedAttributes, BACKEND, SAMPLE_TOTAL,
    SAMPLING, SCENE_HASH, SEED, VERSION,
};
use checksum::{checksum, verify_checksum};
use exr::meta::MetaData;
use exr::prelude::{Encoding, Image as ExrImage, Layer, ReadChannels, ReadLayers, WritableImage};
use layout::check_layout;
use ordered::InOrder;
use plausible::check_plausible;
use records::header_records;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// What a part is a part of, and which samples it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct PartMeta {
    pub version: String,
    pub scene_hash: u64,
    pub seed: u64,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// Sample indices held: sorted, disjoint, none empty. An adaptive
    /// part's pixels hold `0..count` each, up to its one range's end.
    pub ranges: Vec<Range<u32>>,
    /// How the samples are spread over the pixels.
    pub sampling: Sampling,
    /// The backend that traced the samples: `Rust` or `Embree`, never
    /// `Auto` (which is a request, not a backend).
    pub backend: BackendKind,
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
        (
            SAMPLING,
            ours.sampling.to_string(),
            theirs.sampling.to_string(),
        ),
        (
            BACKEND,
            ours.backend.name().to_string(),
            theirs.backend.name().to_string(),
        ),
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
    /// A header whose data window needs more bytes than the whole file has.
    #[error(
        "{}: dataWindow: {width}x{height} pixels of {bytes_per_pixel} bytes need at least {needed} bytes, the file holds {held}: it is truncated, or its header is damaged or edited",
        path.display()
    )]
    Truncated {
        path: PathBuf,
        width: usize,
        height: usize,
        bytes_per_pixel: usize,
        needed: u64,
        held: u64,
    },
    /// A part written before parts carried a checksum (or one edited to
    /// lose it).
    #[error(
        "{}: luz:checksum: missing: written by an older luz, whose parts carry no checksum, or edited; render it again",
        path.display()
    )]
    ChecksumMissing { path: PathBuf },
    /// Sums or metadata that are not those the checksum was made of.
    #[error(
        "{}: luz:checksum: the part's sums and metadata give {computed:016x}, not the stored {stored:016x}: the part is damaged or edited",
        path.display()
    )]
    Checksum {
        path: PathBuf,
        stored: u64,
        computed: u64,
    },
    /// Sums no render can produce, whatever the checksum says.
    #[error(
        "{}: {}: pixel ({x}, {y}): {problem}: the part is damaged or edited",
        path.display(), problem.field(channel)
    )]
    Sum {
        path: PathBuf,
        channel: &'static str,
        x: usize,
        y: usize,
        problem: SumProblem,
    },
}

impl PartError {
    fn invalid(path: &Path, field: &str, message: String) -> Self {
        Self::Invalid {
            path: path.to_path_buf(),
            field: field.to_string(),
            message,
        }
    }
}

/// Writes the part `meta` describes, holding `film`, to `path` atomically
/// (see the module docs for the layout). The same part gives the same
/// bytes, whichever process writes it.
pub fn write(path: &Path, meta: &PartMeta, film: &Film) -> Result<(), PartError> {
    assert_eq!(
        film.plan.is_some(),
        meta.sampling.is_adaptive(),
        "an adaptive part's film has a plan, a uniform one's none"
    );
    let channels = channels::film_channels(film);
    let texts = attribute_texts(meta, film);
    let attributes = layer_attributes(&texts, checksum(&texts, film));
    let layer = Layer::new(
        (film.width as usize, film.height as usize),
        attributes,
        Encoding::UNCOMPRESSED,
        channels,
    );
    write_atomic(path, |out| {
        let format = |message: String| ImageError::Format {
            path: path.to_path_buf(),
            message,
        };
        let mut ordered = InOrder::new(out);
        ExrImage::from_layer(layer)
            .write()
            .to_buffered(&mut ordered)
            .map_err(|e| format(e.to_string()))?;
        ordered.finish().map_err(|e| format(e.to_string()))
    })?;
    Ok(())
}

/// Whether `path` is an OpenEXR file whose header carries luz's part
/// attributes, damaged or not: such a file is read with [`read`], which
/// says what is wrong with it, rather than as a plain image.
pub fn is_part(path: &Path) -> bool {
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let Ok(meta) = MetaData::read_from_buffered(std::io::BufReader::new(file), false) else {
        return false;
    };
    meta.headers.iter().any(|h| {
        h.own_attributes
            .other
            .contains_key(&exr::prelude::Text::from(VERSION))
    })
}

/// Reads a part that [`write`] wrote, checking every field, the checksum
/// and the sums (see the module docs).
pub fn read(path: &Path) -> Result<Part, PartError> {
    let unreadable = |e: exr::error::Error| {
        PartError::invalid(path, "file", format!("not a readable OpenEXR file ({e})"))
    };
    let data = std::fs::read(path).map_err(|source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;

    // The header alone first: nothing below allocates what it claims
    // before `check_layout` has held it against the file's size.
    let meta_data = MetaData::read_from_buffered(data.as_slice(), false).map_err(unreadable)?;
    let header = match meta_data.headers.as_slice() {
        [header] => header,
        headers => {
            return Err(PartError::invalid(
                path,
                "file",
                format!("holds {} layers, a luz part one", headers.len()),
            ))
        }
    };
    let ParsedAttributes {
        texts,
        meta,
        sample_total,
        non_finite,
        checksum: stored,
    } = parse_attributes(path, header)?;
    let adaptive = meta.sampling.is_adaptive();
    let header_len = match header_records(&data) {
        Ok(Some((_, end))) => end,
        _ => 0,
    };
    check_layout(path, header, header_len, data.len(), adaptive)?;

    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(data))
        .map_err(unreadable)?;
    let mut film = channels::film_of_sums(path, &image.layer_data, adaptive)?;
    film.samples = match &film.plan {
        None => meta.sample_count(),
        Some(plan) => plan.count.iter().copied().max().unwrap_or(0) as u64,
    };
    film.non_finite = non_finite;
    verify_checksum(path, &texts, &film, stored)?;
    check_plausible(path, &film)?;
    check_plan(path, &meta, &film, sample_total)?;
    Ok(Part { meta, film })
}

/// Refuses a part whose sample total is not its pixels' counts', or an
/// adaptive part whose counts pass its goals or its range.
fn check_plan(path: &Path, meta: &PartMeta, film: &Film, total: u64) -> Result<(), PartError> {
    if film.total_samples() != total {
        return Err(PartError::invalid(
            path,
            SAMPLE_TOTAL,
            format!(
                "{total}, but the pixels hold {} samples",
                film.total_samples()
            ),
        ));
    }
    let Some(plan) = &film.plan else {
        return Ok(());
    };
    let end = meta.ranges.last().map_or(0, |r| r.end);
    if meta.ranges.len() != 1 || meta.ranges[0].start != 0 {
        return Err(PartError::invalid(
            path,
            attributes::SAMPLES,
            "an adaptive part holds one range from 0".into(),
        ));
    }
    match (0..plan.count.len()).find(|&i| plan.count[i] > plan.goal[i] || plan.count[i] > end) {
        Some(i) => Err(PartError::invalid(
            path,
            channels::COUNT,
            format!(
                "pixel ({}, {}) holds {} samples, past its goal {} or the range's end {end}",
                i % film.width as usize,
                i / film.width as usize,
                plan.count[i],
                plan.goal[i]
            ),
        )),
        None => Ok(()),
    }
}
