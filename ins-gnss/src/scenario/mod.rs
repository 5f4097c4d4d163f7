//! Scenario files for `ins-gnss simulate`: a trajectory from segments, IMU errors, a
//! GNSS receiver with windows, and the initial uncertainty the generated configuration
//! should state. Units are the datasheet ones (deg, deg/s, deg/h, mGal, ppm, hours).
//! A commented example is `ins-gnss/scenarios/drive.toml`.

use std::io::Write;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::checks::{finite, nonneg, positive};
use crate::config::{Config, DataSection, FilterSection, GnssSection, InitSection, NoiseSection};
use crate::run::nav_record;
use ins_gnss_core::imu::{BiasModel, ImuNoise, DEG_PER_H, DEG_PER_SQRT_H, MGAL, M_S_PER_SQRT_H};
use ins_gnss_core::GeoPos;
use ins_gnss_io::formats::{
    create_partial, partial_path, publish, write_gnss, write_imu, write_nav,
};

mod monte_carlo;
mod spec;
mod write;

pub use monte_carlo::{MonteCarlo, SeedRun};
pub use spec::*;

use ins_gnss_sim::{
    self, GnssSim, GnssWindow, GnssWindowKind, ImuErrors, Segment, Start, Trajectory,
};

/// A scenario file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Random seed.
    pub seed: u64,
    /// Start.
    pub start: StartSpec,
    /// Segments, in order.
    #[serde(rename = "segment")]
    pub segments: Vec<SegmentSpec>,
    /// IMU.
    pub imu: ImuSpec,
    /// GNSS.
    pub gnss: GnssSpec,
    /// Initial uncertainty.
    pub init: InitSpec,
    /// Raw observations (`obs.rnx`) beside the fixes, and a configuration that couples
    /// them tightly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raw: Option<RawSpec>,
}

fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

fn io_err(path: &Path, e: std::io::Error) -> String {
    format!("{}: {e}", path.display())
}

impl Scenario {
    /// Load a scenario file; errors name the file and the key.
    pub fn load(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| io_err(path, e))?;
        let mut s = Self::parse(&text, &path.display().to_string())?;
        if let Some(r) = s.raw.as_mut().filter(|r| r.nav.is_relative()) {
            r.nav = path.parent().unwrap_or(Path::new(".")).join(&r.nav);
        }
        Ok(s)
    }

    /// Parse the text of a scenario file and [`validate`](Self::validate) it; errors name
    /// `source` and the key.
    pub fn parse(text: &str, source: &str) -> Result<Self, String> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let s: Self = toml::from_str(text).map_err(|e| format!("{source}: {e}"))?;
        s.validate().map_err(|e| format!("{source}: {e}"))?;
        Ok(s)
    }

    /// Every value finite and physical; the message names the key and the limit.
    pub fn validate(&self) -> Result<(), String> {
        self.start.validate()?;
        if self.segments.is_empty() {
            return Err("`segment`: at least one segment is needed".into());
        }
        for (i, seg) in self.segments.iter().enumerate() {
            positive(&format!("segment[{i}].duration"), &[seg.duration])?;
            finite(&format!("segment[{i}].rate"), &[seg.rate])?;
            nonneg(&format!("segment[{i}].accel"), &[seg.accel])?;
        }
        self.imu.validate()?;
        positive("gnss.rate", &[self.gnss.rate])?;
        if let Some(r) = &self.raw {
            r.validate()?;
        }
        self.gnss.validate(self.imu.rate)?;
        self.init.validate()
    }

    /// The built-in demo: the 600 s drive, a consumer MEMS IMU at 100 Hz, GNSS position
    /// and velocity at 1 Hz with interference (×8 noise) at 200–260 s and an outage at
    /// 400–460 s.
    pub fn demo() -> Self {
        let (start, segs) = ins_gnss_sim::scenarios::drive_600s();
        let d = 180.0 / core::f64::consts::PI;
        let segments = segs.iter().map(SegmentSpec::of).collect();
        Scenario {
            seed: 7,
            start: StartSpec {
                time: start.t,
                position: [start.pos.lat * d, start.pos.lon * d, start.pos.h],
                speed: start.speed,
                yaw: start.yaw * d,
                pitch: start.pitch * d,
            },
            segments,
            imu: ImuSpec {
                rate: 100.0,
                arw: 0.3,
                vrw: 0.1,
                gyro_bias_std: 10.0,
                accel_bias_std: 100.0,
                corr_time: 1.0,
                gyro_turn_on: [50.0, -40.0, 30.0],
                accel_turn_on: [500.0, -400.0, 300.0],
                gyro_scale_ppm: [0.0; 3],
                accel_scale_ppm: [0.0; 3],
                vibration: [0.0; 2],
                mounting: [0.0; 3],
                odometer: None,
            },
            gnss: GnssSpec {
                rate: 1.0,
                position_std: [1.0, 1.0, 2.0],
                velocity_std: Some([0.05; 3]),
                lever_arm: [0.5, 0.2, -1.0],
                heading: None,
                windows: vec![
                    WindowSpec {
                        start: 200.0,
                        end: 260.0,
                        kind: "interference".into(),
                        factor: 8.0,
                        probability: 0.0,
                        sigmas: 0.0,
                    },
                    WindowSpec {
                        start: 400.0,
                        end: 460.0,
                        kind: "outage".into(),
                        factor: 0.0,
                        probability: 0.0,
                        sigmas: 0.0,
                    },
                ],
            },
            init: InitSpec {
                attitude_std: [1.0, 1.0, 3.0],
                velocity_std: [0.1; 3],
                position_std: [2.0, 2.0, 3.0],
                attitude_error: [0.5, -0.5, 2.0],
                velocity_error: [0.05, -0.05, 0.02],
                position_error: [1.0, -1.0, 1.5],
            },
            raw: None,
        }
    }

    /// The trajectory.
    pub fn trajectory(&self) -> Result<Trajectory, String> {
        let r = core::f64::consts::PI / 180.0;
        let segs: Result<Vec<Segment>, String> = self
            .segments
            .iter()
            .enumerate()
            .map(|(i, s)| match s.kind.as_str() {
                "stop" => Ok(Segment::stop(s.duration)),
                "straight" => Ok(Segment::straight(s.duration)),
                "turn" => Ok(Segment::turn(s.duration, s.rate * r)),
                "climb" => Ok(Segment::climb(s.duration, s.rate * r)),
                "accelerate" => Ok(Segment::accelerate(s.duration, s.accel)),
                "decelerate" => Ok(Segment::decelerate(s.duration, s.accel)),
                other => Err(format!(
                    "segment {i}: unknown kind `{other}` (stop, straight, turn, accelerate, decelerate, climb)"
                )),
            })
            .collect();
        let p = self.start.position;
        let start = Start {
            t: self.start.time,
            pos: GeoPos::from_degrees(p[0], p[1], p[2]),
            speed: self.start.speed,
            yaw: self.start.yaw * r,
            pitch: self.start.pitch * r,
        };
        Trajectory::new(start, &segs?).map_err(|e| e.to_string())
    }

    /// IMU errors in SI units.
    pub fn imu_errors(&self) -> ImuErrors {
        let i = &self.imu;
        ImuErrors {
            noise: ImuNoise {
                arw: Vector3::repeat(i.arw * DEG_PER_SQRT_H),
                vrw: Vector3::repeat(i.vrw * M_S_PER_SQRT_H),
                gyro_bias: Vector3::repeat(i.gyro_bias_std * DEG_PER_H),
                accel_bias: Vector3::repeat(i.accel_bias_std * MGAL),
                bias_model: BiasModel::GaussMarkov { tau: i.corr_time * 3600.0 },
            },
            gyro_turn_on: v3(i.gyro_turn_on) * DEG_PER_H,
            accel_turn_on: v3(i.accel_turn_on) * MGAL,
            gyro_scale: v3(i.gyro_scale_ppm) * 1e-6,
            accel_scale: v3(i.accel_scale_ppm) * 1e-6,
            vibration: (i.vibration[0].to_radians(), i.vibration[1]),
            odometer: i.odometer.map(|[scale, sigma]| (scale * 1e-6, sigma)),
            mounting: v3(i.mounting) * (core::f64::consts::PI / 180.0),
        }
    }

    /// The GNSS receiver.
    pub fn gnss_sim(&self) -> Result<GnssSim, String> {
        let windows: Result<Vec<GnssWindow>, String> = self
            .gnss
            .windows
            .iter()
            .enumerate()
            .map(|(i, w)| {
                let kind = match w.kind.as_str() {
                    "outage" => GnssWindowKind::Outage,
                    "interference" if w.factor > 0.0 => {
                        GnssWindowKind::Interference { factor: w.factor }
                    }
                    "outliers" if w.probability >= 0.0 && w.sigmas > 0.0 => {
                        GnssWindowKind::Outliers { probability: w.probability, sigmas: w.sigmas }
                    }
                    "interference" => {
                        return Err(format!("gnss.window {i}: interference needs `factor` > 0"))
                    }
                    "outliers" => {
                        return Err(format!(
                            "gnss.window {i}: outliers need `probability` and `sigmas` > 0"
                        ))
                    }
                    other => {
                        return Err(format!(
                        "gnss.window {i}: unknown kind `{other}` (outage, interference, outliers)"
                    ))
                    }
                };
                Ok(GnssWindow { start: w.start, end: w.end, kind })
            })
            .collect();
        Ok(GnssSim {
            rate_hz: self.gnss.rate,
            pos_sigma: v3(self.gnss.position_std),
            vel_sigma: self.gnss.velocity_std.map(v3),
            lever_arm: v3(self.gnss.lever_arm),
            windows: windows?,
        })
    }
}

impl SegmentSpec {
    /// The file's form of a simulator segment (degrees).
    fn of(s: &ins_gnss_sim::Segment) -> Self {
        let d = 180.0 / core::f64::consts::PI;
        let (kind, rate, accel) = if s.yaw_rate != 0.0 {
            ("turn", s.yaw_rate * d, 0.0)
        } else if s.pitch_rate != 0.0 {
            ("climb", s.pitch_rate * d, 0.0)
        } else if s.accel > 0.0 {
            ("accelerate", 0.0, s.accel)
        } else if s.accel < 0.0 {
            ("decelerate", 0.0, -s.accel)
        } else {
            ("straight", 0.0, 0.0)
        };
        SegmentSpec { kind: kind.into(), duration: s.duration, rate, accel }
    }
}
