//! Shared helpers for the core tests: seeded random matrices and the textbook Kalman
//! filter the filter's paths are checked against.
#![allow(dead_code)]

use nalgebra::{Matrix2, Matrix2x4, Matrix4, SMatrix, Vector2, Vector4};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

pub fn gaussian<const R: usize, const C: usize>(rng: &mut StdRng) -> SMatrix<f64, R, C> {
    SMatrix::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal))
}

/// A random symmetric positive-definite matrix `A Aᵀ + floor·I`.
pub fn spd<const N: usize>(rng: &mut StdRng, floor: f64) -> SMatrix<f64, N, N> {
    let a = gaussian::<N, N>(rng);
    a * a.transpose() + SMatrix::identity() * floor
}

/// Relative closeness: `|a − b| ≤ tol · max(1, |b|)` entrywise.
pub fn close<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    b: &SMatrix<f64, R, C>,
    tol: f64,
) -> bool {
    a.iter().zip(b.iter()).all(|(x, y)| (x - y).abs() <= tol * y.abs().max(1.0))
}

/// A plain linear KF written from the textbook, independent of the crate (explicit
/// inverse on purpose: a different numerical path from the filter's Cholesky solve).
pub struct PlainKf {
    pub x: Vector4<f64>,
    pub p: Matrix4<f64>,
}

impl PlainKf {
    pub fn predict(&mut self, f: &Matrix4<f64>, q: &Matrix4<f64>) {
        self.x = f * self.x;
        self.p = f * self.p * f.transpose() + q;
    }

    /// The update; returns the NIS.
    pub fn update(&mut self, h: &Matrix2x4<f64>, z: &Vector2<f64>, r: &Matrix2<f64>) -> f64 {
        let y = z - h * self.x;
        let s = h * self.p * h.transpose() + r;
        let s_inv = s.try_inverse().unwrap();
        let k = self.p * h.transpose() * s_inv;
        self.x += k * y;
        let ikh = Matrix4::identity() - k * h;
        self.p = ikh * self.p * ikh.transpose() + k * r * k.transpose();
        (y.transpose() * s_inv * y)[0]
    }
}
