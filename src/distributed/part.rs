//! Render parts: a film saved as an OpenEXR file that any viewer shows as
//! the mean image, and that also carries what is needed to continue or merge
//! it exactly, and to tell whether it is still what luz wrote.
//!
//! # File layout
//!
//! One uncompressed scan-line layer:
//!
//! - `R`, `G`, `B` (f32): the mean radiance, what viewers display;
//! - `luz.sum.{R,G,B}.{hi,lo}` and `luz.sumsq.{R,G,B}.{hi,lo}` (u32): the
//!   bits of the f64 per-pixel sums of samples and of their squares, high
//!   and low words. EXR has no f64 channels; storing the bits keeps the sums
//!   exact, so a resumed render continues the very same running sums and a
//!   merge adds the sums the renders computed.
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
//!   must be within luz's limits ([`check_resolution`]) and its channels
//!   (uncompressed, as luz writes them) must fit in the file. A header
//!   claiming 16000×16000 pixels in a file of a few kilobytes is refused
//!   before anything is allocated for its pixels.
//! - **Checksum.** `luz:checksum` is xxh3-64 ([`xxhash_rust::xxh3`]) of a
//!   tag, the other luz attributes' texts in the order of the table (name
//!   and value, each followed by a zero byte), width, height and sample
//!   count (little-endian), then the bits of every sum and then every sum of
//!   squares, pixel by pixel in R, G, B order (little-endian u64). It guards
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

pub use super::scene_hash::scene_hash;
use crate::accel::BackendKind;
use crate::image::io::write_atomic;
use crate::image::ImageError;
use crate::render::film::check_resolution;
use crate::render::Film;
use exr::meta::attribute::SampleType;
use exr::meta::header::Header;
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Compression, Encoding, FlatSamples, Image as ExrImage,
    Layer, LayerAttributes, ReadChannels, ReadLayers, SmallVec, Text, WritableImage,
};
use std::collections::HashMap;
use std::fmt;
use std::io::{Seek, SeekFrom, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use xxhash_rust::xxh3::Xxh3;

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

/// Which of a pixel's two sums a [`SumProblem`] is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SumKind {
    /// `luz.sum.*`: the sum of the samples.
    Sum,
    /// `luz.sumsq.*`: the sum of their squares.
    SumSq,
}

impl SumKind {
    fn name(self) -> &'static str {
        match self {
            Self::Sum => "sum",
            Self::SumSq => "sumsq",
        }
    }
}

/// What is impossible about a pixel's sums.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SumProblem {
    /// A sum below zero: radiance never is.
    Negative { kind: SumKind, value: f64 },
    /// An infinite or NaN sum: luz drops non-finite samples.
    NotFinite { kind: SumKind, value: f64 },
    /// `sum² > n·sumsq` beyond rounding, which no `samples` real numbers
    /// allow (Cauchy–Schwarz).
    CauchySchwarz { sum: f64, sum_sq: f64, samples: u64 },
}

impl SumProblem {
    /// The channels the problem is in, for `channel` (`R`, `G` or `B`).
    fn field(&self, channel: &str) -> String {
        match self {
            Self::Negative { kind, .. } | Self::NotFinite { kind, .. } => {
                format!("luz.{}.{channel}", kind.name())
            }
            Self::CauchySchwarz { .. } => format!("luz.sum.{channel}, luz.sumsq.{channel}"),
        }
    }
}

impl fmt::Display for SumProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Negative { value, .. } => {
                write!(f, "holds {value}, a negative sum (radiance never is)")
            }
            Self::NotFinite { value, .. } => write!(f, "holds {value}, not a finite sum"),
            Self::CauchySchwarz {
                sum,
                sum_sq,
                samples,
            } => write!(
                f,
                "sum {sum} and sum of squares {sum_sq} of {samples} samples break \
                 sum² ≤ n·sumsq (Cauchy–Schwarz)"
            ),
        }
    }
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

const VERSION: &str = "luz:version";
const SCENE_HASH: &str = "luz:sceneHash";
const SEED: &str = "luz:seed";
const SPP: &str = "luz:spp";
const SAMPLES: &str = "luz:samples";
const BACKEND: &str = "luz:backend";
const NON_FINITE: &str = "luz:nonFinite";
const CHECKSUM: &str = "luz:checksum";
/// The checksummed attributes, in the order they are written and hashed;
/// `luz:checksum` follows them.
const ATTRIBUTES: [&str; 7] = [VERSION, SCENE_HASH, SEED, SPP, SAMPLES, BACKEND, NON_FINITE];
const RGB: [&str; 3] = ["R", "G", "B"];
/// Versions the checksum's input; a change of what is hashed changes it.
const CHECKSUM_TAG: &[u8] = b"luz part checksum 1\0";

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

/// The texts of the checksummed attributes of a part, in [`ATTRIBUTES`]
/// order.
fn attribute_texts(meta: &PartMeta, non_finite: u64) -> [String; 7] {
    [
        meta.version.clone(),
        format!("{:016x}", meta.scene_hash),
        meta.seed.to_string(),
        meta.spp.to_string(),
        format_ranges(&meta.ranges),
        meta.backend.name().to_string(),
        non_finite.to_string(),
    ]
}

/// The `luz:checksum` of a part whose checksummed attributes hold `texts`
/// (in [`ATTRIBUTES`] order) and whose film is `film` (see the module
/// docs for what goes in).
fn checksum(texts: &[String; 7], film: &Film) -> u64 {
    let mut h = Xxh3::new();
    h.update(CHECKSUM_TAG);
    for (name, text) in ATTRIBUTES.iter().zip(texts) {
        for bytes in [name.as_bytes(), text.as_bytes()] {
            h.update(bytes);
            h.update(&[0]);
        }
    }
    h.update(&film.width.to_le_bytes());
    h.update(&film.height.to_le_bytes());
    h.update(&film.samples.to_le_bytes());
    for sums in [&film.sum, &film.sum_sq] {
        if cfg!(target_endian = "little") {
            // The f64s' memory is their little-endian bytes already.
            h.update(bytemuck::cast_slice(sums));
        } else {
            for v in sums.iter().flatten() {
                h.update(&v.to_bits().to_le_bytes());
            }
        }
    }
    h.digest()
}

/// The first impossible sum of `film`, as (pixel index, channel, problem).
/// See the module docs for the checks and the rounding they allow.
fn implausible_sum(film: &Film) -> Option<(usize, usize, SumProblem)> {
    let n = film.samples as f64;
    let slack = 1.0 + 4.0 * n * f64::EPSILON;
    for (i, (s, q)) in film.sum.iter().zip(&film.sum_sq).enumerate() {
        for c in 0..3 {
            for (kind, value) in [(SumKind::Sum, s[c]), (SumKind::SumSq, q[c])] {
                if !value.is_finite() {
                    return Some((i, c, SumProblem::NotFinite { kind, value }));
                }
                if value < 0.0 {
                    return Some((i, c, SumProblem::Negative { kind, value }));
                }
            }
            if s[c] * s[c] > n * q[c] * slack {
                let problem = SumProblem::CauchySchwarz {
                    sum: s[c],
                    sum_sq: q[c],
                    samples: film.samples,
                };
                return Some((i, c, problem));
            }
        }
    }
    None
}

/// Whether the bytes of an EXR file start with a complete single-part
/// header: then the byte range and name of each of its attribute records
/// and the offset after its end.
type Records = (Vec<(Range<usize>, Vec<u8>)>, usize);

fn header_records(bytes: &[u8]) -> std::io::Result<Option<Records>> {
    let mut pos = 8; // magic number and version
    let mut records = Vec::new();
    let zero = |from: usize| {
        bytes
            .get(from..)
            .and_then(|rest| rest.iter().position(|&b| b == 0))
            .map(|i| from + i)
    };
    loop {
        let Some(name_end) = zero(pos) else {
            return Ok(None);
        };
        if name_end == pos {
            return Ok(Some((records, pos + 1)));
        }
        let Some(type_end) = zero(name_end + 1) else {
            return Ok(None);
        };
        let Some(size) = bytes.get(type_end + 1..type_end + 5) else {
            return Ok(None);
        };
        let size = i32::from_le_bytes(size.try_into().unwrap());
        let size = usize::try_from(size)
            .map_err(|_| std::io::Error::other("negative attribute size in a header"))?;
        let end = type_end + 5 + size;
        if end > bytes.len() {
            return Ok(None);
        }
        records.push((pos..end, bytes[pos..name_end].to_vec()));
        pos = end;
    }
}

/// Puts the `luz:` attribute records of the complete header at the start of
/// `bytes` in [`ATTRIBUTES`] order, then `luz:checksum`, in place: the exr
/// crate writes them in the order of a `HashMap`, which changes from one
/// process (and one map) to the next. They are written one after the other,
/// so reordering them moves no other byte.
fn order_attributes(bytes: &mut [u8], records: &[(Range<usize>, Vec<u8>)]) -> std::io::Result<()> {
    let ours: Vec<&(Range<usize>, Vec<u8>)> = records
        .iter()
        .filter(|(_, name)| name.starts_with(b"luz:"))
        .collect();
    let (Some(first), Some(last)) = (ours.first(), ours.last()) else {
        return Ok(());
    };
    let span = first.0.start..last.0.end;
    if ours.windows(2).any(|w| w[0].0.end != w[1].0.start) {
        return Err(std::io::Error::other(
            "the luz attributes are not written one after the other",
        ));
    }
    let rank = |name: &[u8]| {
        let order = ATTRIBUTES.iter().chain(&[CHECKSUM]);
        let position = order.clone().position(|a| a.as_bytes() == name);
        (position.unwrap_or(usize::MAX), name.to_vec())
    };
    let mut sorted = ours.clone();
    sorted.sort_by_key(|(_, name)| rank(name));
    let reordered: Vec<u8> = sorted
        .iter()
        .flat_map(|(range, _)| bytes[range.clone()].to_vec())
        .collect();
    bytes[span].copy_from_slice(&reordered);
    Ok(())
}

/// A writer that holds back the start of the file until its header is
/// complete, puts the luz attributes in order ([`order_attributes`]), and
/// then lets everything through.
struct InOrder<W> {
    inner: W,
    held: Option<Vec<u8>>,
}

impl<W: Write> InOrder<W> {
    fn new(inner: W) -> Self {
        Self {
            inner,
            held: Some(Vec::new()),
        }
    }

    /// Errs if the header never completed (nothing was written then).
    fn finish(self) -> std::io::Result<()> {
        match self.held {
            None => Ok(()),
            Some(_) => Err(std::io::Error::other("the EXR header was never completed")),
        }
    }
}

impl<W: Write> Write for InOrder<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let Some(held) = &mut self.held else {
            return self.inner.write(buf);
        };
        held.extend_from_slice(buf);
        if let Some((records, _)) = header_records(held)? {
            order_attributes(held, &records)?;
            self.inner.write_all(held)?;
            self.held = None;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl<W: Write + Seek> Seek for InOrder<W> {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        if self.held.is_some() {
            return Err(std::io::Error::other(
                "a seek before the EXR header was complete",
            ));
        }
        self.inner.seek(pos)
    }
}

/// Writes the part `meta` describes, holding `film`, to `path` atomically
/// (see the module docs for the layout). The same part gives the same
/// bytes, whichever process writes it.
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
    let texts = attribute_texts(meta, film.non_finite);
    let sum = format!("{:016x}", checksum(&texts, film));
    let text = |s: &str| AttributeValue::Text(Text::from(s));
    let mut other: HashMap<Text, AttributeValue> = ATTRIBUTES
        .iter()
        .zip(&texts)
        .map(|(name, value)| (Text::from(*name), text(value)))
        .collect();
    other.insert(Text::from(CHECKSUM), text(&sum));
    let attributes = LayerAttributes {
        other,
        ..LayerAttributes::default()
    };
    let layer = Layer::new(
        (film.width as usize, film.height as usize),
        attributes,
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(channels),
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

/// The channels of a part: name and sample type.
fn part_channels() -> Vec<(String, SampleType)> {
    let mut channels = Vec::new();
    for name in RGB {
        channels.push((name.to_string(), SampleType::F32));
        for kind in ["sum", "sumsq"] {
            for word in ["hi", "lo"] {
                channels.push((format!("luz.{kind}.{name}.{word}"), SampleType::U32));
            }
        }
    }
    channels
}

/// Checks what `header` (of `header_len` bytes) says the file holds against
/// luz's layout and limits and against `file_len`, the bytes there are,
/// before any pixel is read: the reader allocates what the header claims.
/// For luz's uncompressed scan lines the bytes needed are exact.
fn check_layout(
    path: &Path,
    header: &Header,
    header_len: usize,
    file_len: usize,
) -> Result<(), PartError> {
    let invalid = |field: &str, message: String| PartError::Invalid {
        path: path.to_path_buf(),
        field: field.to_string(),
        message,
    };
    let (width, height) = (header.layer_size.width(), header.layer_size.height());
    let side = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    check_resolution(side(width), side(height)).map_err(|m| invalid("dataWindow", m))?;
    if header.deep {
        return Err(invalid("type", "deep data: a luz part is flat".into()));
    }
    if let BlockDescription::Tiles(_) = header.blocks {
        return Err(invalid("tiles", "tiled: a luz part is scan lines".into()));
    }
    if header.compression != Compression::Uncompressed {
        return Err(invalid(
            "compression",
            format!("{}: luz writes its parts uncompressed", header.compression),
        ));
    }
    for (name, sample_type) in part_channels() {
        let found = header
            .channels
            .list
            .iter()
            .find(|c| c.name == *name.as_str());
        match found {
            None => return Err(invalid(&name, "channel missing".into())),
            Some(c) if c.sample_type != sample_type => {
                return Err(invalid(
                    &name,
                    format!(
                        "expected a {sample_type:?} channel, found {:?}",
                        c.sample_type
                    ),
                ))
            }
            Some(_) => {}
        }
    }
    if let Some(c) = header.channels.list.iter().find(|c| c.sampling.area() != 1) {
        return Err(invalid(
            &c.name.to_string(),
            "subsampled: a luz part has one sample per pixel".into(),
        ));
    }
    // After the header, each scan-line chunk has an offset-table entry (8
    // bytes), its y and its byte count (4 + 4), and then its pixels.
    let bytes_per_pixel = header.channels.bytes_per_pixel;
    let needed = (header_len as u64)
        .saturating_add(header.chunk_count as u64 * 16)
        .saturating_add((width as u64 * height as u64).saturating_mul(bytes_per_pixel as u64));
    if needed > file_len as u64 {
        return Err(PartError::Truncated {
            path: path.to_path_buf(),
            width,
            height,
            bytes_per_pixel,
            needed,
            held: file_len as u64,
        });
    }
    Ok(())
}

/// Reads a part that [`write`] wrote, checking every field, the checksum
/// and the sums (see the module docs).
pub fn read(path: &Path) -> Result<Part, PartError> {
    let invalid = |field: &str, message: String| PartError::Invalid {
        path: path.to_path_buf(),
        field: field.to_string(),
        message,
    };
    let unreadable =
        |e: exr::error::Error| invalid("file", format!("not a readable OpenEXR file ({e})"));
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
            return Err(invalid(
                "file",
                format!("holds {} layers, a luz part one", headers.len()),
            ))
        }
    };
    let attr = |name: &str| -> Result<String, PartError> {
        match header.own_attributes.other.get(&Text::from(name)) {
            Some(AttributeValue::Text(t)) => Ok(t.to_string()),
            Some(_) => Err(invalid(name, "is not a text attribute".into())),
            None => Err(invalid(
                name,
                "missing: not a render part written by luz".into(),
            )),
        }
    };
    let texts: [String; 7] = [
        attr(VERSION)?,
        attr(SCENE_HASH)?,
        attr(SEED)?,
        attr(SPP)?,
        attr(SAMPLES)?,
        attr(BACKEND)?,
        attr(NON_FINITE)?,
    ];
    let [version, hash_text, seed_text, spp_text, ranges_text, backend_text, non_finite_text] =
        &texts;
    let number = |name: &str, s: &str| -> Result<u64, PartError> {
        s.parse()
            .map_err(|_| invalid(name, format!("expected an unsigned integer, found `{s}`")))
    };
    let hex = |name: &str, s: &str| -> Result<u64, PartError> {
        if s.len() != 16 {
            return Err(invalid(
                name,
                format!("expected 16 hex digits, found `{s}`"),
            ));
        }
        u64::from_str_radix(s, 16)
            .map_err(|_| invalid(name, format!("expected 16 hex digits, found `{s}`")))
    };
    let scene_hash = hex(SCENE_HASH, hash_text)?;
    let seed = number(SEED, seed_text)?;
    let spp = u32::try_from(number(SPP, spp_text)?)
        .map_err(|_| invalid(SPP, "does not fit in 32 bits".into()))?;
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
    let backend: BackendKind = backend_text.parse().map_err(|m| invalid(BACKEND, m))?;
    if backend == BackendKind::Auto {
        return Err(invalid(
            BACKEND,
            "`auto` names no backend: a part records the one that traced it".into(),
        ));
    }
    let non_finite = number(NON_FINITE, non_finite_text)?;
    let stored = match header.own_attributes.other.get(&Text::from(CHECKSUM)) {
        None => {
            return Err(PartError::ChecksumMissing {
                path: path.to_path_buf(),
            })
        }
        Some(_) => hex(CHECKSUM, &attr(CHECKSUM)?)?,
    };

    let header_len = match header_records(&data) {
        Ok(Some((_, end))) => end,
        _ => 0,
    };
    check_layout(path, header, header_len, data.len())?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(data))
        .map_err(unreadable)?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let n = width * height;
    let channel = |name: &str| -> Result<&Vec<u32>, PartError> {
        let found = layer.channel_data.list.iter().find(|c| c.name == *name);
        match found.map(|c| &c.sample_data) {
            Some(FlatSamples::U32(v)) if v.len() == n => Ok(v),
            Some(_) => Err(invalid(name, "expected a u32 channel".into())),
            None => Err(invalid(name, "channel missing".into())),
        }
    };
    let mut film = Film::try_new(width as u32, height as u32)
        .map_err(|m| invalid("dataWindow", m.to_string()))?;
    for (c, name) in RGB.iter().enumerate() {
        for (kind, sums) in [("sum", &mut film.sum), ("sumsq", &mut film.sum_sq)] {
            let hi = channel(&format!("luz.{kind}.{name}.hi"))?;
            let lo = channel(&format!("luz.{kind}.{name}.lo"))?;
            for (i, s) in sums.iter_mut().enumerate() {
                s[c] = join_bits(hi[i], lo[i]);
            }
        }
    }
    let meta = PartMeta {
        version: version.clone(),
        scene_hash,
        seed,
        spp,
        ranges,
        backend,
    };
    film.samples = meta.sample_count();
    film.non_finite = non_finite;

    let computed = checksum(&texts, &film);
    if computed != stored {
        return Err(PartError::Checksum {
            path: path.to_path_buf(),
            stored,
            computed,
        });
    }
    if let Some((i, c, problem)) = implausible_sum(&film) {
        return Err(PartError::Sum {
            path: path.to_path_buf(),
            channel: RGB[c],
            x: i % width,
            y: i / width,
            problem,
        });
    }
    let most = film.samples.saturating_mul(n as u64);
    if film.non_finite > most {
        return Err(invalid(
            NON_FINITE,
            format!(
                "{} dropped samples, more than the {most} samples of {width}x{height} pixels",
                film.non_finite
            ),
        ));
    }
    Ok(Part { meta, film })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory for test `name`.
    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("luz-part-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A 3x2 part of 7 samples with sums that are plausible yet need every
    /// bit of their f64s.
    fn sample_part() -> Part {
        let mut film = Film::new(3, 2);
        for (i, (s, q)) in film.sum.iter_mut().zip(&mut film.sum_sq).enumerate() {
            let a = 0.1 * i as f64;
            *s = [a, 1.0 / 3.0, 1e30];
            *q = [a * a / 3.0 + f64::MIN_POSITIVE, 2.0f64.sqrt(), 1e300];
        }
        film.samples = 7;
        film.non_finite = 3;
        Part {
            meta: PartMeta {
                version: "0.1.0".into(),
                scene_hash: 0xfedc_ba98_7654_3210,
                seed: u64::MAX,
                spp: 9,
                ranges: vec![1..3, 4..9],
                backend: BackendKind::Rust,
            },
            film,
        }
    }

    /// Writes `part` to `dir/name` and returns the file's path and bytes.
    fn written(dir: &Path, name: &str, part: &Part) -> (PathBuf, Vec<u8>) {
        let path = dir.join(name);
        write(&path, &part.meta, &part.film).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        (path, bytes)
    }

    /// The byte range of the value of header attribute `name` in `bytes`.
    fn value_of(bytes: &[u8], name: &str) -> Range<usize> {
        let (records, _) = header_records(bytes).unwrap().unwrap();
        let (range, _) = records
            .into_iter()
            .find(|(_, n)| n == name.as_bytes())
            .unwrap_or_else(|| panic!("no attribute {name}"));
        // name, zero, type name, zero, 4 bytes of size, then the value.
        let type_end = range.start + name.len() + 1;
        let type_end = type_end + bytes[type_end..].iter().position(|&b| b == 0).unwrap();
        type_end + 5..range.end
    }

    #[test]
    fn sums_survive_a_round_trip_bit_for_bit() {
        let dir = temp_dir("round-trip");
        let part = sample_part();
        let (path, _) = written(&dir, "p.exr", &part);
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

    #[test]
    fn the_checksum_covers_every_sum_bit_every_attribute_and_the_shape() {
        let part = sample_part();
        let texts = attribute_texts(&part.meta, part.film.non_finite);
        let base = checksum(&texts, &part.film);
        let mut seen = vec![base];
        for bit in 0..64 {
            for sum_sq in [false, true] {
                let mut film = part.film.clone();
                let sums = if sum_sq {
                    &mut film.sum_sq
                } else {
                    &mut film.sum
                };
                sums[4][1] = f64::from_bits(sums[4][1].to_bits() ^ (1 << bit));
                seen.push(checksum(&texts, &film));
            }
        }
        for i in 0..texts.len() {
            let mut edited = texts.clone();
            edited[i].push('0');
            seen.push(checksum(&edited, &part.film));
        }
        let mut film = part.film.clone();
        (film.width, film.height) = (2, 3);
        seen.push(checksum(&texts, &film));
        let mut film = part.film.clone();
        film.samples += 1;
        seen.push(checksum(&texts, &film));
        let count = seen.len();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), count, "every change gives another checksum");
    }

    #[test]
    fn a_damaged_or_edited_part_fails_its_checksum() {
        let dir = temp_dir("checksum");
        let (path, bytes) = written(&dir, "p.exr", &sample_part());
        let refused = |bytes: &[u8]| {
            std::fs::write(&path, bytes).unwrap();
            let err = read(&path).unwrap_err();
            assert!(matches!(err, PartError::Checksum { .. }), "{err}");
            let message = err.to_string();
            assert!(
                message.starts_with(&format!("{}: luz:checksum: ", path.display()))
                    && message.ends_with("the part is damaged or edited"),
                "{message}"
            );
        };
        // The last four bytes are the low word of the last pixel's last
        // channel (luz.sumsq.R.lo): its lowest bit is one ulp of the sum.
        let mut flipped = bytes.clone();
        let at = flipped.len() - 4;
        flipped[at] ^= 1;
        refused(&flipped);
        // An edited seed, same length.
        let mut edited = bytes.clone();
        let seed = value_of(&edited, SEED);
        edited[seed.start] = b'0';
        refused(&edited);
        // An edited checksum.
        let mut edited = bytes.clone();
        let sum = value_of(&edited, CHECKSUM);
        edited[sum.start] = if edited[sum.start] == b'0' {
            b'1'
        } else {
            b'0'
        };
        refused(&edited);
        // Without it: an older luz's part.
        let mut old = bytes.clone();
        let sum = value_of(&old, CHECKSUM);
        let name = sum.start - 4 - b"string\0".len() - 2;
        assert_eq!(&old[name..name + 2], b"m\0");
        old[name] = b'n';
        std::fs::write(&path, &old).unwrap();
        let err = read(&path).unwrap_err();
        assert!(matches!(err, PartError::ChecksumMissing { .. }), "{err}");
        assert!(err
            .to_string()
            .contains("luz:checksum: missing: written by an older luz"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_unknown_or_auto_backend_is_a_located_error() {
        let dir = temp_dir("backend");
        let (path, mut bytes) = written(&dir, "p.exr", &sample_part());
        let backend = value_of(&bytes, BACKEND);
        bytes[backend.clone()].copy_from_slice(b"ruby");
        std::fs::write(&path, &bytes).unwrap();
        let err = read(&path).unwrap_err().to_string();
        assert!(
            err.contains("p.exr: luz:backend: unknown backend `ruby` (known: auto, rust, embree)"),
            "{err}"
        );
        bytes[backend.start..backend.start + 4].copy_from_slice(b"auto");
        std::fs::write(&path, &bytes).unwrap();
        let err = read(&path).unwrap_err().to_string();
        assert!(
            err.contains("p.exr: luz:backend: `auto` names no backend"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn impossible_sums_are_refused_even_under_a_fresh_checksum() {
        let dir = temp_dir("sums");
        type Damage = fn(&mut Film);
        let cases: [(Damage, &str); 4] = [
            // sum 4 of 4 samples needs a sum of squares of at least 4.
            (
                |f| f.sum[1][1] = 4.0,
                "pixel (1, 0): sum 4 and sum of squares 0 of 4 samples break sum² ≤ n·sumsq",
            ),
            (
                |f| f.sum_sq[5][2] = -1.0,
                "luz.sumsq.B: pixel (2, 1): holds -1, a negative sum",
            ),
            (
                |f| f.sum[0][0] = f64::NAN,
                "luz.sum.R: pixel (0, 0): holds NaN, not a finite sum",
            ),
            (
                |f| f.sum_sq[3][0] = f64::INFINITY,
                "luz.sumsq.R: pixel (0, 1): holds inf, not a finite sum",
            ),
        ];
        for (i, (damage, needle)) in cases.into_iter().enumerate() {
            let mut part = sample_part();
            part.meta.ranges = std::iter::once(0..4).collect();
            part.film.samples = 4;
            part.film.sum = vec![[0.0; 3]; 6];
            part.film.sum_sq = vec![[0.0; 3]; 6];
            damage(&mut part.film);
            let (path, _) = written(&dir, &format!("{i}.exr"), &part);
            let err = read(&path).unwrap_err();
            assert!(matches!(err, PartError::Sum { .. }), "{err}");
            let message = err.to_string();
            assert!(message.contains(needle), "{needle:?} in {message}");
            assert!(
                message.ends_with("the part is damaged or edited"),
                "{message}"
            );
        }
        let err = read(&dir.join("0.exr")).unwrap_err().to_string();
        assert!(
            err.contains("0.exr: luz.sum.G, luz.sumsq.G: pixel (1, 0)"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn rounding_in_real_sums_passes_the_cauchy_schwarz_check() {
        // Equal samples are the equality case, where rounding alone decides.
        for (value, n) in [
            (0.1f32, 1000),
            (1.0 / 3.0, 100_000),
            (7e-30, 3),
            (3e37, 999),
        ] {
            let mut p = crate::render::film::PixelSum::default();
            for _ in 0..n {
                p.add(crate::math::Rgb::splat(value));
            }
            let mut film = Film::new(1, 1);
            (film.sum[0], film.sum_sq[0], film.samples) = (p.sum, p.sum_sq, n);
            assert_eq!(implausible_sum(&film), None, "{value} x {n}");
        }
        // Samples of a thousand magnitudes, summed in two orders.
        let samples: Vec<f64> = (0..5000)
            .map(|i| ((i * 7919) % 1000) as f64 * 1e-3)
            .collect();
        for order in [samples.clone(), samples.iter().rev().copied().collect()] {
            let mut film = Film::new(1, 1);
            film.samples = order.len() as u64;
            for v in order {
                film.sum[0][0] += v;
                film.sum_sq[0][0] += v * v;
            }
            assert_eq!(implausible_sum(&film), None);
        }
    }

    #[test]
    fn a_header_claiming_more_than_the_file_holds_is_refused_before_its_pixels() {
        let dir = temp_dir("header");
        let (path, bytes) = written(&dir, "p.exr", &sample_part());
        let mut huge = bytes.clone();
        let window = value_of(&huge, "dataWindow");
        let corners: Vec<u8> = [0i32, 0, 15999, 15999]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        huge[window].copy_from_slice(&corners);
        let chunks = value_of(&huge, "chunkCount");
        huge[chunks].copy_from_slice(&16000i32.to_le_bytes());
        std::fs::write(&path, &huge).unwrap();
        let err = read(&path).unwrap_err();
        let message = err.to_string();
        assert!(
            matches!(
                err,
                PartError::Truncated {
                    width: 16000,
                    height: 16000,
                    bytes_per_pixel: 60,
                    ..
                }
            ),
            "{message}"
        );
        assert!(message.contains(&format!(
            "p.exr: dataWindow: 16000x16000 pixels of 60 bytes need at least {} bytes, the file holds {}",
            header_records(&bytes).unwrap().unwrap().1 as u64 + 16000 * 16 + 16000 * 16000 * 60,
            bytes.len()
        )), "{message}");

        // A truncated part is the same mismatch, seen from the other side.
        std::fs::write(&path, &bytes[..bytes.len() - 100]).unwrap();
        let err = read(&path).unwrap_err();
        assert!(
            matches!(
                err,
                PartError::Truncated {
                    width: 3,
                    height: 2,
                    ..
                }
            ),
            "{err}"
        );

        // Beyond luz's limits, whatever the file's size.
        let mut wide = bytes.clone();
        let window = value_of(&wide, "dataWindow");
        wide[window.start + 8..window.start + 12].copy_from_slice(&40000i32.to_le_bytes());
        std::fs::write(&path, &wide).unwrap();
        let err = read(&path).unwrap_err().to_string();
        assert!(
            err.contains("p.exr: dataWindow: resolution 40001x2 is outside"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_same_part_is_written_as_the_same_bytes() {
        // Every write builds its own attribute map, whose random hasher
        // orders the attributes differently.
        let dir = temp_dir("same-bytes");
        let part = sample_part();
        let (_, first) = written(&dir, "0.exr", &part);
        for i in 1..8 {
            let (_, again) = written(&dir, &format!("{i}.exr"), &part);
            assert!(again == first, "write {i} differs from the first");
        }
        let (records, _) = header_records(&first).unwrap().unwrap();
        let ours: Vec<&[u8]> = records
            .iter()
            .map(|(_, name)| name.as_slice())
            .filter(|name| name.starts_with(b"luz:"))
            .collect();
        let expected: Vec<&[u8]> = ATTRIBUTES
            .iter()
            .chain(&[CHECKSUM])
            .map(|a| a.as_bytes())
            .collect();
        assert_eq!(ours, expected);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
