//! Merging render parts: films of disjoint sample ranges of one render add
//! up to the film of all their samples (see the determinism rule of the
//! render loop). Everything that would make the sum wrong is refused.

use super::part::{self, format_ranges, Part, PartMeta};
use crate::render::Film;
use std::ops::Range;
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error("no parts to merge")]
    Empty,
    #[error(
        "{}: luz:sampling: `{sampling}`: an adaptive render does not split into parts (its pixels' samples all start at 0); render it in one job, resuming from checkpoints as needed",
        path.display()
    )]
    Adaptive { path: PathBuf, sampling: String },
    #[error(
        "{}: {field} {theirs} differs from {}'s {ours}: parts of different renders cannot be merged",
        path.display(), first.display()
    )]
    Mismatch {
        path: PathBuf,
        first: PathBuf,
        field: &'static str,
        ours: String,
        theirs: String,
    },
    #[error("{} and {} both hold samples {}..{}", a.display(), b.display(), overlap.start, overlap.end)]
    Overlap {
        a: PathBuf,
        b: PathBuf,
        overlap: Range<u32>,
    },
    #[error(
        "samples {} of {spp} per pixel are in no part (pass --allow-gaps to merge without them)",
        format_ranges(missing)
    )]
    Gaps { missing: Vec<Range<u32>>, spp: u32 },
}

#[derive(Debug)]
pub struct Merged {
    pub part: Part,
    /// Sample indices below the render's spp that no part holds.
    pub missing: Vec<Range<u32>>,
}

/// Merges `parts` (each with the file it came from, for messages). The
/// result does not depend on the order of `parts`: films are added in the
/// order of their samples.
pub fn merge(mut parts: Vec<(PathBuf, Part)>, allow_gaps: bool) -> Result<Merged, MergeError> {
    let (first_path, first) = parts.first().ok_or(MergeError::Empty)?;
    if let Some((path, part)) = parts.iter().find(|(_, p)| p.meta.sampling.is_adaptive()) {
        return Err(MergeError::Adaptive {
            path: path.clone(),
            sampling: part.meta.sampling.to_string(),
        });
    }
    for (path, part) in &parts[1..] {
        let size = |f: &Film| (f.width, f.height);
        if let Some(m) = part::first_mismatch(
            (&first.meta, size(&first.film)),
            (&part.meta, size(&part.film)),
        ) {
            return Err(MergeError::Mismatch {
                path: path.clone(),
                first: first_path.clone(),
                field: m.attribute,
                ours: m.ours,
                theirs: m.theirs,
            });
        }
    }

    let mut held: Vec<(Range<u32>, usize)> = parts
        .iter()
        .enumerate()
        .flat_map(|(i, (_, p))| p.meta.ranges.iter().map(move |r| (r.clone(), i)))
        .collect();
    held.sort_by_key(|(r, _)| r.start);
    for w in held.windows(2) {
        let ((a, i), (b, j)) = (&w[0], &w[1]);
        if a.end > b.start {
            return Err(MergeError::Overlap {
                a: parts[*i].0.clone(),
                b: parts[*j].0.clone(),
                overlap: b.start..a.end.min(b.end),
            });
        }
    }
    let mut ranges: Vec<Range<u32>> = Vec::new();
    for (r, _) in held {
        match ranges.last_mut() {
            Some(last) if last.end == r.start => last.end = r.end,
            _ => ranges.push(r),
        }
    }
    let end = ranges.last().map_or(0, |r| r.end);
    let spp = parts.iter().map(|(_, p)| p.meta.spp).max().unwrap_or(0);
    let mut missing = Vec::new();
    let mut next = 0;
    for r in ranges
        .iter()
        .chain(std::iter::once(&(spp.max(end)..u32::MAX)))
    {
        if next < r.start {
            missing.push(next..r.start);
        }
        next = r.end;
    }
    if !missing.is_empty() && !allow_gaps {
        return Err(MergeError::Gaps { missing, spp });
    }

    parts.sort_by_key(|(_, p)| p.meta.ranges[0].start);
    let (width, height) = (parts[0].1.film.width, parts[0].1.film.height);
    let mut film = Film::new(width, height);
    for (_, part) in &parts {
        film.merge(&part.film);
    }
    let meta = PartMeta {
        ranges,
        spp,
        ..parts[0].1.meta.clone()
    };
    Ok(Merged {
        part: Part { meta, film },
        missing,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BackendKind;

    fn part(ranges: &[(u32, u32)], value: f64) -> (PathBuf, Part) {
        let mut film = Film::new(2, 1);
        film.sum = vec![[value; 3]; 2];
        film.sum_sq = vec![[value * value; 3]; 2];
        let meta = PartMeta {
            version: "1".into(),
            scene_hash: 42,
            seed: 7,
            spp: 8,
            ranges: ranges.iter().map(|&(a, b)| a..b).collect(),
            sampling: crate::render::Sampling::Uniform,
            backend: BackendKind::Rust,
        };
        film.samples = meta.sample_count();
        let name = format!("{}.exr", format_ranges(&meta.ranges));
        (name.into(), Part { meta, film })
    }

    #[test]
    fn merges_in_sample_order_and_coalesces_ranges() {
        let merged = merge(vec![part(&[(4, 8)], 2.0), part(&[(0, 4)], 1.0)], false).unwrap();
        assert_eq!(merged.part.meta.ranges, vec![0..8]);
        assert_eq!(merged.part.film.samples, 8);
        assert_eq!(merged.part.film.sum[0], [3.0; 3]);
        assert!(merged.missing.is_empty());
    }

    #[test]
    fn refuses_overlaps_gaps_and_foreign_parts() {
        let err = merge(vec![part(&[(0, 5)], 1.0), part(&[(4, 8)], 1.0)], false).unwrap_err();
        assert_eq!(
            err.to_string(),
            "0..5.exr and 4..8.exr both hold samples 4..5"
        );

        let err = merge(vec![part(&[(0, 2)], 1.0), part(&[(4, 6)], 1.0)], false).unwrap_err();
        assert!(err
            .to_string()
            .starts_with("samples 2..4,6..8 of 8 per pixel are in no part"));
        let merged = merge(vec![part(&[(0, 2)], 1.0), part(&[(4, 6)], 1.0)], true).unwrap();
        assert_eq!(merged.missing, vec![2..4, 6..8]);
        assert_eq!(merged.part.meta.ranges, vec![0..2, 4..6]);

        let mut other = part(&[(4, 8)], 1.0);
        other.1.meta.seed = 8;
        let err = merge(vec![part(&[(0, 4)], 1.0), other], false).unwrap_err();
        assert_eq!(
            err.to_string(),
            "4..8.exr: luz:seed 8 differs from 0..4.exr's 7: parts of different renders cannot be merged"
        );

        let mut other = part(&[(4, 8)], 1.0);
        other.1.film = Film::new(1, 2);
        let err = merge(vec![part(&[(0, 4)], 1.0), other], false).unwrap_err();
        assert!(err
            .to_string()
            .contains("dataWindow 1x2 differs from 0..4.exr's 2x1"));
    }
}
