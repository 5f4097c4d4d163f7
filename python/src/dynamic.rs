//! The dynamic-dimension core behind the Python callables: states beyond
//! [`MAX_N`](crate::cores::MAX_N) or measurements beyond
//! [`MAX_M`](crate::cores::MAX_M), where no compiled instance exists. The same
//! equations as the library's filter (the Joseph-form update, `P⁻ = λ F P Fᵀ + Q`, the
//! points' statistical linear regression for the unscented update, the χ² gate, the RTS
//! and fixed-lag smoothers over the recorded steps) on nalgebra's heap matrices. The
//! strategies that adapt the noise are the library's generic code over compile-time
//! dimensions and are not here: `fixed` and `chi2-gate` only; any other is refused by name.

use estimator_core::consistency::chi2_gate;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::cores::{Core, Updated};

/// One recorded prediction: the posterior it started from, the transition and the prior.
#[derive(Clone, Serialize, Deserialize)]
struct Step {
    x_post: DVector<f64>,
    p_post: DMatrix<f64>,
    phi: DMatrix<f64>,
    x_prior: DVector<f64>,
    p_prior: DMatrix<f64>,
}

/// Which smoother records.
#[derive(Clone, Copy, Serialize, Deserialize)]
enum Record {
    None,
    Interval,
    Lag(usize),
}

/// The heap filter: state, covariance, the gate's probability (`None`: fixed noise) and
/// the recorded steps.
#[derive(Clone, Serialize, Deserialize)]
pub struct DynFilter {
    x: DVector<f64>,
    p: DMatrix<f64>,
    gate: Option<f64>,
    record: Record,
    steps: Vec<Step>,
}

fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    m.transpose().iter().copied().collect()
}

fn matrix(r: usize, c: usize, v: &[f64]) -> DMatrix<f64> {
    DMatrix::from_row_slice(r, c, v)
}

impl DynFilter {
    /// A filter of `n` states (`x = 0`, `P = I`) with strategy `fixed` or `chi2-gate`.
    pub fn new(n: usize, strategy: &str, smooth: bool, lag: Option<usize>) -> Result<Self, String> {
        let gate = match strategy {
            "fixed" | "kf" => None,
            "chi2-gate" => Some(0.01),
            s => {
                return Err(format!(
                    "strategy {s:?} with {n} states or more than {} measurement rows: the \
                     adaptive strategies run on the compiled sizes (states 1 to {}, rows 1 \
                     to {}); beyond them only \"fixed\" and \"chi2-gate\"",
                    crate::cores::MAX_M,
                    crate::cores::MAX_N,
                    crate::cores::MAX_M
                ));
            }
        };
        let record = match (smooth, lag) {
            (true, Some(_)) => return Err("smooth and lag: one smoother or the other".into()),
            (true, None) => Record::Interval,
            (false, Some(k)) => Record::Lag(k),
            (false, None) => Record::None,
        };
        Ok(Self {
            x: DVector::zeros(n),
            p: DMatrix::identity(n, n),
            gate,
            record,
            steps: Vec::new(),
        })
    }

    fn n(&self) -> usize {
        self.x.len()
    }

    /// The Joseph-form update with `H`, noise `R` and innovation `y`; `None` when `S` is
    /// not positive definite.
    fn update_linear(
        &mut self,
        y: &DVector<f64>,
        h: &DMatrix<f64>,
        r: &DMatrix<f64>,
    ) -> Result<Updated, String> {
        let (n, m) = (self.n(), y.len());
        let ph = &self.p * h.transpose();
        let mut s = h * &ph + r;
        s = (&s + s.transpose()) * 0.5;
        let chol =
            s.clone().cholesky().ok_or("the innovation covariance S is not positive definite")?;
        let nis = y.dot(&chol.solve(y));
        let ln_det: f64 = chol.l().diagonal().iter().map(|d| 2.0 * d.ln()).sum();
        let log_likelihood = -0.5 * (m as f64 * (2.0 * std::f64::consts::PI).ln() + ln_det + nis);
        let rejected = self.gate.is_some_and(|a| nis > chi2_gate(m, a));
        let mut k = DMatrix::zeros(n, m);
        if !rejected {
            k = chol.solve(&ph.transpose()).transpose();
            self.x += &k * y;
            let i_kh = DMatrix::identity(n, n) - &k * h;
            let p = &i_kh * &self.p * i_kh.transpose() + &k * r * k.transpose();
            self.p = (&p + p.transpose()) * 0.5;
            if !self.x.iter().chain(self.p.iter()).all(|v| v.is_finite()) {
                return Err("the update gave a state or covariance that is not finite".into());
            }
        }
        Ok(Updated {
            x: self.x.iter().copied().collect(),
            P: row_major(&self.p),
            K: row_major(&k),
            S: row_major(&s),
            nis,
            nis_adapted: nis,
            log_likelihood,
            verdict: if rejected { "rejected" } else { "accepted" },
        })
    }

    /// The smoothed `(x, P)` over `steps`, ending at the current posterior.
    fn rts(&self, steps: &[Step]) -> Result<(Vec<f64>, Vec<f64>), String> {
        let mut xs = vec![self.x.clone()];
        let mut ps = vec![self.p.clone()];
        for st in steps.iter().rev() {
            let (xn, pn) = (xs.last().expect("one"), ps.last().expect("one"));
            let chol = st
                .p_prior
                .clone()
                .cholesky()
                .ok_or("a recorded prior covariance is not positive definite")?;
            // C = P Φᵀ (P⁻)⁻¹
            let c = chol.solve(&(&st.phi * &st.p_post)).transpose();
            let x = &st.x_post + &c * (xn - &st.x_prior);
            let p = &st.p_post + &c * (pn - &st.p_prior) * c.transpose();
            xs.push(x);
            ps.push((&p + p.transpose()) * 0.5);
        }
        xs.reverse();
        ps.reverse();
        Ok((
            xs.iter().flat_map(|x| x.iter().copied()).collect(),
            ps.iter().flat_map(row_major).collect(),
        ))
    }
}

impl Core for DynFilter {
    fn set(&mut self, x: &[f64], P: &[f64]) -> Result<(), String> {
        let n = self.n();
        let p = matrix(n, n, P);
        if !x.iter().chain(P).all(|v| v.is_finite()) {
            return Err("x or P is not finite".into());
        }
        if (&p - p.transpose()).amax() > 1e-9 * p.amax().max(1.0) {
            return Err("P: not symmetric".into());
        }
        self.x = DVector::from_row_slice(x);
        self.p = (&p + p.transpose()) * 0.5;
        Ok(())
    }

    fn predict(&mut self, x: &[f64], F: &[f64], Q: &[f64], _dt: f64) -> Result<Vec<f64>, String> {
        let n = self.n();
        let (f, q) = (matrix(n, n, F), matrix(n, n, Q));
        let mut p = &f * &self.p * f.transpose() + q;
        p = (&p + p.transpose()) * 0.5;
        let x = DVector::from_row_slice(x);
        if !x.iter().chain(p.iter()).all(|v| v.is_finite()) {
            return Err("the prediction gave a state or covariance that is not finite".into());
        }
        if !matches!(self.record, Record::None) {
            self.steps.push(Step {
                x_post: self.x.clone(),
                p_post: self.p.clone(),
                phi: f,
                x_prior: x.clone(),
                p_prior: p.clone(),
            });
            if let Record::Lag(k) = self.record
                && self.steps.len() > k
            {
                self.steps.remove(0);
            }
        }
        self.x = x;
        self.p = p;
        Ok(row_major(&self.p))
    }

    fn update(
        &mut self,
        y: &[f64],
        H: &[f64],
        R: &[f64],
        Pzz: Option<&[f64]>,
    ) -> Result<Updated, String> {
        let (n, m) = (self.n(), y.len());
        let y = DVector::from_row_slice(y);
        let r = matrix(m, m, R);
        match Pzz {
            None => self.update_linear(&y, &matrix(m, n, H), &r),
            Some(pzz) => {
                // H̃ = P_xzᵀ P⁻¹, noise R + P_zz − H̃ P_xz (the library's regression)
                let pxz = matrix(n, m, H);
                let chol =
                    self.p.clone().cholesky().ok_or("the covariance P is not positive definite")?;
                let h = chol.solve(&pxz).transpose();
                let mut total = matrix(m, m, pzz) - &h * &pxz + r;
                total = (&total + total.transpose()) * 0.5;
                self.update_linear(&y, &h, &total)
            }
        }
    }

    fn smooth(&self) -> Result<(Vec<f64>, Vec<f64>), String> {
        match self.record {
            Record::None => Err("the filter was made without smooth or lag".into()),
            _ => self.rts(&self.steps),
        }
    }

    fn strategy(&self) -> &'static str {
        if self.gate.is_some() {
            "chi2-gate"
        } else {
            "fixed"
        }
    }

    fn save(&self) -> Result<Vec<u8>, String> {
        crate::cores::to_bytes(self)
    }

    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        *self = crate::cores::from_bytes(state)?;
        Ok(())
    }

    fn reset_history(&mut self) {
        self.steps.clear();
    }
}
