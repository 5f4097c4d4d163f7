//! The robust fit: residuals, their robust scale, and the consensus over subsets that refuses gross fixes.

use super::*;

/// A fix's residual beyond this many times the fixes' robust scale (and at least this
/// many σ) is a gross error to the in-motion fit: the norm of a 3-D residual in units of
/// its σ exceeds 8 with probability 1e-13, so no fit the model explains is touched for it.
pub const GROSS: f64 = 8.0;

/// The RMS residual (in units of the fixes' σ) beyond which the least-squares in-motion
/// fit is not kept as it is but found again by consensus: navego fits at 1.4σ, and with
/// gross errors among its fixes at tens; drive-0708's centimetre RTK fixes, which the
/// model misfits beyond 4σ, go to the consensus too (54 of 287 fixes left out there).
pub const MISFIT: f64 = 4.0;

/// Samples of six fixes tried by the consensus fit: a sample of fixes half of which are
/// gross errors is clean with probability 1/64, so 500 samples all miss with probability
/// 4e-4 (a sample is a 3×3 SVD and one pass over the fixes).
pub(super) const CONSENSUS_SAMPLES: usize = 500;

/// The norm of each fix's residual at `x`, in units of its σ.
pub(super) fn residuals(fixes: &[Fix], x: &Params) -> Vec<f64> {
    fixes
        .iter()
        .map(|f| {
            let r = f.y - (x.p0 + x.v0 * f.tau + x.c * (f.a + f.jac * x.db));
            r.norm() * f.w.sqrt()
        })
        .collect()
}

/// The robust scale of normalised 3-D residuals: their median over the median of χ(3)
/// (1.538), at least 1.
pub(super) fn robust_scale(r: &[f64]) -> f64 {
    let mut v: Vec<f64> = r.to_vec();
    if v.is_empty() {
        return 1.0;
    }
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    (*m / 1.538).max(1.0)
}

/// The sums of the fixes in `keep`.
pub(super) fn sums_of<'a>(fixes: impl IntoIterator<Item = &'a Fix>) -> Sums {
    let mut s = Sums::default();
    for f in fixes {
        s.add(f.tau, &f.y, &f.a, f.w);
    }
    s
}

/// The in-motion fit with gross errors left out. The least-squares fit ([`solve`]) is
/// kept when its RMS residual is at most [`MISFIT`] and it leaves no fix beyond
/// [`GROSS`] × the robust scale of its residuals (navego: the same fit as before).
/// Otherwise a consensus: samples of six fixes, one from each sixth of the span, each solved in closed form (Wahba's problem), are scored
/// by the 35 % quantile of all fixes' residuals (a least-quantile criterion, which holds
/// with up to 65 % of the fixes wrong where a least-median one breaks at 50 %); the fixes
/// within [`GROSS`] × the best sample's robust scale are fitted again, and those within it
/// of that fit make the result. Sampling is seeded by the number of fixes, so a run is
/// repeatable.
///
/// Why a consensus and not an M-estimator, measured (`benches/campaign.py`, navego, 1 km
/// errors at random bearings, 10 seeds per cell): a Tukey-biweight IRLS started from the
/// least-squares fit did as well up to 20 % of the fixes, but with half of them wrong from
/// the first fix and no `[init]` it kept every fix in 3 of 10 seeds ("finds the heading
/// only to ±22–30°", refused), where the consensus started all 10; least squares, which
/// half of the fixes 1 km off pull far away, is a start the weights do not recover from.
pub(super) fn robust_solve(
    fixes: &[Fix],
    reference: GeoPos,
    t_a: f64,
    t_b: f64,
    gyro_bias: &Vector3<f64>,
    priors: Priors,
) -> Option<MotionFit> {
    let all = sums_of(fixes);
    let ls = solve(&all, fixes, reference, t_a, t_b, gyro_bias, priors);
    if let Some((fit, x)) = &ls {
        // (a fit that half of the fixes pulled away leaves every residual large, the good
        // fixes' too, so their median is no scale: such a fit shows in its RMS)
        let r = residuals(fixes, x);
        let scale = robust_scale(&r);
        if fit.residual <= MISFIT && r.iter().all(|&v| v <= GROSS * scale) {
            return Some(*fit);
        }
    }
    let n = fixes.len();
    if n < 12 {
        return ls.map(|(f, _)| f);
    }
    // consensus over stratified samples of six
    let mut rng = (n as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move |k: usize| {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng % k as u64) as usize
    };
    let h = ((n as f64 * 0.35).ceil() as usize).clamp(7, n) - 1;
    let mut best: Option<(f64, Params)> = None;
    let mut r = vec![0.0; n];
    for _ in 0..CONSENSUS_SAMPLES {
        let mut s = Sums::default();
        for b in 0..6 {
            let (lo, hi) = (b * n / 6, (b + 1) * n / 6);
            let f = &fixes[lo + next(hi - lo)];
            s.add(f.tau, &f.y, &f.a, f.w);
        }
        let Some((x, _)) = closed_form(&s) else { continue };
        for (ri, f) in r.iter_mut().zip(fixes) {
            let d = f.y - (x.p0 + x.v0 * f.tau + x.c * f.a);
            *ri = d.norm() * f.w.sqrt();
        }
        let (_, q, _) = r.select_nth_unstable_by(h, f64::total_cmp);
        let q = *q;
        if best.as_ref().is_none_or(|(b, _)| q < *b) {
            best = Some((q, x));
        }
    }
    let (_, x) = best?;
    // the fixes the best sample explains, fitted again; then those the refit explains
    let keep = |x: &Params| -> Vec<Fix> {
        let r = residuals(fixes, x);
        let mut inl: Vec<f64> = r.clone();
        inl.sort_by(f64::total_cmp);
        let scale = robust_scale(&inl[..=h]);
        fixes.iter().zip(&r).filter(|&(_, &v)| v <= GROSS * scale).map(|(f, _)| *f).collect()
    };
    let first = keep(&x);
    if first.len() < 8 {
        return ls.map(|(f, _)| f);
    }
    let (_, x1) = solve(&sums_of(&first), &first, reference, t_a, t_b, gyro_bias, priors)?;
    let used = keep(&x1);
    if used.len() < 8 {
        return ls.map(|(f, _)| f);
    }
    let (mut fit, _) = solve(&sums_of(&used), &used, reference, t_a, t_b, gyro_bias, priors)?;
    fit.rejected = n - used.len();
    Some(fit)
}
