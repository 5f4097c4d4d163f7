//! A navigation state augmented by a block of `C` states that evolve on their own — each
//! decays by its factor `a_k` and gains the variance `q_k` per step, uncoupled from the
//! navigation states: the fixes' persisting error ([`crate::fix_error`], Gauss–Markov,
//! `a = e^{−Δt/τ}`) and the calibration states ([`crate::calibration`], random walks,
//! `a = 1`). The process: `Φ = [Φ_nav 0; 0 diag(a)]`, `Q = [Q_nav 0; 0 diag(q)]`, and
//! `Φ P Φᵀ + Q` by blocks (the navigation block by the base model's fused step).

use nalgebra::{Const, SMatrix, SVector};

use estimator_core::ProcessJacobians;

/// `[Φ_nav 0; 0 diag(a)]` and `[Q_nav 0; 0 diag(q)]` from the base model's Jacobians.
pub(crate) fn augmented<const B: usize, const C: usize, const N: usize>(
    j: &ProcessJacobians<Const<B>>,
    a: &SVector<f64, C>,
    q: &SVector<f64, C>,
) -> ProcessJacobians<Const<N>> {
    let mut Phi = SMatrix::<f64, N, N>::zeros();
    let mut Q = SMatrix::<f64, N, N>::zeros();
    Phi.fixed_view_mut::<B, B>(0, 0).copy_from(&j.Phi);
    Q.fixed_view_mut::<B, B>(0, 0).copy_from(&j.Q);
    for k in 0..C {
        Phi[(B + k, B + k)] = a[k];
        Q[(B + k, B + k)] = q[k];
    }
    ProcessJacobians { Phi, Q }
}

/// The leading `B×B` block of `p`, copied column by column as slices (nalgebra's
/// strided block copy went element by element: a third of the augmented step's time).
#[inline]
pub(crate) fn leading_block<const B: usize, const N: usize>(
    p: &SMatrix<f64, N, N>,
) -> SMatrix<f64, B, B> {
    let mut out = SMatrix::<f64, B, B>::zeros();
    let (src, dst) = (p.as_slice(), out.as_mut_slice());
    for j in 0..B {
        dst[j * B..(j + 1) * B].copy_from_slice(&src[j * N..j * N + B]);
    }
    out
}

/// `block` into the leading `B×B` block of `out`, column by column as slices.
#[inline]
pub(crate) fn set_leading_block<const B: usize, const N: usize>(
    out: &mut SMatrix<f64, N, N>,
    block: &SMatrix<f64, B, B>,
) {
    let (src, dst) = (block.as_slice(), out.as_mut_slice());
    for j in 0..B {
        dst[j * N..j * N + B].copy_from_slice(&src[j * B..(j + 1) * B]);
    }
}

/// The block's and the cross blocks' part of `Φ P Φᵀ + Q`, given the navigation block's
/// `Φ_navᵀ` (`phi_t`): `out_nc = Φ_nav P_nc diag(a)`, `out_cc = diag(a) P_cc diag(a) +
/// diag(q)`.
pub(crate) fn block_covariance<const B: usize, const C: usize, const N: usize>(
    phi_t: &SMatrix<f64, B, B>,
    p: &SMatrix<f64, N, N>,
    a: &SVector<f64, C>,
    q: &SVector<f64, C>,
    out: &mut SMatrix<f64, N, N>,
) {
    let mut cross = phi_t.tr_mul(&p.fixed_view::<B, C>(0, B));
    for k in 0..C {
        cross.column_mut(k).scale_mut(a[k]);
    }
    out.fixed_view_mut::<B, C>(0, B).copy_from(&cross);
    out.fixed_view_mut::<C, B>(B, 0).copy_from(&cross.transpose());
    let mut cc: SMatrix<f64, C, C> = p.fixed_view::<C, C>(B, B).into_owned();
    for i in 0..C {
        for j in 0..C {
            cc[(i, j)] *= a[i] * a[j];
        }
        cc[(i, i)] += q[i];
    }
    out.fixed_view_mut::<C, C>(B, B).copy_from(&cc);
}

/// `ProcessModel` for `$process` over its `base` model (error state of `$B` dimensions)
/// and a block `$field` of `$C` states (`$N = $B + $C`): `$decay(self, h)` and
/// `$added(self, h)` give the block's decay factors and added variances over a sample of
/// `h` seconds.
macro_rules! augmented_process {
    ($process:ty, $state:ident, $field:ident, $B:literal, $C:literal, $N:literal,
     decay: $decay:expr, added: $added:expr) => {
        impl estimator_core::ProcessModel for $process {
            type State = $state;
            type Input = $crate::model::ImuInput;

            fn propagate(&self, x: &$state, u: &$crate::model::ImuInput, dt: f64) -> $state {
                let a: nalgebra::SVector<f64, $C> = $decay(self, u.cur.dt);
                $state {
                    nav: self.base.propagate(&x.nav, u, dt),
                    $field: x.$field.component_mul(&a),
                }
            }

            fn jacobians(
                &self,
                x: &$state,
                u: &$crate::model::ImuInput,
                dt: f64,
            ) -> estimator_core::ProcessJacobians<nalgebra::Const<$N>> {
                self.step(x, u, dt).1
            }

            fn step(
                &self,
                x: &$state,
                u: &$crate::model::ImuInput,
                dt: f64,
            ) -> ($state, estimator_core::ProcessJacobians<nalgebra::Const<$N>>) {
                let (nav, j) = self.base.step(&x.nav, u, dt);
                let h = u.cur.dt;
                let a: nalgebra::SVector<f64, $C> = $decay(self, h);
                let next = $state { nav, $field: x.$field.component_mul(&a) };
                (next, $crate::augment::augmented::<$B, $C, $N>(&j, &a, &$added(self, h)))
            }

            /// `Φ P Φᵀ + Q` by blocks: the navigation block by the base model's fused
            /// step (which hands over its `Φᵀ`), the block's and cross blocks directly.
            fn step_covariance(
                &self,
                x: &$state,
                u: &$crate::model::ImuInput,
                dt: f64,
                P: &estimator_core::Cov<nalgebra::Const<$N>>,
                out: &mut estimator_core::Cov<nalgebra::Const<$N>>,
            ) -> $state {
                let mut phi_t = estimator_core::Cov::<nalgebra::Const<$N>>::zeros();
                self.step_covariance_adjoint(x, u, dt, P, out, &mut phi_t)
            }

            fn step_covariance_adjoint(
                &self,
                x: &$state,
                u: &$crate::model::ImuInput,
                dt: f64,
                P: &estimator_core::Cov<nalgebra::Const<$N>>,
                out: &mut estimator_core::Cov<nalgebra::Const<$N>>,
                phi_t: &mut estimator_core::Cov<nalgebra::Const<$N>>,
            ) -> $state {
                let pn = $crate::augment::leading_block::<$B, $N>(P);
                let mut on = nalgebra::SMatrix::<f64, $B, $B>::zeros();
                let mut tn = nalgebra::SMatrix::<f64, $B, $B>::zeros();
                let nav = self.base.step_covariance_adjoint(&x.nav, u, dt, &pn, &mut on, &mut tn);
                $crate::augment::set_leading_block::<$B, $N>(out, &on);
                let h = u.cur.dt;
                let a: nalgebra::SVector<f64, $C> = $decay(self, h);
                $crate::augment::block_covariance::<$B, $C, $N>(&tn, P, &a, &$added(self, h), out);
                phi_t.as_mut_slice().fill(0.0);
                $crate::augment::set_leading_block::<$B, $N>(phi_t, &tn);
                for k in 0..$C {
                    phi_t[($B + k, $B + k)] = a[k];
                }
                $state { nav, $field: x.$field.component_mul(&a) }
            }

            const FUSED_STEP_COVARIANCE: bool = true;

            fn transition_transposed(
                &self,
                x: &$state,
                u: &$crate::model::ImuInput,
                dt: f64,
                phi_t: &mut estimator_core::Cov<nalgebra::Const<$N>>,
            ) {
                let mut tn = nalgebra::SMatrix::<f64, $B, $B>::zeros();
                self.base.transition_transposed(&x.nav, u, dt, &mut tn);
                phi_t.as_mut_slice().fill(0.0);
                $crate::augment::set_leading_block::<$B, $N>(phi_t, &tn);
                let a: nalgebra::SVector<f64, $C> = $decay(self, u.cur.dt);
                for k in 0..$C {
                    phi_t[($B + k, $B + k)] = a[k];
                }
            }

            fn noise_times(
                &self,
                x: &$state,
                u: &$crate::model::ImuInput,
                dt: f64,
                phi_t: &estimator_core::Cov<nalgebra::Const<$N>>,
                v: &nalgebra::SVector<f64, $N>,
                phi_t_v: &nalgebra::SVector<f64, $N>,
                out: &mut nalgebra::SVector<f64, $N>,
            ) {
                let tn = $crate::augment::leading_block::<$B, $N>(phi_t);
                let vn: nalgebra::SVector<f64, $B> = v.fixed_rows::<$B>(0).into_owned();
                let wn: nalgebra::SVector<f64, $B> = phi_t_v.fixed_rows::<$B>(0).into_owned();
                let mut on = nalgebra::SVector::<f64, $B>::zeros();
                self.base.noise_times(&x.nav, u, dt, &tn, &vn, &wn, &mut on);
                out.fixed_rows_mut::<$B>(0).copy_from(&on);
                let q: nalgebra::SVector<f64, $C> = $added(self, u.cur.dt);
                for k in 0..$C {
                    out[$B + k] = q[k] * v[$B + k];
                }
            }

            fn fold_input(
                &self,
                sum: &mut Option<$crate::model::ImuInput>,
                u: &$crate::model::ImuInput,
            ) -> bool {
                u.fold_into(sum);
                true
            }
        }
    };
}

pub(crate) use augmented_process;
