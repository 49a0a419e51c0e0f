//! Values of a closed set named on the command line (backends, Embree
//! qualities, study dimensions): one lookup and one error message for all.

/// The value of `all` that `name` calls `s`, or an error that names `what`
/// was asked for and lists every known name.
pub fn parse<T: Copy>(
    s: &str,
    all: &[T],
    name: fn(T) -> &'static str,
    what: &str,
) -> Result<T, String> {
    all.iter().copied().find(|&v| name(v) == s).ok_or_else(|| {
        let known: Vec<&str> = all.iter().map(|&v| name(v)).collect();
        format!("unknown {what} `{s}` (known: {})", known.join(", "))
    })
}

#[cfg(test)]
mod tests {
    use crate::accel::{BackendKind, Quality};

    #[test]
    fn names_parse_back_and_unknown_ones_list_the_known() {
        for k in BackendKind::ALL {
            assert_eq!(k.name().parse::<BackendKind>(), Ok(k));
        }
        assert_eq!("native".parse::<BackendKind>(), Ok(BackendKind::Rust));
        assert_eq!(
            "fast".parse::<Quality>(),
            Err("unknown build quality `fast` (known: auto, low, medium, high)".to_string())
        );
    }
}
