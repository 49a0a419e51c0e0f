//! Values echoed back in error messages, shortened: a 10 MB string that
//! failed to parse must not come back whole in the message.

/// The most characters of a value an error message repeats.
const MAX_ECHOED_CHARS: usize = 60;

/// `s` in backquotes, cut after [`MAX_ECHOED_CHARS`] characters with its
/// full length stated, so the message stays one readable line.
pub fn echo(s: &str) -> String {
    match s.char_indices().nth(MAX_ECHOED_CHARS) {
        None => format!("`{s}`"),
        Some((cut, _)) => format!("`{}…` ({} bytes)", &s[..cut], s.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::echo;

    #[test]
    fn short_values_are_echoed_whole() {
        assert_eq!(echo("abc"), "`abc`");
        assert_eq!(echo(""), "``");
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
