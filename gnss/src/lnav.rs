//! The GPS legacy navigation message (LNAV, IS-GPS-200 §20.3.3): subframes 1–3 to a
//! broadcast ephemeris and back.
//!
//! One table of fields (word, bit, width, sign, scale) serves both directions, so the
//! decoder is the encoder's inverse by construction; the encoder makes the simulator's
//! u-blox logs, and RTKLIB's own decoder (`convbin`) reading those logs is the independent
//! check (`tests/ubx.rs`). A word is handed over as u-blox's RXM-SFRBX does: the 30 bits
//! of the word in bits 29…0 of a `u32`, data bits 1–24 in bits 29…6. The parity bits are
//! neither checked nor (by the encoder) computed, as RTKLIB's and the `ublox` crate's
//! readers of RXM-SFRBX do; a record is taken when the preamble is there and the three
//! subframes agree on their issue of data.

use super::ephemeris::{ura_index, ura_metres, Ephemeris};
use super::fields::{self, SC};
use super::time::{GpsTime, Sat, System, WEEK};

/// A field: pieces `(word 1–10, first data bit 1–24, width)` most significant first,
/// signed (two's complement), and the scale of one unit.
struct Field {
    pieces: &'static [(usize, usize, usize)],
    signed: bool,
    scale: f64,
}

const fn f(pieces: &'static [(usize, usize, usize)], signed: bool, scale: f64) -> Field {
    Field { pieces, signed, scale }
}

const P5: f64 = 1.0 / 32.0;
const P19: f64 = 1.0 / 524_288.0;
const P29: f64 = 1.0 / 536_870_912.0;
const P31: f64 = 1.0 / 2_147_483_648.0;
const P33: f64 = 1.0 / 8_589_934_592.0;
const P43: f64 = 1.0 / 8_796_093_022_208.0;
const P55: f64 = 1.0 / 36_028_797_018_963_968.0;

// subframe 1
const WN: Field = f(&[(3, 1, 10)], false, 1.0);
const URA_INDEX: Field = f(&[(3, 13, 4)], false, 1.0);
const HEALTH: Field = f(&[(3, 17, 6)], false, 1.0);
const IODC: Field = f(&[(3, 23, 2), (8, 1, 8)], false, 1.0);
const TGD: Field = f(&[(7, 17, 8)], true, P31);
const TOC: Field = f(&[(8, 9, 16)], false, 16.0);
const AF2: Field = f(&[(9, 1, 8)], true, P55);
const AF1: Field = f(&[(9, 9, 16)], true, P43);
const AF0: Field = f(&[(10, 1, 22)], true, P31);
// subframe 2
const IODE2: Field = f(&[(3, 1, 8)], false, 1.0);
const CRS: Field = f(&[(3, 9, 16)], true, P5);
const DELTA_N: Field = f(&[(4, 1, 16)], true, P43 * SC);
const M0: Field = f(&[(4, 17, 8), (5, 1, 24)], true, P31 * SC);
const CUC: Field = f(&[(6, 1, 16)], true, P29);
const ECC: Field = f(&[(6, 17, 8), (7, 1, 24)], false, P33);
const CUS: Field = f(&[(8, 1, 16)], true, P29);
const SQRT_A: Field = f(&[(8, 17, 8), (9, 1, 24)], false, P19);
const TOE: Field = f(&[(10, 1, 16)], false, 16.0);
// subframe 3
const CIC: Field = f(&[(3, 1, 16)], true, P29);
const OMEGA0: Field = f(&[(3, 17, 8), (4, 1, 24)], true, P31 * SC);
const CIS: Field = f(&[(5, 1, 16)], true, P29);
const I0: Field = f(&[(5, 17, 8), (6, 1, 24)], true, P31 * SC);
const CRC: Field = f(&[(7, 1, 16)], true, P5);
const OMEGA: Field = f(&[(7, 17, 8), (8, 1, 24)], true, P31 * SC);
const OMEGA_DOT: Field = f(&[(9, 1, 24)], true, P43 * SC);
const IODE3: Field = f(&[(10, 1, 8)], false, 1.0);
const IDOT: Field = f(&[(10, 9, 14)], true, P43 * SC);
// words 1 and 2
const PREAMBLE: Field = f(&[(1, 1, 8)], false, 1.0);
const TOW_COUNT: Field = f(&[(2, 1, 17)], false, 6.0);
const SUBFRAME_ID: Field = f(&[(2, 20, 3)], false, 1.0);

// subframe 4, page 18 (SV ID 56): the ionosphere's coefficients
const DATA_ID_SV_ID: Field = f(&[(3, 1, 8)], false, 1.0);
const ALPHA: [Field; 4] = [
    f(&[(3, 9, 8)], true, 1.0 / 1_073_741_824.0),
    f(&[(3, 17, 8)], true, 1.0 / 134_217_728.0),
    f(&[(4, 1, 8)], true, 1.0 / 16_777_216.0),
    f(&[(4, 9, 8)], true, 1.0 / 16_777_216.0),
];
const BETA: [Field; 4] = [
    f(&[(4, 17, 8)], true, 2048.0),
    f(&[(5, 1, 8)], true, 16_384.0),
    f(&[(5, 9, 8)], true, 65_536.0),
    f(&[(5, 17, 8)], true, 65_536.0),
];
/// Data ID 1 (bits 1–2) and SV ID 56 (bits 3–8) of page 18.
const PAGE_18: f64 = 64.0 + 56.0;

/// A subframe: ten words as RXM-SFRBX gives them.
pub type Subframe = [u32; 10];

fn bits(sf: &Subframe, word: usize, first: usize, width: usize) -> u64 {
    let data = (sf[word - 1] >> 6) & 0x00ff_ffff;
    ((data >> (24 - (first - 1) - width)) & ((1 << width) - 1)) as u64
}

fn read(sf: &Subframe, fd: &Field) -> f64 {
    let (mut v, mut n) = (0u64, 0usize);
    for &(w, b, len) in fd.pieces {
        v = (v << len) | bits(sf, w, b, len);
        n += len;
    }
    fields::value(v, n, fd.signed, fd.scale)
}

fn write(sf: &mut Subframe, fd: &Field, value: f64) {
    let n: usize = fd.pieces.iter().map(|p| p.2).sum();
    let mut v = fields::pattern(value, n, fd.scale);
    for &(w, b, len) in fd.pieces.iter().rev() {
        let piece = (v & ((1 << len) - 1)) as u32;
        v >>= len;
        let shift = 6 + (24 - (b - 1) - len);
        let mask = ((1u32 << len) - 1) << shift;
        sf[w - 1] = (sf[w - 1] & !mask) | (piece << shift);
    }
}

/// Which subframe (1–5) a subframe is, when its preamble is there.
pub fn subframe_id(sf: &Subframe) -> Option<u8> {
    (read(sf, &PREAMBLE) as u32 == 0x8b).then(|| read(sf, &SUBFRAME_ID) as u8)
}

/// The time of week (s) a subframe's HOW gives: the start of the next subframe.
pub fn tow(sf: &Subframe) -> f64 {
    read(sf, &TOW_COUNT)
}

/// Encodes the Keplerian record of a GPS satellite as subframes 1–3, the first one
/// transmitted at `tow` (s of week; the HOW holds the next subframe's start).
pub fn encode(e: &Ephemeris, tow: f64) -> [Subframe; 3] {
    let mut out = [[0u32; 10]; 3];
    for (k, sf) in out.iter_mut().enumerate() {
        write(sf, &PREAMBLE, 139.0);
        write(sf, &TOW_COUNT, ((tow / 6.0).floor() + 1.0 + k as f64) * 6.0);
        write(sf, &SUBFRAME_ID, (k + 1) as f64);
    }
    let [s1, s2, s3] = &mut out;
    write(s1, &WN, (e.toe.week % 1024) as f64);
    write(s1, &URA_INDEX, ura_index(e.accuracy) as f64);
    write(s1, &HEALTH, e.health as f64);
    write(s1, &IODC, e.iodc as f64);
    write(s1, &TGD, e.tgd[0]);
    write(s1, &TOC, e.toc.tow);
    write(s1, &AF2, e.af[2]);
    write(s1, &AF1, e.af[1]);
    write(s1, &AF0, e.af[0]);
    let [cuc, cus, crc, crs, cic, cis] = e.harmonics;
    write(s2, &IODE2, e.iode as f64);
    write(s2, &CRS, crs);
    write(s2, &DELTA_N, e.delta_n);
    write(s2, &M0, e.m0);
    write(s2, &CUC, cuc);
    write(s2, &ECC, e.e);
    write(s2, &CUS, cus);
    write(s2, &SQRT_A, e.sqrt_a);
    write(s2, &TOE, e.toe_sow);
    write(s3, &CIC, cic);
    write(s3, &OMEGA0, e.omega0);
    write(s3, &CIS, cis);
    write(s3, &I0, e.i0);
    write(s3, &CRC, crc);
    write(s3, &OMEGA, e.omega);
    write(s3, &OMEGA_DOT, e.omega_dot);
    write(s3, &IODE3, e.iode as f64);
    write(s3, &IDOT, e.idot);
    out
}

/// Decodes subframes 1–3 of `prn` into a record; `near` (a time of the log) resolves the
/// 10-bit week. `None` when a preamble is missing or the issues of data disagree (a
/// record caught across an upload).
pub fn decode(prn: u8, sf: &[Subframe; 3], near: &GpsTime) -> Option<Ephemeris> {
    for (k, s) in sf.iter().enumerate() {
        if subframe_id(s)? != k as u8 + 1 {
            return None;
        }
    }
    let [s1, s2, s3] = sf;
    let iodc = read(s1, &IODC) as i32;
    let (iode2, iode3) = (read(s2, &IODE2) as i32, read(s3, &IODE3) as i32);
    if iode2 != iode3 || iode2 != (iodc & 0xff) {
        return None;
    }
    let wn = read(s1, &WN) as i32;
    let week = near.week - (near.week - wn).rem_euclid(1024);
    // the week of toe and toc: the one that puts them within half a week of the log
    let near_week = |sow: f64| {
        let t = GpsTime::new(week, sow);
        let d = t.diff(near);
        t.add(-(d / WEEK).round() * WEEK)
    };
    let toe_sow = read(s2, &TOE);
    let ura = read(s1, &URA_INDEX) as usize;
    Some(Ephemeris {
        sat: Sat { sys: System::Gps, prn },
        toc: near_week(read(s1, &TOC)),
        toe: near_week(toe_sow),
        toe_sow,
        af: [read(s1, &AF0), read(s1, &AF1), read(s1, &AF2)],
        iode: iode2,
        iodc,
        sqrt_a: read(s2, &SQRT_A),
        e: read(s2, &ECC),
        i0: read(s3, &I0),
        omega0: read(s3, &OMEGA0),
        omega: read(s3, &OMEGA),
        m0: read(s2, &M0),
        delta_n: read(s2, &DELTA_N),
        omega_dot: read(s3, &OMEGA_DOT),
        idot: read(s3, &IDOT),
        harmonics: [
            read(s2, &CUC),
            read(s2, &CUS),
            read(s3, &CRC),
            read(s2, &CRS),
            read(s3, &CIC),
            read(s3, &CIS),
        ],
        tgd: [read(s1, &TGD), 0.0],
        health: read(s1, &HEALTH) as u32,
        accuracy: ura_metres(ura),
    })
}

/// Subframe 4, page 18 with the broadcast ionosphere, transmitted at `tow`.
pub fn encode_ionosphere(k: &super::atmosphere::Klobuchar, tow: f64) -> Subframe {
    let mut sf = [0u32; 10];
    write(&mut sf, &PREAMBLE, 139.0);
    write(&mut sf, &TOW_COUNT, ((tow / 6.0).floor() + 1.0) * 6.0);
    write(&mut sf, &SUBFRAME_ID, 4.0);
    write(&mut sf, &DATA_ID_SV_ID, PAGE_18);
    for (fd, v) in ALPHA.iter().zip(k.alpha).chain(BETA.iter().zip(k.beta)) {
        write(&mut sf, fd, v);
    }
    sf
}

/// The broadcast ionosphere of a subframe 4 page 18; `None` for any other subframe.
pub fn decode_ionosphere(sf: &Subframe) -> Option<super::atmosphere::Klobuchar> {
    if subframe_id(sf)? != 4 || read(sf, &DATA_ID_SV_ID) != PAGE_18 {
        return None;
    }
    Some(super::atmosphere::Klobuchar {
        alpha: [read(sf, &ALPHA[0]), read(sf, &ALPHA[1]), read(sf, &ALPHA[2]), read(sf, &ALPHA[3])],
        beta: [read(sf, &BETA[0]), read(sf, &BETA[1]), read(sf, &BETA[2]), read(sf, &BETA[3])],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_round_trip_at_their_resolution_and_do_not_overlap() {
        // each subframe's fields written together, then each read back
        let subframes: [&[(&Field, f64)]; 3] = [
            &[
                (&WN, 292.0),
                (&URA_INDEX, 1.0),
                (&HEALTH, 0.0),
                (&IODC, 301.0),
                (&TGD, -1.1e-8),
                (&TOC, 525_600.0),
                (&AF2, 0.0),
                (&AF1, -3.2e-12),
                (&AF0, -3.0e-4),
            ],
            &[
                (&IODE2, 45.0),
                (&CRS, -52.1875),
                (&DELTA_N, 4.0e-9),
                (&M0, -2.5),
                (&CUC, -2.6e-6),
                (&ECC, 0.0123),
                (&CUS, 4.1e-6),
                (&SQRT_A, 5153.6),
                (&TOE, 525_600.0),
            ],
            &[
                (&CIC, 1.1e-7),
                (&OMEGA0, 2.87),
                (&CIS, -9.3e-8),
                (&I0, 0.98),
                (&CRC, 309.375),
                (&OMEGA, -1.65),
                (&OMEGA_DOT, -7.9e-9),
                (&IODE3, 45.0),
                (&IDOT, -4.0e-10),
            ],
        ];
        for fields in subframes {
            let mut sf = [0u32; 10];
            for (fd, v) in fields {
                write(&mut sf, fd, *v);
            }
            for (fd, v) in fields {
                let back = read(&sf, fd);
                assert!((back - v).abs() <= fd.scale / 2.0 + 1e-15 * v.abs(), "{v} → {back}");
            }
            // a word's upper padding bits and parity stay zero
            assert!(sf.iter().all(|w| w >> 30 == 0 && w & 0x3f == 0));
        }
    }
}
