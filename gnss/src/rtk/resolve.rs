//! The integer ambiguities: the float solution's resolution (LAMBDA, the ratio test, the
//! success rate), the position conditioned on a fix, and fix-and-hold.

use nalgebra::{DMatrix, DVector, Vector3};

use super::*;

impl Rtk {
    /// The float solution, or the fixed one when the ratio test passes; with a fix whose
    /// float covariance promised [`HOLD_SUCCESS_RATE`], its integer combinations of the
    /// states (cycles) and their integers, which fix-and-hold may use.
    pub(super) fn resolve(
        &self,
        time: GpsTime,
        groups: &[Vec<Common>],
        sats: usize,
    ) -> (RtkEpoch, Option<Fix>) {
        let n = self.x.len();
        let pos = Vector3::new(self.x[0], self.x[1], self.x[2]);
        let cov = self.p.fixed_view::<3, 3>(0, 0).into_owned();
        let float =
            RtkEpoch { time, pos, cov, fixed: false, fixed_ambiguities: 0, ratio: f64::NAN, sats };
        // G: double-differenced ambiguities in cycles from the states
        let m: usize = groups.iter().map(|g| g.len() - 1).sum();
        let mut g_mat = DMatrix::zeros(m, n);
        let mut row = 0;
        for g in groups {
            let j0 = self.slots[&g[0].key].0;
            for c in &g[1..] {
                let j = self.slots[&c.key].0;
                g_mat[(row, j)] = 1.0 / c.wavelength;
                g_mat[(row, j0)] = -1.0 / c.wavelength;
                row += 1;
            }
        }
        let a = &g_mat * &self.x;
        let q = &g_mat * &self.p * g_mat.transpose();
        let q = (&q + q.transpose()) * 0.5;
        let Ok(found) = lambda::solve(a.as_slice(), &q, 2) else {
            return (float, None);
        };
        let ratio = found.ratio();
        if ratio >= self.opt.ratio
            && found.success_rate >= self.opt.min_success_rate
            && let Some(e) = self.condition(&float, &g_mat, &a, &q, found.best(), ratio)
        {
            let holdable = found.success_rate >= HOLD_SUCCESS_RATE;
            return (e, holdable.then(|| (g_mat, integers(found.best()))));
        }
        if self.opt.partial {
            let least =
                if self.opt.min_success_rate > 0.0 { self.opt.min_success_rate } else { 0.999 };
            if let Ok(Some(part)) = lambda::solve_partial(a.as_slice(), &q, least) {
                let r = part.solution.ratio();
                if r >= self.opt.ratio {
                    let combos = &part.combinations * &g_mat;
                    let a_c = &combos * &self.x;
                    let q_c = &combos * &self.p * combos.transpose();
                    let best = part.solution.best();
                    if let Some(e) = self.condition(&float, &combos, &a_c, &q_c, best, r) {
                        let holdable = part.solution.success_rate >= HOLD_SUCCESS_RATE;
                        return (e, holdable.then(|| (combos, integers(best))));
                    }
                }
            }
        }
        (RtkEpoch { ratio, ..float }, None)
    }

    /// The float solution conditioned on the integer combinations `h x = fixed` of the
    /// states, whose float values `a = h x̂` and covariance `q = h P hᵀ` the caller has:
    /// `x̌ = x̂ − P hᵀ q⁻¹ (a − ǎ)` for the position and its covariance.
    #[allow(clippy::too_many_arguments)]
    fn condition(
        &self,
        float: &RtkEpoch,
        h: &DMatrix<f64>,
        a: &DVector<f64>,
        q: &DMatrix<f64>,
        fixed: &[i64],
        ratio: f64,
    ) -> Option<RtkEpoch> {
        let qi = ((q + q.transpose()) * 0.5).cholesky()?.inverse();
        let fixed = integers(fixed);
        let pxa = self.p.rows(0, 3) * h.transpose();
        let gain = &pxa * qi;
        let dx = &gain * (a - fixed);
        let dp = &gain * pxa.transpose();
        Some(RtkEpoch {
            pos: float.pos - Vector3::new(dx[0], dx[1], dx[2]),
            cov: float.cov - dp.fixed_view::<3, 3>(0, 0).into_owned(),
            fixed: true,
            fixed_ambiguities: h.nrows(),
            ratio,
            ..float.clone()
        })
    }

    /// Fix-and-hold: the fix's integers `a` of the combinations `h` of the states as
    /// measurements of variance [`HOLD_VARIANCE`].
    pub(super) fn hold(&mut self, (h, a): &Fix) {
        let r = DMatrix::identity(h.nrows(), h.nrows()) * HOLD_VARIANCE;
        let s = h * &self.p * h.transpose() + &r;
        let Some(chol) = ((&s + s.transpose()) * 0.5).cholesky() else { return };
        let v = a - h * &self.x;
        self.correct(h, &v, &r, chol.inverse());
    }
}

/// A fix the filter may hold: integer combinations of the states (cycles), one per row,
/// and their integers.
pub(super) type Fix = (DMatrix<f64>, DVector<f64>);

/// Integers as a vector of floats.
fn integers(v: &[i64]) -> DVector<f64> {
    DVector::from_iterator(v.len(), v.iter().map(|&x| x as f64))
}
