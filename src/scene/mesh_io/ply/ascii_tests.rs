//! Tests of the ascii PLY reader: the chunked read against the serial one,
//! and the errors' lines and fields.

use super::super::builder::Builder;
use super::super::{parse_header, plan::plan};
use super::{chunked_body, parallel_body, serial_body};
use crate::scene::mesh_io::test_support::{check_example, err, load_str, ply, ASCII};

/// What reading `text`'s body gives, serially or in chunks of about
/// `chunk` bytes (`None`), as text to compare.
fn read(text: &str, chunk: Option<usize>) -> String {
    let data = text.as_bytes();
    let h = parse_header(data).unwrap();
    let p = plan(&h.elements, h.body_line - 1).unwrap();
    let body = &data[h.body..];
    let (nv, nf) = (h.elements[p.vertex].count, h.elements[p.face].count);
    let mut out = Builder::new(nv, nf, &p, body.len());
    let r = match chunk {
        None => serial_body(body, h.body_line, &h.elements, &p.roles, &mut out),
        Some(c) => chunked_body(body, h.body_line, &h.elements, &p.roles, &mut out, c),
    };
    match r {
        Ok(()) => format!(
            "{:?} {:?} {:?} {:?}",
            out.positions, out.uvs, out.normals, out.indices
        ),
        Err(f) => format!("{f:?}"),
    }
}

/// Whether the parallel read of `text` in chunks of `chunk` bytes
/// decides by itself, without the serial read.
fn parallel_decides(text: &str, chunk: usize) -> bool {
    let data = text.as_bytes();
    let h = parse_header(data).unwrap();
    let p = plan(&h.elements, h.body_line - 1).unwrap();
    let body = &data[h.body..];
    let (nv, nf) = (h.elements[p.vertex].count, h.elements[p.face].count);
    let mut out = Builder::new(nv, nf, &p, body.len());
    parallel_body(body, h.body_line, &h.elements, &p.roles, &mut out, chunk).is_some()
}

/// Chunks cut everywhere (mid-line, at CRLF, in blank and trailing
/// lines) read as the serial read does: the same mesh or the same
/// error at the same line and column.
#[test]
fn chunks_read_as_the_serial_read() {
    let bodies = [
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n",
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2",
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n\n \r\n\n",
        "  0 0 0  \n\t1 0 0\n0 1 0 \n 3 0 1 2 \n",
        "0 0 0\n\n1 0 0\n0 1 0\n3 0 1 2\n",
        "0 0\n0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "0 0 0 1 0 0\n0 1 0\n3 0 1 2\n",
        "0 0 0\n1 0 0\n0 1 0\n3 0 1\n2\n",
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n1\n",
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 7\n",
        "0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n",
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 x\n",
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
        "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
        "0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n",
        "0 0 0\n1 0 0\n0 1 0\n3 0 1",
        "0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
        "0 0 0\n1 0 0\n0 1 0\n-1 0 1\n",
        "0 0 0\n1 0 0\n0 1 0\n9 0 1 2\n",
        "0 0 0\n1 0 abc 7\n0 1 0\n3 0 1 2\n",
        "0 0 0\n1 0\n",
        "0 0 0\r1 0 0\r0 1 0\r3 0 1 2\r",
        "",
    ];
    let mut texts: Vec<String> = bodies.iter().map(|b| ply(b)).collect();
    texts.push(ASCII.to_string());
    texts.push(ASCII.replace("0 1 -2 0 0 1\r\n", "0 1 -2 0 0 x\r\n"));
    texts.push(ASCII.replace("2 1 2\r\n", "2 1 2\r\n3\r\n"));
    // The regular ones (and the value errors) never need the serial read.
    for k in [0, 1, 2, 3, 4, 11, 12, 13, 14, 15, 16, 18, 19] {
        for chunk in 1..20 {
            assert!(parallel_decides(&texts[k], chunk), "{:?}", texts[k]);
        }
    }
    assert!(parallel_decides(ASCII, 30));
    for text in &texts {
        let want = read(text, None);
        for chunk in 1..text.len() + 2 {
            assert_eq!(read(text, Some(chunk)), want, "{text:?}, chunks of {chunk}");
        }
    }
}

/// A body large enough for the real chunk size: the same mesh as the
/// serial read, and an error far into it at its own line.
#[test]
fn large_body_in_chunks() {
    let n = 100_000;
    let mut body = String::new();
    for i in 0..n {
        body.push_str(&format!("{} {}.5 -{}.25\n", i % 97, i % 89, i % 83));
    }
    for i in 0..n - 2 {
        body.push_str(&format!("3 {} {} {}\n", i, i + 1, i + 2));
    }
    let text = |body: &str| {
        ply(body)
            .replace("vertex 3", &format!("vertex {n}"))
            .replace("face 1", &format!("face {}", n - 2))
    };
    let good = text(&body);
    assert!(good.len() > 2 * super::CHUNK_BYTES);
    let serial = read(&good, None);
    assert_eq!(read(&good, Some(super::CHUNK_BYTES)), serial);
    assert!(serial.len() > 1000);
    // Line 10 is the first vertex: face 40000 is on line
    // 10 + 100000 + 40000.
    let bad = good.replace("\n3 40000 40001 40002\n", "\n3 40000 40001 4000x\n");
    let want = "Text(140010, 15)";
    assert!(read(&bad, None).contains(want), "{}", read(&bad, None));
    assert_eq!(read(&bad, Some(super::CHUNK_BYTES)), read(&bad, None));
    assert!(parallel_decides(&good, super::CHUNK_BYTES));
    assert!(parallel_decides(&bad, super::CHUNK_BYTES));
    let e = err("big.ply", bad.as_bytes());
    assert!(e.starts_with(":140010:15: face property"), "{e}");
}

#[test]
fn ascii_ply_with_skipped_lists_and_quads() {
    check_example(&load_str("a.ply", ASCII).unwrap());
}

#[test]
fn ascii_errors_name_line_and_field() {
    let e = err("e.ply", ply("0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n").as_bytes());
    assert_eq!(
        e,
        ":11:3: vertex property `y`: expected a number, found `abc`"
    );
    let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n3 0 1 x\n").as_bytes());
    assert!(
        e.starts_with(":13:7: face property `vertex_indices`: expected an integer"),
        "{e}"
    );
    let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n").as_bytes());
    assert_eq!(
        e,
        ":13:7: face 0: vertex index 3 is out of range (3 vertices)"
    );
    let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n").as_bytes());
    assert!(e.contains("vertex index -1 is out of range"), "{e}");
    let e = err("e.ply", ply("0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n").as_bytes());
    assert!(
        e.starts_with(":11:1: vertex 1: coordinates must be finite"),
        "{e}"
    );
    let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n").as_bytes());
    assert!(
        e.starts_with(":12:1: vertex 2: coordinates must be finite"),
        "{e}"
    );
    let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n3 0 1").as_bytes());
    assert!(e.starts_with(":13:6: file ends early: face 0 of 1"), "{e}");
    let e = err("e.ply", ply("0 0 0\n1 0 0\n0 1 0\n2 0 1\n").as_bytes());
    assert!(e.contains(":13:5: face 0 has 2 vertices"), "{e}");
}

#[test]
fn elements_without_properties_take_no_time() {
    let text = ply("0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").replace(
        "end_header",
        "element nothing 18000000000000000000\nend_header",
    );
    let m = load_str("e.ply", &text).unwrap();
    assert_eq!(m.indices, vec![[0, 1, 2]]);
}
