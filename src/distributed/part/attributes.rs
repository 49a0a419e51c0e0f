//! The luz header attributes of a part (the table in the module docs of
//! [`super`]): their names and order, their texts, and their parsing.

use super::ranges::{format_ranges, parse_range};
use super::{PartError, PartMeta};
use crate::accel::BackendKind;
use crate::render::{Film, Sampling};
use exr::meta::header::Header;
use exr::prelude::{AttributeValue, LayerAttributes, Text};
use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;

pub(super) const VERSION: &str = "luz:version";
pub(super) const SCENE_HASH: &str = "luz:sceneHash";
pub(super) const SEED: &str = "luz:seed";
pub(super) const SPP: &str = "luz:spp";
pub(super) const SAMPLES: &str = "luz:samples";
pub(super) const SAMPLING: &str = "luz:sampling";
pub(super) const SAMPLE_TOTAL: &str = "luz:sampleTotal";
pub(super) const BACKEND: &str = "luz:backend";
pub(super) const NON_FINITE: &str = "luz:nonFinite";
pub(super) const CHECKSUM: &str = "luz:checksum";
/// The checksummed attributes, in the order they are written and hashed;
/// `luz:checksum` follows them.
pub(super) const ATTRIBUTES: [&str; 9] = [
    VERSION,
    SCENE_HASH,
    SEED,
    SPP,
    SAMPLES,
    SAMPLING,
    SAMPLE_TOTAL,
    BACKEND,
    NON_FINITE,
];

/// The texts of the checksummed attributes, in [`ATTRIBUTES`] order.
pub(super) type Texts = [String; 9];

/// The texts of the checksummed attributes of a part holding `film`, in
/// [`ATTRIBUTES`] order.
pub(super) fn attribute_texts(meta: &PartMeta, film: &Film) -> Texts {
    [
        meta.version.clone(),
        format!("{:016x}", meta.scene_hash),
        meta.seed.to_string(),
        meta.spp.to_string(),
        format_ranges(&meta.ranges),
        meta.sampling.to_string(),
        film.total_samples().to_string(),
        meta.backend.name().to_string(),
        film.non_finite.to_string(),
    ]
}

/// The header attributes of a part whose checksummed attributes hold
/// `texts` and whose checksum is `checksum`.
pub(super) fn layer_attributes(texts: &Texts, checksum: u64) -> LayerAttributes {
    let text = |s: &str| AttributeValue::Text(Text::from(s));
    let mut other: HashMap<Text, AttributeValue> = ATTRIBUTES
        .iter()
        .zip(texts)
        .map(|(name, value)| (Text::from(*name), text(value)))
        .collect();
    other.insert(Text::from(CHECKSUM), text(&format!("{checksum:016x}")));
    LayerAttributes {
        other,
        ..LayerAttributes::default()
    }
}

/// The luz attributes of a part's header, each parsed and checked.
pub(super) struct ParsedAttributes {
    /// Their texts, in [`ATTRIBUTES`] order: what the checksum hashes.
    pub texts: Texts,
    pub meta: PartMeta,
    pub sample_total: u64,
    pub non_finite: u64,
    /// The `luz:checksum` stored.
    pub checksum: u64,
}

/// Parses the luz attributes of `header`, read from `path`, refusing the
/// first that is missing or malformed.
pub(super) fn parse_attributes(
    path: &Path,
    header: &Header,
) -> Result<ParsedAttributes, PartError> {
    let text = |name: &str| attribute_text(path, header, name);
    let texts: Texts = [
        text(VERSION)?,
        text(SCENE_HASH)?,
        text(SEED)?,
        text(SPP)?,
        text(SAMPLES)?,
        text(SAMPLING)?,
        text(SAMPLE_TOTAL)?,
        text(BACKEND)?,
        text(NON_FINITE)?,
    ];
    let [version, hash_text, seed_text, spp_text, ranges_text, sampling_text, total_text, backend_text, non_finite_text] =
        &texts;
    // Fields are evaluated in the order written: the first bad one is the
    // one reported.
    let meta = PartMeta {
        version: version.clone(),
        scene_hash: hex(path, SCENE_HASH, hash_text)?,
        seed: number(path, SEED, seed_text)?,
        spp: u32::try_from(number(path, SPP, spp_text)?)
            .map_err(|_| PartError::invalid(path, SPP, "does not fit in 32 bits".into()))?,
        ranges: sample_ranges(path, ranges_text)?,
        sampling: sampling_text
            .parse::<Sampling>()
            .map_err(|m| PartError::invalid(path, SAMPLING, m))?,
        backend: traced_by(path, backend_text)?,
    };
    let sample_total = number(path, SAMPLE_TOTAL, total_text)?;
    let non_finite = number(path, NON_FINITE, non_finite_text)?;
    let checksum = match header.own_attributes.other.get(&Text::from(CHECKSUM)) {
        None => {
            return Err(PartError::ChecksumMissing {
                path: path.to_path_buf(),
            })
        }
        Some(_) => hex(path, CHECKSUM, &text(CHECKSUM)?)?,
    };
    Ok(ParsedAttributes {
        texts,
        meta,
        sample_total,
        non_finite,
        checksum,
    })
}

/// The text of attribute `name` of `header`.
fn attribute_text(path: &Path, header: &Header, name: &str) -> Result<String, PartError> {
    match header.own_attributes.other.get(&Text::from(name)) {
        Some(AttributeValue::Text(t)) => Ok(t.to_string()),
        Some(_) => Err(PartError::invalid(
            path,
            name,
            "is not a text attribute".into(),
        )),
        None => Err(PartError::invalid(
            path,
            name,
            "missing: not a render part written by luz".into(),
        )),
    }
}

fn number(path: &Path, name: &str, s: &str) -> Result<u64, PartError> {
    s.parse().map_err(|_| {
        PartError::invalid(
            path,
            name,
            format!("expected an unsigned integer, found `{s}`"),
        )
    })
}

fn hex(path: &Path, name: &str, s: &str) -> Result<u64, PartError> {
    let bad = || PartError::invalid(path, name, format!("expected 16 hex digits, found `{s}`"));
    if s.len() != 16 {
        return Err(bad());
    }
    u64::from_str_radix(s, 16).map_err(|_| bad())
}

/// The ranges of `luz:samples`, which must be sorted and disjoint.
fn sample_ranges(path: &Path, text: &str) -> Result<Vec<Range<u32>>, PartError> {
    let mut ranges = Vec::new();
    for r in text.split(',') {
        ranges.push(parse_range(r).map_err(|m| PartError::invalid(path, SAMPLES, m))?);
    }
    if ranges.windows(2).any(|w| w[0].end > w[1].start) {
        return Err(PartError::invalid(
            path,
            SAMPLES,
            format!("ranges `{text}` are not sorted and disjoint"),
        ));
    }
    Ok(ranges)
}

/// The backend of `luz:backend`, one that traces (not `auto`).
fn traced_by(path: &Path, text: &str) -> Result<BackendKind, PartError> {
    let backend: BackendKind = text
        .parse()
        .map_err(|m| PartError::invalid(path, BACKEND, m))?;
    if backend == BackendKind::Auto {
        return Err(PartError::invalid(
            path,
            BACKEND,
            "`auto` names no backend: a part records the one that traced it".into(),
        ));
    }
    Ok(backend)
}
