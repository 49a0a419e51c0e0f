//! Damaged and edited render parts: a flipped bit in a sum, an edited
//! sample range, a header claiming more pixels than the file holds. Each
//! must make `luz merge` and `luz render --resume` exit with status 2 and
//! one line naming the file and the field, writing nothing; both run under
//! the 1 GiB address-space limit, so a reader that allocated for the
//! header's resolution aborts instead of passing.

use super::{luz_limited, scene};
use crate::common::{luz, temp_dir};
use std::path::{Path, PathBuf};

const SPP: &str = "4";

/// Renders samples 0..4 of the 8x8 test scene into `dir/name`.
fn render_part(dir: &Path, name: &str) -> PathBuf {
    let scene_path = dir.join("scene.toml");
    std::fs::write(&scene_path, scene(None, false)).unwrap();
    let part = dir.join(name);
    let out = luz(&[
        "render",
        scene_path.to_str().unwrap(),
        "--spp",
        SPP,
        "--samples",
        "0..4",
        "--quiet",
        "-o",
        part.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    part
}

/// The attribute records of a single-part EXR header: (name, value range),
/// and the offset where the header ends.
fn attributes(bytes: &[u8]) -> (Vec<(String, std::ops::Range<usize>)>, usize) {
    let mut pos = 8;
    let mut found = Vec::new();
    let zero = |from: usize| from + bytes[from..].iter().position(|&b| b == 0).unwrap();
    loop {
        let name_end = zero(pos);
        if name_end == pos {
            return (found, pos + 1);
        }
        let name = String::from_utf8(bytes[pos..name_end].to_vec()).unwrap();
        let type_end = zero(name_end + 1);
        let size = i32::from_le_bytes(bytes[type_end + 1..type_end + 5].try_into().unwrap());
        let value = type_end + 5..type_end + 5 + size as usize;
        pos = value.end;
        found.push((name, value));
    }
}

fn value_of(bytes: &[u8], name: &str) -> std::ops::Range<usize> {
    let (found, _) = attributes(bytes);
    found
        .into_iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no attribute {name}"))
        .1
}

/// Where the u32 of channel `channel` at pixel (x, y) lies in the
/// uncompressed scan-line file `bytes` of width `width`.
fn sample_offset(bytes: &[u8], channel: &str, width: usize, (x, y): (usize, usize)) -> usize {
    let (_, header_end) = attributes(bytes);
    let at = header_end + 8 * y;
    let chunk = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    let mut channels = vec!["R".to_string(), "G".into(), "B".into()];
    for kind in ["sum", "sumsq"] {
        for c in ["R", "G", "B"] {
            for word in ["hi", "lo"] {
                channels.push(format!("luz.{kind}.{c}.{word}"));
            }
        }
    }
    channels.sort();
    let index = channels.iter().position(|c| c == channel).unwrap();
    // A chunk starts with its line's y and its byte count.
    chunk + 8 + (index * width + x) * 4
}

/// `luz merge PART` and `luz render --resume PART` both exit with status 2
/// and one line naming `PART` and the field `field`, and saying `why`,
/// writing nothing.
fn assert_refused(dir: &Path, part: &Path, field: &str, why: &str) {
    let merged = dir.join("merged.exr");
    let resumed = dir.join("resumed.exr");
    let scene_path = dir.join("scene.toml");
    let (scene_path, part_path) = (scene_path.to_str().unwrap(), part.to_str().unwrap());
    let merge = [
        "merge",
        "--allow-gaps",
        "--quiet",
        "-o",
        merged.to_str().unwrap(),
        part_path,
    ];
    let resume = [
        "render",
        scene_path,
        "--spp",
        SPP,
        "--resume",
        part_path,
        "--quiet",
        "-o",
        resumed.to_str().unwrap(),
    ];
    let name = part.file_name().unwrap().to_str().unwrap();
    for (args, output) in [(&merge[..], &merged), (&resume[..], &resumed)] {
        let out = luz_limited(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{} {name}: {stderr}", args[0]);
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
        assert!(
            stderr.contains(&format!("{name}: {field}")),
            "expected `{name}: {field}` in {stderr}"
        );
        assert!(stderr.contains(why), "expected {why:?} in {stderr}");
        assert!(!output.exists(), "{} must not be written", output.display());
    }
}

#[test]
fn a_flipped_bit_in_a_sum_is_refused() {
    let dir = temp_dir("flipped-sum");
    let part = render_part(&dir, "a.exr");
    let mut bytes = std::fs::read(&part).unwrap();
    // The lowest bit of the sum's low word: a change of one ulp, which no
    // plausibility check can see.
    let at = sample_offset(&bytes, "luz.sum.G.lo", 8, (4, 4));
    bytes[at] ^= 1;
    std::fs::write(&part, &bytes).unwrap();
    assert_refused(&dir, &part, "luz:checksum:", "damaged or edited");
}

#[test]
fn an_edited_sample_range_is_refused() {
    let dir = temp_dir("edited-samples");
    let part = render_part(&dir, "a.exr");
    let mut bytes = std::fs::read(&part).unwrap();
    let value = value_of(&bytes, "luz:samples");
    assert_eq!(&bytes[value.clone()], b"0..4");
    // Four samples' sums declared as three: a mean 33% too bright.
    bytes[value.end - 1] = b'3';
    std::fs::write(&part, &bytes).unwrap();
    assert_refused(&dir, &part, "luz:checksum:", "damaged or edited");
}

#[test]
fn a_header_claiming_more_pixels_than_the_file_holds_is_refused() {
    let dir = temp_dir("huge-header");
    let part = render_part(&dir, "a.exr");
    let mut bytes = std::fs::read(&part).unwrap();
    let value = value_of(&bytes, "dataWindow");
    let window: Vec<u8> = [0i32, 0, 15999, 15999]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    bytes[value].copy_from_slice(&window);
    // The chunk count the writer records must agree, or the reader stops
    // at the disagreement before it allocates.
    let value = value_of(&bytes, "chunkCount");
    bytes[value].copy_from_slice(&16000i32.to_le_bytes());
    std::fs::write(&part, &bytes).unwrap();
    assert_refused(&dir, &part, "dataWindow: 16000x16000", "the file holds");
}

#[test]
fn two_renders_of_one_part_are_byte_identical() {
    let dir = temp_dir("identical");
    let a = std::fs::read(render_part(&dir, "a.exr")).unwrap();
    let b = std::fs::read(render_part(&dir, "b.exr")).unwrap();
    assert!(a == b, "two renders of one part differ in their bytes");
}
