//! Sample ranges as `luz:samples` and the command line write them: `A..B`,
//! comma separated.

use std::ops::Range;

/// Formats sample ranges as `luz:samples` stores them: `0..64,128..192`.
pub fn format_ranges(ranges: &[Range<u32>]) -> String {
    let parts: Vec<String> = ranges
        .iter()
        .map(|r| format!("{}..{}", r.start, r.end))
        .collect();
    parts.join(",")
}

/// Parses one range `A..B` with `A < B`.
pub fn parse_range(s: &str) -> Result<Range<u32>, String> {
    let bad = || format!("expected a sample range A..B such as 0..64, found `{s}`");
    let (a, b) = s.trim().split_once("..").ok_or_else(bad)?;
    let (a, b): (u32, u32) = (a.parse().map_err(|_| bad())?, b.parse().map_err(|_| bad())?);
    if a >= b {
        return Err(format!(
            "sample range {a}..{b} is empty (A must be below B)"
        ));
    }
    Ok(a..b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse_and_refuse_empty_or_malformed() {
        assert_eq!(parse_range("3..17"), Ok(3..17));
        for bad in ["5..5", "6..2", "1-2", "..4", "a..b", "-1..3"] {
            assert!(parse_range(bad).is_err(), "{bad}");
        }
        assert_eq!(format_ranges(&[0..4, 8..9]), "0..4,8..9");
    }
}
