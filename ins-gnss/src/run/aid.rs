//! The GNSS side of a run, read epoch by epoch: a receiver's fixes (loose coupling), or
//! raw observations with their broadcast ephemerides (tight coupling, [`RawInput`]), each
//! raw epoch with its single point — the fix the start's checks and alignment look at,
//! and the receiver clock the tight filter starts from; with RTK, each rover epoch paired
//! with the base station's.

use super::RunError;
use crate::config::{Config, Coupling};
use crate::raw_input::RawInput;
use gnss::spp::{prepare, solve_prepared};
use gnss::{SppOptions, System};
use ins_gnss_core::navigator::{RawEpoch, TightConfig};
use ins_gnss_core::GnssEpoch;
use ins_gnss_io::formats::{GnssReader, Input};
use ins_gnss_io::SkipCounts;
use nalgebra::Vector3;
use std::path::PathBuf;

/// One GNSS epoch of a run: its time on the IMU's clock, the fix (a receiver's, or the
/// raw epoch's single point when it has one) and, with tight coupling, the raw epoch.
#[derive(Clone, Debug)]
pub struct AidEpoch {
    /// Time, s (the IMU's clock: GPS seconds of week).
    pub t: f64,
    /// The position fix.
    pub fix: Option<GnssEpoch>,
    /// The satellites (tight coupling) and the single point's receiver clock `c·dt` (m).
    pub raw: Option<(RawEpoch, Option<f64>)>,
    /// RTK: the rover's epoch and the base's paired with it (`None`: no base epoch
    /// recent enough, or not RTK).
    pub rtk: Option<Box<RtkPair>>,
}

/// A rover epoch and the base epoch paired with it (RTK).
#[derive(Clone, Debug)]
pub struct RtkPair {
    /// The rover's observations.
    pub rover: gnss::ObsEpoch,
    /// The base's, at the same instant or up to `gnss.rtk.max_age` before.
    pub base: gnss::ObsEpoch,
    /// The instant the rover's position holds at, on the run's clock (s): the stamp less
    /// the receiver clock's offset, when the single point found it.
    pub t: f64,
    /// That offset, s (the instant less the stamp).
    pub clock: f64,
}

/// The base station's epochs, paired with the rover's as they come.
struct BaseStream {
    input: RawInput,
    /// The latest base epoch at or before the rover's, and the next one.
    current: Option<gnss::ObsEpoch>,
    coming: Option<gnss::ObsEpoch>,
    max_age: f64,
}

impl BaseStream {
    /// The base epoch for a rover epoch at `time`: the latest at or before it (within
    /// [`gnss::rtk::PAIRING`]), if at most `max_age` older.
    fn pair(&mut self, time: &gnss::GpsTime) -> Result<Option<&gnss::ObsEpoch>, RunError> {
        while self.coming.as_ref().is_some_and(|x| x.time.diff(time) <= gnss::rtk::PAIRING) {
            self.current = self.coming.take();
            self.coming = self.input.next_epoch().map_err(RunError::Raw)?;
        }
        let age = self.max_age + gnss::rtk::PAIRING;
        Ok(self.current.as_ref().filter(|x| time.diff(&x.time) <= age))
    }
}

/// What the run's RTK filter starts from: its options, the base's position and the
/// ephemerides (`AidReader::rtk`).
#[derive(Clone, Debug)]
pub struct RtkSetup {
    /// The filter's options.
    pub options: gnss::rtk::RtkOptions,
    /// The base station's antenna (ECEF, m).
    pub base: Vector3<f64>,
    /// The broadcast ephemerides (the rover's, copied once: the setup is shared).
    pub ephemerides: std::sync::Arc<gnss::Ephemerides>,
    /// What the base's file held that is not read (an RTCM 3 file's other messages).
    pub notes: Vec<String>,
}

/// Where a run's GNSS epochs come from.
pub enum AidReader {
    /// A receiver's fixes.
    Fixes(Box<GnssReader<Input>>),
    /// Raw observations.
    Raw(Box<RawReader>),
}

/// Raw observations read for tight coupling.
pub struct RawReader {
    input: RawInput,
    tight: TightConfig,
    /// The last single point (the next one starts there).
    prior: Option<Vector3<f64>>,
    /// The first epoch's GPS week: later weeks continue the seconds.
    week0: Option<i32>,
    /// Solve each epoch as a single point (the start and the first fix need them; the
    /// filter does not).
    single_points: bool,
    /// A heading file's headings (`data.heading`).
    headings: ins_gnss_core::heading::HeadingQueue,
    /// RTK: the base station's epochs and the filter's setup.
    base: Option<(BaseStream, RtkSetup)>,
}

impl AidReader {
    /// The configured GNSS input: `fixes` (already open) with loose coupling; the raw
    /// observations of `data.gnss` and `data.nav` with tight coupling.
    pub fn open(
        config: &Config,
        fixes: impl FnOnce() -> Result<GnssReader<Input>, RunError>,
    ) -> Result<Self, RunError> {
        if !config.gnss.coupling.is_raw() {
            return Ok(Self::Fixes(Box::new(fixes()?)));
        }
        let input = RawInput::open(&config.data.gnss, &config.data.nav).map_err(RunError::Raw)?;
        let models = config.gnss.tight.spp_options().map_err(|message| {
            RunError::Config(crate::config::ConfigError {
                path: PathBuf::from("gnss.tight"),
                message,
            })
        })?;
        // without broadcast coefficients, RTKLIB's fallback ones (as the single point)
        let klobuchar = input.nav.klobuchar.unwrap_or_default();
        let tight = TightConfig {
            models,
            klobuchar,
            use_doppler: config.gnss.tight.doppler,
            error_floor: config.gnss.tight.error_floor,
            carrier: config.gnss.tight.carrier,
            phase_std: config.gnss.tight.phase_std,
        };
        let headings = match &config.data.heading {
            Some(path) => ins_gnss_io::read_headings(path, config.bad_lines())?.list,
            None => Vec::new(),
        };
        let base = match config.gnss.coupling {
            Coupling::Rtk => Some(open_base(config, &input)?),
            _ => None,
        };
        let reader = RawReader {
            input,
            tight,
            prior: None,
            week0: None,
            single_points: true,
            headings: ins_gnss_core::heading::HeadingQueue::new(headings),
            base,
        };
        Ok(Self::Raw(Box::new(reader)))
    }

    /// The next epoch, `None` at the end.
    pub fn next_epoch(&mut self) -> Result<Option<AidEpoch>, RunError> {
        match self {
            AidReader::Fixes(r) => {
                Ok(r.next_epoch()?.map(|g| AidEpoch { t: g.t, fix: Some(g), raw: None, rtk: None }))
            }
            AidReader::Raw(r) => r.next_epoch(),
        }
    }

    /// The line the last epoch ended on (0: not a text file).
    pub fn line(&self) -> usize {
        match self {
            AidReader::Fixes(r) => r.line(),
            AidReader::Raw(r) => r.input.line(),
        }
    }

    /// The heading file's headings that found no fix at their time (0 without one).
    pub fn headings_unmatched(&self) -> usize {
        match self {
            AidReader::Fixes(r) => r.headings_unmatched(),
            AidReader::Raw(r) => r.headings.unmatched(),
        }
    }

    /// NMEA fixes whose σ came from their HDOP (0 for other inputs).
    pub fn sigma_from_hdop(&self) -> usize {
        match self {
            AidReader::Fixes(r) => r.nmea_sigma_from_hdop(),
            AidReader::Raw(_) => 0,
        }
    }

    /// Malformed lines skipped (fixes; raw files refuse them).
    pub fn skipped(&self) -> SkipCounts {
        match self {
            AidReader::Fixes(r) => r.skipped,
            AidReader::Raw(_) => SkipCounts::default(),
        }
    }

    /// From now on, raw epochs come without their single point (`fix` and clock `None`):
    /// once the run has started and has its first fix, nothing uses them. No effect on
    /// fixes.
    /// (RTK keeps them: each epoch's single point is the filter's leash while it floats.)
    pub fn skip_single_points(&mut self) {
        if let AidReader::Raw(r) = self
            && r.base.is_none()
        {
            r.single_points = false;
        }
    }

    /// The tight filter's satellite models (`None` with loose coupling and RTK).
    pub fn tight(&self) -> Option<&TightConfig> {
        match self {
            AidReader::Raw(r) if r.base.is_none() => Some(&r.tight),
            _ => None,
        }
    }

    /// RTK's setup (`None` without a base station).
    pub fn rtk(&self) -> Option<&RtkSetup> {
        match self {
            AidReader::Raw(r) => r.base.as_ref().map(|b| &b.1),
            AidReader::Fixes(_) => None,
        }
    }
}

/// The base station's observations (`data.base`) and the RTK filter's setup: its position
/// from `gnss.rtk.base_position` or the RINEX header, refused without either.
fn open_base(config: &Config, rover: &RawInput) -> Result<(BaseStream, RtkSetup), RunError> {
    let key = |k: &str, message: String| {
        RunError::Config(crate::config::ConfigError { path: PathBuf::from(k), message })
    };
    let path = config.data.base.as_ref().ok_or_else(|| {
        key("data.base", "`gnss.coupling = \"rtk\"` needs a base station's observations".into())
    })?;
    let mut input =
        RawInput::open_base(path, &config.data.nav, rover.near()).map_err(RunError::Raw)?;
    let base = match config.gnss.rtk.base_position {
        Some(p) => Vector3::from(p),
        None => input.approx_position().ok_or_else(|| {
            key(
                "gnss.rtk.base_position",
                format!(
                    "{}: no APPROX POSITION XYZ in the header (RTCM 3: no 1005 or 1006 \
                     message): give the base station's ECEF position",
                    path.display()
                ),
            )
        })?,
    };
    crate::config::rtk_settings::base_position(base.as_slice()).map_err(|e| {
        key(
            "gnss.rtk.base_position",
            format!("the base station's position {}: {e}", path.display()),
        )
    })?;
    let options = config.gnss.rtk.options().map_err(|m| key("gnss.rtk", m))?;
    let coming = input.next_epoch().map_err(RunError::Raw)?;
    let max_age = options.max_age;
    let ephemerides = std::sync::Arc::new(rover.nav.ephemerides.clone());
    let notes = input.unread().map(str::to_owned).into_iter().collect();
    let setup = RtkSetup { options, base, ephemerides, notes };
    Ok((BaseStream { input, current: None, coming, max_age }, setup))
}

impl RawReader {
    fn next_epoch(&mut self) -> Result<Option<AidEpoch>, RunError> {
        let Some(e) = self.input.next_epoch().map_err(RunError::Raw)? else {
            return Ok(None);
        };
        let week0 = *self.week0.get_or_insert(e.time.week);
        let t = e.time.tow + f64::from(e.time.week - week0) * 604_800.0;
        let eph = &self.input.nav.ephemerides;
        let opt: &SppOptions = &self.tight.models;
        let (sats, dropped) = prepare(&e, eph, opt);
        let kb = Some(&self.tight.klobuchar);
        let spp = self
            .single_points
            .then(|| solve_prepared(e.time, &sats, dropped, kb, opt, self.prior.as_ref()).ok())
            .flatten();
        if let Some(s) = &spp {
            self.prior = Some(s.pos);
        }
        let clock = spp.as_ref().and_then(|s| {
            let gps = s.clocks.iter().find(|(sys, _)| *sys == System::Gps);
            gps.or(s.clocks.first()).map(|c| c.1)
        });
        // the heading file's heading at this epoch (within 1 ms)
        let heading = self.headings.take(t);
        // (RTK: the instant of the rover's position, the stamp less the receiver clock's
        // offset; the single point's fix at the stamp, as tight coupling's)
        let offset = spp.as_ref().map_or(0.0, |s| s.solution_time().diff(&e.time));
        let fix = spp.map(|s| GnssEpoch { heading, ..GnssEpoch::from_single_point(&s, t) });
        if let Some((base, _)) = &mut self.base {
            let rtk = base
                .pair(&e.time)?
                .cloned()
                .map(|b| Box::new(RtkPair { rover: e, base: b, t: t + offset, clock: offset }));
            return Ok(Some(AidEpoch { t, fix, raw: None, rtk }));
        }
        Ok(Some(AidEpoch {
            t,
            fix,
            raw: Some((RawEpoch { t, time: e.time, sats, heading }, clock)),
            rtk: None,
        }))
    }
}
