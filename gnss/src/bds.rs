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
use super::fields::{self, p2, SC};
use super::time::{GpsTime, Sat, System, BDT_MINUS_GPST, BDT_WEEK_OFFSET, WEEK};

/// A field: pieces `(subframe or page 0…, first bit 0–299, width)` most significant
/// first, signed (two's complement), and the scale of one unit.
struct Field {
    pieces: &'static [(usize, usize, usize)],
    signed: bool,
    scale: f64,
}

const fn f(pieces: &'static [(usize, usize, usize)], signed: bool, scale: f64) -> Field {
    Field { pieces, signed, scale }
}

// every subframe: word 1 and the start of word 2 (read from one subframe at a time)
const PREAMBLE: Field = f(&[(0, 0, 11)], false, 1.0);
const FRAME_ID: Field = f(&[(0, 15, 3)], false, 1.0);
const SOW: Field = f(&[(0, 18, 8), (0, 30, 12)], false, 1.0);

/// D1: subframes 1–3 (0–2 here).
mod d1 {
    use super::{f, p2, Field, SC};
    // subframe 1
    pub const SAT_H1: Field = f(&[(0, 42, 1)], false, 1.0);
    pub const AODC: Field = f(&[(0, 43, 5)], false, 1.0);
    pub const URAI: Field = f(&[(0, 48, 4)], false, 1.0);
    pub const WN: Field = f(&[(0, 60, 13)], false, 1.0);
    pub const TOC: Field = f(&[(0, 73, 9), (0, 90, 8)], false, 8.0);
    pub const TGD1: Field = f(&[(0, 98, 10)], true, 1e-10);
    pub const TGD2: Field = f(&[(0, 108, 4), (0, 120, 6)], true, 1e-10);
    pub const A2: Field = f(&[(0, 214, 11)], true, p2(60) * p2(6));
    pub const A0: Field = f(&[(0, 225, 7), (0, 240, 17)], true, p2(33));
    pub const A1: Field = f(&[(0, 257, 5), (0, 270, 17)], true, p2(50));
    pub const AODE: Field = f(&[(0, 287, 5)], false, 1.0);
    // subframe 2
    pub const DELTA_N: Field = f(&[(1, 42, 10), (1, 60, 6)], true, p2(43) * SC);
    pub const CUC: Field = f(&[(1, 66, 16), (1, 90, 2)], true, p2(31));
    pub const M0: Field = f(&[(1, 92, 20), (1, 120, 12)], true, p2(31) * SC);
    pub const ECC: Field = f(&[(1, 132, 10), (1, 150, 22)], false, p2(33));
    pub const CUS: Field = f(&[(1, 180, 18)], true, p2(31));
    pub const CRC: Field = f(&[(1, 198, 4), (1, 210, 14)], true, p2(6));
    pub const CRS: Field = f(&[(1, 224, 8), (1, 240, 10)], true, p2(6));
    pub const SQRT_A: Field = f(&[(1, 250, 12), (1, 270, 20)], false, p2(19));
    // toe: its 2 most significant bits end subframe 2, the other 15 start subframe 3
    pub const TOE: Field = f(&[(1, 290, 2), (2, 42, 10), (2, 60, 5)], false, 8.0);
    // subframe 3
    pub const I0: Field = f(&[(2, 65, 17), (2, 90, 15)], true, p2(31) * SC);
    pub const CIC: Field = f(&[(2, 105, 7), (2, 120, 11)], true, p2(31));
    pub const OMEGA_DOT: Field = f(&[(2, 131, 11), (2, 150, 13)], true, p2(43) * SC);
    pub const CIS: Field = f(&[(2, 163, 9), (2, 180, 9)], true, p2(31));
    pub const IDOT: Field = f(&[(2, 189, 13), (2, 210, 1)], true, p2(43) * SC);
    pub const OMEGA0: Field = f(&[(2, 211, 21), (2, 240, 11)], true, p2(31) * SC);
    pub const OMEGA: Field = f(&[(2, 251, 11), (2, 270, 21)], true, p2(31) * SC);
}

/// D2: pages 1–10 of subframe 1 (0–9 here; page 2, the ionosphere's grid, not read).
/// Fields cross pages where the message splits them.
mod d2 {
    use super::{f, p2, Field, SC};
    pub const PAGE: Field = f(&[(0, 42, 4)], false, 1.0);
    // page 1
    pub const SAT_H1: Field = f(&[(0, 46, 1)], false, 1.0);
    pub const AODC: Field = f(&[(0, 47, 5)], false, 1.0);
    pub const URAI: Field = f(&[(0, 60, 4)], false, 1.0);
    pub const WN: Field = f(&[(0, 64, 13)], false, 1.0);
    pub const TOC: Field = f(&[(0, 77, 5), (0, 90, 12)], false, 8.0);
    pub const TGD1: Field = f(&[(0, 102, 10)], true, 1e-10);
    pub const TGD2: Field = f(&[(0, 120, 10)], true, 1e-10);
    // pages 3–4
    pub const A0: Field = f(&[(2, 100, 12), (2, 120, 12)], true, p2(33));
    pub const A1: Field = f(&[(2, 132, 4), (3, 46, 6), (3, 60, 12)], true, p2(50));
    pub const A2: Field = f(&[(3, 72, 10), (3, 90, 1)], true, p2(60) * p2(6));
    pub const AODE: Field = f(&[(3, 91, 5)], false, 1.0);
    pub const DELTA_N: Field = f(&[(3, 96, 16)], true, p2(43) * SC);
    pub const CUC: Field = f(&[(3, 120, 14), (4, 46, 4)], true, p2(31));
    // pages 5–6
    pub const M0: Field = f(&[(4, 50, 2), (4, 60, 22), (4, 90, 8)], true, p2(31) * SC);
    pub const CUS: Field = f(&[(4, 98, 14), (4, 120, 4)], true, p2(31));
    pub const ECC: Field = f(&[(4, 124, 10), (5, 46, 6), (5, 60, 16)], false, p2(33));
    pub const SQRT_A: Field = f(&[(5, 76, 6), (5, 90, 22), (5, 120, 4)], false, p2(19));
    pub const CIC: Field = f(&[(5, 124, 10), (6, 46, 6), (6, 60, 2)], true, p2(31));
    // pages 7–8
    pub const CIS: Field = f(&[(6, 62, 18)], true, p2(31));
    pub const TOE: Field = f(&[(6, 80, 2), (6, 90, 15)], false, 8.0);
    pub const I0: Field =
        f(&[(6, 105, 7), (6, 120, 14), (7, 46, 6), (7, 60, 5)], true, p2(31) * SC);
    pub const CRC: Field = f(&[(7, 65, 17), (7, 90, 1)], true, p2(6));
    pub const CRS: Field = f(&[(7, 91, 18)], true, p2(6));
    pub const OMEGA_DOT: Field = f(&[(7, 109, 3), (7, 120, 16), (8, 46, 5)], true, p2(43) * SC);
    // pages 9–10
    pub const OMEGA0: Field = f(&[(8, 51, 1), (8, 60, 22), (8, 90, 9)], true, p2(31) * SC);
    pub const OMEGA: Field = f(&[(8, 99, 13), (8, 120, 14), (9, 46, 5)], true, p2(31) * SC);
    pub const IDOT: Field = f(&[(9, 51, 1), (9, 60, 13)], true, p2(43) * SC);
}

/// The D1/D2 preamble, `11100010010`.
const PREAMBLE_BITS: f64 = 0x712 as f64;

/// A subframe: ten words as RXM-SFRBX gives them.
pub type Subframe = [u32; 10];

fn bits(sf: &Subframe, start: usize, width: usize) -> u64 {
    (start..start + width).fold(0, |v, b| (v << 1) | u64::from((sf[b / 30] >> (29 - b % 30)) & 1))
}

fn read(frames: &[Subframe], fd: &Field) -> f64 {
    let (mut v, mut n) = (0u64, 0usize);
    for &(k, start, width) in fd.pieces {
        v = (v << width) | bits(&frames[k], start, width);
        n += width;
    }
    fields::value(v, n, fd.signed, fd.scale)
}

fn write(frames: &mut [Subframe], fd: &Field, value: f64) {
    let n: usize = fd.pieces.iter().map(|p| p.2).sum();
    let v = fields::pattern(value, n, fd.scale);
    let mut at = n;
    for &(k, start, width) in fd.pieces {
        at -= width;
        for j in 0..width {
            let bit = ((v >> (at + width - 1 - j)) & 1) as u32;
            let b = start + j;
            let shift = 29 - b % 30;
            let word = &mut frames[k][b / 30];
            *word = (*word & !(1 << shift)) | (bit << shift);
        }
    }
}

/// Which subframe (1–5) a D1 or D2 subframe is, when its preamble is there.
pub fn subframe_id(sf: &Subframe) -> Option<u8> {
    let one = core::slice::from_ref(sf);
    (read(one, &PREAMBLE) == PREAMBLE_BITS).then(|| read(one, &FRAME_ID) as u8)
}

/// The page number (1–10) of a D2 subframe 1.
pub fn d2_page(sf: &Subframe) -> u8 {
    read(core::slice::from_ref(sf), &d2::PAGE) as u8
}

/// The seconds of week a subframe states.
fn sow(sf: &Subframe) -> f64 {
    read(core::slice::from_ref(sf), &SOW)
}

/// Headers (preamble, subframe ID, seconds of week) of `frames`, the first stating `first`
/// and each later one `step` seconds on.
fn headers(frames: &mut [Subframe], id: impl Fn(usize) -> usize, first: f64, step: f64) {
    for (k, sf) in frames.iter_mut().enumerate() {
        let one = core::slice::from_mut(sf);
        write(one, &PREAMBLE, PREAMBLE_BITS);
        write(one, &FRAME_ID, id(k) as f64);
        write(one, &SOW, (first + step * k as f64).rem_euclid(WEEK));
    }
}

/// The fields a record has in both messages, in one message's table.
struct Table {
    sat_h1: Field,
    aodc: Field,
    urai: Field,
    wn: Field,
    toc: Field,
    toe: Field,
    tgd: [Field; 2],
    af: [Field; 3],
    aode: Field,
    kepler: [Field; 9],
    harmonics: [Field; 6],
}

/// `kepler`: √A, e, i0, Ω0, ω, M0, Δn, Ω̇, IDOT; `harmonics` in [`Ephemeris::harmonics`]'s
/// order.
const D1: Table = Table {
    sat_h1: d1::SAT_H1,
    aodc: d1::AODC,
    urai: d1::URAI,
    wn: d1::WN,
    toc: d1::TOC,
    toe: d1::TOE,
    tgd: [d1::TGD1, d1::TGD2],
    af: [d1::A0, d1::A1, d1::A2],
    aode: d1::AODE,
    kepler: [
        d1::SQRT_A,
        d1::ECC,
        d1::I0,
        d1::OMEGA0,
        d1::OMEGA,
        d1::M0,
        d1::DELTA_N,
        d1::OMEGA_DOT,
        d1::IDOT,
    ],
    harmonics: [d1::CUC, d1::CUS, d1::CRC, d1::CRS, d1::CIC, d1::CIS],
};

const D2: Table = Table {
    sat_h1: d2::SAT_H1,
    aodc: d2::AODC,
    urai: d2::URAI,
    wn: d2::WN,
    toc: d2::TOC,
    toe: d2::TOE,
    tgd: [d2::TGD1, d2::TGD2],
    af: [d2::A0, d2::A1, d2::A2],
    aode: d2::AODE,
    kepler: [
        d2::SQRT_A,
        d2::ECC,
        d2::I0,
        d2::OMEGA0,
        d2::OMEGA,
        d2::M0,
        d2::DELTA_N,
        d2::OMEGA_DOT,
        d2::IDOT,
    ],
    harmonics: [d2::CUC, d2::CUS, d2::CRC, d2::CRS, d2::CIC, d2::CIS],
};

fn encode_fields(e: &Ephemeris, t: &Table, frames: &mut [Subframe]) {
    let bdt_week = e.toe.add(BDT_MINUS_GPST).week - BDT_WEEK_OFFSET;
    write(frames, &t.sat_h1, f64::from(u8::from(e.health != 0)));
    write(frames, &t.aodc, f64::from(e.iodc.rem_euclid(32)));
    write(frames, &t.urai, ura_index(e.accuracy) as f64);
    write(frames, &t.wn, f64::from(bdt_week));
    write(frames, &t.toc, e.toe_sow);
    write(frames, &t.toe, e.toe_sow);
    for (fd, v) in t.tgd.iter().zip(e.tgd) {
        write(frames, fd, v);
    }
    for (fd, v) in t.af.iter().zip(e.af) {
        write(frames, fd, v);
    }
    write(frames, &t.aode, f64::from(e.iode.rem_euclid(32)));
    let kepler = [e.sqrt_a, e.e, e.i0, e.omega0, e.omega, e.m0, e.delta_n, e.omega_dot, e.idot];
    for (fd, v) in t.kepler.iter().zip(kepler) {
        write(frames, fd, v);
    }
    for (fd, v) in t.harmonics.iter().zip(e.harmonics) {
        write(frames, fd, v);
    }
}

fn decode_fields(prn: u8, t: &Table, frames: &[Subframe]) -> Option<Ephemeris> {
    let toe_sow = read(frames, &t.toe);
    let toc_sow = read(frames, &t.toc);
    if toc_sow != toe_sow {
        return None;
    }
    // BDT week and second of week to a GPS-time instant: the week that puts the reference
    // time within half a week of the first subframe's transmission
    let week = read(frames, &t.wn) as i32 + BDT_WEEK_OFFSET;
    let sent = GpsTime::new(week, sow(&frames[0]) - BDT_MINUS_GPST);
    let near = |sow: f64| {
        let t = GpsTime::new(week, sow - BDT_MINUS_GPST);
        t.add(-(t.diff(&sent) / WEEK).round() * WEEK)
    };
    let [sqrt_a, e, i0, omega0, omega, m0, delta_n, omega_dot, idot] =
        t.kepler.each_ref().map(|fd| read(frames, fd));
    let aode = read(frames, &t.aode) as i32;
    Some(Ephemeris {
        sat: Sat { sys: System::BeiDou, prn },
        toc: near(toc_sow),
        toe: near(toe_sow),
        toe_sow,
        af: t.af.each_ref().map(|fd| read(frames, fd)),
        // (the RINEX reader takes the age of data for both, as RINEX carries AODE only in
        // the issue-of-data column)
        iode: aode,
        iodc: aode,
        sqrt_a,
        e,
        i0,
        omega0,
        omega,
        m0,
        delta_n,
        omega_dot,
        idot,
        harmonics: t.harmonics.each_ref().map(|fd| read(frames, fd)),
        tgd: t.tgd.each_ref().map(|fd| read(frames, fd)),
        health: read(frames, &t.sat_h1) as u32,
        accuracy: ura_metres(read(frames, &t.urai) as usize),
    })
}

/// Encodes the record of a BeiDou MEO or IGSO satellite as D1 subframes 1–3, the first
/// starting at the BDT second of week after `bdt_sow` (a multiple of 6), the others 6 s
/// and 12 s later. The record's `toe_sow` must be a multiple of 8 s and its `toc` equal
/// to its `toe`, as the message has them; the Klobuchar coefficients are written as zero.
pub fn encode(e: &Ephemeris, bdt_sow: f64) -> [Subframe; 3] {
    let mut out = [[0u32; 10]; 3];
    headers(&mut out, |k| k + 1, ((bdt_sow / 6.0).floor() + 1.0) * 6.0, 6.0);
    encode_fields(e, &D1, &mut out);
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
    let t0 = sow(&sf[0]);
    if sow(&sf[1]) != t0 + 6.0 || sow(&sf[2]) != t0 + 12.0 {
        return None;
    }
    decode_fields(prn, &D1, sf)
}

/// Encodes the record of a BeiDou GEO satellite as D2 subframe 1, pages 1–10, page 1 at
/// the BDT second of week after `bdt_sow` that is a multiple of 30, each next page 3 s
/// later (page 2, the ionosphere's, carries its header only). `toe_sow` and `toc` as for
/// [`encode`].
pub fn encode_d2(e: &Ephemeris, bdt_sow: f64) -> [Subframe; 10] {
    let mut out = [[0u32; 10]; 10];
    headers(&mut out, |_| 1, ((bdt_sow / 30.0).floor() + 1.0) * 30.0, 3.0);
    for (k, sf) in out.iter_mut().enumerate() {
        write(core::slice::from_mut(sf), &d2::PAGE, (k + 1) as f64);
    }
    encode_fields(e, &D2, &mut out);
    out
}

/// Decodes D2 subframe 1, pages 1–10 (page 2 unused) of BeiDou GEO satellite `prn` into a
/// record. `None` when a preamble is missing, a page is out of place, the pages are not
/// 3 s apart, or toc is not toe, as RTKLIB refuses them.
pub fn decode_d2(prn: u8, pages: &[Subframe; 10]) -> Option<Ephemeris> {
    for (k, s) in pages.iter().enumerate() {
        if subframe_id(s)? != 1 || usize::from(d2_page(s)) != k + 1 {
            return None;
        }
    }
    let t0 = sow(&pages[0]);
    if (2..10).any(|k| sow(&pages[k]) != t0 + 3.0 * k as f64) {
        return None;
    }
    decode_fields(prn, &D2, pages)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table_fields(t: &Table) -> Vec<&Field> {
        let mut v = vec![&t.sat_h1, &t.aodc, &t.urai, &t.wn, &t.toc, &t.toe, &t.aode];
        v.extend(t.tgd.iter().chain(&t.af).chain(&t.kepler).chain(&t.harmonics));
        v
    }

    /// Each message's fields (and the headers, and D2's page number) cover each bit at most
    /// once, stay inside one word's data bits (none on a parity bit), and have the ICD's
    /// widths.
    #[test]
    fn the_fields_share_no_bit_and_leave_the_parity_alone() {
        // the parity bits: word 1's last 4, words 2–10's last 8
        let parity = |b: usize| if b < 30 { b >= 26 } else { b % 30 >= 22 };
        for (t, frames, extra) in [(&D1, 3, vec![]), (&D2, 10, vec![&d2::PAGE])] {
            let mut used = vec![[false; 300]; frames];
            for frame in used.iter_mut() {
                for fd in [&PREAMBLE, &FRAME_ID, &SOW].into_iter().chain(extra.iter().copied()) {
                    for &(_, start, width) in fd.pieces {
                        frame[start..start + width].fill(true);
                    }
                }
            }
            for fd in table_fields(t) {
                for &(k, start, width) in fd.pieces {
                    assert_eq!(start / 30, (start + width - 1) / 30, "a piece across words");
                    for (b, u) in used[k].iter_mut().enumerate().skip(start).take(width) {
                        assert!(!parity(b), "bit {b} of frame {k} is parity");
                        assert!(!*u, "bit {b} of frame {k} used twice");
                        *u = true;
                    }
                }
            }
            // the ICD's widths (both messages carry the same ones)
            let width = |fd: &Field| fd.pieces.iter().map(|p| p.2).sum::<usize>();
            let widths: Vec<usize> = table_fields(t).into_iter().map(width).collect();
            assert_eq!(
                widths,
                [1, 5, 4, 13, 17, 17, 5, 10, 10, 24, 22, 11, 32, 32, 32, 32, 32, 32, 16, 24, 14]
                    .into_iter()
                    .chain([18, 18, 18, 18, 18, 18])
                    .collect::<Vec<_>>()
            );
        }
    }

    fn record(prn: u8) -> Ephemeris {
        let toe = GpsTime::new(BDT_WEEK_OFFSET + 984, 345_600.0 - BDT_MINUS_GPST);
        Ephemeris {
            sat: Sat { sys: System::BeiDou, prn },
            toc: toe,
            toe,
            toe_sow: 345_600.0,
            af: [-3.1e-4, 4.4e-11, -1.0e-20],
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
            harmonics: [1.0e-6, -8.0e-6, 200.5, -10.25, 3.0e-8, -2.0e-8],
            tgd: [-5.3e-9, 2.1e-9],
            health: 1,
            accuracy: 2.0,
        }
    }

    /// Every field within half a unit of its last bit, the times exact.
    fn assert_close(back: &Ephemeris, e: &Ephemeris, t: &Table) {
        assert_eq!((back.sat, back.toe, back.toc), (e.sat, e.toe, e.toc));
        assert_eq!((back.iode, back.accuracy, back.health), (7, 2.0, 1));
        let kepler = [e.sqrt_a, e.e, e.i0, e.omega0, e.omega, e.m0, e.delta_n, e.omega_dot, e.idot];
        let got = [
            back.sqrt_a,
            back.e,
            back.i0,
            back.omega0,
            back.omega,
            back.m0,
            back.delta_n,
            back.omega_dot,
            back.idot,
        ];
        let pairs = t.kepler.iter().zip(kepler.iter().zip(got));
        let pairs = pairs
            .chain(t.af.iter().zip(e.af.iter().zip(back.af)))
            .chain(t.tgd.iter().zip(e.tgd.iter().zip(back.tgd)))
            .chain(t.harmonics.iter().zip(e.harmonics.iter().zip(back.harmonics)));
        for (fd, (a, b)) in pairs {
            assert!((a - b).abs() <= fd.scale / 2.0 * (1.0 + 1e-12), "{a} → {b}");
        }
    }

    /// A record through D1's subframes and D2's pages and back, sent 1.5 h before its toe
    /// and 3 days after it.
    #[test]
    fn a_record_survives_both_messages() {
        for sent in [345_600.0 - 5400.0, 604_600.0] {
            let e = record(23);
            assert_close(&decode(23, &encode(&e, sent)).unwrap(), &e, &D1);
            let e = record(3);
            assert_close(&decode_d2(3, &encode_d2(&e, sent)).unwrap(), &e, &D2);
        }
    }

    /// Out of place or from two frames: no record, as RTKLIB takes none.
    #[test]
    fn mixed_frames_give_no_record() {
        let e = record(23);
        let mut sf = encode(&e, 0.0);
        sf.swap(1, 2);
        assert!(decode(23, &sf).is_none());
        let (a, b) = (encode(&e, 0.0), encode(&e, 30.0));
        assert!(decode(23, &[a[0], b[1], b[2]]).is_none());
        let (a, b) = (encode_d2(&e, 0.0), encode_d2(&e, 30.0));
        let mut mixed = a;
        mixed[5] = b[5];
        assert!(decode_d2(3, &mixed).is_none());
        let mut swapped = a;
        swapped.swap(3, 4);
        assert!(decode_d2(3, &swapped).is_none());
        // toc ≠ toe (a record caught across an upload)
        let mut moved = a;
        write(&mut moved, &d2::TOC, e.toe_sow + 8.0);
        assert!(decode_d2(3, &moved).is_none());
    }
}
