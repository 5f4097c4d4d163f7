//! The BeiDou D1 navigation message (BDS-SIS-ICD-B1I-3.0, §5.2: the MEO and IGSO
//! satellites' B1I message): subframes 1–3 to a broadcast ephemeris and back.
//!
//! A subframe is ten 30-bit words as u-blox's RXM-SFRBX hands them over (bits 29…0 of a
//! `u32`, the word's first bit the most significant), de-interleaved: word 1 is the
//! preamble (11 bits), 4 reserved bits, the subframe ID (3), the seconds of week's 8 most
//! significant bits and 4 parity bits; words 2–10 are 22 data bits and 8 parity bits. A
//! field's bits are numbered 0–299 over the subframe, parity bits included (the ICD's
//! figure 5-11-1 and RTKLIB's and GNSSTk's decoders number them so). As with
//! [`super::lnav`], one table of fields serves both directions, the parity bits are
//! neither checked nor computed (RTKLIB's reader of RXM-SFRBX does not check them), and
//! RTKLIB's `convbin` decoding the simulator's logs is the independent check
//! (`tests/ubx.rs`). A record is taken as RTKLIB takes it: subframes 1, 2 and 3 in a row
//! (their seconds of week 6 s apart) and the clock's reference time equal to the
//! orbit's.
//!
//! The geostationary satellites' D2 message (ten pages of subframe 1) is not decoded: a
//! log's GEO satellites need a navigation file.

use super::ephemeris::{ura_index, ura_metres, Ephemeris};
use super::time::{GpsTime, Sat, System, BDT_MINUS_GPST, BDT_WEEK_OFFSET, WEEK};

/// The ICD's π for semicircles (as GPS's).
#[allow(clippy::approx_constant)]
const SC: f64 = 3.1415926535898;

/// A field: pieces `(first bit 0–299, width)` most significant first, signed (two's
/// complement), and the scale of one unit.
struct Field {
    pieces: &'static [(usize, usize)],
    signed: bool,
    scale: f64,
}

const fn f(pieces: &'static [(usize, usize)], signed: bool, scale: f64) -> Field {
    Field { pieces, signed, scale }
}

const fn p2(n: i32) -> f64 {
    // 2^-n for the scales below (n ≤ 60)
    1.0 / (1u64 << n) as f64
}

// every subframe: word 1 and the start of word 2
const PREAMBLE: Field = f(&[(0, 11)], false, 1.0);
const FRAME_ID: Field = f(&[(15, 3)], false, 1.0);
const SOW: Field = f(&[(18, 8), (30, 12)], false, 1.0);
// subframe 1
const SAT_H1: Field = f(&[(42, 1)], false, 1.0);
const AODC: Field = f(&[(43, 5)], false, 1.0);
const URAI: Field = f(&[(48, 4)], false, 1.0);
const WN: Field = f(&[(60, 13)], false, 1.0);
const TOC: Field = f(&[(73, 9), (90, 8)], false, 8.0);
const TGD1: Field = f(&[(98, 10)], true, 1e-10);
const TGD2: Field = f(&[(108, 4), (120, 6)], true, 1e-10);
const A2: Field = f(&[(214, 11)], true, p2(60) * p2(6));
const A0: Field = f(&[(225, 7), (240, 17)], true, p2(33));
const A1: Field = f(&[(257, 5), (270, 17)], true, p2(50));
const AODE: Field = f(&[(287, 5)], false, 1.0);
// subframe 2
const DELTA_N: Field = f(&[(42, 10), (60, 6)], true, p2(43) * SC);
const CUC: Field = f(&[(66, 16), (90, 2)], true, p2(31));
const M0: Field = f(&[(92, 20), (120, 12)], true, p2(31) * SC);
const ECC: Field = f(&[(132, 10), (150, 22)], false, p2(33));
const CUS: Field = f(&[(180, 18)], true, p2(31));
const CRC: Field = f(&[(198, 4), (210, 14)], true, p2(6));
const CRS: Field = f(&[(224, 8), (240, 10)], true, p2(6));
const SQRT_A: Field = f(&[(250, 12), (270, 20)], false, p2(19));
// toe: its 2 most significant bits end subframe 2, the other 15 start subframe 3
const TOE_MSB: Field = f(&[(290, 2)], false, 1.0);
const TOE_LSB: Field = f(&[(42, 10), (60, 5)], false, 1.0);
// subframe 3
const I0: Field = f(&[(65, 17), (90, 15)], true, p2(31) * SC);
const CIC: Field = f(&[(105, 7), (120, 11)], true, p2(31));
const OMEGA_DOT: Field = f(&[(131, 11), (150, 13)], true, p2(43) * SC);
const CIS: Field = f(&[(163, 9), (180, 9)], true, p2(31));
const IDOT: Field = f(&[(189, 13), (210, 1)], true, p2(43) * SC);
const OMEGA0: Field = f(&[(211, 21), (240, 11)], true, p2(31) * SC);
const OMEGA: Field = f(&[(251, 11), (270, 21)], true, p2(31) * SC);

/// The D1 preamble, `11100010010`.
const PREAMBLE_BITS: f64 = 0x712 as f64;
/// toe and toc are counted in units of 8 s.
const TOE_UNIT: f64 = 8.0;

/// A subframe: ten words as RXM-SFRBX gives them.
pub type Subframe = [u32; 10];

fn bits(sf: &Subframe, start: usize, width: usize) -> u64 {
    (start..start + width).fold(0, |v, b| (v << 1) | u64::from((sf[b / 30] >> (29 - b % 30)) & 1))
}

fn read(sf: &Subframe, fd: &Field) -> f64 {
    let (mut v, mut n) = (0u64, 0usize);
    for &(start, width) in fd.pieces {
        v = (v << width) | bits(sf, start, width);
        n += width;
    }
    let x = if fd.signed && v >> (n - 1) == 1 { v as i64 - (1i64 << n) } else { v as i64 };
    x as f64 * fd.scale
}

fn write(sf: &mut Subframe, fd: &Field, value: f64) {
    let n: usize = fd.pieces.iter().map(|p| p.1).sum();
    let v = ((value / fd.scale).round() as i64 as u64) & ((1u64 << n) - 1);
    let mut at = n;
    for &(start, width) in fd.pieces {
        at -= width;
        for k in 0..width {
            let bit = ((v >> (at + width - 1 - k)) & 1) as u32;
            let b = start + k;
            let shift = 29 - b % 30;
            sf[b / 30] = (sf[b / 30] & !(1 << shift)) | (bit << shift);
        }
    }
}

/// Which subframe (1–5) a D1 subframe is, when its preamble is there.
pub fn subframe_id(sf: &Subframe) -> Option<u8> {
    (read(sf, &PREAMBLE) == PREAMBLE_BITS).then(|| read(sf, &FRAME_ID) as u8)
}

/// Encodes the record of a BeiDou MEO or IGSO satellite as D1 subframes 1–3, the first
/// starting at the BDT second of week after `bdt_sow` (a multiple of 6), the others 6 s
/// and 12 s later. The record's `toe_sow` must be a multiple of 8 s and its `toc` equal
/// to its `toe`, as the message has them; the Klobuchar coefficients are written as zero.
pub fn encode(e: &Ephemeris, bdt_sow: f64) -> [Subframe; 3] {
    let mut out = [[0u32; 10]; 3];
    let first = ((bdt_sow / 6.0).floor() + 1.0) * 6.0;
    for (k, sf) in out.iter_mut().enumerate() {
        write(sf, &PREAMBLE, PREAMBLE_BITS);
        write(sf, &FRAME_ID, (k + 1) as f64);
        write(sf, &SOW, (first + 6.0 * k as f64).rem_euclid(WEEK));
    }
    let [s1, s2, s3] = &mut out;
    let bdt_week = e.toe.add(BDT_MINUS_GPST).week - BDT_WEEK_OFFSET;
    write(s1, &SAT_H1, f64::from(u8::from(e.health != 0)));
    write(s1, &AODC, f64::from(e.iodc.rem_euclid(32)));
    write(s1, &URAI, ura_index(e.accuracy) as f64);
    write(s1, &WN, f64::from(bdt_week));
    write(s1, &TOC, e.toe_sow);
    write(s1, &TGD1, e.tgd[0]);
    write(s1, &TGD2, e.tgd[1]);
    write(s1, &A2, e.af[2]);
    write(s1, &A0, e.af[0]);
    write(s1, &A1, e.af[1]);
    write(s1, &AODE, f64::from(e.iode.rem_euclid(32)));
    let [cuc, cus, crc, crs, cic, cis] = e.harmonics;
    let toe = (e.toe_sow / TOE_UNIT).round();
    write(s2, &DELTA_N, e.delta_n);
    write(s2, &CUC, cuc);
    write(s2, &M0, e.m0);
    write(s2, &ECC, e.e);
    write(s2, &CUS, cus);
    write(s2, &CRC, crc);
    write(s2, &CRS, crs);
    write(s2, &SQRT_A, e.sqrt_a);
    write(s2, &TOE_MSB, (toe / 32_768.0).floor());
    write(s3, &TOE_LSB, toe.rem_euclid(32_768.0));
    write(s3, &I0, e.i0);
    write(s3, &CIC, cic);
    write(s3, &OMEGA_DOT, e.omega_dot);
    write(s3, &CIS, cis);
    write(s3, &IDOT, e.idot);
    write(s3, &OMEGA0, e.omega0);
    write(s3, &OMEGA, e.omega);
    out
}

/// Decodes D1 subframes 1–3 of BeiDou satellite `prn` into a record, times as GPS-time
/// instants (BDT + 14 s). `None` when a preamble is missing, the subframes are not 1, 2
/// and 3 in a row, or the clock's reference time is not the orbit's (a record caught
/// across an upload), as RTKLIB refuses them.
pub fn decode(prn: u8, sf: &[Subframe; 3]) -> Option<Ephemeris> {
    for (k, s) in sf.iter().enumerate() {
        if subframe_id(s)? != k as u8 + 1 {
            return None;
        }
    }
    let [s1, s2, s3] = sf;
    let sow = read(s1, &SOW);
    if read(s2, &SOW) != sow + 6.0 || read(s3, &SOW) != sow + 12.0 {
        return None;
    }
    let toe_sow = (read(s2, &TOE_MSB) * 32_768.0 + read(s3, &TOE_LSB)) * TOE_UNIT;
    let toc_sow = read(s1, &TOC);
    if toc_sow != toe_sow {
        return None;
    }
    // BDT week and second of week to a GPS-time instant: the week that puts the reference
    // time within half a week of the subframe's transmission
    let week = read(s1, &WN) as i32 + BDT_WEEK_OFFSET;
    let sent = GpsTime::new(week, sow - BDT_MINUS_GPST);
    let near = |sow: f64| {
        let t = GpsTime::new(week, sow - BDT_MINUS_GPST);
        t.add(-(t.diff(&sent) / WEEK).round() * WEEK)
    };
    let aode = read(s1, &AODE) as i32;
    Some(Ephemeris {
        sat: Sat { sys: System::BeiDou, prn },
        toc: near(toc_sow),
        toe: near(toe_sow),
        toe_sow,
        af: [read(s1, &A0), read(s1, &A1), read(s1, &A2)],
        // (the RINEX reader takes the age of data for both, as RINEX carries AODE only in
        // the issue-of-data column)
        iode: aode,
        iodc: aode,
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
            read(s2, &CRC),
            read(s2, &CRS),
            read(s3, &CIC),
            read(s3, &CIS),
        ],
        tgd: [read(s1, &TGD1), read(s1, &TGD2)],
        health: read(s1, &SAT_H1) as u32,
        accuracy: ura_metres(read(s1, &URAI) as usize),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field of a subframe written, then read back at its resolution: no two fields
    /// share a bit, and none touches the parity bits or the words' two padding bits.
    #[test]
    fn fields_round_trip_at_their_resolution_and_leave_the_parity_alone() {
        let subframes: [&[(&Field, f64)]; 3] = [
            &[
                (&SAT_H1, 1.0),
                (&AODC, 17.0),
                (&URAI, 2.0),
                (&WN, 984.0),
                (&TOC, 345_600.0),
                (&TGD1, -5.3e-9),
                (&TGD2, 2.1e-9),
                (&A2, -1.0e-20),
                (&A0, -3.1e-4),
                (&A1, 4.4e-11),
                (&AODE, 30.0),
            ],
            &[
                (&DELTA_N, 4.0e-9),
                (&CUC, -2.6e-6),
                (&M0, -2.5),
                (&ECC, 0.00123),
                (&CUS, 4.1e-6),
                (&CRC, 309.375),
                (&CRS, -52.1875),
                (&SQRT_A, 5282.62),
                (&TOE_MSB, 1.0),
            ],
            &[
                (&TOE_LSB, 10_800.0),
                (&I0, 0.96),
                (&CIC, 1.1e-7),
                (&OMEGA_DOT, -7.0e-9),
                (&CIS, -9.3e-8),
                (&IDOT, -4.0e-10),
                (&OMEGA0, 2.87),
                (&OMEGA, -1.65),
            ],
        ];
        // the parity bits: word 1's last 4, words 2–10's last 8
        let parity = |b: usize| if b < 30 { b >= 26 } else { b % 30 >= 22 };
        for fields in subframes {
            let mut sf = [0u32; 10];
            for (fd, v) in
                fields.iter().copied().chain([(&PREAMBLE, PREAMBLE_BITS), (&SOW, 604_794.0)])
            {
                write(&mut sf, fd, v);
            }
            for (fd, v) in
                fields.iter().copied().chain([(&PREAMBLE, PREAMBLE_BITS), (&SOW, 604_794.0)])
            {
                let back = read(&sf, fd);
                assert!((back - v).abs() <= fd.scale / 2.0 + 1e-15 * v.abs(), "{v} → {back}");
            }
            assert!(sf.iter().all(|w| w >> 30 == 0));
            assert!((0..300).filter(|b| parity(*b)).all(|b| bits(&sf, b, 1) == 0));
        }
        // and each field's pieces fit their words' data bits
        let all = [
            &PREAMBLE, &FRAME_ID, &SOW, &SAT_H1, &AODC, &URAI, &WN, &TOC, &TGD1, &TGD2, &A2, &A0,
            &A1, &AODE, &DELTA_N, &CUC, &M0, &ECC, &CUS, &CRC, &CRS, &SQRT_A, &TOE_MSB, &TOE_LSB,
            &I0, &CIC, &OMEGA_DOT, &CIS, &IDOT, &OMEGA0, &OMEGA,
        ];
        for fd in all {
            for &(start, width) in fd.pieces {
                assert!((start..start + width).all(|b| !parity(b) && b / 30 == start / 30));
            }
        }
    }

    /// A record through the subframes and back: every field within half a unit of its
    /// last bit, the times exact.
    #[test]
    fn a_record_survives_its_subframes() {
        let toe = GpsTime::new(BDT_WEEK_OFFSET + 984, 345_600.0 - BDT_MINUS_GPST);
        let e = Ephemeris {
            sat: Sat { sys: System::BeiDou, prn: 23 },
            toc: toe,
            toe,
            toe_sow: 345_600.0,
            af: [-3.1e-4, 4.4e-11, 0.0],
            iode: 7,
            iodc: 7,
            sqrt_a: 5282.6,
            e: 0.0012,
            i0: 0.96,
            omega0: -2.1,
            omega: 1.3,
            m0: 0.4,
            delta_n: 3.9e-9,
            omega_dot: -6.9e-9,
            idot: 2.0e-10,
            harmonics: [1.0e-6, 8.0e-6, 200.5, -10.25, 3.0e-8, -2.0e-8],
            tgd: [-5.3e-9, 2.1e-9],
            health: 0,
            accuracy: 2.0,
        };
        // sent 1.5 h before its toe, and 3 days after it
        for sent in [345_600.0 - 5400.0, 604_600.0] {
            let sf = encode(&e, sent);
            let back = decode(23, &sf).unwrap();
            assert_eq!(back.toe, e.toe);
            assert_eq!(back.toc, e.toc);
            let close = |a: f64, b: f64, unit: f64| (a - b).abs() <= unit / 2.0;
            assert!(close(back.sqrt_a, e.sqrt_a, SQRT_A.scale));
            assert!(close(back.m0, e.m0, M0.scale));
            assert!(close(back.omega0, e.omega0, OMEGA0.scale));
            assert!(close(back.af[0], e.af[0], A0.scale));
            assert!(close(back.tgd[1], e.tgd[1], TGD2.scale));
            assert!(close(back.harmonics[2], e.harmonics[2], CRC.scale));
            assert_eq!((back.iode, back.accuracy), (7, 2.0));
        }
        // a subframe out of its place, or 2 and 3 from another frame: no record
        let mut sf = encode(&e, 0.0);
        sf.swap(1, 2);
        assert!(decode(23, &sf).is_none());
        let (a, b) = (encode(&e, 0.0), encode(&e, 30.0));
        assert!(decode(23, &[a[0], b[1], b[2]]).is_none());
    }
}
