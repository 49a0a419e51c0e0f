//! Numbers in ascii PLY: integers, and floats with a fast path for the
//! common short decimals.

use super::header::Ty;

pub(super) fn parse_int(tok: &[u8]) -> Option<i64> {
    let (neg, digits) = match tok.first()? {
        b'-' => (true, &tok[1..]),
        b'+' => (false, &tok[1..]),
        _ => (false, tok),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut v: i64 = 0;
    for &b in digits {
        if !b.is_ascii_digit() {
            return None;
        }
        v = v * 10 + (b - b'0') as i64;
    }
    Some(if neg { -v } else { v })
}

/// Clinger's fast path: a decimal whose digits and power of ten are both
/// exact in the target type converts with one correctly rounded operation.
/// That covers nearly every number in scanned meshes (`-0.0378297`); the rest
/// go to the standard library.
#[inline]
fn fast_float(tok: &[u8], ty: Ty) -> Option<f32> {
    const P32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];
    const P64: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let (neg, s) = match tok.first()? {
        b'-' => (true, &tok[1..]),
        b'+' => (false, &tok[1..]),
        _ => (false, tok),
    };
    let (mut m, mut e, mut digits, mut i) = (0u64, 0i32, 0, 0);
    while i < s.len() && s[i].is_ascii_digit() {
        m = m * 10 + (s[i] - b'0') as u64;
        digits += 1;
        i += 1;
    }
    if i < s.len() && s[i] == b'.' {
        i += 1;
        while i < s.len() && s[i].is_ascii_digit() {
            m = m * 10 + (s[i] - b'0') as u64;
            e -= 1;
            digits += 1;
            i += 1;
        }
    }
    if digits == 0 || digits > 18 {
        return None;
    }
    if i < s.len() && s[i] | 0x20 == b'e' {
        let x = parse_int(&s[i + 1..]).filter(|x| x.abs() < 1000)?;
        e += x as i32;
        i = s.len();
    }
    if i != s.len() {
        return None;
    }
    let v = if ty == Ty::F64 {
        if m > 1 << 53 || e.unsigned_abs() > 22 {
            return None;
        }
        let p = P64[e.unsigned_abs() as usize];
        (if e < 0 { m as f64 / p } else { m as f64 * p }) as f32
    } else {
        if m > 1 << 24 || e.unsigned_abs() > 10 {
            return None;
        }
        let p = P32[e.unsigned_abs() as usize];
        if e < 0 {
            m as f32 / p
        } else {
            m as f32 * p
        }
    };
    Some(if neg { -v } else { v })
}

pub(in crate::scene::mesh_io) fn parse_float(tok: &[u8], ty: Ty) -> Option<f32> {
    if let Some(v) = fast_float(tok, ty) {
        return Some(v);
    }
    let s = std::str::from_utf8(tok).ok()?;
    if ty == Ty::F64 {
        s.parse::<f64>().ok().map(|v| v as f32)
    } else {
        s.parse::<f32>().ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_float_matches_std() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let digits = (x % 9) as usize;
            let int = (x >> 8) % 1_000_000;
            let frac = (x >> 30) % 10u64.pow(digits as u32);
            let sign = if x & 1 == 1 { "-" } else { "" };
            let exp = match (x >> 60) % 3 {
                0 => String::new(),
                1 => format!("e{}", (x >> 40) % 12),
                _ => format!("E-{}", (x >> 40) % 12),
            };
            let s = format!("{sign}{int}.{frac:0digits$}{exp}");
            let s = s.replace(".e", "e").replace(".E", "E");
            let s = s.trim_end_matches('.');
            let want32 = s.parse::<f32>().unwrap();
            let want64 = s.parse::<f64>().unwrap() as f32;
            assert_eq!(parse_float(s.as_bytes(), Ty::F32), Some(want32), "{s}");
            assert_eq!(parse_float(s.as_bytes(), Ty::F64), Some(want64), "{s}");
        }
        for bad in ["", "-", ".", "1.2.3", "1e", "e5", "0x10", "1,5", "--1"] {
            assert_eq!(parse_float(bad.as_bytes(), Ty::F32), None, "{bad}");
        }
        assert_eq!(
            parse_float(b"-0", Ty::F32).map(f32::to_bits),
            Some((-0f32).to_bits())
        );
        assert_eq!(parse_float(b"1.", Ty::F32), Some(1.0));
        assert_eq!(parse_float(b".5", Ty::F32), Some(0.5));
    }
}
