//! Raw GNSS input, epoch by epoch: a receiver's observations (RINEX or a u-blox log; a base
//! station's also RTCM 3) with their broadcast ephemerides, [`RawInput`] — what a tightly
//! coupled run (`run`'s GNSS side), `ins-gnss spp` and `ins-gnss rtk` read.

use gnss::rtcm::read_rtcm;
use gnss::ubx::read_ubx;
use gnss::{read_nav, Ephemerides, NavData, ObsEpoch, ObsReader, RawError};
use std::path::{Path, PathBuf};

/// A raw observation file — RINEX, or a u-blox log (`.ubx`, with the GPS ephemerides of
/// its RXM-SFRBX) — and the ephemerides of its navigation files, merged.
pub struct RawInput {
    /// Ephemerides and the broadcast ionosphere.
    pub nav: NavData,
    epochs: RawEpochs,
    path: PathBuf,
    navs: Vec<PathBuf>,
    /// Whether the first epoch was checked against the ephemerides' weeks.
    checked: bool,
    /// An RTCM 3 station's antenna reference point (1005/1006), ECEF m.
    station: Option<nalgebra::Vector3<f64>>,
    /// An RTCM 3 file's messages not read, as a note naming the file.
    unread: Option<String>,
}

enum RawEpochs {
    Rinex(Box<ObsReader>),
    Log(std::vec::IntoIter<ObsEpoch>),
}

impl RawInput {
    /// Opens `obs` (the file's name says a u-blox log: `.ubx`, compressed or not) with the
    /// ephemerides of `navs`. No ephemeris at all is refused.
    pub fn open(obs: &Path, navs: &[PathBuf]) -> Result<Self, RawError> {
        Self::open_with(obs, navs, true, None)
    }

    /// A base station's observations (RTK): its ephemerides are not needed (the rover's
    /// serve the double differences), so a file without them — a RINEX base beside a
    /// u-blox rover log that brings its own — is taken; those of `navs` are kept. A file
    /// whose name says RTCM 3 (`.rtcm`, `.rtcm3`, compressed or not) is read as one, its
    /// times of week in the week nearest `near` (the rover's ephemerides: MSM carries no
    /// week); without `near` it is refused.
    pub fn open_base(
        obs: &Path,
        navs: &[PathBuf],
        near: Option<gnss::GpsTime>,
    ) -> Result<Self, RawError> {
        if has_in_name(obs, ".rtcm") {
            let Some(near) = near else {
                return Err(RawError {
                    path: obs.to_path_buf(),
                    line: 0,
                    message: "RTCM 3 carries the time of week, not the week: give a \
                              navigation file (or a rover log with ephemerides)"
                        .into(),
                });
            };
            let log = read_rtcm(obs, near)?;
            let mut input = Self::open_with(obs, navs, false, Some(log.epochs))?;
            input.station = log.position;
            input.unread =
                gnss::rtcm::unread_text(&log.other).map(|n| format!("{}: {n}", obs.display()));
            return Ok(input);
        }
        Self::open_with(obs, navs, false, None)
    }

    /// A time near the observations: the median of the ephemerides' reference times.
    pub fn near(&self) -> Option<gnss::GpsTime> {
        let mut toes: Vec<gnss::GpsTime> =
            self.nav.ephemerides.records().iter().map(|r| r.toe).collect();
        toes.sort_by(|a, b| a.diff(b).total_cmp(&0.0));
        toes.get(toes.len() / 2).copied()
    }

    fn open_with(
        obs: &Path,
        navs: &[PathBuf],
        need_ephemerides: bool,
        decoded: Option<Vec<ObsEpoch>>,
    ) -> Result<Self, RawError> {
        let mut nav = NavData::default();
        let mut records = Vec::new();
        for n in navs {
            let d = read_nav(n)?;
            records.extend(d.ephemerides.records().iter().cloned());
            nav.klobuchar = nav.klobuchar.or(d.klobuchar);
            nav.unused += d.unused;
        }
        let epochs = if let Some(d) = decoded {
            RawEpochs::Log(d.into_iter())
        } else if has_in_name(obs, ".ubx") {
            let log = read_ubx(obs)?;
            records.extend(log.ephemerides.records().iter().cloned());
            nav.klobuchar = nav.klobuchar.or(log.klobuchar);
            RawEpochs::Log(log.epochs.into_iter())
        } else {
            RawEpochs::Rinex(Box::new(ObsReader::open(obs)?))
        };
        if records.is_empty() && need_ephemerides {
            let what = navs.first().map_or(obs, PathBuf::as_path);
            return Err(RawError {
                path: what.to_path_buf(),
                line: 0,
                message: "no GPS, Galileo, BeiDou or QZSS ephemeris (give a RINEX navigation \
                          file)"
                    .into(),
            });
        }
        nav.ephemerides = Ephemerides::new(records);
        Ok(Self {
            nav,
            epochs,
            path: obs.to_path_buf(),
            navs: navs.to_vec(),
            checked: false,
            station: None,
            unread: None,
        })
    }

    /// The next epoch (`None` at the end). The first is checked against the ephemerides:
    /// none within a week of it is refused.
    pub fn next_epoch(&mut self) -> Result<Option<ObsEpoch>, RawError> {
        let e = match &mut self.epochs {
            RawEpochs::Rinex(r) => r.next_epoch()?,
            RawEpochs::Log(l) => l.next(),
        };
        if let (Some(e), false) = (&e, self.checked) {
            self.checked = true;
            self.refuse_far_records(e)?;
        }
        Ok(e)
    }

    /// The line the last epoch ended on (a RINEX file), 0 for a log.
    pub fn line(&self) -> usize {
        match &self.epochs {
            RawEpochs::Rinex(r) => r.line(),
            RawEpochs::Log(_) => 0,
        }
    }

    /// A RINEX file's `APPROX POSITION XYZ` or an RTCM 3 station's antenna reference
    /// point (ECEF, m; `None` for a u-blox log or a header without one).
    pub fn approx_position(&self) -> Option<nalgebra::Vector3<f64>> {
        match &self.epochs {
            RawEpochs::Rinex(r) => r.header.approx_position,
            RawEpochs::Log(_) => self.station,
        }
    }

    /// What the file held that is not read (an RTCM 3 file's other messages), as a note
    /// naming the file.
    pub fn unread(&self) -> Option<&str> {
        self.unread.as_deref()
    }

    /// The observation file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Refuses navigation records when a system the first epoch observes has records none
    /// of which is within a week of it: that system's satellites could never be used
    /// (with GPS alone, no epoch solved), and the likely cause is a 10-bit GPS week
    /// resolved against another date (`convbin` resolves it against today's). A file that
    /// mixes systems is checked system by system: Galileo's 12-bit week can be right while
    /// GPS's is not.
    fn refuse_far_records(&self, first: &ObsEpoch) -> Result<(), RawError> {
        let records = self.nav.ephemerides.records();
        let mut systems: Vec<_> = records.iter().map(|r| r.sat.sys).collect();
        systems.dedup();
        for sys in systems {
            if !first.sats.iter().any(|s| s.sat.sys == sys) {
                continue;
            }
            let of_sys = || records.iter().filter(move |r| r.sat.sys == sys);
            if of_sys().any(|r| r.toe.diff(&first.time).abs() < 604_800.0) {
                continue;
            }
            let (lo, hi) = of_sys()
                .fold((i32::MAX, i32::MIN), |(a, b), r| (a.min(r.toe.week), b.max(r.toe.week)));
            let names: Vec<String> = if self.navs.is_empty() {
                vec![self.path.display().to_string()]
            } else {
                self.navs.iter().map(|p| p.display().to_string()).collect()
            };
            return Err(RawError {
                path: self.path.clone(),
                line: 0,
                message: format!(
                    "the {} ephemerides of {} are of GPS weeks {lo}–{hi}, the observations \
                     of week {} ({}): none is within a week of them (a 10-bit week resolved \
                     against another date — convbin resolves it against today's — or the wrong \
                     navigation file)",
                    sys.name(),
                    names.join(", "),
                    first.time.week,
                    first.time
                ),
            });
        }
        Ok(())
    }
}

/// Whether the file's name contains `part` (case aside).
fn has_in_name(path: &Path, part: &str) -> bool {
    path.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.to_ascii_lowercase().contains(part))
}
