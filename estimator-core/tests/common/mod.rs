//! Shared helpers for the core tests: seeded random matrices.
#![allow(dead_code)]

use nalgebra::SMatrix;
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
