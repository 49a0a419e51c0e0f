//! Tests of `write` and `read` together, and the parts they share with the
//! tests of the other files.

use super::attributes::{BACKEND, CHECKSUM, SEED};
use super::records::header_records;
use super::*;

/// A fresh directory for test `name`.
pub(super) fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("luz-part-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A 3x2 part of 7 samples with sums that are plausible yet need every
/// bit of their f64s.
pub(super) fn sample_part() -> Part {
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
            sampling: crate::render::Sampling::Uniform,
            backend: BackendKind::Rust,
        },
        film,
    }
}

/// Writes `part` to `dir/name` and returns the file's path and bytes.
pub(super) fn written(dir: &Path, name: &str, part: &Part) -> (PathBuf, Vec<u8>) {
    let path = dir.join(name);
    write(&path, &part.meta, &part.film).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    (path, bytes)
}

/// The byte range of the value of header attribute `name` in `bytes`.
pub(super) fn value_of(bytes: &[u8], name: &str) -> Range<usize> {
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
    // The last row ends with luz.sumsq.R.lo and then the three stderr
    // channels (channels are sorted by name), 3 pixels of 4 bytes each: the
    // four bytes before those are the low word of the last pixel's
    // luz.sumsq.R, whose lowest bit is one ulp of the sum.
    let mut flipped = bytes.clone();
    let at = flipped.len() - 4 - 3 * 3 * 4;
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

/// `sample_part` as the first decisions of an adaptive render left it.
fn adaptive_part() -> Part {
    let mut part = sample_part();
    part.meta.sampling = crate::render::Sampling::NoiseThreshold {
        threshold: 0.05,
        min_spp: 4,
        max_spp: 9,
    };
    part.meta.ranges = std::iter::once(0..9).collect();
    part.film.samples = 7;
    part.film.non_finite = 0;
    part.film.plan = Some(crate::render::PixelPlan {
        count: vec![4, 7, 7, 4, 6, 7],
        goal: vec![4, 8, 8, 4, 8, 8],
        met: vec![true, false, true, true, false, false],
    });
    part
}

#[test]
fn an_adaptive_part_keeps_its_plan_and_every_part_its_standard_errors() {
    let dir = temp_dir("adaptive");
    for part in [sample_part(), adaptive_part()] {
        let (path, _) = written(&dir, "p.exr", &part);
        assert_eq!(read(&path).unwrap(), part);
        // Any EXR reader sees the standard errors as float channels.
        let exr = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
        let channels = &exr.layer_data[0].channel_data.list;
        let stderr = part.film.standard_error();
        for (c, name) in ["stderr.R", "stderr.G", "stderr.B"].iter().enumerate() {
            let found = channels.iter().find(|ch| ch.name == **name).unwrap();
            let values: Vec<f32> = found.sample_data.values_as_f32().collect();
            let want: Vec<f32> = stderr.pixels.iter().map(|p| p[c]).collect();
            assert_eq!(values, want, "{name}");
        }
    }
    let err = crate::distributed::merge::merge(vec![(dir.join("p.exr"), adaptive_part())], false)
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("an adaptive render does not split into parts"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_adaptive_part_with_an_edited_count_or_total_is_refused() {
    let dir = temp_dir("adaptive-edit");
    let mut past_goal = adaptive_part();
    past_goal.film.plan.as_mut().unwrap().goal[1] = 5;
    let (path, _) = written(&dir, "goal.exr", &past_goal);
    let err = read(&path).unwrap_err().to_string();
    assert!(
        err.contains("goal.exr: luz.count: pixel (1, 0) holds 7 samples, past its goal 5"),
        "{err}"
    );
    // A count changed after writing: the checksum covers the plan.
    let (path, bytes) = written(&dir, "count.exr", &adaptive_part());
    let total = value_of(&bytes, super::attributes::SAMPLE_TOTAL);
    assert_eq!(&bytes[total.clone()], b"35");
    let mut edited = bytes.clone();
    edited[total.start + 1] = b'6';
    std::fs::write(&path, &edited).unwrap();
    let err = read(&path).unwrap_err();
    assert!(matches!(err, PartError::Checksum { .. }), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
