//! What the navigation messages' field tables ([`super::lnav`], [`super::inav`],
//! [`super::bds`]) share: the ICDs' π, the power-of-two scales, and a field's bits to its
//! value and back (two's complement where signed).

/// The ICDs' π for semicircles (IS-GPS-200 §20.3.3.4.3.1 states it to 14 digits; the
/// Galileo and BeiDou ICDs take the same).
#[allow(clippy::approx_constant)]
pub(crate) const SC: f64 = 3.1415926535898;

/// 2^-n (n ≤ 63), for the messages' scales.
pub(crate) const fn p2(n: i32) -> f64 {
    1.0 / (1u64 << n) as f64
}

/// A field's value: its `n` bits `v` (two's complement when `signed`) times `scale`.
pub(crate) fn value(v: u64, n: usize, signed: bool, scale: f64) -> f64 {
    let x = if signed && v >> (n - 1) == 1 { v as i64 - (1i64 << n) } else { v as i64 };
    x as f64 * scale
}

/// The `n` bits of `value` in units of `scale`, rounded (two's complement when negative).
pub(crate) fn pattern(value: f64, n: usize, scale: f64) -> u64 {
    ((value / scale).round() as i64 as u64) & ((1u64 << n) - 1)
}
