//! The streamed parse of gzipped PLY files against the parse of the same
//! files held whole: the same mesh to the bit and the same notes, or the
//! same error message, through windows from one byte (every record cut at
//! every place) to several kilobytes.

use super::parse_ply;
use crate::scene::mesh_io::gzip::parse_ply_windowed;
use crate::scene::mesh_io::test_support::{corruptions, examples, gz, ply, push_ordered, ASCII};
use crate::scene::mesh_io::{MeshError, Noted};
use std::path::Path;

/// A parse's outcome as text to compare: the mesh's arrays as bits and the
/// notes, or the error's message.
fn outcome(read: Result<Noted, MeshError>) -> String {
    match read {
        Ok((m, notes)) => {
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let positions: Vec<f32> = m.positions.iter().flat_map(|p| p.to_array()).collect();
            let uvs: Option<Vec<f32>> = m
                .uvs
                .map(|uvs| uvs.iter().flat_map(|u| u.to_array()).collect());
            let normals: Option<Vec<f32>> = m
                .normals
                .map(|n| n.iter().flat_map(|n| n.to_array()).collect());
            format!(
                "{:?} {:?} {:?} {:?} {notes:?}",
                bits(&positions),
                uvs.as_deref().map(bits),
                normals.as_deref().map(bits),
                m.indices
            )
        }
        Err(e) => e.to_string(),
    }
}

fn path() -> &'static Path {
    Path::new("m.ply.gz")
}

/// The parse of `data` held whole, as if it had been inflated whole.
fn whole(data: &[u8]) -> String {
    outcome(parse_ply(data).map_err(|f| f.at(path())))
}

/// Checks that `data`, gzipped, parses through each of `windows` as it
/// does held whole, and returns that outcome.
fn streams_alike(data: &[u8], windows: impl IntoIterator<Item = usize>) -> String {
    let want = whole(data);
    let packed = gz(data);
    for window in windows {
        let got = outcome(parse_ply_windowed(&packed, path(), window));
        assert_eq!(got, want, "window of {window} bytes");
    }
    want
}

fn is_error(outcome: &str) -> bool {
    outcome.starts_with("m.ply.gz")
}

/// A value of PLY type `ty` in the file's byte order, or as ascii text.
fn put(out: &mut Vec<u8>, format: &str, ty: &str, x: f64) {
    if format == "ascii" {
        out.extend_from_slice(format!("{x} ").as_bytes());
        return;
    }
    let le: Vec<u8> = match ty {
        "uchar" => vec![x as u8],
        "ushort" => (x as u16).to_le_bytes().to_vec(),
        "int" => (x as i32).to_le_bytes().to_vec(),
        "float" => (x as f32).to_le_bytes().to_vec(),
        _ => x.to_le_bytes().to_vec(),
    };
    push_ordered(out, &le, format == "binary_big_endian");
}

/// An `n`×`n` grid of vertices and its faces in `format`. Plain: float
/// x y z and triangles as `uchar int` lists (the layouts read in bulk from
/// a file held whole). Rich: double positions, float normals and texture
/// coordinates, quads as `uchar ushort` lists with a list of weights, and
/// an element of lists after the faces.
fn grid(format: &str, n: usize, rich: bool) -> Vec<u8> {
    let quads = (n - 1) * (n - 1);
    let mut out = format!(
        "ply\r\nformat {format} 1.0\r\ncomment a grid\r\nelement vertex {}\r\n",
        n * n
    )
    .into_bytes();
    let (position, index) = if rich {
        ("double", "ushort")
    } else {
        ("float", "int")
    };
    for c in ["x", "y", "z"] {
        out.extend_from_slice(format!("property {position} {c}\r\n").as_bytes());
    }
    if rich {
        out.extend_from_slice(b"property float nx\r\nproperty float ny\r\nproperty float nz\r\n");
        out.extend_from_slice(b"property float u\r\nproperty float v\r\n");
    }
    let faces = if rich { quads } else { 2 * quads };
    out.extend_from_slice(
        format!("element face {faces}\r\nproperty list uchar {index} vertex_indices\r\n")
            .as_bytes(),
    );
    if rich {
        out.extend_from_slice(b"property list uchar float weights\r\n");
        out.extend_from_slice(b"element edge 2\r\nproperty list uchar int ends\r\n");
    }
    out.extend_from_slice(b"end_header\r\n");
    let end_record = |out: &mut Vec<u8>| {
        if format == "ascii" {
            out.extend_from_slice(b"\r\n");
        }
    };
    for k in 0..n * n {
        let (i, j) = ((k % n) as f64, (k / n) as f64);
        let mut values = vec![i * 0.37, j / 3.0, ((k * 7) % 13) as f64 - 6.5];
        if rich {
            values.extend([0.5, -0.25, 1.0, i / n as f64, j / n as f64]);
        }
        for (c, x) in values.into_iter().enumerate() {
            put(&mut out, format, if c < 3 { position } else { "float" }, x);
        }
        end_record(&mut out);
    }
    for q in 0..quads {
        let a = (q % (n - 1) + q / (n - 1) * n) as f64;
        let corners = [a, a + 1.0, a + 1.0 + n as f64, a + n as f64];
        let polygons = match rich {
            true => vec![corners.to_vec()],
            false => vec![corners[..3].to_vec(), vec![a, corners[2], corners[3]]],
        };
        for polygon in polygons {
            put(&mut out, format, "uchar", polygon.len() as f64);
            for i in polygon {
                put(&mut out, format, index, i);
            }
            if rich {
                put(&mut out, format, "uchar", (q % 3) as f64);
                for w in 0..q % 3 {
                    put(&mut out, format, "float", w as f64 + 0.5);
                }
            }
            end_record(&mut out);
        }
    }
    if rich {
        for ends in [[0.0, 1.0], [2.0, 3.0]] {
            put(&mut out, format, "uchar", 2.0);
            ends.iter().for_each(|&e| put(&mut out, format, "int", e));
            end_record(&mut out);
        }
    }
    out
}

const FORMATS: [&str; 3] = ["ascii", "binary_little_endian", "binary_big_endian"];

/// The examples through every window from one byte to more than the file:
/// every record cut at every place.
#[test]
fn small_files_stream_through_every_window() {
    for data in &examples() {
        let read = streams_alike(data, 1..data.len() + 2);
        assert!(!is_error(&read), "{read}");
    }
    let read = streams_alike(one_value_a_line(ASCII).as_bytes(), 1..ASCII.len() + 2);
    assert!(!is_error(&read), "{read}");
}

/// The ascii `text` with every value of its body on a line of its own: a
/// record over many lines, cut off by a window's last line end after some
/// of its faces were read.
fn one_value_a_line(text: &str) -> String {
    let body = text.find("end_header").unwrap() + 12;
    format!("{}{}", &text[..body], text[body..].replace(' ', "\n"))
}

/// Files of many windows, plain and rich, in every format: the mesh of
/// the whole file's parallel and bulk paths, read window by window.
#[test]
fn large_files_stream_alike() {
    for format in FORMATS {
        for rich in [false, true] {
            let data = grid(format, 60, rich);
            assert!(data.len() > 20 << 10, "{}", data.len());
            let read = streams_alike(&data, [1, 2, 3, 7, 13, 64, 255, 1000, 4096]);
            assert!(read.contains("0, 1, 61"), "{format} {rich}: {read}");
        }
    }
    let text = one_value_a_line(std::str::from_utf8(&grid("ascii", 60, true)).unwrap());
    let read = streams_alike(text.as_bytes(), [1, 2, 3, 7, 13, 64, 255, 1000, 4096]);
    assert!(read.contains("0, 1, 61"), "{read}");
}

/// Files cut anywhere fail as the whole file's parse does, at the same
/// byte or line.
#[test]
fn truncated_files_fail_alike() {
    for data in &examples() {
        for cut in 0..data.len() {
            streams_alike(&data[..cut], [1, 5, 64]);
        }
    }
    for format in FORMATS {
        let data = grid(format, 30, true);
        for cut in (0..data.len()).step_by(97) {
            let read = streams_alike(&data[..cut], [7, 300]);
            // Cut in the last line's end, an ascii file is whole.
            assert!(
                is_error(&read) || cut + 3 > data.len(),
                "{format} {cut}: {read}"
            );
        }
    }
}

/// Damaged files fail with the whole file's parse's message: data after
/// the last element, an index out of range, a non-finite vertex, a bad
/// token, each deep in a file of many windows.
#[test]
fn damaged_files_fail_alike() {
    let windows = [1, 9, 256];
    let fails = |data: &[u8], needle: &str| {
        let read = streams_alike(data, windows);
        assert!(is_error(&read) && read.contains(needle), "{read}");
    };
    for format in FORMATS {
        for rich in [false, true] {
            let data = grid(format, 30, rich);
            fails(&[&data[..], b"1 2 3\n"].concat(), "the data goes on after");
            fails(
                &[&data[..], b"\n\n  \n7"].concat(),
                "the data goes on after",
            );
        }
    }
    // Ascii, at their lines and columns.
    let text = String::from_utf8(grid("ascii", 30, true)).unwrap();
    fails(
        text.replace("\r\n4 34 35 65 64 ", "\r\n4 34 35 65 964 ")
            .as_bytes(),
        "out of range",
    );
    let (at, _) = text.match_indices("0.5 -0.25 1 ").nth(700).unwrap();
    let nan = format!("{}0.5 nan 1 {}", &text[..at], &text[at + 12..]);
    fails(nan.as_bytes(), "normal (nx ny nz) must be finite");
    fails(
        text.replace("\r\n4 34 35 65 64 ", "\r\n4 34 3x5 65 64 ")
            .as_bytes(),
        "found `3x5`",
    );
    fails(
        ply("0 0 0\n1 0 0\n0 1 0\n3 0 1 2 junk\n").as_bytes(),
        "the data goes on",
    );
    // Binary, at their bytes: the last index, and a NaN in the last vertex.
    for format in &FORMATS[1..] {
        let mut data = grid(format, 40, false);
        let at = data.len() - 4;
        data[at..].copy_from_slice(&[0x7f; 4]);
        fails(&data, "out of range");
        let at = data.len() - (2 * 39 * 39) * 13 - 4;
        data[at..at + 4].copy_from_slice(&[0x7f, 0xc0, 0xc0, 0x7f]);
        fails(&data, "must be finite");
        // A file cut short in its vertices fails as cut short, as the
        // parse of the whole file checks the element's length first.
        let mut data = grid(format, 40, false);
        let body = data.len() - (2 * 39 * 39) * 13 - 40 * 40 * 12;
        data[body + 16..body + 20].copy_from_slice(&[0x7f, 0xc0, 0xc0, 0x7f]);
        fails(
            &data[..body + 1000 * 12 + 5],
            "file ends early: vertex 1000 of 1600",
        );
    }
}

/// Bytes overwritten anywhere: the same mesh or the same failure.
#[test]
fn corrupted_bytes_fail_alike() {
    for format in FORMATS {
        let data = grid(format, 8, true);
        let mut errors = 0;
        for d in corruptions(&data, 300) {
            errors += is_error(&streams_alike(&d, [3, 64])) as usize;
        }
        assert!(errors > 10, "{format}: {errors}");
    }
}

/// Data past the most the header's counts allow fails at that byte, before
/// any failure in the records: as when the file was inflated up to there.
#[test]
fn a_body_past_its_limit_fails_there() {
    let mut data = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
        property float x\nproperty float y\nproperty float z\nelement face 1\n\
        property list uchar int vertex_indices\nend_header\n"
        .to_vec();
    let body = data.len();
    for x in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        data.extend_from_slice(&x.to_le_bytes());
    }
    data.push(3);
    for i in [0i32, 1, 2] {
        data.extend_from_slice(&i.to_le_bytes());
    }
    assert!(!is_error(&whole(&data)), "{}", whole(&data));
    // Three vertices of 12 bytes, a face of at most 255 indices.
    let limit = body + 3 * 12 + 1 + 255 * 4;
    data.resize(limit + 5000, 0);
    let want = format!(
        "m.ply.gz: byte {limit}: the data goes on after the last element the header declares \
         (3 `vertex`, 1 `face`) (decompression stopped here: the counts allow no more)"
    );
    for window in [1, 64, 4096] {
        let read = outcome(parse_ply_windowed(&gz(&data), path(), window));
        assert_eq!(read, want);
        let mut nan = data.clone();
        nan[body..body + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let read = outcome(parse_ply_windowed(&gz(&nan), path(), window));
        assert_eq!(read, want);
    }
}

/// A gzip stream cut short is a gzip failure, wherever the parse is then.
#[test]
fn a_broken_stream_is_a_gzip_failure() {
    let data = grid("binary_little_endian", 30, false);
    let packed = gz(&data);
    for cut in [packed.len() / 2, packed.len() - 3] {
        for window in [5, 4096] {
            let read = outcome(parse_ply_windowed(&packed[..cut], path(), window));
            assert!(read.starts_with("m.ply.gz: gzip: "), "{read}");
        }
    }
}
