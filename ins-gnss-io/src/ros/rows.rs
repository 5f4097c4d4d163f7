//! A recording as the IMU and GNSS formats' rows, with its rate and noise.

use super::*;

impl Recording {
    /// The offset that takes the recording's Unix times to GPST seconds of week (taken at
    /// the first IMU message, kept for the whole recording).
    pub fn gpst_offset(&self) -> f64 {
        let t0 = self.imu.first().map_or(0.0, |r| r.t);
        TimeScale::UnixUtc.offset_at(t0)
    }

    /// The IMU's rate, Hz: the median interval of its messages.
    pub fn imu_rate(&self) -> Option<f64> {
        let mut dt: Vec<f64> = self.imu.windows(2).map(|w| w[1].t - w[0].t).collect();
        if dt.is_empty() {
            return None;
        }
        dt.sort_by(f64::total_cmp);
        let median = dt[dt.len() / 2];
        (median > 0.0).then(|| 1.0 / median)
    }

    /// The median of the IMU messages' covariance diagonals, σ per sample (rad/s and
    /// m/s²), when they give them.
    pub fn imu_sigma(&self) -> Option<([f64; 3], [f64; 3])> {
        let median = |get: &dyn Fn(&ImuRecord) -> f64| {
            let mut v: Vec<f64> =
                self.imu.iter().map(get).filter(|v| v.is_finite() && *v > 0.0).collect();
            if v.len() < self.imu.len() / 2 || v.is_empty() {
                return None;
            }
            v.sort_by(f64::total_cmp);
            Some(v[v.len() / 2].sqrt())
        };
        let mut w = [0.0; 3];
        let mut f = [0.0; 3];
        for i in 0..3 {
            w[i] = median(&|r: &ImuRecord| r.w_var[i])?;
            f[i] = median(&|r: &ImuRecord| r.f_var[i])?;
        }
        Some((w, f))
    }

    /// The IMU rows of the rates format (`t` in GPST seconds of week, ω in rad/s, f in
    /// m/s²), with the odometry's forward speed as an 8th column when read (linear
    /// between the odometry messages around each sample, held before the first and
    /// after the last). Returns the rows, their width and the longest odometry interval
    /// a sample fell in, s.
    pub fn imu_rows(&self) -> (Vec<f64>, usize, f64) {
        let offset = self.gpst_offset();
        let width = if self.odometry_topic.is_some() { 8 } else { 7 };
        let mut rows = Vec::with_capacity(self.imu.len() * width);
        let mut longest: f64 = 0.0;
        let mut k = 0;
        for r in &self.imu {
            rows.push(r.t + offset);
            rows.extend_from_slice(&r.w);
            rows.extend_from_slice(&r.f);
            if width == 8 {
                let o = &self.odometry;
                while k + 1 < o.len() && o[k + 1].t <= r.t {
                    k += 1;
                }
                let speed = match (o.get(k), o.get(k + 1)) {
                    (Some(a), Some(b)) if a.t <= r.t && b.t > a.t => {
                        longest = longest.max(b.t - a.t);
                        a.speed + (b.speed - a.speed) * (r.t - a.t) / (b.t - a.t)
                    }
                    (Some(a), _) => a.speed,
                    (None, _) => 0.0,
                };
                rows.push(speed);
            }
        }
        (rows, width, longest)
    }

    /// The GNSS rows of the 7-column format (`t`, latitude and longitude in degrees,
    /// height, σ N E D in m). A fix without a position (status −1) is left out, as are
    /// the statuses `quality` drops (status 0 as `single`, 1 SBAS as `sbas`, 2 GBAS as
    /// `dgps`). The σ are the message's covariance as it is: `quality`'s factors, which
    /// make up for RTKLIB's and NMEA's optimistic σ, are not applied (on the Husky bag
    /// the SBAS factor 5 left the innovations at 0.21× their σ; as given, 0.42×). A fix
    /// whose covariance is unknown (type 0) takes `sigma` (N, E, D), and is refused
    /// without it; `sigma` replaces every fix's when given. Returns the rows and the
    /// fixes left out.
    pub fn fix_rows(
        &self,
        quality: &QualityFactors,
        sigma: Option<[f64; 3]>,
        sigma_key: &str,
    ) -> Result<(Vec<f64>, usize), LineError> {
        let offset = self.gpst_offset();
        let mut rows = Vec::with_capacity(self.fixes.len() * 7);
        let mut dropped = 0;
        for (i, r) in self.fixes.iter().enumerate() {
            // RTKLIB's qualities: 5 single, 3 SBAS, 4 DGPS
            let q = match r.status {
                0 => 5,
                1 => 3,
                2 => 4,
                _ => {
                    dropped += 1;
                    continue;
                }
            };
            if quality.drop[q] {
                dropped += 1;
                continue;
            }
            let s = match (r.covariance_type, sigma) {
                (_, Some(s)) => s,
                (0, None) => {
                    return Err(LineError {
                        path: self.fix_name(),
                        line: i + 1,
                        kind: LineErrorKind::Invalid(format!(
                            "NavSatFix with an unknown covariance (type 0): set `{sigma_key}`"
                        )),
                    });
                }
                (_, None) => {
                    let v = r.var_enu;
                    [v[1].sqrt(), v[0].sqrt(), v[2].sqrt()]
                }
            };
            rows.push(r.t + offset);
            rows.extend_from_slice(&r.position);
            rows.extend_from_slice(&s);
        }
        Ok((rows, dropped))
    }

    /// The name the IMU rows go by in errors: the file and topic.
    pub fn imu_name(&self) -> PathBuf {
        PathBuf::from(format!("{} {}", self.path.display(), self.imu_topic.0))
    }

    /// The name the GNSS rows go by in errors.
    pub fn fix_name(&self) -> PathBuf {
        PathBuf::from(format!("{} {}", self.path.display(), self.fix_topic.0))
    }
}
