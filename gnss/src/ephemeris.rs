//! Broadcast ephemerides of the Keplerian systems (GPS, Galileo, BeiDou, QZSS):
//! satellite position, velocity and clock at a GPS-time instant.
//!
//! The orbit is IS-GPS-200 table 20-IV (Galileo OS-SIS-ICD §5.1.1 and BeiDou's ICD
//! §5.2.4.12 use the same model with their own μ and Ω̇e; BeiDou's geostationary satellites
//! are rotated by −5° about x and by Ω̇e·tk about z). The clock is the polynomial about
//! `toc` plus the relativistic term `F·e·√A·sin E` (IS-GPS-200 §20.3.3.3.3.1), minus the
//! first frequency's group delay ([`Ephemeris::group_delay`]): the clock of the L1 (GPS) /
//! E1 (Galileo) / B1I (BeiDou) code; an iono-free user adds the group delay back.
//!
//! Velocity and clock drift are the analytic derivatives of the same expressions (checked
//! against differences in the tests).

use super::time::{GpsTime, Sat, System, BDT_MINUS_GPST};
use nalgebra::Vector3;

/// Speed of light, m/s.
pub const C: f64 = 299_792_458.0;
/// GPS's Earth gravitational constant, m³/s².
const MU_GPS: f64 = 3.986_005e14;
/// Galileo's and BeiDou's, m³/s².
const MU_GAL_BDS: f64 = 3.986_004_418e14;
/// Earth rotation rate of GPS and Galileo (WGS-84), rad/s.
pub const OMEGA_E: f64 = 7.292_115_146_7e-5;
/// BeiDou's (CGCS2000), rad/s.
const OMEGA_E_BDS: f64 = 7.292_115e-5;

/// One broadcast ephemeris (a RINEX navigation record of a Keplerian system).
#[derive(Clone, Debug, PartialEq)]
pub struct Ephemeris {
    /// The satellite.
    pub sat: Sat,
    /// Clock reference time (as a GPS-time instant).
    pub toc: GpsTime,
    /// Ephemeris reference time (as a GPS-time instant).
    pub toe: GpsTime,
    /// `toe` in seconds of the system's own week (BDT for BeiDou), as broadcast.
    pub toe_sow: f64,
    /// Clock bias (s), drift (s/s), drift rate (s/s²).
    pub af: [f64; 3],
    /// Issue of data (ephemeris).
    pub iode: i32,
    /// Issue of data (clock).
    pub iodc: i32,
    /// √A, m^½.
    pub sqrt_a: f64,
    /// Eccentricity.
    pub e: f64,
    /// Inclination at `toe`, rad.
    pub i0: f64,
    /// Right ascension at the week's start, rad.
    pub omega0: f64,
    /// Argument of perigee, rad.
    pub omega: f64,
    /// Mean anomaly at `toe`, rad.
    pub m0: f64,
    /// Mean motion correction, rad/s.
    pub delta_n: f64,
    /// Rate of right ascension, rad/s.
    pub omega_dot: f64,
    /// Rate of inclination, rad/s.
    pub idot: f64,
    /// Harmonic corrections: `[cuc, cus, crc, crs, cic, cis]` (rad, rad, m, m, rad, rad).
    pub harmonics: [f64; 6],
    /// Group delays, s: GPS/QZSS `[T_GD, 0]`, Galileo `[BGD E5a/E1, BGD E5b/E1]`,
    /// BeiDou `[TGD1 B1/B3, TGD2 B2/B3]`.
    pub tgd: [f64; 2],
    /// Health (0 = healthy).
    pub health: u32,
    /// User range accuracy (GPS URA, Galileo SISA, BeiDou URA), m.
    pub accuracy: f64,
}

/// A satellite's state at an instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SatState {
    /// ECEF position at the instant (in the ECEF frame of that instant), m.
    pub pos: Vector3<f64>,
    /// ECEF velocity, m/s.
    pub vel: Vector3<f64>,
    /// Clock offset (satellite − system time) including relativity and `T_GD`, s.
    pub clock: f64,
    /// Clock drift, s/s.
    pub drift: f64,
    /// Variance of the broadcast orbit and clock from the accuracy index, m².
    pub variance: f64,
}

/// The ICD's URA index upper bounds, m (IS-GPS-200 §20.3.3.3.1.3): the accuracy a
/// record states is rounded up to one of them, as receivers and RTKLIB do.
const URA: [f64; 15] = [
    2.4, 3.4, 4.85, 6.85, 9.65, 13.65, 24.0, 48.0, 96.0, 192.0, 384.0, 768.0, 1536.0, 3072.0,
    6144.0,
];

/// The ICD's nominal URA of an index (2^(1 + N/2) m up to 6, 2^(N − 2) m above), what
/// RTKLIB writes to RINEX for GPS, QZSS and BeiDou; the variance rounds it up to the
/// index's bound.
pub fn ura_metres(index: usize) -> f64 {
    if index <= 6 {
        2f64.powf(1.0 + index as f64 / 2.0)
    } else {
        2f64.powi(index as i32 - 2)
    }
}

/// The URA index of an accuracy (m): the first index whose bound it does not exceed, 15
/// beyond the table (or for a NaN).
pub fn ura_index(accuracy: f64) -> usize {
    URA.iter().position(|u| accuracy <= *u).unwrap_or(15)
}

impl Ephemeris {
    fn constants(&self) -> (f64, f64) {
        match self.sat.sys {
            System::Galileo => (MU_GAL_BDS, OMEGA_E),
            System::BeiDou => (MU_GAL_BDS, OMEGA_E_BDS),
            _ => (MU_GPS, OMEGA_E),
        }
    }

    /// The largest |t − toe| for which the record is used, s.
    pub fn validity(&self) -> f64 {
        match self.sat.sys {
            System::Galileo => 14_400.0,
            System::BeiDou => 21_600.0,
            _ => 7_200.0,
        }
    }

    /// Variance of the signal in space from the stated accuracy, m².
    ///
    /// GPS, QZSS and BeiDou state a URA in metres, rounded up here to the ICD's index bound
    /// (0 is index 0, 2.4 m, as RTKLIB reads it); Galileo's SISA is used as stated, and a
    /// SISA ≤ 0 ("no accuracy prediction available") or a NaN as the table's last bound.
    pub fn variance(&self) -> f64 {
        let a = match self.sat.sys {
            System::Galileo if self.accuracy > 0.0 => self.accuracy,
            System::Galileo => 6144.0,
            _ if self.accuracy.is_nan() => 6144.0,
            _ => URA.get(ura_index(self.accuracy)).copied().unwrap_or(6144.0),
        };
        a * a
    }

    /// The satellite clock offset (s) at GPS time `t`, without relativity, with the
    /// first-frequency group delay ([`Self::group_delay`]).
    pub fn clock_polynomial(&self, t: &GpsTime) -> f64 {
        let dt = t.diff(&self.toc);
        self.af[0] + self.af[1] * dt + self.af[2] * dt * dt - self.group_delay()
    }

    /// The group delay the first-frequency code carries, s (`tgd[0]` in every system:
    /// GPS `T_GD`, Galileo `BGD E5a/E1`, BeiDou `TGD1`, as RTKLIB 2.4.3 applies them).
    pub fn group_delay(&self) -> f64 {
        self.tgd[0]
    }

    /// Position, velocity and clock at GPS time `t` (the signal's transmission time).
    pub fn state(&self, t: &GpsTime) -> SatState {
        let (mu, we) = self.constants();
        let tk = t.diff(&self.toe);
        let a = self.sqrt_a * self.sqrt_a;
        let n = (mu / (a * a * a)).sqrt() + self.delta_n;
        let mk = self.m0 + n * tk;
        // Kepler's equation by Newton's method
        let mut ek = mk;
        for _ in 0..30 {
            let step = (ek - self.e * ek.sin() - mk) / (1.0 - self.e * ek.cos());
            ek -= step;
            if step.abs() < 1e-14 {
                break;
            }
        }
        let (se, ce) = ek.sin_cos();
        let one_e_cos = 1.0 - self.e * ce;
        let ek_dot = n / one_e_cos;
        let root = (1.0 - self.e * self.e).sqrt();
        let nu = (root * se).atan2(ce - self.e);
        let phi = nu + self.omega;
        let phi_dot = root * ek_dot / one_e_cos;
        let (s2, c2) = (2.0 * phi).sin_cos();
        let [cuc, cus, crc, crs, cic, cis] = self.harmonics;
        let u = phi + cus * s2 + cuc * c2;
        let r = a * one_e_cos + crs * s2 + crc * c2;
        let i = self.i0 + self.idot * tk + cis * s2 + cic * c2;
        let u_dot = phi_dot * (1.0 + 2.0 * (cus * c2 - cuc * s2));
        let r_dot = a * self.e * se * ek_dot + 2.0 * phi_dot * (crs * c2 - crc * s2);
        let i_dot = self.idot + 2.0 * phi_dot * (cis * c2 - cic * s2);
        let (su, cu) = u.sin_cos();
        let (xp, yp) = (r * cu, r * su);
        let (xp_dot, yp_dot) = (r_dot * cu - r * u_dot * su, r_dot * su + r * u_dot * cu);
        let (si, ci) = i.sin_cos();
        let geo = self.sat.beidou_geo();
        // right ascension: in the inertial frame for BeiDou's GEO, Earth-fixed otherwise
        let (big_omega, big_omega_dot) = if geo {
            (self.omega0 + self.omega_dot * tk - we * self.toe_sow, self.omega_dot)
        } else {
            (self.omega0 + (self.omega_dot - we) * tk - we * self.toe_sow, self.omega_dot - we)
        };
        let (so, co) = big_omega.sin_cos();
        let pos = Vector3::new(xp * co - yp * ci * so, xp * so + yp * ci * co, yp * si);
        let vel = Vector3::new(
            xp_dot * co - yp_dot * ci * so + yp * si * so * i_dot - pos.y * big_omega_dot,
            xp_dot * so + yp_dot * ci * co - yp * si * co * i_dot + pos.x * big_omega_dot,
            yp_dot * si + yp * ci * i_dot,
        );
        let (pos, vel) = if geo { geo_rotation(pos, vel, we, tk) } else { (pos, vel) };
        // relativity: −2√(μA)·e·sin E / c²
        let rel = -2.0 * (mu * a).sqrt() * self.e * se / (C * C);
        let rel_dot = -2.0 * (mu * a).sqrt() * self.e * ce * ek_dot / (C * C);
        let dt = t.diff(&self.toc);
        SatState {
            pos,
            vel,
            clock: self.clock_polynomial(t) + rel,
            drift: self.af[1] + 2.0 * self.af[2] * dt + rel_dot,
            variance: self.variance(),
        }
    }
}

/// BeiDou GEO: the inertial-like orbit rotated by −5° about x, then by Ω̇e·tk about z.
fn geo_rotation(
    p: Vector3<f64>,
    v: Vector3<f64>,
    we: f64,
    tk: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let (s5, c5) = (-5f64.to_radians()).sin_cos();
    let rx = |w: Vector3<f64>| Vector3::new(w.x, c5 * w.y + s5 * w.z, -s5 * w.y + c5 * w.z);
    let (sz, cz) = (we * tk).sin_cos();
    let rz = |w: Vector3<f64>| Vector3::new(cz * w.x + sz * w.y, -sz * w.x + cz * w.y, w.z);
    let (pg, vg) = (rx(p), rx(v));
    // d/dt Rz(ωt)·p = Rz·ṗ + Ṙz·p, Ṙz·p = ω·(−sin·x + cos·y, −cos·x − sin·y, 0)
    let rz_dot = Vector3::new(we * (-sz * pg.x + cz * pg.y), we * (-cz * pg.x - sz * pg.y), 0.0);
    (rz(pg), rz(vg) + rz_dot)
}

/// The navigation records of a file, by satellite, and the choice among them.
#[derive(Clone, Debug, Default)]
pub struct Ephemerides {
    records: Vec<Ephemeris>,
}

impl Ephemerides {
    /// From records in any order.
    pub fn new(mut records: Vec<Ephemeris>) -> Self {
        records.sort_by(|a, b| {
            a.sat.cmp(&b.sat).then(a.toe.partial_cmp(&b.toe).unwrap_or(core::cmp::Ordering::Equal))
        });
        Self { records }
    }

    /// All records.
    pub fn records(&self) -> &[Ephemeris] {
        &self.records
    }

    /// The healthy record of `sat` whose `toe` is nearest to `t` and within its validity
    /// (the later one on a tie, as a receiver switching to a new upload would).
    pub fn select(&self, sat: Sat, t: &GpsTime) -> Option<&Ephemeris> {
        let start = self.records.partition_point(|e| e.sat < sat);
        let mut best: Option<(&Ephemeris, f64)> = None;
        for e in self.records[start..].iter().take_while(|e| e.sat == sat) {
            let d = t.diff(&e.toe).abs();
            if e.health != 0 || d > e.validity() {
                continue;
            }
            if best.is_none_or(|(_, b)| d <= b) {
                best = Some((e, d));
            }
        }
        best.map(|(e, _)| e)
    }
}

/// BeiDou time of week (s) of a GPS-time instant's tow.
pub fn bdt_sow(t: &GpsTime) -> f64 {
    t.add(BDT_MINUS_GPST).tow
}

#[cfg(test)]
mod tests {
    use super::*;

    /// G03's record of 2005-04-02 00:00 in the shipped `07590920.05n`.
    pub(crate) fn g03() -> Ephemeris {
        let toc = GpsTime::from_calendar(2005, 4, 2, 0, 0, 0.0);
        Ephemeris {
            sat: Sat { sys: System::Gps, prn: 3 },
            toc,
            toe: toc,
            toe_sow: 518_400.0,
            af: [4.8e-4, 1.1e-11, 0.0],
            iode: 10,
            iodc: 10,
            sqrt_a: 5153.6,
            e: 0.0067,
            i0: 0.95,
            omega0: -1.2,
            omega: 2.1,
            m0: 0.4,
            delta_n: 4.5e-9,
            omega_dot: -8.0e-9,
            idot: 2.0e-10,
            harmonics: [1.0e-6, 8.0e-6, 230.0, 20.0, 1.0e-7, -1.0e-7],
            tgd: [-4.7e-9, 0.0],
            health: 0,
            accuracy: 2.0,
        }
    }

    #[test]
    fn velocity_and_drift_are_the_derivatives() {
        for sat in [Sat { sys: System::Gps, prn: 3 }, Sat { sys: System::BeiDou, prn: 2 }] {
            let mut e = g03();
            e.sat = sat;
            for dt in [-3600.0, 0.0, 1234.5, 7000.0] {
                let t = e.toe.add(dt);
                let s = e.state(&t);
                // (a tow near 5e5 s resolves 1e-10 s: a longer step keeps the difference exact)
                let h = 0.5;
                let (a, b) = (e.state(&t.add(h)), e.state(&t.add(-h)));
                let v = (a.pos - b.pos) / (2.0 * h);
                assert!((v - s.vel).norm() < 2e-5, "{sat} {dt}: {}", (v - s.vel).norm());
                let d = (a.clock - b.clock) / (2.0 * h);
                assert!((d - s.drift).abs() < 1e-15, "{sat} {dt}");
            }
        }
    }

    #[test]
    fn orbit_radius_and_speed_are_a_gps_orbit() {
        let e = g03();
        let s = e.state(&e.toe.add(900.0));
        let r = s.pos.norm();
        assert!((r - 26_560e3).abs() < 300e3, "{r}");
        // inertial speed ≈ 3.87 km/s; the Earth-fixed one differs by ω × r
        let v_i = s.vel + Vector3::new(0.0, 0.0, OMEGA_E).cross(&s.pos);
        assert!((v_i.norm() - 3874.0).abs() < 40.0, "{}", v_i.norm());
    }

    #[test]
    fn ura_rounds_up_to_the_index_bound() {
        let mut e = g03();
        assert_eq!(e.variance(), 2.4 * 2.4);
        e.accuracy = 3.0;
        assert_eq!(e.variance(), 3.4 * 3.4);
        e.accuracy = 0.0;
        assert_eq!(e.variance(), 2.4 * 2.4);
        e.accuracy = 9999.0;
        assert_eq!(e.variance(), 6144.0 * 6144.0);
        e.sat.sys = System::Galileo;
        e.accuracy = -1.0;
        assert_eq!(e.variance(), 6144.0 * 6144.0);
    }

    #[test]
    fn selection_takes_the_nearest_healthy_record_in_its_window() {
        let a = g03();
        let mut b = g03();
        b.toe = a.toe.add(7200.0);
        let mut c = g03();
        c.toe = a.toe.add(3600.0);
        c.health = 1;
        let set = Ephemerides::new(vec![b.clone(), c, a.clone()]);
        assert_eq!(set.select(a.sat, &a.toe.add(3000.0)).unwrap().toe, a.toe);
        assert_eq!(set.select(a.sat, &a.toe.add(3600.0)).unwrap().toe, b.toe);
        assert!(set.select(a.sat, &a.toe.add(20_000.0)).is_none());
        assert!(set.select(Sat { sys: System::Gps, prn: 4 }, &a.toe).is_none());
    }
}
