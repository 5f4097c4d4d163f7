//! Fast fixed-point formatting for the output files: `value` with `decimals` digits after
//! the point, through integer formatting (`itoa`) instead of the general float
//! formatter, which dominated the time of a run that writes every IMU epoch.
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

/// Append `value` with `decimals` (≤ 15) digits after the point to `out`.
pub fn push_fixed(out: &mut Vec<u8>, value: f64, decimals: usize) {
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

/// Append space-separated fixed-point values and a newline.
pub fn push_row(out: &mut Vec<u8>, values: &[(f64, usize)]) {
    for (i, (v, d)) in values.iter().enumerate() {
        if i > 0 {
            out.push(b' ');
        }
        push_fixed(out, *v, *d);
    }
    out.push(b'\n');
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

    #[test]
    fn non_finite_and_huge_fall_back() {
        assert_eq!(fmt(f64::NAN, 3), "NaN");
        assert_eq!(fmt(1e30, 2), format!("{:.2}", 1e30));
        assert_eq!(fmt(f64::INFINITY, 1), "inf");
    }
}
