//! The Galileo I/NAV message (Galileo OS SIS ICD, §4.3.5): word types 0–5 to a
//! broadcast ephemeris and back, and the nominal page as u-blox's RXM-SFRBX hands it over.
//!
//! A *word* is the page's 128 data bits (`u128`, the ICD's first bit the most
//! significant), its type in the first 6. Types 1–4 carry the ephemeris and clock under
//! one issue of data (IODnav), type 5 the group delays, the health and the GST week and
//! time of week, type 0 the time again. As with [`super::lnav`], one table of fields
//! serves both directions, and RTKLIB's `convbin` decoding the simulator's logs is the
//! independent check (`tests/ubx.rs`).
//!
//! RXM-SFRBX gives a nominal page as eight 32-bit words, each read most significant bit
//! first: the even page part (120 bits) in words 1–4, the odd part in words 5–8. Even
//! part: even/odd flag 0, page type 0, the word's first 112 bits, 6 tail bits. Odd part:
//! flag 1, page type 0, the word's last 16 bits, OSNMA (40), SAR (22), spare (2), the
//! CRC-24Q (24) over both parts' bits before it (196 bits), SSP (8), tail (6). A page
//! whose flags or CRC do not check is not a page ([`decode_page`] returns `None`).

use super::ephemeris::Ephemeris;
use super::fields::{self, p2, SC};
use super::time::{GpsTime, Sat, System, WEEK};

/// GPS week of GST week 0 (1999-08-22).
pub const GST_WEEK_OFFSET: i32 = 1024;

/// A field of a word: first bit (0 = the word's most significant), width, two's
/// complement or not, the scale of one unit.
struct Field {
    start: u32,
    width: u32,
    signed: bool,
    scale: f64,
}

const fn f(start: u32, width: u32, signed: bool, scale: f64) -> Field {
    Field { start, width, signed, scale }
}

const TYPE: Field = f(0, 6, false, 1.0);
const IOD: Field = f(6, 10, false, 1.0);
// word type 0: time field (2 = the week and time of week are valid), WN, TOW
const TIME_FIELD: Field = f(6, 2, false, 1.0);
const WN0: Field = f(96, 12, false, 1.0);
const TOW0: Field = f(108, 20, false, 1.0);
// word type 1
const TOE: Field = f(16, 14, false, 60.0);
const M0: Field = f(30, 32, true, p2(31) * SC);
const ECC: Field = f(62, 32, false, p2(33));
const SQRT_A: Field = f(94, 32, false, p2(19));
// word type 2
const OMEGA0: Field = f(16, 32, true, p2(31) * SC);
const I0: Field = f(48, 32, true, p2(31) * SC);
const OMEGA: Field = f(80, 32, true, p2(31) * SC);
const IDOT: Field = f(112, 14, true, p2(43) * SC);
// word type 3
const OMEGA_DOT: Field = f(16, 24, true, p2(43) * SC);
const DELTA_N: Field = f(40, 16, true, p2(43) * SC);
const CUC: Field = f(56, 16, true, p2(29));
const CUS: Field = f(72, 16, true, p2(29));
const CRC: Field = f(88, 16, true, p2(5));
const CRS: Field = f(104, 16, true, p2(5));
const SISA: Field = f(120, 8, false, 1.0);
// word type 4
const SVID: Field = f(16, 6, false, 1.0);
const CIC: Field = f(22, 16, true, p2(29));
const CIS: Field = f(38, 16, true, p2(29));
const TOC: Field = f(54, 14, false, 60.0);
const AF0: Field = f(68, 31, true, p2(34));
const AF1: Field = f(99, 21, true, p2(46));
const AF2: Field = f(120, 6, true, p2(59));
// word type 5 (the ionosphere's a_i0…a_i2 and disturbance flags, bits 6–46, not used)
const BGD_E5A: Field = f(47, 10, true, p2(32));
const BGD_E5B: Field = f(57, 10, true, p2(32));
const E5B_HS: Field = f(67, 2, false, 1.0);
const E1B_HS: Field = f(69, 2, false, 1.0);
const E5B_DVS: Field = f(71, 1, false, 1.0);
const E1B_DVS: Field = f(72, 1, false, 1.0);
const WN5: Field = f(73, 12, false, 1.0);
const TOW5: Field = f(85, 20, false, 1.0);
// word type 6: GST − UTC (A0, A1, Δt_LS, t_ot, WN_ot, WN_LSF, DN, Δt_LSF), TOW
const A0: Field = f(6, 32, true, p2(30));
const A1: Field = f(38, 24, true, p2(50));
const DT_LS: Field = f(62, 8, true, 1.0);
const T_OT: Field = f(70, 8, false, 3600.0);
const WN_OT: Field = f(78, 8, false, 1.0);
const WN_LSF: Field = f(86, 8, false, 1.0);
const DN: Field = f(94, 3, false, 1.0);
const DT_LSF: Field = f(97, 8, true, 1.0);
const TOW6: Field = f(105, 20, false, 1.0);

fn read(w: u128, fd: &Field) -> f64 {
    let v = (w >> (128 - fd.start - fd.width)) & ((1u128 << fd.width) - 1);
    fields::value(v as u64, fd.width as usize, fd.signed, fd.scale)
}

fn write(w: &mut u128, fd: &Field, value: f64) {
    let mask = (1u128 << fd.width) - 1;
    let shift = 128 - fd.start - fd.width;
    let bits = u128::from(fields::pattern(value, fd.width as usize, fd.scale));
    *w = (*w & !(mask << shift)) | (bits << shift);
}

/// The type (0–63) of a word.
pub fn word_type(w: u128) -> u8 {
    read(w, &TYPE) as u8
}

/// SISA (m) of an index (ICD table 76: 1 cm steps to 0.49 m, 2 cm to 0.98 m, 4 cm to 1.96
/// m, 16 cm to 6 m); `None` for the spare indices and 255 (no accuracy prediction).
pub fn sisa_metres(index: u8) -> Option<f64> {
    let n = f64::from(index);
    Some(match index {
        0..=49 => 0.01 * n,
        50..=74 => 0.5 + 0.02 * (n - 50.0),
        75..=99 => 1.0 + 0.04 * (n - 75.0),
        100..=125 => 2.0 + 0.16 * (n - 100.0),
        _ => return None,
    })
}

/// The SISA index whose value is the smallest not below `m` (255, no accuracy prediction:
/// `m` negative, as RINEX writes that, not finite, or above 6 m).
pub fn sisa_index(m: f64) -> u8 {
    if m.is_nan() || m < 0.0 {
        return 255;
    }
    (0..=125u8).find(|&i| sisa_metres(i).is_some_and(|s| s >= m - 1e-9)).unwrap_or(255)
}

/// Words of types 0–5 for a Galileo record, transmitted at GST time of week `tow` (s).
/// Health as RINEX 3 writes it for Galileo: bit 0 E1-B DVS, bits 1–2 E1-B HS, bit 6 E5b
/// DVS, bits 7–8 E5b HS.
pub fn encode(e: &Ephemeris, tow: f64) -> [u128; 6] {
    let mut w = [0u128; 6];
    for (k, word) in w.iter_mut().enumerate() {
        write(word, &TYPE, k as f64);
    }
    let gst_week = f64::from((e.toe.week - GST_WEEK_OFFSET).rem_euclid(4096));
    let iod = f64::from(e.iode);
    let [cuc, cus, crc, crs, cic, cis] = e.harmonics;
    let tow = tow.floor();
    for (word, fields) in [
        (0usize, &[(&TIME_FIELD, 2.0), (&WN0, gst_week), (&TOW0, tow)][..]),
        (1, &[(&IOD, iod), (&TOE, e.toe_sow), (&M0, e.m0), (&ECC, e.e), (&SQRT_A, e.sqrt_a)][..]),
        (
            2,
            &[(&IOD, iod), (&OMEGA0, e.omega0), (&I0, e.i0), (&OMEGA, e.omega), (&IDOT, e.idot)][..],
        ),
        (
            3,
            &[
                (&IOD, iod),
                (&OMEGA_DOT, e.omega_dot),
                (&DELTA_N, e.delta_n),
                (&CUC, cuc),
                (&CUS, cus),
                (&CRC, crc),
                (&CRS, crs),
                (&SISA, f64::from(sisa_index(e.accuracy))),
            ][..],
        ),
        (
            4,
            &[
                (&IOD, iod),
                (&SVID, f64::from(e.sat.prn)),
                (&CIC, cic),
                (&CIS, cis),
                (&TOC, e.toc.tow),
                (&AF0, e.af[0]),
                (&AF1, e.af[1]),
                (&AF2, e.af[2]),
            ][..],
        ),
        (
            5,
            &[
                (&BGD_E5A, e.tgd[0]),
                (&BGD_E5B, e.tgd[1]),
                (&E1B_DVS, f64::from(e.health & 1)),
                (&E1B_HS, f64::from((e.health >> 1) & 3)),
                (&E5B_DVS, f64::from((e.health >> 6) & 1)),
                (&E5B_HS, f64::from((e.health >> 7) & 3)),
                (&WN5, gst_week),
                (&TOW5, tow),
            ][..],
        ),
    ] {
        for (fd, v) in fields {
            write(&mut w[word], fd, *v);
        }
    }
    w
}

/// Word type 6, GST − UTC: `leap` whole seconds (no fraction, no drift, no leap second
/// announced), transmitted in GPS week `week` at time of week `tow`. The ephemeris does
/// not need it; RTKLIB's u-blox reader takes a record only once it has one.
pub fn encode_utc(leap: i8, week: i32, tow: f64) -> u128 {
    let mut w = 0u128;
    let wn = f64::from((week - GST_WEEK_OFFSET).rem_euclid(256));
    for (fd, v) in [
        (&TYPE, 6.0),
        (&A0, 0.0),
        (&A1, 0.0),
        (&DT_LS, f64::from(leap)),
        (&T_OT, 0.0),
        (&WN_OT, wn),
        (&WN_LSF, wn),
        (&DN, 1.0),
        (&DT_LSF, f64::from(leap)),
        (&TOW6, tow.floor()),
    ] {
        write(&mut w, fd, v);
    }
    w
}

/// GST − UTC (s) of a word of type 6 (`A0` and `Δt_LS`; the drift not applied).
pub fn decode_utc(w: u128) -> Option<f64> {
    (word_type(w) == 6).then(|| read(w, &DT_LS) + read(w, &A0))
}

/// Decodes words of types 0–5 (in order) into a record. `None` when a type is out of
/// place, the time field does not say the time is valid, the issues of data of types 1–4
/// disagree (a record caught across an upload), or the SVID is 0.
pub fn decode(w: &[u128; 6]) -> Option<Ephemeris> {
    if w.iter().enumerate().any(|(k, x)| usize::from(word_type(*x)) != k) {
        return None;
    }
    if read(w[0], &TIME_FIELD) != 2.0 {
        return None;
    }
    let iod = read(w[1], &IOD) as i32;
    if w[2..5].iter().any(|x| read(*x, &IOD) as i32 != iod) {
        return None;
    }
    let prn = read(w[4], &SVID) as u8;
    if prn == 0 {
        return None;
    }
    // the GST week and time of week of word 5; toe and toc in the week that puts them
    // within half a week of it
    let sent = GpsTime::new(read(w[5], &WN5) as i32 + GST_WEEK_OFFSET, read(w[5], &TOW5));
    let near = |sow: f64| {
        let t = GpsTime::new(sent.week, sow);
        t.add(-(t.diff(&sent) / WEEK).round() * WEEK)
    };
    let toe_sow = read(w[1], &TOE);
    let health = read(w[5], &E1B_DVS) as u32
        | (read(w[5], &E1B_HS) as u32) << 1
        | (read(w[5], &E5B_DVS) as u32) << 6
        | (read(w[5], &E5B_HS) as u32) << 7;
    Some(Ephemeris {
        sat: Sat { sys: System::Galileo, prn },
        toc: near(read(w[4], &TOC)),
        toe: near(toe_sow),
        toe_sow,
        af: [read(w[4], &AF0), read(w[4], &AF1), read(w[4], &AF2)],
        iode: iod,
        iodc: iod,
        sqrt_a: read(w[1], &SQRT_A),
        e: read(w[1], &ECC),
        i0: read(w[2], &I0),
        omega0: read(w[2], &OMEGA0),
        omega: read(w[2], &OMEGA),
        m0: read(w[1], &M0),
        delta_n: read(w[3], &DELTA_N),
        omega_dot: read(w[3], &OMEGA_DOT),
        idot: read(w[2], &IDOT),
        harmonics: [
            read(w[3], &CUC),
            read(w[3], &CUS),
            read(w[3], &CRC),
            read(w[3], &CRS),
            read(w[4], &CIC),
            read(w[4], &CIS),
        ],
        tgd: [read(w[5], &BGD_E5A), read(w[5], &BGD_E5B)],
        health,
        // no accuracy prediction (NAPA): as RINEX writes it, −1
        accuracy: sisa_metres(read(w[3], &SISA) as u8).unwrap_or(-1.0),
    })
}

/// CRC-24Q (polynomial 0x1864CFB, initial value 0) of `n` bits taken most significant
/// first from `bits`.
fn crc24q(bits: impl Iterator<Item = bool>) -> u32 {
    let mut crc = 0u32;
    for b in bits {
        let top = ((crc >> 23) & 1 == 1) ^ b;
        crc = (crc << 1) & 0xff_ffff;
        if top {
            crc ^= 0x86_4cfb;
        }
    }
    crc
}

/// Bit `i` (0 = the first word's most significant) of a page's eight words.
fn bit(words: &[u32; 8], i: usize) -> bool {
    (words[i / 32] >> (31 - i % 32)) & 1 == 1
}

fn set_bits(words: &mut [u32; 8], at: usize, width: usize, value: u128) {
    for k in 0..width {
        if (value >> (width - 1 - k)) & 1 == 1 {
            let i = at + k;
            words[i / 32] |= 1 << (31 - i % 32);
        }
    }
}

fn get_bits(words: &[u32; 8], at: usize, width: usize) -> u128 {
    (0..width).fold(0u128, |v, k| (v << 1) | u128::from(bit(words, at + k)))
}

/// The odd part starts at the fifth word.
const ODD: usize = 128;

/// The 196 bits the page's CRC covers: the even part's first 114, the odd part's first 82.
fn crc_of(words: &[u32; 8]) -> u32 {
    crc24q((0..114).map(|i| bit(words, i)).chain((ODD..ODD + 82).map(|i| bit(words, i))))
}

/// A nominal page holding word `w`, as RXM-SFRBX's eight words.
pub fn encode_page(w: u128) -> [u32; 8] {
    let mut p = [0u32; 8];
    // even part: flag 0, page type 0, the first 112 bits
    set_bits(&mut p, 2, 112, w >> 16);
    // odd part: flag 1, page type 0, the last 16 bits, then OSNMA, SAR, spare (zero)
    set_bits(&mut p, ODD, 1, 1);
    set_bits(&mut p, ODD + 2, 16, w & 0xffff);
    let crc = crc_of(&p);
    set_bits(&mut p, ODD + 82, 24, u128::from(crc));
    p
}

/// The word of a nominal page given as RXM-SFRBX's eight words; `None` for an alert page,
/// parts out of order, or a CRC that does not check.
pub fn decode_page(p: &[u32; 8]) -> Option<u128> {
    if bit(p, 0) || !bit(p, ODD) || bit(p, 1) || bit(p, ODD + 1) {
        return None;
    }
    if get_bits(p, ODD + 82, 24) as u32 != crc_of(p) {
        return None;
    }
    Some((get_bits(p, 2, 112) << 16) | get_bits(p, ODD + 2, 16))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record() -> Ephemeris {
        Ephemeris {
            sat: Sat { sys: System::Galileo, prn: 11 },
            toc: GpsTime::new(2345, 302_400.0),
            toe: GpsTime::new(2345, 302_400.0),
            toe_sow: 302_400.0,
            af: [-5.1e-4, -7.9e-12, 0.0],
            iode: 97,
            iodc: 97,
            sqrt_a: 5440.612,
            e: 2.9e-4,
            i0: 0.9776,
            omega0: -1.234,
            omega: 0.4567,
            m0: 2.345,
            delta_n: 2.9e-9,
            omega_dot: -5.6e-9,
            idot: 1.2e-10,
            harmonics: [-1.3e-6, 8.1e-6, 187.5, -28.4, 2.2e-8, -4.3e-8],
            tgd: [-2.3e-9, -2.6e-9],
            health: 0,
            accuracy: 3.12,
        }
    }

    #[test]
    fn a_record_survives_its_words_and_pages_at_their_resolution() {
        let e = Ephemeris { health: 0b1_1100_0011, ..record() };
        let words = encode(&e, 302_391.0);
        let pages: Vec<[u32; 8]> = words.iter().map(|w| encode_page(*w)).collect();
        let back: Vec<u128> = pages.iter().map(|p| decode_page(p).unwrap()).collect();
        assert_eq!(back, words);
        let d = decode(&words).unwrap();
        assert_eq!((d.sat, d.iode, d.iodc, d.health), (e.sat, 97, 97, e.health));
        assert_eq!((d.toe, d.toc, d.toe_sow), (e.toe, e.toc, e.toe_sow));
        assert_eq!(d.accuracy, 3.12);
        let fields = [
            (d.af[0], e.af[0], AF0.scale),
            (d.af[1], e.af[1], AF1.scale),
            (d.sqrt_a, e.sqrt_a, SQRT_A.scale),
            (d.e, e.e, ECC.scale),
            (d.i0, e.i0, I0.scale),
            (d.omega0, e.omega0, OMEGA0.scale),
            (d.omega, e.omega, OMEGA.scale),
            (d.m0, e.m0, M0.scale),
            (d.delta_n, e.delta_n, DELTA_N.scale),
            (d.omega_dot, e.omega_dot, OMEGA_DOT.scale),
            (d.idot, e.idot, IDOT.scale),
            (d.tgd[0], e.tgd[0], BGD_E5A.scale),
            (d.tgd[1], e.tgd[1], BGD_E5B.scale),
            (d.harmonics[2], e.harmonics[2], CRC.scale),
            (d.harmonics[4], e.harmonics[4], CIC.scale),
        ];
        for (k, (x, y, scale)) in fields.iter().enumerate() {
            assert!((x - y).abs() <= scale / 2.0 + 1e-15 * y.abs(), "field {k}: {x} vs {y}");
        }
    }

    #[test]
    fn the_utc_word_round_trips() {
        let w = encode_utc(13, 1316, 518_400.5);
        assert_eq!(word_type(w), 6);
        assert_eq!(decode_utc(w), Some(13.0));
        assert_eq!(decode_page(&encode_page(w)), Some(w));
        assert_eq!(decode_utc(encode(&record(), 0.0)[5]), None);
    }

    #[test]
    fn fields_tile_each_word_without_overlap() {
        // each word's fields, set to all ones one at a time, light disjoint bits
        let words: [&[&Field]; 7] = [
            &[&TYPE, &TIME_FIELD, &WN0, &TOW0],
            &[&TYPE, &IOD, &TOE, &M0, &ECC, &SQRT_A],
            &[&TYPE, &IOD, &OMEGA0, &I0, &OMEGA, &IDOT],
            &[&TYPE, &IOD, &OMEGA_DOT, &DELTA_N, &CUC, &CUS, &CRC, &CRS, &SISA],
            &[&TYPE, &IOD, &SVID, &CIC, &CIS, &TOC, &AF0, &AF1, &AF2],
            &[&TYPE, &BGD_E5A, &BGD_E5B, &E5B_HS, &E1B_HS, &E5B_DVS, &E1B_DVS, &WN5, &TOW5],
            &[&TYPE, &A0, &A1, &DT_LS, &T_OT, &WN_OT, &WN_LSF, &DN, &DT_LSF, &TOW6],
        ];
        for fields in words {
            let mut seen = 0u128;
            for fd in fields {
                let ones = ((1u128 << fd.width) - 1) << (128 - fd.start - fd.width);
                assert_eq!(seen & ones, 0, "field at bit {}", fd.start);
                seen |= ones;
            }
        }
        // the ephemeris words (1–4) are full but for 2 spare bits of types 1, 2 and 4
        assert_eq!(IDOT.start + IDOT.width, 126);
        assert_eq!(SQRT_A.start + SQRT_A.width, 126);
        assert_eq!(SISA.start + SISA.width, 128);
        assert_eq!(AF2.start + AF2.width, 126);
        assert_eq!(TOW0.start + TOW0.width, 128);
    }

    #[test]
    fn a_page_with_a_flipped_bit_or_parts_swapped_is_refused() {
        let w = encode(&record(), 100.0)[3];
        let p = encode_page(w);
        assert_eq!(decode_page(&p), Some(w));
        for i in [2usize, 40, 113, ODD + 2, ODD + 17, ODD + 90] {
            let mut q = p;
            q[i / 32] ^= 1 << (31 - i % 32);
            assert_eq!(decode_page(&q), None, "bit {i}");
        }
        let mut swapped = [0u32; 8];
        swapped[..4].copy_from_slice(&p[4..]);
        swapped[4..].copy_from_slice(&p[..4]);
        assert_eq!(decode_page(&swapped), None);
    }

    #[test]
    fn crc24q_of_a_known_message() {
        // CRC-24Q of the bytes "123456789" (the check value of the polynomial)
        let bytes = b"123456789";
        let bits = bytes.iter().flat_map(|b| (0..8).rev().map(move |k| (b >> k) & 1 == 1));
        assert_eq!(crc24q(bits), 0xcd_e703);
    }

    #[test]
    fn sisa_indices_and_values_agree() {
        for i in 0..=125u8 {
            assert_eq!(sisa_index(sisa_metres(i).unwrap()), i);
        }
        assert_eq!(sisa_metres(255), None);
        assert_eq!(sisa_index(-1.0), 255);
        assert_eq!(sisa_index(f64::NAN), 255);
        assert_eq!(sisa_index(7.0), 255);
        assert!((sisa_metres(107).unwrap() - 3.12).abs() < 1e-12);
    }
}
