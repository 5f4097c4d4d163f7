//! Fast fixed-point formatting for the output files: `value` with `decimals` digits after
//! the point, through integer digits written two at a time from a table instead of the
//! general float formatter, which dominated the time of a run that writes every IMU
//! epoch. A row is built on the stack and copied into the output once (the `itoa`-based
//! version before made four small copies per value; it is the byte-for-byte reference of
//! the tests).
//!
//! The value is rounded as `round(value · 10^decimals)`; for the magnitudes written here
//! (|value · 10^d| < 9·10^18) the result equals `format!("{:.d$}", value)` except, rarely,
//! in the last digit of exact half-way cases. Values out of that range, NaN and ±∞ use
//! the standard formatter.

use std::io::Write;

const POW10: [u64; 16] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
    10_000_000_000,
    100_000_000_000,
    1_000_000_000_000,
    10_000_000_000_000,
    100_000_000_000_000,
    1_000_000_000_000_000,
];

/// Two decimal digits per entry, `"00"` to `"99"`.
const PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// Room for one value: a sign, 19 digits and the point.
const ROOM: usize = 24;

/// `f::<d>(args)` for `d` in 0..=15 (larger values as 15): the digit loops of a value
/// unroll for its number of decimals, which a file's column keeps from row to row.
macro_rules! with_decimals {
    ($d:expr, $f:ident ( $($arg:expr),* )) => {
        match $d {
            0 => $f::<0>($($arg),*),
            1 => $f::<1>($($arg),*),
            2 => $f::<2>($($arg),*),
            3 => $f::<3>($($arg),*),
            4 => $f::<4>($($arg),*),
            5 => $f::<5>($($arg),*),
            6 => $f::<6>($($arg),*),
            7 => $f::<7>($($arg),*),
            8 => $f::<8>($($arg),*),
            9 => $f::<9>($($arg),*),
            10 => $f::<10>($($arg),*),
            11 => $f::<11>($($arg),*),
            12 => $f::<12>($($arg),*),
            13 => $f::<13>($($arg),*),
            14 => $f::<14>($($arg),*),
            _ => $f::<15>($($arg),*),
        }
    };
}

/// `value` with `d` digits after the point, written right-aligned into `buf`; the start
/// of the text, or `None` when the value needs the standard formatter.
#[inline(always)]
fn fixed_into(buf: &mut [u8; ROOM], value: f64, d: usize) -> Option<usize> {
    with_decimals!(d, fixed_with(buf, value))
}

/// [`fixed_into`] for `D` decimals, inlined into the row's loop with [`fixed_into`]. (One
/// function for every count took 1.15 times as long: criterion
/// `text_io/nav_writer_20k_rows` 7.44–8.14 ms against 6.75–7.00 ms, three alternating
/// runs; `docs/history/benches.md`.)
#[inline(always)]
fn fixed_with<const D: usize>(buf: &mut [u8; ROOM], value: f64) -> Option<usize> {
    let scaled = round(value * POW10[D] as f64);
    if !scaled.is_finite() || scaled.abs() >= 9.0e18 {
        return None;
    }
    digits_into::<D>(buf, value, scaled, false)
}

/// [`fixed_into`] that writes exactly the bytes of `format!("{value:.d$}")`: the product
/// `value · 10^d` is within half an ulp of the exact one, so rounding it to an integer
/// gives the correctly rounded decimal unless it lies within a few ulps of a half-integer
/// (the standard formatter also rounds exact ties to even); those values, about one in
/// 10¹⁴ of arbitrary ones, go to the standard formatter (`None`).
#[inline]
fn exact_into(buf: &mut [u8; ROOM], value: f64, d: usize) -> Option<usize> {
    let raw = value * POW10[d] as f64;
    if !raw.is_finite() || raw.abs() >= 9.0e18 {
        return None;
    }
    // (for |raw| < 2⁵³ the fraction is computed exactly)
    let a = raw.abs();
    let whole = a as u64 as f64;
    let fraction = a - whole;
    if (fraction - 0.5).abs() <= 4.0 * f64::EPSILON * a.max(1.0) {
        return None;
    }
    // rounded half away from zero, as `round` does (no tie gets here); the standard
    // formatter keeps the sign of a negative value that rounds to zero
    let scaled = if fraction > 0.5 { whole + 1.0 } else { whole };
    with_decimals!(d, digits_into(buf, value, scaled, true))
}

/// `x.round()` (half away from zero) without the library call that `f64::round` is on
/// x86-64 without SSE4.1: the truncation is an integer conversion, exact below 9·10¹⁸,
/// and so is the fraction below 2⁵³ (above it every `f64` is an integer).
#[inline(always)]
fn round(x: f64) -> f64 {
    let a = x.abs();
    if a.is_nan() || a >= 9.0e18 {
        return x.round();
    }
    let t = a as u64 as f64;
    let r = if a - t >= 0.5 { t + 1.0 } else { t };
    r.copysign(x)
}

/// The digits of the integer `scaled = round(value · 10^D)` with the point `D` digits from
/// the right, right-aligned in `buf`; the start of the text. A negative value that rounds
/// to zero is written with its sign when `signed_zero`.
#[inline(always)]
fn digits_into<const D: usize>(
    buf: &mut [u8; ROOM],
    value: f64,
    scaled: f64,
    signed_zero: bool,
) -> Option<usize> {
    let mut n = scaled.abs() as u64;
    let negative = value.is_sign_negative() && (n != 0 || signed_zero);
    let mut at = ROOM;
    let pair = |buf: &mut [u8; ROOM], at: &mut usize, r: u64| {
        *at -= 2;
        let r = 2 * r as usize;
        buf[*at] = PAIRS[r];
        buf[*at + 1] = PAIRS[r + 1];
    };
    // the fraction, exactly `D` digits
    let mut left = D;
    while left >= 2 {
        pair(buf, &mut at, n % 100);
        n /= 100;
        left -= 2;
    }
    if left == 1 {
        at -= 1;
        buf[at] = b'0' + (n % 10) as u8;
        n /= 10;
    }
    if D > 0 {
        at -= 1;
        buf[at] = b'.';
    }
    // the integer part, at least one digit
    while n >= 100 {
        pair(buf, &mut at, n % 100);
        n /= 100;
    }
    if n >= 10 {
        pair(buf, &mut at, n);
    } else {
        at -= 1;
        buf[at] = b'0' + n as u8;
    }
    if negative {
        at -= 1;
        buf[at] = b'-';
    }
    Some(at)
}

/// Append `value` with `decimals` (≤ 15) digits after the point to `out`.
pub fn push_fixed(out: &mut Vec<u8>, value: f64, decimals: usize) {
    let d = decimals.min(15);
    let mut buf = [0u8; ROOM];
    match fixed_into(&mut buf, value, d) {
        Some(at) => out.extend_from_slice(&buf[at..]),
        None => {
            let _ = write!(out, "{value:.d$}");
        }
    }
}

/// Append `value` with `decimals` (≤ 15) digits after the point, right-aligned in
/// `width` characters (padded with spaces), exactly as `format!("{value:width$.decimals$}")`
/// writes it.
pub fn push_exact(out: &mut Vec<u8>, value: f64, width: usize, decimals: usize) {
    let d = decimals.min(15);
    let mut buf = [0u8; ROOM];
    match exact_into(&mut buf, value, d) {
        Some(at) => {
            let text = &buf[at..];
            out.extend(std::iter::repeat_n(b' ', width.saturating_sub(text.len())));
            out.extend_from_slice(text);
        }
        None => {
            let _ = write!(out, "{value:width$.decimals$}");
        }
    }
}

/// Append space-separated values and a newline, each exactly as `format!("{v:.d$}")`
/// writes it ([`push_exact`] without padding).
pub fn push_exact_row(out: &mut Vec<u8>, values: &[(f64, usize)]) {
    for (i, (v, d)) in values.iter().enumerate() {
        if i > 0 {
            out.push(b' ');
        }
        push_exact(out, *v, 0, *d);
    }
    out.push(b'\n');
}

/// Values a row builds on the stack before one copy into `out`.
const ROW_VALUES: usize = 32;

/// Append space-separated fixed-point values and a newline (the row is built on the stack
/// and copied once). Each value's text is moved into the row as a whole `ROOM` (24) bytes,
/// a copy of fixed size that compiles to a few register moves (the text's own length made
/// it a call of `memcpy`, 2.7 % of a forward run's samples); the bytes past the text are
/// overwritten by the next value or left out of the row.
pub fn push_row(out: &mut Vec<u8>, values: &[(f64, usize)]) {
    // (room after the last value for a whole `ROOM`-byte copy)
    let mut line = [0u8; ROW_VALUES * (ROOM + 1) + ROOM];
    let mut len = 0;
    // a value's text right-aligned in the first half, copied from where it starts
    let mut buf = [[0u8; ROOM]; 2];
    for (i, (v, d)) in values.iter().enumerate() {
        if i >= ROW_VALUES {
            out.extend_from_slice(&line[..len]);
            len = 0;
            for (v, d) in &values[i..] {
                out.push(b' ');
                push_fixed(out, *v, *d);
            }
            break;
        }
        if i > 0 {
            line[len] = b' ';
            len += 1;
        }
        match fixed_into(&mut buf[0], *v, (*d).min(15)) {
            Some(at) => {
                line[len..len + ROOM].copy_from_slice(&buf.as_flattened()[at..at + ROOM]);
                len += ROOM - at;
            }
            None => {
                out.extend_from_slice(&line[..len]);
                len = 0;
                push_fixed(out, *v, *d);
            }
        }
    }
    line[len] = b'\n';
    out.extend_from_slice(&line[..len + 1]);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fmt(v: f64, d: usize) -> String {
        let mut o = Vec::new();
        push_fixed(&mut o, v, d);
        String::from_utf8(o).unwrap()
    }

    #[test]
    fn matches_std_formatting() {
        for &(v, d) in &[
            (-32.8307739961, 10),
            (100000.005, 6),
            (0.0, 4),
            (-0.00001, 4),
            (700.0, 4),
            (-15.0, 8),
            (1e-12, 3),
            (123456.789, 0),
            (-0.5, 0),
        ] {
            let ours = fmt(v, d);
            let std = format!("{v:.d$}");
            let a: f64 = ours.parse().unwrap();
            let b: f64 = std.parse().unwrap();
            assert!((a - b).abs() <= 10f64.powi(-(d as i32)) * 1.0001, "{v} {d}: {ours} vs {std}");
        }
    }

    /// The previous, `itoa`-based formatter: the new one must write the same bytes.
    fn reference(out: &mut Vec<u8>, value: f64, decimals: usize) {
        let d = decimals.min(15);
        let scaled = (value * POW10[d] as f64).round();
        if !scaled.is_finite() || scaled.abs() >= 9.0e18 {
            let _ = write!(out, "{value:.d$}");
            return;
        }
        let n = scaled.abs() as u64;
        if value.is_sign_negative() && n != 0 {
            out.push(b'-');
        }
        let mut buf = itoa::Buffer::new();
        out.extend_from_slice(buf.format(n / POW10[d]).as_bytes());
        if d > 0 {
            out.push(b'.');
            let frac = buf.format(n % POW10[d]).as_bytes();
            out.extend(std::iter::repeat_n(b'0', d - frac.len()));
            out.extend_from_slice(frac);
        }
    }

    /// A row through the reference: the values one by one, spaces between, a newline.
    fn reference_row(values: &[(f64, usize)]) -> Vec<u8> {
        let mut out = Vec::new();
        for (i, (v, d)) in values.iter().enumerate() {
            if i > 0 {
                out.push(b' ');
            }
            reference(&mut out, *v, *d);
        }
        out.push(b'\n');
        out
    }

    proptest::proptest! {
        #[test]
        fn writes_the_same_bytes_as_the_itoa_formatter(
            mantissa in -1e7f64..1e7,
            exponent in -12i32..12,
            d in 0usize..16,
        ) {
            let v = mantissa * 10f64.powi(exponent);
            let (mut a, mut b) = (Vec::new(), Vec::new());
            push_fixed(&mut a, v, d);
            reference(&mut b, v, d);
            proptest::prop_assert_eq!(&a, &b, "{} with {} decimals", v, d);
        }
    }

    proptest::proptest! {
        /// A row writes the same bytes as its values one by one through the reference.
        #[test]
        fn rows_write_the_reference_bytes(
            values in proptest::collection::vec((-1e7f64..1e7, -12i32..12, 0usize..16), 0..40),
        ) {
            let values: Vec<(f64, usize)> =
                values.iter().map(|(m, e, d)| (m * 10f64.powi(*e), *d)).collect();
            let mut row = Vec::new();
            push_row(&mut row, &values);
            proptest::prop_assert_eq!(row, reference_row(&values));
        }
    }

    #[test]
    fn rows_equal_their_values_one_by_one() {
        let values: Vec<(f64, usize)> =
            (0..40).map(|i| ((i as f64 - 17.3) * 1.37e3f64.powi(i % 5), i as usize % 13)).collect();
        for n in [0, 1, 5, 22, 32, 33, 40] {
            let mut row = Vec::new();
            push_row(&mut row, &values[..n]);
            let one = reference_row(&values[..n]);
            assert_eq!(String::from_utf8(row).unwrap(), String::from_utf8(one).unwrap(), "{n}");
        }
        let odd = [(1.5, 2), (f64::NAN, 3), (1e30, 1), (-0.25, 1)];
        let mut row = Vec::new();
        push_row(&mut row, &odd);
        assert_eq!(row, reference_row(&odd));
        // the longest texts the fast path writes (a sign, 19 digits, the point), up to and
        // past a full row: each value's whole-`ROOM` copy stays inside the line
        let longest = [(-8_990.123_456_789_012, 15); 40];
        let mut one = Vec::new();
        push_fixed(&mut one, longest[0].0, 15);
        assert_eq!(one.len(), 21, "{}", String::from_utf8_lossy(&one));
        for n in [1, 31, 32, 33, 40] {
            let mut row = Vec::new();
            push_row(&mut row, &longest[..n]);
            assert_eq!(row, reference_row(&longest[..n]), "{n}");
        }
    }

    proptest::proptest! {
        /// The exact formatter writes the standard formatter's bytes, padding included.
        #[test]
        fn exact_formatter_writes_the_standard_bytes(
            mantissa in -1e7f64..1e7,
            exponent in -12i32..12,
            d in 0usize..16,
            width in 0usize..24,
        ) {
            let v = mantissa * 10f64.powi(exponent);
            let mut a = Vec::new();
            push_exact(&mut a, v, width, d);
            proptest::prop_assert_eq!(String::from_utf8(a).unwrap(), format!("{v:width$.d$}"));
        }

        /// Values at and next to the half-way points of their last digit, where rounding
        /// the scaled product can go the other way.
        #[test]
        fn exact_formatter_at_ties(k in -10_000_000i64..10_000_000, d in 0usize..9, ulps in -3i64..4) {
            let tie = (k as f64 + 0.5) / 10f64.powi(d as i32);
            let v = f64::from_bits((tie.to_bits() as i64 + ulps) as u64);
            let mut a = Vec::new();
            push_exact(&mut a, v, 0, d);
            proptest::prop_assert_eq!(String::from_utf8(a).unwrap(), format!("{v:.d$}"));
        }
    }

    proptest::proptest! {
        /// The formatters' rounding is `f64::round`, bit for bit.
        #[test]
        fn rounding_is_the_standard_one(bits in proptest::num::u64::ANY, k in -4i64..5) {
            let x = f64::from_bits(bits);
            let near_half = (k as f64 + 0.5) * 10f64.powi((bits % 19) as i32);
            for v in [x, near_half, f64::from_bits(near_half.to_bits().wrapping_add(1))] {
                let (a, b) = (round(v), v.round());
                proptest::prop_assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{}", v);
            }
        }
    }

    #[test]
    fn exact_rows_and_special_values() {
        let mut row = Vec::new();
        push_exact_row(&mut row, &[(0.125, 2), (-0.5, 0), (2.5, 0), (f64::NAN, 3), (1e30, 1)]);
        let expected = format!("{:.2} {:.0} {:.0} {:.3} {:.1}\n", 0.125, -0.5, 2.5, f64::NAN, 1e30);
        assert_eq!(String::from_utf8(row).unwrap(), expected);
        let mut padded = Vec::new();
        push_exact(&mut padded, -3.25, 11, 4);
        assert_eq!(String::from_utf8(padded).unwrap(), format!("{:11.4}", -3.25));
    }

    #[test]
    fn non_finite_and_huge_fall_back() {
        assert_eq!(fmt(f64::NAN, 3), "NaN");
        assert_eq!(fmt(1e30, 2), format!("{:.2}", 1e30));
        assert_eq!(fmt(f64::INFINITY, 1), "inf");
    }
}
