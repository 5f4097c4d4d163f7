//! Checks against the GNSS course: the gyro scale from turns, the IMU–GNSS time offset.

use super::*;

/// The slope of the GNSS course change on the gyro's turn ([`turn_ratio`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurnRatio {
    /// Least-squares slope `Σ Δχ Δψ / Σ Δψ²`.
    pub ratio: f64,
    /// Pairs of consecutive moving fixes used.
    pub pairs: usize,
    /// Σ (Δχ − Δψ)², rad²: the misfit at the declared scale.
    pub misfit_declared: f64,
    /// Σ (Δχ − ratio·Δψ)², rad²: the misfit at the fitted slope.
    pub misfit_fitted: f64,
    /// Σ |ratio·Δψ|, rad: how far the vehicle turned by the fit.
    pub turned: f64,
}

/// Minimum horizontal speed for a fix's course, m/s (velocity given), or the distance
/// between its neighbours, m (course from positions; at least 4× their horizontal σ).
const COURSE_SPEED: f64 = 3.0;
const COURSE_BASE: f64 = 6.0;

/// Fixes of `(t_a, t_b]` about a second apart (a course from 0.2 s of noisy positions is
/// noise).
pub(super) fn fixes_a_second_apart(gnss: &[GnssEpoch], t_a: f64, t_b: f64) -> Vec<&GnssEpoch> {
    let mut fixes: Vec<&GnssEpoch> = Vec::new();
    for e in gnss.iter().filter(|e| e.t > t_a && e.t <= t_b) {
        if fixes.last().is_none_or(|l| e.t >= l.t + 0.9) {
            fixes.push(e);
        }
    }
    fixes
}

/// The horizontal noise (m, the norm of the two axes' σ) the fixes show from one to the
/// next: the median length of their second differences `p₊ − 2p + p₋` as the Rayleigh
/// median of white noise (`1.177 · √6 σ` per axis); motion's curvature only adds to it.
/// Errors that wander cancel in it as they cancel in a course from two fixes. `∞` for
/// fewer than 5 fixes (the declared σ then decides).
pub(super) fn shown_noise(fixes: &[&GnssEpoch]) -> f64 {
    let mut d2: Vec<f64> = fixes
        .windows(3)
        .map(|w| {
            let a = geodetic_to_local_ned(w[1].pos.tuple(), w[0].pos.tuple());
            let c = geodetic_to_local_ned(w[1].pos.tuple(), w[2].pos.tuple());
            (a + c).xy().norm()
        })
        .collect();
    if d2.len() < 3 {
        return f64::INFINITY;
    }
    let mid = d2.len() / 2;
    let median = *d2.select_nth_unstable_by(mid, f64::total_cmp).1;
    core::f64::consts::SQRT_2 * median / (1.1774 * 6f64.sqrt())
}

/// The course at each fix: from its velocity, else from its neighbours' positions (`None`
/// where it does not move enough to tell: less than [`COURSE_BASE`] or 4× their noise,
/// the declared σ or, when smaller, what the fixes show — a declared σ is a prior, and
/// fixes declared ten times noisier than they are left no course at a car's speed).
fn courses(fixes: &[&GnssEpoch]) -> Vec<Option<f64>> {
    let shown = shown_noise(fixes);
    (0..fixes.len())
        .map(|i| match fixes[i].vel {
            Some((v, _)) => (v.xy().norm() >= COURSE_SPEED).then(|| v.y.atan2(v.x)),
            None if i > 0 && i + 1 < fixes.len() => {
                let d = geodetic_to_local_ned(fixes[i - 1].pos.tuple(), fixes[i + 1].pos.tuple());
                let declared =
                    fixes[i - 1].pos_std.xy().norm().max(fixes[i + 1].pos_std.xy().norm());
                let noise = declared.min(shown);
                (d.xy().norm() >= COURSE_BASE.max(4.0 * noise)
                    && fixes[i + 1].t - fixes[i - 1].t <= 5.0)
                    .then(|| d.y.atan2(d.x))
            }
            None => None,
        })
        .collect()
}

/// A course change wrapped into (−π, π].
fn wrapped(d: f64) -> f64 {
    (d + core::f64::consts::PI).rem_euclid(2.0 * core::f64::consts::PI) - core::f64::consts::PI
}

/// The GNSS course change `Δχ` between consecutive moving fixes in `(t_a, t_b]` against
/// the gyro's rotation `Δψ` about the down axis (the mean specific force's opposite)
/// over the same interval. `None` when fewer than 10 pairs move.
pub fn turn_ratio(imu: &[ImuSample], gnss: &[GnssEpoch], t_a: f64, t_b: f64) -> Option<TurnRatio> {
    let imu: Vec<&ImuSample> = imu.iter().filter(|s| s.t > t_a && s.t <= t_b).collect();
    let fixes = fixes_a_second_apart(gnss, t_a, t_b);
    let f_sum: Vector3<f64> = imu.iter().map(|s| s.dvel).sum();
    let down = -f_sum.try_normalize(1e-12)?;
    let course = courses(&fixes);
    // the gyro's turn about `down` accumulated up to each fix
    let mut psi = Vec::with_capacity(fixes.len());
    let (mut acc, mut k) = (0.0, 0);
    for e in &fixes {
        while k < imu.len() && imu[k].t <= e.t {
            acc += imu[k].dtheta.dot(&down);
            k += 1;
        }
        psi.push(acc);
    }
    let mut pairs = Vec::new();
    for i in 1..fixes.len() {
        if let (Some(a), Some(b)) = (course[i - 1], course[i])
            && fixes[i].t - fixes[i - 1].t <= 2.5
        {
            pairs.push((wrapped(b - a), psi[i] - psi[i - 1]));
        }
    }
    if pairs.len() < 10 {
        return None;
    }
    let sxy: f64 = pairs.iter().map(|(x, y)| x * y).sum();
    let syy: f64 = pairs.iter().map(|(_, y)| y * y).sum();
    if syy <= 0.0 {
        return None;
    }
    let ratio = sxy / syy;
    let misfit = |r: f64| pairs.iter().map(|(x, y)| (x - r * y).powi(2)).sum::<f64>();
    Some(TurnRatio {
        ratio,
        pairs: pairs.len(),
        misfit_declared: misfit(1.0),
        misfit_fitted: misfit(ratio),
        turned: pairs.iter().map(|(_, y)| (ratio * y).abs()).sum(),
    })
}

/// The IMU–GNSS time offset [`time_offset`] finds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeOffset {
    /// Seconds by which the IMU's time stamps are late on the GNSS's: the gyro's turn at
    /// GNSS time `t` is stamped `t + offset` (so `−offset` added to the IMU's times
    /// corrects them).
    pub offset: f64,
    /// 1σ of [`offset`](Self::offset), s (from the misfit's curvature).
    pub std: f64,
    /// Pairs of consecutive moving fixes used.
    pub pairs: usize,
    /// `Σ (Δχ − Δψ)²` at no offset and at [`offset`](Self::offset), rad².
    pub misfit_zero: f64,
    /// See [`misfit_zero`](Self::misfit_zero).
    pub misfit_best: f64,
    /// `Σ |Δχ|` over the pairs: how far the course turned, rad.
    pub turned: f64,
    /// The lag-one autocorrelation of the residuals `Δχ − Δψ` at
    /// [`offset`](Self::offset), in pair order: fixes whose errors wander (a single-point
    /// receiver's) leave course errors that persist from pair to pair, and the pairs are
    /// then fewer independent samples than they number (`(1 − ρ)/(1 + ρ)` of them).
    pub lag_one: f64,
}

impl TimeOffset {
    /// The pairs' worth as independent samples, `n (1 − ρ)/(1 + ρ)` with the residuals'
    /// lag-one autocorrelation `ρ` (taken in `[0, 0.95]`).
    pub fn effective_pairs(&self) -> f64 {
        let rho = if self.lag_one.is_finite() { self.lag_one.clamp(0.0, 0.95) } else { 0.0 };
        self.pairs as f64 * (1.0 - rho) / (1.0 + rho)
    }
}

/// The first index `k` of the ascending `ts` with `ts[k] ≥ t` (`ts.len()` when none):
/// what `ts.partition_point(|&x| x < t)` gives, found from where a steady rate puts `t`
/// and a galloping search from there, so that a steady stream takes a comparison or two
/// instead of a binary search's twenty (the time-offset check asks it twice per fix
/// pair for each of its 1,001 offsets).
fn first_at_or_after(ts: &[f64], t: f64) -> usize {
    let n = ts.len();
    let (first, last) = match (ts.first(), ts.last()) {
        (Some(a), Some(b)) if b > a => (*a, *b),
        _ => return ts.partition_point(|&x| x < t),
    };
    let guess = (t - first) / (last - first) * (n - 1) as f64;
    // (a NaN guess is not in the range: the binary search decides)
    if !(0.0..n as f64).contains(&guess) {
        return ts.partition_point(|&x| x < t);
    }
    let k = guess as usize;
    // gallop to a bracket `lo < answer ≤ hi` (as indices: ts[lo] < t ≤ ts[hi], with
    // lo = −1 and hi = n standing for the ends), then search inside it
    let (lo, hi) = if ts[k] < t {
        let mut step = 1;
        let mut lo = k;
        loop {
            let probe = lo + step;
            if probe >= n {
                break (lo + 1, n);
            }
            if ts[probe] >= t {
                break (lo + 1, probe);
            }
            lo = probe;
            step *= 2;
        }
    } else {
        let mut step = 1;
        let mut hi = k;
        loop {
            if hi < step {
                break (0, hi);
            }
            let probe = hi - step;
            if ts[probe] < t {
                break (probe + 1, hi);
            }
            hi = probe;
            step *= 2;
        }
    };
    lo + ts[lo..hi].partition_point(|&x| x < t)
}

/// What a course stands for in [`time_offset`]: the span of the heading it averages
/// (start, end, s; one instant for a velocity's course) and its sideslip factor (the
/// antenna's lever arm ahead over the speed, s).
type CourseSpan = (f64, f64, f64);

/// Grid step of [`time_offset`]'s search, s (refined by a parabola through the best
/// point and its neighbours).
const OFFSET_STEP: f64 = 0.02;

/// The gyro's turn about the mean "down" of a span: ψ at each sample's end from the first
/// sample's start, and its integral Ψ (trapezoids: ψ is linear within a sample).
struct Turn {
    ts: Vec<f64>,
    psi: Vec<f64>,
    big: Vec<f64>,
}

impl Turn {
    fn of(imu: &[&ImuSample]) -> Option<Self> {
        let first = imu.first()?;
        let f_sum: Vector3<f64> = imu.iter().map(|s| s.dvel).sum();
        let down = -f_sum.try_normalize(1e-12)?;
        let mut ts = Vec::with_capacity(imu.len() + 1);
        let mut psi = Vec::with_capacity(imu.len() + 1);
        let mut big = Vec::with_capacity(imu.len() + 1);
        ts.push(first.t - first.dt);
        psi.push(0.0);
        big.push(0.0);
        for s in imu {
            let (t0, p0) = (ts[ts.len() - 1], psi[psi.len() - 1]);
            let p1 = p0 + s.dtheta.dot(&down);
            ts.push(s.t);
            psi.push(p1);
            big.push(big[big.len() - 1] + 0.5 * (p0 + p1) * (s.t - t0));
        }
        Some(Self { ts, psi, big })
    }

    /// ψ and Ψ at `t`, from one search.
    fn at(&self, t: f64) -> Option<(f64, f64)> {
        let (ts, psi, big) = (&self.ts, &self.psi, &self.big);
        let k = first_at_or_after(ts, t);
        if k == 0 || k >= ts.len() {
            return None;
        }
        let (h, dt, dpsi) = (t - ts[k - 1], ts[k] - ts[k - 1], psi[k] - psi[k - 1]);
        let slope = dpsi / dt;
        Some((psi[k - 1] + h / dt * dpsi, big[k - 1] + h * (psi[k - 1] + 0.5 * slope * h)))
    }

    fn psi_at(&self, t: f64) -> Option<f64> {
        self.at(t).map(|(p, _)| p)
    }

    /// The heading a course stands for, the IMU's stamps shifted by `d`: the instant's for
    /// a velocity's course, the mean over the chord's span for a chord's (a chord of a
    /// turn points along the mean heading, not the middle instant's: compared with the
    /// instant's, the rounding of the turn's corners looks like an offset of a quarter of
    /// the span, ±0.25 s for fixes 1 s apart, decisive on fixes of centimetres).
    /// (`slip`: the lever arm ahead over the speed, s: the antenna's course leads by
    /// `slip` times the turn rate)
    fn heading(&self, (a, b, slip): CourseSpan, d: f64) -> Option<f64> {
        if b - a < 1e-9 {
            let rate = (self.psi_at(a + d + 0.05)? - self.psi_at(a + d - 0.05)?) / 0.1;
            Some(self.psi_at(a + d)? + slip * rate)
        } else {
            let ((pa, ia), (pb, ib)) = (self.at(a + d)?, self.at(b + d)?);
            Some((ib - ia + slip * (pb - pa)) / (b - a))
        }
    }
}

/// The grid's least misfit refined at the vertex of the parabola through it and its
/// neighbours: (offset, misfit, the misfit's curvature there; NaN at the grid's edge or
/// where it does not curve up).
fn refine(grid: &[(f64, f64)], misfit: &dyn Fn(f64) -> Option<f64>) -> Option<(f64, f64, f64)> {
    let k = (0..grid.len()).min_by(|&a, &b| grid[a].1.total_cmp(&grid[b].1))?;
    let (mut offset, mut best) = grid[k];
    let mut curvature = f64::NAN;
    if k > 0 && k + 1 < grid.len() {
        let (m0, m1, m2) = (grid[k - 1].1, grid[k].1, grid[k + 1].1);
        let c = (m0 - 2.0 * m1 + m2) / (OFFSET_STEP * OFFSET_STEP);
        if c > 0.0 {
            let shift = 0.5 * OFFSET_STEP * (m0 - m2) / (m0 - 2.0 * m1 + m2);
            offset += shift;
            best = misfit(offset).unwrap_or(best).min(best);
            curvature = c;
        }
    }
    Some((offset, best, curvature))
}

/// The lag-one autocorrelation of a series (0 for a series of zeros).
fn lag_one(residuals: &[f64]) -> f64 {
    let (mut dot, mut sq) = (0.0, 0.0);
    for w in residuals.windows(2) {
        dot += w[0] * w[1];
    }
    for r in residuals {
        sq += r * r;
    }
    if sq > 0.0 {
        dot / sq
    } else {
        0.0
    }
}

/// The offset between the IMU's and the GNSS's time stamps within `±max_offset` s: the
/// GNSS course changes `Δχ` between consecutive moving fixes of `(t_a + max_offset,
/// t_b − max_offset]` (about a second apart, as [`turn_ratio`]) against the gyro's turn
/// about the down axis shifted by the candidate offset, `Δψ(δ) = ψ̄ᵢ(δ) − ψ̄ᵢ₋₁(δ)` (`ψ`
/// the gyro's rotation about down integrated sample by sample and interpolated; `ψ̄ᵢ(δ)`
/// the heading fix `i`'s course stands for: `ψ(tᵢ + δ)` for a velocity's course, the mean
/// of `ψ` over `(tᵢ₋₁ + δ, tᵢ₊₁ + δ)` for a chord's); the offset minimises
/// `Σ (Δχ − Δψ(δ))²`. The course turns
/// with the vehicle whatever its mounting, so the check needs no attitude. `None` when
/// fewer than 10 pairs move or the IMU does not cover the shifted intervals.
///
/// The antenna's course is its own, not the body's: an antenna `l_x` ahead of the IMU
/// (`lever`, body FRD) slips sideways by `r l_x` in a turn at rate `r`, its course leading
/// the heading by `r l_x / u` at speed `u` — an apparent offset of `l_x / u` (0.04 s for
/// 0.6 m at 15 m/s, decisive on fixes of centimetres); the headings are moved by it.
pub fn time_offset(
    imu: &[ImuSample],
    gnss: &[GnssEpoch],
    t_a: f64,
    t_b: f64,
    max_offset: f64,
    lever: &Vector3<f64>,
) -> Option<TimeOffset> {
    let (lo, hi) = (t_a + max_offset, t_b - max_offset);
    if hi <= lo {
        return None;
    }
    let imu: Vec<&ImuSample> =
        imu.iter().filter(|s| s.t > t_a - s.dt && s.t <= t_b + s.dt).collect();
    let turn = Turn::of(&imu)?;
    let heading = |span: CourseSpan, d: f64| turn.heading(span, d);
    let fixes = fixes_a_second_apart(gnss, lo, hi);
    let course = courses(&fixes);
    let span = |i: usize| match fixes[i].vel {
        Some((v, _)) => (fixes[i].t, fixes[i].t, lever.x / v.xy().norm()),
        None => {
            let (a, b) = (fixes[i - 1], fixes[i + 1]);
            let chord = geodetic_to_local_ned(a.pos.tuple(), b.pos.tuple()).xy().norm();
            (a.t, b.t, lever.x * (b.t - a.t) / chord)
        }
    };
    let mut pairs: Vec<(f64, CourseSpan, CourseSpan)> = Vec::new();
    for i in 1..fixes.len() {
        if let (Some(a), Some(b)) = (course[i - 1], course[i])
            && fixes[i].t - fixes[i - 1].t <= 2.5
        {
            pairs.push((wrapped(b - a), span(i - 1), span(i)));
        }
    }
    if pairs.len() < 10 {
        return None;
    }
    let misfit = |d: f64| -> Option<f64> {
        let mut sum = 0.0;
        for &(dchi, s0, s1) in &pairs {
            let dpsi = heading(s1, d)? - heading(s0, d)?;
            sum += (dchi - dpsi).powi(2);
        }
        Some(sum)
    };
    let n = (max_offset / OFFSET_STEP).round() as i64;
    let grid: Vec<(f64, f64)> = (-n..=n)
        .filter_map(|k| {
            let d = k as f64 * OFFSET_STEP;
            misfit(d).map(|m| (d, m))
        })
        .collect();
    let (offset, best, curvature) = refine(&grid, &misfit)?;
    // the residuals' lag-one autocorrelation at the offset found
    let residuals: Vec<f64> = pairs
        .iter()
        .filter_map(|&(dchi, s0, s1)| Some(dchi - (heading(s1, offset)? - heading(s0, offset)?)))
        .collect();
    let lag_one = lag_one(&residuals);
    // var(δ) = 2 s² / f'' for a least-squares misfit f with residual variance s²
    let s2 = best / (pairs.len() - 1) as f64;
    let std = if curvature > 0.0 { (2.0 * s2 / curvature).sqrt() } else { f64::INFINITY };
    Some(TimeOffset {
        offset,
        std,
        pairs: pairs.len(),
        misfit_zero: misfit(0.0)?,
        misfit_best: best,
        turned: pairs.iter().map(|p| p.0.abs()).sum(),
        lag_one,
    })
}

#[cfg(test)]
mod tests {
    use super::{first_at_or_after, shown_noise, GeoPos, GnssEpoch};
    use crate::earth::local_ned_to_geodetic;
    use nalgebra::Vector3;
    use rand::{rngs::StdRng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// Fixes along a straight road at 12 m/s, one a second, declaring `declared` m: the
    /// true track plus `err(k)`.
    fn road(n: usize, declared: f64, mut err: impl FnMut(usize) -> Vector3<f64>) -> Vec<GnssEpoch> {
        let origin = (0.7, 0.2, 100.0);
        (0..n)
            .map(|k| {
                let ned = Vector3::new(12.0 * k as f64, 5.0 * k as f64, 0.0) + err(k);
                let (lat, lon, h) = local_ned_to_geodetic(origin, &ned);
                GnssEpoch {
                    t: k as f64,
                    pos: GeoPos { lat, lon, h },
                    pos_std: Vector3::repeat(declared),
                    vel: None,
                    pos_cov: None,
                    vel_cov: None,
                    heading: None,
                }
            })
            .collect()
    }

    /// The noise the fixes show is their white σ (the horizontal norm, √2 σ), whatever
    /// they declare, over 5 seeds and σ from 0.3 to 3 m; a wander of 3 m over 300 s beside
    /// 0.5 m of white noise shows as the white part (the wander cancels in a course).
    #[test]
    fn fixes_show_their_white_noise_whatever_they_declare() {
        for seed in 0..5u64 {
            let mut rng = StdRng::seed_from_u64(seed);
            for sigma in [0.3, 1.0, 3.0] {
                let white = Normal::new(0.0, sigma).unwrap();
                let fixes =
                    road(400, 10.0 * sigma, |_| Vector3::from_fn(|_, _| white.sample(&mut rng)));
                let refs: Vec<&GnssEpoch> = fixes.iter().collect();
                let shown = shown_noise(&refs) / (2f64.sqrt() * sigma);
                assert!((0.85..1.15).contains(&shown), "seed {seed}, σ {sigma}: {shown}");
            }
            // a first-order Gauss–Markov wander, σ 3 m, τ 300 s, plus 0.5 m white
            let (tau, s) = (300.0f64, 3.0);
            let phi = (-1.0 / tau).exp();
            let step = Normal::new(0.0, s * (1.0 - phi * phi).sqrt()).unwrap();
            let white = Normal::new(0.0, 0.5).unwrap();
            let mut w = Vector3::zeros();
            let fixes = road(400, 3.0, |_| {
                w = w * phi + Vector3::from_fn(|_, _| step.sample(&mut rng));
                w + Vector3::from_fn(|_, _| white.sample(&mut rng))
            });
            let refs: Vec<&GnssEpoch> = fixes.iter().collect();
            let shown = shown_noise(&refs) / (2f64.sqrt() * 0.5);
            assert!((0.85..1.25).contains(&shown), "seed {seed}, wander: {shown}");
        }
        // too few fixes to tell: the declared σ decides
        let fixes = road(4, 1.0, |_| Vector3::zeros());
        let refs: Vec<&GnssEpoch> = fixes.iter().collect();
        assert_eq!(shown_noise(&refs), f64::INFINITY);
    }

    proptest::proptest! {
        /// The galloping search from a steady rate's guess finds what the binary search
        /// finds: on steady streams, streams with gaps and repeated times, and for times
        /// before, inside and after them.
        #[test]
        fn the_guessed_search_is_the_binary_one(
            start in -1e5f64..1e5,
            steps in proptest::collection::vec((0u8..6, 0.0f64..1.0), 0..300),
            probes in proptest::collection::vec(-0.2f64..1.2, 1..40),
        ) {
            // steps: mostly steady, some repeated, some gaps of up to a thousand steps
            let mut ts = Vec::with_capacity(steps.len());
            let mut t = start;
            for (kind, jitter) in &steps {
                t += match kind {
                    0 => 0.0,
                    1 => 1000.0 * 0.005 * jitter,
                    _ => 0.005 * (1.0 + 1e-3 * jitter),
                };
                ts.push(t);
            }
            let span = ts.last().map_or(1.0, |l| l - start).max(1e-3);
            for p in &probes {
                let q = start + p * span;
                for q in [q, ts.get((p.abs() * 7.0) as usize % ts.len().max(1)).copied().unwrap_or(q)] {
                    proptest::prop_assert_eq!(
                        first_at_or_after(&ts, q),
                        ts.partition_point(|&x| x < q),
                        "t = {} in {:?}", q, ts
                    );
                }
            }
            for q in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                proptest::prop_assert_eq!(first_at_or_after(&ts, q), ts.partition_point(|&x| x < q));
            }
        }
    }
}
