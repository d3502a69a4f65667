//! Tokens and numbers of text mesh formats.
//!
//! Floats go through `str::parse::<f32>` on the token, which rounds correctly (Eisel–Lemire
//! with an exact fallback): a decimal string becomes the nearest `f32` directly, with no
//! double rounding through `f64`. Integers (face indices) use a small hand-written parser.

/// Whitespace-separated tokens of a line (space, tab, form feed, vertical tab, CR).
#[inline]
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| matches!(b, b' ' | b'\t' | b'\r' | b'\x0b' | b'\x0c'))
        .filter(|t| !t.is_empty())
}

/// An `f32` from a decimal token (`1`, `-2.5`, `1e-6`, `.5`, `inf`, `nan`); `None` if the
/// token is not a number.
#[inline]
pub(crate) fn parse_f32(tok: &[u8]) -> Option<f32> {
    std::str::from_utf8(tok).ok()?.parse::<f32>().ok()
}

/// An `f64` from a decimal token.
#[inline]
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    std::str::from_utf8(tok).ok()?.parse::<f64>().ok()
}

/// A signed decimal integer (`12`, `-3`, `+4`); `None` on anything else, including overflow
/// and an empty token.
#[inline]
pub(crate) fn parse_i64(tok: &[u8]) -> Option<i64> {
    let (neg, digits) = match tok.first()? {
        b'-' => (true, &tok[1..]),
        b'+' => (false, &tok[1..]),
        _ => (false, tok),
    };
    if digits.is_empty() {
        return None;
    }
    // Accumulate negatively so i64::MIN parses.
    let mut v: i64 = 0;
    for &b in digits {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v.checked_mul(10)?.checked_sub(d as i64)?;
    }
    if neg { Some(v) } else { v.checked_neg() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn integers() {
        assert_eq!(parse_i64(b"0"), Some(0));
        assert_eq!(parse_i64(b"123"), Some(123));
        assert_eq!(parse_i64(b"-7"), Some(-7));
        assert_eq!(parse_i64(b"+7"), Some(7));
        assert_eq!(parse_i64(b"9223372036854775807"), Some(i64::MAX));
        assert_eq!(parse_i64(b"-9223372036854775808"), Some(i64::MIN));
        for bad in [
            &b""[..],
            b"-",
            b"+",
            b"1.0",
            b"1a",
            b"9223372036854775808",
            b"--1",
            b" 1",
        ] {
            assert_eq!(parse_i64(bad), None, "{:?}", std::str::from_utf8(bad));
        }
    }

    #[test]
    fn floats() {
        assert_eq!(parse_f32(b"1e-006"), Some(1e-6));
        assert_eq!(parse_f32(b"-.5"), Some(-0.5));
        assert_eq!(parse_f32(b"5."), Some(5.0));
        assert_eq!(parse_f32(b"0.1"), Some(0.1f32));
        assert!(parse_f32(b"inf").unwrap().is_infinite());
        assert!(parse_f32(b"nan").unwrap().is_nan());
        for bad in [&b""[..], b"1.2.3", b"1,5", b"0x10", b"e5", b"\xff"] {
            assert_eq!(parse_f32(bad), None);
        }
    }

    #[test]
    fn f32_rounds_directly_not_through_f64() {
        // 1.00000005960464477539062500000001 is just above the midpoint between 1 and the next
        // f32: correct rounding gives 1 + 2^-23; rounding through f64 first gives the midpoint
        // exactly, which then ties to even (1.0).
        let s = b"1.00000005960464477539062500000001";
        assert_eq!(parse_f32(s), Some(1.0 + f32::EPSILON));
        assert_eq!(parse_f64(s).unwrap() as f32, 1.0);
    }

    #[test]
    fn token_split() {
        let t: Vec<&[u8]> = tokens(b"  f\t1/2/3  4//5 \r").collect();
        assert_eq!(t, vec![&b"f"[..], b"1/2/3", b"4//5"]);
    }

    proptest! {
        #[test]
        fn integer_round_trip(v in any::<i64>()) {
            prop_assert_eq!(parse_i64(v.to_string().as_bytes()), Some(v));
        }

        #[test]
        fn float_round_trip(bits in any::<u32>()) {
            let v = f32::from_bits(bits);
            prop_assume!(v.is_finite());
            prop_assert_eq!(parse_f32(format!("{v:e}").as_bytes()), Some(v));
            prop_assert_eq!(parse_f32(format!("{v}").as_bytes()), Some(v));
        }
    }
}
