//! The text of the loader's messages: values and vectors as they are
//! quoted, serde's messages shortened and located, and the key a typo meant.

use crate::echo::echo;
use crate::geometry::MAX_COORDINATE;
use crate::math::Vec3;

/// Why a position is refused: where it lies and the bound.
pub(super) fn outside(p: Vec3) -> String {
    format!(
        "{} lies beyond ±{MAX_COORDINATE:e}, the most luz places anything at on an axis (its f32 intersection tests cube coordinate differences)",
        vec3(p)
    )
}

/// A vector for a message, each component in the shorter of plain and
/// exponent notation: `(3e38, 0, 0)`.
pub(super) fn vec3(v: Vec3) -> String {
    let c = |x: f32| {
        let (plain, exp) = (format!("{x}"), format!("{x:e}"));
        if plain.len() <= exp.len() {
            plain
        } else {
            exp
        }
    };
    format!("({}, {}, {})", c(v.x), c(v.y), c(v.z))
}

/// `message` with every backquoted or double-quoted value longer than
/// [`echo`] repeats cut short: serde's messages quote the offending key or
/// string whole, which may be megabytes.
pub(super) fn shorten_quoted(message: &str) -> String {
    let mut out = String::new();
    let mut rest = message;
    while let Some(open) = rest.find(['`', '"']) {
        let quote = rest[open..].chars().next().unwrap_or('`');
        out.push_str(&rest[..open]);
        let inner = &rest[open + 1..];
        match inner.find(quote) {
            Some(close) => {
                let value = &inner[..close];
                if value.len() > 60 {
                    out.push_str(&echo(value));
                } else {
                    out.push(quote);
                    out.push_str(value);
                    out.push(quote);
                }
                rest = &inner[close + 1..];
            }
            None => {
                out.push(quote);
                rest = inner;
                break;
            }
        }
    }
    out.push_str(rest);
    // Whatever else it holds, one line of a bounded length.
    match out.char_indices().nth(400) {
        Some((cut, _)) => format!("{}…", &out[..cut]),
        None => out,
    }
}

/// The key of a `key = value` line whose value starts at `offset`: serde's
/// type errors point at the value and do not name the field.
pub(super) fn key_before(text: &str, offset: usize) -> Option<&str> {
    let line_start = text.get(..offset)?.rfind('\n').map_or(0, |i| i + 1);
    let (key, rest) = text[line_start..offset].split_once('=')?;
    let key = key.trim().trim_matches('"');
    let is_key = !key.is_empty()
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
    (is_key && rest.trim().is_empty()).then_some(key)
}

/// The unknown key named by a serde "unknown field" message.
pub(super) fn unknown_field(message: &str) -> Option<&str> {
    let rest = message.strip_prefix("unknown field `")?;
    rest.split('`').next()
}

/// The closest expected key to an unknown one, if it is a likely typo.
pub(super) fn did_you_mean(message: &str) -> Option<String> {
    let unknown = unknown_field(message)?;
    if unknown.len() > 64 {
        return None;
    }
    let expected = message.split("expected").nth(1)?;
    expected
        .split('`')
        .skip(1)
        .step_by(2)
        .map(|cand| (edit_distance(unknown, cand), cand))
        .filter(|&(d, cand)| d <= 2.max(cand.len() / 3))
        .min()
        .map(|(_, c)| c.to_string())
}

pub(super) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}
