//! Values echoed back in error messages, shortened: a 10 MB string that
//! failed to parse must not come back whole in the message.

/// The most characters of a value an error message repeats.
const MAX_ECHOED_CHARS: usize = 60;

/// `s` in backquotes, cut after [`MAX_ECHOED_CHARS`] characters with its
/// full length stated, its control characters escaped (a line break as
/// `\n`), so the message stays one readable line.
pub fn echo(s: &str) -> String {
    match s.char_indices().nth(MAX_ECHOED_CHARS) {
        None => format!("`{}`", escape_controls(s)),
        Some((cut, _)) => format!("`{}…` ({} bytes)", escape_controls(&s[..cut]), s.len()),
    }
}

/// `s` with its control characters written as Rust escapes.
fn escape_controls(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::echo;

    #[test]
    fn short_values_are_echoed_whole() {
        assert_eq!(echo("abc"), "`abc`");
        assert_eq!(echo(""), "``");
    }

    /// Found by `fuzz_props::scene_mutated`: a TOML string `"po\nt"` made
    /// a two-line message.
    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(echo("po\nt"), "`po\\nt`");
        assert_eq!(echo("a\tb\u{1b}\r"), "`a\\tb\\u{1b}\\r`");
        assert_eq!(echo("é ok"), "`é ok`");
        assert_eq!(echo(&"\n".repeat(100)).lines().count(), 1);
    }

    #[test]
    fn long_values_are_cut_on_a_character_boundary_with_their_length() {
        let long = "é".repeat(5_000_000);
        let echoed = echo(&long);
        assert!(echoed.len() < 200, "{} bytes echoed", echoed.len());
        assert!(echoed.ends_with("…` (10000000 bytes)"), "{echoed}");
        assert!(echoed.starts_with("`éé"));
    }
}
