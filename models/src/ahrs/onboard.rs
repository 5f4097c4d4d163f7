//! The AHRS as a flight controller runs it: one filter fed one sample at a time, and a
//! compact recording format for sensor sequences (raw 16-bit counts, as a MEMS part gives
//! them). Both are `no_std` without an allocator; the firmware example
//! (`firmware/`, run under QEMU) and the host replay (`cargo run -p models --example
//! ahrs_replay`) share them, so the two runs differ only in the machine.

use estimator_core::{
    ErrorStateFilter, FilterError, FilterScalar, FixedNoise, NoiseStrategy, StaticCov, UpdateReport,
};
use manifolds::{Real, So3};
use nalgebra::{Const, Quaternion, SMatrix, SVector, UnitQuaternion, Vector3};

use super::{AccelModel, AhrsInput, AhrsMeasurement, AhrsModel, AhrsState, AhrsTuning};
use crate::cs::CsVariance;

/// The paper's shared settings (see [`experiment`](super::experiment)): `P₀ = 0.01·I₉`,
/// `R = 0.02·I₆`, drift and acceleration starting at zero.
pub const P0: f64 = 0.01;
/// Measurement noise variance of each accelerometer and magnetometer axis.
pub const R: f64 = 0.02;

/// The CS-MAEKF of the experiment for a gyro with white noise `gyro_noise` (rad/s per
/// sample) at `rate` Hz: `α = 1/60`, the paper's membership and limits, σ_a² floor 1
/// ([`Variant::CsMaekf`](super::experiment::Variant::CsMaekf) builds this model).
pub fn cs_maekf_model(gyro_noise: f64, rate: f64) -> AhrsModel {
    AhrsModel {
        tuning: AhrsTuning { gyro_psd: gyro_noise * gyro_noise / rate, drift_psd: 1e-10 },
        accel: AccelModel::CurrentStatistical {
            alpha: 1.0 / 60.0,
            variance: CsVariance::default(),
        },
    }
}

/// An AHRS filter driven sample by sample: predict with the gyro, update with the
/// accelerometer and magnetometer; over the scalar `T` (`f64` unless named, `Ahrs<f32>` on
/// a single-precision FPU) with the noise strategy `A` ([`FixedNoise`] unless named). The
/// experiment, the Python binding, the host replay and the firmware all run the AHRS
/// through it.
#[derive(Clone, Debug)]
pub struct Ahrs<T: FilterScalar = f64, A: NoiseStrategy<T> = FixedNoise> {
    filter: ErrorStateFilter<AhrsState<T>, A, StaticCov, T>,
    model: AhrsModel,
    meas: AhrsMeasurement<T>,
    r: SMatrix<T, 6, 6>,
    dt: T,
}

impl<T: FilterScalar> Ahrs<T> {
    /// A filter at attitude `att0` with the paper's settings ([`P0`], [`R`], drift and
    /// acceleration zero), sampling at `rate` Hz.
    pub fn new(
        model: AhrsModel,
        meas: AhrsMeasurement<T>,
        att0: So3<T>,
        rate: f64,
    ) -> Result<Self, FilterError> {
        let x0 = AhrsState { att: att0, bg: Vector3::zeros(), acc: Vector3::zeros() };
        let p0 = SMatrix::<T, 9, 9>::identity() * T::lit(P0);
        let filter = ErrorStateFilter::new(x0, p0, FixedNoise)?;
        Ok(Self::from_filter(filter, model, meas, T::lit(R), rate))
    }
}

impl<T: FilterScalar, A: NoiseStrategy<T>> Ahrs<T, A> {
    /// Around a filter the caller set up (its start, `P₀` and strategy), with measurement
    /// noise `r·I₆`, sampling at `rate` Hz.
    pub fn from_filter(
        filter: ErrorStateFilter<AhrsState<T>, A, StaticCov, T>,
        model: AhrsModel,
        meas: AhrsMeasurement<T>,
        r: T,
        rate: f64,
    ) -> Self {
        let r = SMatrix::<T, 6, 6>::identity() * r;
        Self { filter, model, meas, r, dt: T::lit(1.0 / rate) }
    }

    /// The same filter with another covariance update formula (default: the Joseph form,
    /// multiplied out).
    pub fn with_update_form(mut self, form: estimator_core::UpdateForm) -> Self {
        self.filter = self.filter.with_update_form(form);
        self
    }

    /// The prediction over one sample interval with the mean angular rate `gyro` (rad/s);
    /// the current acceleration estimate is the CS model's `ā`. On `Err` the filter is
    /// unchanged.
    pub fn predict(&mut self, gyro: &Vector3<T>) -> Result<(), FilterError> {
        let u = AhrsInput { gyro: *gyro, abar: self.filter.state().acc };
        self.filter.predict(&self.model, &u, self.dt)
    }

    /// The update with the specific force `accel` (m/s²) and the magnetic field `mag` at
    /// the interval's end. On `Err` the filter is unchanged.
    pub fn update(
        &mut self,
        accel: &Vector3<T>,
        mag: &Vector3<T>,
    ) -> Result<UpdateReport<Const<6>, T>, FilterError> {
        let z = SVector::<T, 6>::new(accel.x, accel.y, accel.z, mag.x, mag.y, mag.z);
        self.filter.update(&self.meas, &z, &self.r)
    }

    /// One sample: [`predict`](Self::predict) then [`update`](Self::update). On `Err` from
    /// the update the prediction stays done.
    pub fn step(
        &mut self,
        gyro: &Vector3<T>,
        accel: &Vector3<T>,
        mag: &Vector3<T>,
    ) -> Result<UpdateReport<Const<6>, T>, FilterError> {
        self.predict(gyro)?;
        self.update(accel, mag)
    }

    /// The current state.
    pub fn state(&self) -> &AhrsState<T> {
        self.filter.state()
    }

    /// The filter (covariance, time, …).
    pub fn filter(&self) -> &ErrorStateFilter<AhrsState<T>, A, StaticCov, T> {
        &self.filter
    }
}

/// Why a recording could not be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordingError {
    /// The bytes do not start with [`Recording::MAGIC`].
    NotARecording,
    /// Shorter than its header says.
    Truncated,
}

impl core::fmt::Display for RecordingError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            RecordingError::NotARecording => "not an AHRS recording (magic bytes differ)",
            RecordingError::Truncated => "AHRS recording shorter than its header says",
        })
    }
}

/// A recorded sensor sequence: a header of little-endian `f64` constants, then per sample
/// nine little-endian `i16` counts (gyro x y z, accelerometer x y z, magnetometer x y z),
/// each scaled by its sensor's least significant bit.
///
/// | bytes | content |
/// |---|---|
/// | 8 | [`MAGIC`](Self::MAGIC) |
/// | 8 × 15 | rate (Hz), gyro white noise (rad/s per sample), `g_n` (3), `m_n` (3), initial attitude quaternion `w i j k` (4), LSB of gyro, accelerometer, magnetometer (3) |
/// | 4 | sample count `n` (`u32`) |
/// | 18 n | the samples |
#[derive(Clone, Copy, Debug)]
pub struct Recording<'a> {
    /// Sample rate, Hz.
    pub rate: f64,
    /// Gyro white noise, rad/s per sample (what the model's `gyro_psd` is built from).
    pub gyro_noise: f64,
    /// Gravity in NED, m/s².
    pub g_n: Vector3<f64>,
    /// Magnetic field in NED.
    pub m_n: Vector3<f64>,
    /// Attitude at the first sample.
    pub att0: So3,
    /// Least significant bits: gyro (rad/s), accelerometer (m/s²), magnetometer.
    pub lsb: [f64; 3],
    samples: &'a [u8],
}

impl<'a> Recording<'a> {
    /// The first eight bytes of a recording.
    pub const MAGIC: [u8; 8] = *b"AHRSREC1";
    const HEADER: usize = 8 + 8 * 15 + 4;
    const SAMPLE: usize = 18;

    /// Read a recording from its bytes (borrowed: nothing is copied).
    pub fn parse(bytes: &'a [u8]) -> Result<Self, RecordingError> {
        if bytes.len() < 8 || bytes[..8] != Self::MAGIC {
            return Err(RecordingError::NotARecording);
        }
        if bytes.len() < Self::HEADER {
            return Err(RecordingError::Truncated);
        }
        let f = |i: usize| {
            let o = 8 + 8 * i;
            let mut b = [0u8; 8];
            b.copy_from_slice(&bytes[o..o + 8]);
            f64::from_le_bytes(b)
        };
        let mut nb = [0u8; 4];
        nb.copy_from_slice(&bytes[Self::HEADER - 4..Self::HEADER]);
        let n = u32::from_le_bytes(nb) as usize;
        // (checked: a corrupt count must not overflow a 32-bit microcontroller's usize)
        let samples = n
            .checked_mul(Self::SAMPLE)
            .and_then(|len| len.checked_add(Self::HEADER))
            .and_then(|end| bytes.get(Self::HEADER..end))
            .ok_or(RecordingError::Truncated)?;
        let q = Quaternion::new(f(8), f(9), f(10), f(11));
        Ok(Self {
            rate: f(0),
            gyro_noise: f(1),
            g_n: Vector3::new(f(2), f(3), f(4)),
            m_n: Vector3::new(f(5), f(6), f(7)),
            // a unit quaternion is taken bit for bit (what was written is what is read);
            // anything else is normalised
            att0: if (q.norm() - 1.0).abs() < 1e-12 {
                So3::from_unit_quaternion_unchecked(UnitQuaternion::new_unchecked(q))
            } else {
                So3::from_quaternion(UnitQuaternion::new_unchecked(q))
            },
            lsb: [f(12), f(13), f(14)],
            samples,
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len() / Self::SAMPLE
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Sample `k`, scaled to SI units (count × LSB in `f64`, then rounded to `T`):
    /// `(gyro, accel, mag)`. `None` past the end.
    pub fn sample<T: Real>(&self, k: usize) -> Option<[Vector3<T>; 3]> {
        let s = self.samples.get(k * Self::SAMPLE..(k + 1) * Self::SAMPLE)?;
        let c = |i: usize| i16::from_le_bytes([s[2 * i], s[2 * i + 1]]) as f64;
        let v = |first: usize, lsb: f64| {
            Vector3::new(c(first) * lsb, c(first + 1) * lsb, c(first + 2) * lsb).map(T::lit)
        };
        Some([v(0, self.lsb[0]), v(3, self.lsb[1]), v(6, self.lsb[2])])
    }

    /// The bytes of a recording of `samples` (`(gyro, accel, mag)` in SI units, rounded to
    /// the nearest count and saturated at ±32767), appended to `out`.
    #[cfg(feature = "std")]
    #[allow(clippy::too_many_arguments)]
    pub fn write(
        out: &mut Vec<u8>,
        rate: f64,
        gyro_noise: f64,
        g_n: &Vector3<f64>,
        m_n: &Vector3<f64>,
        att0: &So3,
        lsb: [f64; 3],
        samples: &[[Vector3<f64>; 3]],
    ) {
        out.extend_from_slice(&Self::MAGIC);
        let q = att0.quaternion();
        let header = [
            rate, gyro_noise, g_n.x, g_n.y, g_n.z, m_n.x, m_n.y, m_n.z, q.w, q.i, q.j, q.k, lsb[0],
            lsb[1], lsb[2],
        ];
        for v in header {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&(samples.len() as u32).to_le_bytes());
        for s in samples {
            for (v, lsb) in s.iter().zip(lsb) {
                for x in v.iter() {
                    let c = (x / lsb).round().clamp(-32767.0, 32767.0) as i16;
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
    }
}
