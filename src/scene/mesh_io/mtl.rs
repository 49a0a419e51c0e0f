//! Wavefront MTL material libraries: the statements luz maps to its own
//! materials (`newmtl`, `Kd`, `Ks`, `Ns`, `Ke`, `map_Kd`), each malformed
//! value an error at its line and column; every other statement is counted
//! in one note per file.

use super::checks::summarize;
use super::fail::{column, fail_at, show, Fail};
use super::MeshError;
use crate::echo::echo;
use crate::location::{line_column, read_regular_file};
use crate::math::Rgb;
use std::path::Path;

/// The most distinct unused keywords counted, as for OBJ files.
const MAX_UNUSED_KEYWORDS: usize = 32;

/// One `newmtl` block, with what luz reads of it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MtlMaterial {
    pub name: String,
    /// The line of its `newmtl`.
    pub line: usize,
    /// Diffuse reflectance.
    pub kd: Option<Rgb>,
    /// Specular reflectance.
    pub ks: Option<Rgb>,
    /// Emitted radiance.
    pub ke: Option<Rgb>,
    /// Phong exponent of the specular lobe.
    pub ns: Option<f32>,
    /// The diffuse texture's file, relative to the library, and its line.
    pub map_kd: Option<(String, usize)>,
}

/// A material library: its materials in order, and notes on what of the
/// file luz did not use.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MtlLibrary {
    pub materials: Vec<MtlMaterial>,
    pub notes: Vec<String>,
}

/// Reads the library at `path`; its errors name the file, line and column.
pub fn read_mtl(path: &Path) -> Result<MtlLibrary, MeshError> {
    let data = read_regular_file(path).map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_mtl(&data).map_err(|f| f.at(path))
}

pub(super) fn parse_mtl(data: &[u8]) -> Result<MtlLibrary, Fail> {
    let text = std::str::from_utf8(data).map_err(|e| {
        let (line, column) = line_column(data, e.valid_up_to());
        fail_at(line, column, "the file is not UTF-8 text")
    })?;
    let mut library = MtlLibrary::default();
    let mut unused: Vec<(String, usize)> = Vec::new();
    let mut options: Vec<String> = Vec::new();
    for (no, line) in text.lines().enumerate() {
        let no = no + 1;
        let mut words = line.split_ascii_whitespace();
        let Some(kw) = words.next().filter(|w| !w.starts_with('#')) else {
            continue;
        };
        // Everything after the keyword: names may hold spaces.
        let rest = line[column(line, kw) - 1 + kw.len()..].trim();
        if kw == "newmtl" {
            if rest.is_empty() {
                return Err(fail_at(no, column(line, kw), "`newmtl` needs a name"));
            }
            library.materials.push(MtlMaterial {
                name: rest.to_string(),
                line: no,
                ..MtlMaterial::default()
            });
            continue;
        }
        let read = matches!(kw, "Kd" | "Ks" | "Ke" | "Ns" | "map_Kd");
        if !read {
            count_unused(&mut unused, kw);
            continue;
        }
        let Some(m) = library.materials.last_mut() else {
            return Err(fail_at(
                no,
                column(line, kw),
                format!("`{kw}` before any `newmtl`: which material does it describe?"),
            ));
        };
        match kw {
            "Kd" | "Ks" | "Ke" => {
                let words: Vec<&str> = words.collect();
                let colour = colour(kw, line, &words, no)?;
                match kw {
                    "Kd" => m.kd = Some(colour),
                    "Ks" => m.ks = Some(colour),
                    _ => m.ke = Some(colour),
                }
            }
            "Ns" => {
                let Some(w) = words.next() else {
                    return Err(fail_at(no, column(line, kw), "`Ns` needs a number"));
                };
                m.ns = Some(number(kw, line, w, no)?);
            }
            _ => {
                let (file, skipped) = texture_file(line, rest, no)?;
                options.extend(skipped);
                m.map_kd = Some((file.to_string(), no));
            }
        }
    }
    note_duplicates(&mut library);
    if !unused.is_empty() {
        let items: Vec<String> = unused
            .iter()
            .map(|(kw, n)| format!("{} ({n})", echo(kw)))
            .collect();
        library
            .notes
            .push(format!("not used: {}", summarize(&items)));
    }
    options.sort();
    options.dedup();
    if !options.is_empty() {
        library.notes.push(format!(
            "`map_Kd` options not used (textures are mapped by the mesh's own coordinates): {}",
            options.join(", ")
        ));
    }
    Ok(library)
}

/// A colour statement's values: `r g b`, or one value for grey, each finite
/// and not negative.
fn colour(kw: &str, line: &str, words: &[&str], no: usize) -> Result<Rgb, Fail> {
    if let Some(&form @ ("spectral" | "xyz")) = words.first() {
        return Err(fail_at(
            no,
            column(line, form),
            format!("`{kw} {form}` is not supported: luz reads RGB colours (`{kw} r g b`)"),
        ));
    }
    let mut c = [0.0f32; 3];
    match words.len() {
        1 | 3 => {
            for (k, w) in words.iter().enumerate() {
                c[k] = number(kw, line, w, no)?;
            }
            if words.len() == 1 {
                c = [c[0]; 3];
            }
        }
        n => {
            return Err(fail_at(
                no,
                column(line, kw),
                format!("`{kw}` needs 3 numbers (r g b) or 1 (grey), got {n}"),
            ))
        }
    }
    Ok(Rgb::from(c))
}

/// A value `w` of statement `kw` on `line`: finite and not negative.
fn number(kw: &str, line: &str, w: &str, no: usize) -> Result<f32, Fail> {
    let col = column(line, w);
    match w.parse::<f32>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        Ok(_) => Err(fail_at(
            no,
            col,
            format!("`{kw}`: must be finite and not negative, got `{w}`"),
        )),
        Err(_) => Err(fail_at(
            no,
            col,
            format!("`{kw}`: expected a number, found `{}`", show(w.as_bytes())),
        )),
    }
}

/// The file of a `map_Kd` statement whose text after the keyword is
/// `rest`: what follows its options (`-o 0 0`, `-clamp on`, ...), which
/// it returns by name.
fn texture_file<'a>(line: &str, rest: &'a str, no: usize) -> Result<(&'a str, Vec<String>), Fail> {
    let mut skipped = Vec::new();
    let mut rest = rest;
    while let Some(option) = rest
        .split_ascii_whitespace()
        .next()
        .filter(|w| w.starts_with('-'))
    {
        let Some((least, most)) = option_arguments(option) else {
            return Err(fail_at(
                no,
                column(line, option),
                format!("`map_Kd`: unknown option {}", echo(option)),
            ));
        };
        let mut after = rest[option.len()..].trim_start();
        for k in 0..most {
            let Some(w) = after.split_ascii_whitespace().next() else {
                break;
            };
            // -o, -s and -t take one to three numbers.
            if k >= least && w.parse::<f32>().is_err() {
                break;
            }
            after = after[w.len()..].trim_start();
        }
        skipped.push(option.to_string());
        rest = after;
    }
    if rest.is_empty() {
        return Err(fail_at(no, line.len() + 1, "`map_Kd` needs a file name"));
    }
    Ok((rest, skipped))
}

/// How many arguments a texture option takes (at least, at most), or
/// `None` if MTL has no such option.
fn option_arguments(option: &str) -> Option<(usize, usize)> {
    Some(match option {
        "-blendu" | "-blendv" | "-bm" | "-boost" | "-cc" | "-clamp" | "-imfchan" | "-texres"
        | "-type" => (1, 1),
        "-mm" => (2, 2),
        "-o" | "-s" | "-t" => (1, 3),
        _ => return None,
    })
}

/// Counts one statement of keyword `kw` into `unused`.
fn count_unused(unused: &mut Vec<(String, usize)>, kw: &str) {
    if let Some(e) = unused.iter_mut().find(|(k, _)| k == kw) {
        e.1 += 1;
    } else if unused.len() < MAX_UNUSED_KEYWORDS {
        unused.push((kw.to_string(), 1));
    }
}

/// Keeps the first of materials of one name, with a note on the others.
fn note_duplicates(library: &mut MtlLibrary) {
    let mut seen: std::collections::HashMap<String, usize> = Default::default();
    let mut again = Vec::new();
    library.materials.retain(|m| match seen.get(&m.name) {
        Some(first) => {
            again.push(format!("{} (lines {first} and {})", echo(&m.name), m.line));
            false
        }
        None => {
            seen.insert(m.name.clone(), m.line);
            true
        }
    });
    if !again.is_empty() {
        library.notes.push(format!(
            "materials defined twice, the first definition used: {}",
            summarize(&again)
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> MtlLibrary {
        parse_mtl(text.as_bytes()).unwrap_or_else(|f| panic!("{}", f.msg))
    }

    /// The error as `read_mtl` reports it, without the path.
    fn err(text: &str) -> String {
        let path = Path::new("m.mtl");
        let e = parse_mtl(text.as_bytes()).unwrap_err().at(path).to_string();
        e["m.mtl".len()..].to_string()
    }

    #[test]
    fn reads_what_luz_maps_and_notes_the_rest() {
        let lib = parse(
            "# a comment\n\nnewmtl  shiny red \n\tKd 0.5 0.1 0.1\n  Ks 0.25\nNs 100\nKa 1 1 1\n\
             illum 2\nnewmtl lamp\nKe 17 12 4\nmap_Kd -s 2 2 1 -clamp on -bm 0.5 tex\\my wood.png\n\
             newmtl shiny red\nKd 1 1 1\nd 0.5\n",
        );
        assert_eq!(lib.materials.len(), 2);
        let red = &lib.materials[0];
        assert_eq!((red.name.as_str(), red.line), ("shiny red", 3));
        assert_eq!(red.kd, Some(Rgb::new(0.5, 0.1, 0.1)));
        assert_eq!(red.ks, Some(Rgb::splat(0.25)));
        assert_eq!((red.ns, red.ke, &red.map_kd), (Some(100.0), None, &None));
        let lamp = &lib.materials[1];
        assert_eq!(lamp.ke, Some(Rgb::new(17.0, 12.0, 4.0)));
        assert_eq!(lamp.map_kd, Some(("tex\\my wood.png".to_string(), 11)));
        assert_eq!(
            lib.notes,
            [
                "materials defined twice, the first definition used: `shiny red` (lines 3 and 12)",
                "not used: `Ka` (1), `illum` (1), `d` (1)",
                "`map_Kd` options not used (textures are mapped by the mesh's own coordinates): -bm, -clamp, -s",
            ]
        );
    }

    #[test]
    fn bad_values_are_located() {
        let cases = [
            (
                "newmtl a\nKd 0.5 x 0.5\n",
                ":2:8: `Kd`: expected a number, found `x`",
            ),
            (
                "newmtl a\n Ks 0.5 -0.1 0\n",
                ":2:9: `Ks`: must be finite and not negative, got `-0.1`",
            ),
            (
                "newmtl a\nKe 1 inf 1\n",
                ":2:6: `Ke`: must be finite and not negative, got `inf`",
            ),
            (
                "newmtl a\nKd 1 1\n",
                ":2:1: `Kd` needs 3 numbers (r g b) or 1 (grey), got 2",
            ),
            ("newmtl a\nNs\n", ":2:1: `Ns` needs a number"),
            (
                "Kd 1 1 1\n",
                ":1:1: `Kd` before any `newmtl`: which material does it describe?",
            ),
            ("newmtl\n", ":1:1: `newmtl` needs a name"),
            (
                "newmtl a\nmap_Kd -s 1 1\n",
                ":2:14: `map_Kd` needs a file name",
            ),
            (
                "newmtl a\nmap_Kd -wrap x.png\n",
                ":2:8: `map_Kd`: unknown option `-wrap`",
            ),
            (
                "newmtl a\nKd spectral x.rfl\n",
                ":2:4: `Kd spectral` is not supported: luz reads RGB colours (`Kd r g b`)",
            ),
        ];
        for (text, want) in cases {
            assert_eq!(err(text), want, "{text:?}");
        }
        let e = parse_mtl(b"newmtl a\nKd 1 \xff 1\n")
            .unwrap_err()
            .at(Path::new("m.mtl"));
        assert_eq!(e.to_string(), "m.mtl:2:6: the file is not UTF-8 text");
    }
}
