//! Integer least squares for carrier-phase ambiguities: the LAMBDA method (Teunissen 1995,
//! *The least-squares ambiguity decorrelation adjustment*, J. Geodesy 70; implementation
//! aspects after de Jonge & Tiberius 1996, LGR Series 12) with the search of MLAMBDA
//! (Chang, Yang & Zhou 2005, *MLAMBDA: a modified LAMBDA method for integer least-squares
//! estimation*, J. Geodesy 79: depth first, Schnorr–Euchner order, the ellipsoid shrunk to
//! the m-th best candidate found so far).
//!
//! Given float ambiguities `â` and their covariance `Q`, the integer vectors `a` that
//! minimise `(â − a)ᵀ Q⁻¹ (â − a)`, best first, with that squared norm. Three steps:
//!
//! 1. `Q = Lᵀ D L` (`L` unit lower triangular, `D` diagonal), factored from the last row.
//! 2. Reduction: integer Gauss transformations (`|L_ij| ≤ ½`) and swaps of neighbours
//!    where the later one's conditional variance would shrink, accumulated in a unimodular
//!    `Z` (integer, `|det Z| = 1`): `ẑ = Zᵀ â`, `Zᵀ Q Z = Lᵀ D L` with the new `L`, `D`.
//!    Integer vectors map one to one, so the minimiser is the same problem's; the search
//!    is fast because the conditional variances `d_k` no longer fall steeply.
//! 3. Search on `Σ_k (z̄_k − z_k)² / d_k`, `z̄_{n−1} = ẑ_{n−1}`,
//!    `z̄_k = ẑ_k − Σ_{j>k} L_jk (z̄_j − z_j)`, from the last index down, then `a = Z⁻ᵀ z`.
//!
//! The ratio test that decides whether the best is taken (second best's squared norm over
//! the best's, against a threshold such as 3) is the caller's: [`IntegerSolution::ratio`].

use nalgebra::DMatrix;

/// Why [`solve`] gave no candidates.
#[derive(Clone, Debug, PartialEq)]
pub enum LambdaError {
    /// `â` and `Q` disagree in size, or nothing to solve.
    Shape(String),
    /// `Q` is not symmetric positive definite (a conditional variance ≤ 0 or not finite).
    NotPositiveDefinite,
    /// The search went past its budget of steps without `m` candidates.
    SearchBudget,
}

impl core::fmt::Display for LambdaError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LambdaError::Shape(s) => write!(f, "ambiguities: {s}"),
            LambdaError::NotPositiveDefinite => {
                write!(f, "ambiguities: the covariance is not positive definite")
            }
            LambdaError::SearchBudget => {
                write!(f, "ambiguities: the integer search went past its budget")
            }
        }
    }
}

impl std::error::Error for LambdaError {}

/// The search's budget of steps (a step visits one integer at one level): far beyond
/// what a reduced problem of 60 ambiguities needs.
pub const SEARCH_BUDGET: usize = 10_000_000;

/// The `m` best integer vectors, best first.
#[derive(Clone, Debug, PartialEq)]
pub struct IntegerSolution {
    /// Each candidate and its squared norm `(â − a)ᵀ Q⁻¹ (â − a)`, the smallest first.
    pub candidates: Vec<(Vec<i64>, f64)>,
    /// The probability that integer bootstrapping on the reduced problem finds the true
    /// integers (Teunissen 1998: `Π (2Φ(1/(2√dᵢ)) − 1)` over the conditional variances
    /// `dᵢ`), a lower bound of the integer least-squares search's: what the float
    /// solution's covariance promises before any data are looked at.
    pub success_rate: f64,
}

impl IntegerSolution {
    /// The second best's squared norm over the best's (∞ with one candidate, or a best
    /// of norm 0 — a float solution already integer).
    pub fn ratio(&self) -> f64 {
        match self.candidates.as_slice() {
            [(_, a), (_, b), ..] if *a > 0.0 => b / a,
            _ => f64::INFINITY,
        }
    }

    /// The best candidate.
    pub fn best(&self) -> &[i64] {
        &self.candidates[0].0
    }
}

/// The reduced problem: `Zᵀ Q Z = Lᵀ D L`, with `Z⁻¹` (both integer, kept as f64).
#[derive(Clone, Debug)]
pub struct Reduced {
    /// Unit lower triangular.
    pub l: DMatrix<f64>,
    /// The conditional variances.
    pub d: Vec<f64>,
    /// The unimodular transformation.
    pub z: DMatrix<f64>,
    /// Its inverse.
    pub z_inv: DMatrix<f64>,
}

/// `Q = Lᵀ D L`, from the last row up.
pub fn ltdl(q: &DMatrix<f64>) -> Result<(DMatrix<f64>, Vec<f64>), LambdaError> {
    let n = q.nrows();
    let mut a = q.clone();
    let mut l = DMatrix::<f64>::identity(n, n);
    let mut d = vec![0.0; n];
    for i in (0..n).rev() {
        let di = a[(i, i)];
        if !(di > 0.0 && di.is_finite()) {
            return Err(LambdaError::NotPositiveDefinite);
        }
        d[i] = di;
        for j in 0..i {
            l[(i, j)] = a[(i, j)] / di;
        }
        // what is left of the leading block once row i's part is taken out
        for j in 0..i {
            for k in 0..=j {
                a[(j, k)] -= l[(i, j)] * l[(i, k)] * di;
                a[(k, j)] = a[(j, k)];
            }
        }
    }
    Ok((l, d))
}

/// The reduction of `Q`'s factors (step 2).
pub fn reduce(q: &DMatrix<f64>) -> Result<Reduced, LambdaError> {
    let n = q.nrows();
    let (mut l, mut d) = ltdl(q)?;
    let mut z = DMatrix::<f64>::identity(n, n);
    let mut z_inv = DMatrix::<f64>::identity(n, n);
    // integer Gauss transformation: column j less round(L_ij) times column i (i > j)
    let gauss = |l: &mut DMatrix<f64>, z: &mut DMatrix<f64>, zi: &mut DMatrix<f64>, i, j| {
        let mu = l[(i, j)].round();
        if mu != 0.0 {
            for r in i..n {
                l[(r, j)] -= mu * l[(r, i)];
            }
            for r in 0..n {
                z[(r, j)] -= mu * z[(r, i)];
                zi[(i, r)] += mu * zi[(j, r)];
            }
        }
    };
    if n < 2 {
        return Ok(Reduced { l, d, z, z_inv });
    }
    let mut k = n - 2;
    let mut swapped = true;
    let mut sweeps = 0usize;
    while swapped && sweeps < 100 * n * n {
        sweeps += 1;
        swapped = false;
        let mut i = n - 1;
        while !swapped && i > 0 {
            i -= 1;
            if i <= k {
                for r in i + 1..n {
                    gauss(&mut l, &mut z, &mut z_inv, r, i);
                }
            }
            let eta = l[(i + 1, i)];
            let delta = d[i] + eta * eta * d[i + 1];
            // (the tolerance keeps round-off from swapping a pair back and forth)
            if delta < d[i + 1] * (1.0 - 1e-9) {
                // the pair (i, i + 1) swapped
                let beta = d[i] / delta;
                let lam = d[i + 1] * eta / delta;
                d[i] = beta * d[i + 1];
                d[i + 1] = delta;
                for c in 0..i {
                    let (a0, a1) = (l[(i, c)], l[(i + 1, c)]);
                    l[(i, c)] = -eta * a0 + a1;
                    l[(i + 1, c)] = beta * a0 + lam * a1;
                }
                l[(i + 1, i)] = lam;
                for r in i + 2..n {
                    l.swap((r, i), (r, i + 1));
                }
                z.swap_columns(i, i + 1);
                z_inv.swap_rows(i, i + 1);
                k = i;
                swapped = true;
            }
        }
    }
    // every column size-reduced at the end
    for j in (0..n - 1).rev() {
        for r in j + 1..n {
            gauss(&mut l, &mut z, &mut z_inv, r, j);
        }
    }
    Ok(Reduced { l, d, z, z_inv })
}

/// The `m` best integer vectors for float ambiguities `a` of covariance `q` (`m ≥ 1`).
pub fn solve(a: &[f64], q: &DMatrix<f64>, m: usize) -> Result<IntegerSolution, LambdaError> {
    let n = a.len();
    if n == 0 || q.nrows() != n || q.ncols() != n || m == 0 {
        return Err(LambdaError::Shape(format!(
            "{n} ambiguities, a {}×{} covariance, {m} candidates asked",
            q.nrows(),
            q.ncols()
        )));
    }
    if a.iter().chain(q.iter()).any(|v| !v.is_finite()) {
        return Err(LambdaError::Shape("a value is not finite".into()));
    }
    let r = reduce(q)?;
    // ẑ = Zᵀ â, shifted by its rounding (the search runs near 0; integers shift back)
    let zhat: Vec<f64> = (0..n).map(|j| (0..n).map(|i| r.z[(i, j)] * a[i]).sum()).collect();
    let shift: Vec<f64> = zhat.iter().map(|v| v.round()).collect();
    let zf: Vec<f64> = zhat.iter().zip(&shift).map(|(v, s)| v - s).collect();
    let found = search(&r.l, &r.d, &zf, m)?;
    let candidates = found
        .into_iter()
        .map(|(z, dist)| {
            // a = Z⁻ᵀ (z + shift)
            let zs: Vec<f64> = z.iter().zip(&shift).map(|(v, s)| v + s).collect();
            let a: Vec<i64> = (0..n)
                .map(|i| (0..n).map(|k| r.z_inv[(k, i)] * zs[k]).sum::<f64>().round() as i64)
                .collect();
            (a, dist)
        })
        .collect();
    let success_rate = r.d.iter().map(|&d| 2.0 * normal_cdf(0.5 / d.sqrt()) - 1.0).product();
    Ok(IntegerSolution { candidates, success_rate })
}

/// A subset of the decorrelated ambiguities fixed (partial ambiguity resolution).
#[derive(Clone, Debug, PartialEq)]
pub struct PartialSolution {
    /// The combinations fixed: rows of `Zᵀ`, each an integer combination of the original
    /// ambiguities (`k × n`).
    pub combinations: DMatrix<f64>,
    /// Their best integer values and the second best's.
    pub solution: IntegerSolution,
}

/// Partial ambiguity resolution (Teunissen, de Jonge & Tiberius 1999): of the reduced
/// problem's decorrelated ambiguities, the largest set the bootstrapped success rate of
/// which is at least `min_success` — the last ones, conditioned on none but each other,
/// the most precise after the reduction — searched for the two best integer vectors.
/// `None`: not even one ambiguity promises that much.
pub fn solve_partial(
    a: &[f64],
    q: &DMatrix<f64>,
    min_success: f64,
) -> Result<Option<PartialSolution>, LambdaError> {
    let n = a.len();
    if n == 0 || q.nrows() != n || q.ncols() != n {
        return Err(LambdaError::Shape(format!(
            "{n} ambiguities, a {}×{} covariance",
            q.nrows(),
            q.ncols()
        )));
    }
    let r = reduce(q)?;
    let mut rate = 1.0;
    let mut first = n;
    for i in (0..n).rev() {
        let p = rate * (2.0 * normal_cdf(0.5 / r.d[i].sqrt()) - 1.0);
        if p < min_success {
            break;
        }
        rate = p;
        first = i;
    }
    if first == n {
        return Ok(None);
    }
    let zt = r.z.transpose().rows(first, n - first).into_owned();
    let za = &zt * nalgebra::DVector::from_column_slice(a);
    let qz = &zt * q * zt.transpose();
    let qz = (&qz + qz.transpose()) * 0.5;
    let solution = solve(za.as_slice(), &qz, 2)?;
    Ok(Some(PartialSolution { combinations: zt, solution }))
}

/// The `m` integer vectors of least `Σ_k (z̄_k − z_k)² / d_k` (step 3), best first.
fn search(
    l: &DMatrix<f64>,
    d: &[f64],
    zf: &[f64],
    m: usize,
) -> Result<Vec<(Vec<f64>, f64)>, LambdaError> {
    let n = zf.len();
    let (mut zb, mut z, mut step, mut dist) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let sign = |v: f64| if v <= 0.0 { -1.0 } else { 1.0 };
    let mut best: Vec<(Vec<f64>, f64)> = Vec::with_capacity(m + 1);
    let mut bound = f64::INFINITY;
    let mut k = n - 1;
    zb[k] = zf[k];
    z[k] = zb[k].round();
    let mut y = zb[k] - z[k];
    step[k] = sign(y);
    for _ in 0..SEARCH_BUDGET {
        let here = dist[k] + y * y / d[k];
        if here < bound {
            if k > 0 {
                k -= 1;
                dist[k] = here;
                zb[k] = zf[k] - (k + 1..n).map(|j| l[(j, k)] * (zb[j] - z[j])).sum::<f64>();
                z[k] = zb[k].round();
                y = zb[k] - z[k];
                step[k] = sign(y);
                continue;
            }
            // a whole candidate: kept among the m best; the bound is the m-th's
            best.push((z.clone(), here));
            best.sort_by(|a, b| a.1.total_cmp(&b.1));
            best.truncate(m);
            if best.len() == m {
                bound = best[m - 1].1;
            }
            // the next integer at level 0, in Schnorr–Euchner order
            z[0] += step[0];
            y = zb[0] - z[0];
            step[0] = -step[0] - sign(step[0]);
        } else {
            if k == n - 1 {
                return Ok(best);
            }
            k += 1;
            z[k] += step[k];
            y = zb[k] - z[k];
            step[k] = -step[k] - sign(step[k]);
        }
    }
    Err(LambdaError::SearchBudget)
}

/// The standard normal distribution function, `Φ(x) = ½ erfc(−x/√2)`, erfc by W. J.
/// Cody's rational Chebyshev approximation as given in Numerical Recipes' `erfcc`
/// (fractional error below 1.2e-7 everywhere).
pub fn normal_cdf(x: f64) -> f64 {
    let z = -x / std::f64::consts::SQRT_2;
    let a = z.abs();
    let t = 1.0 / (1.0 + 0.5 * a);
    let poly = -a * a - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    0.5 * if z >= 0.0 { erfc } else { 2.0 - erfc }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A covariance like a float solution's: `A Aᵀ σ² + ε I` with strongly correlated
    /// columns (the ambiguities of satellites seen from one position).
    fn covariance(n: usize, seed: &[f64], scale: f64) -> DMatrix<f64> {
        let a = DMatrix::from_fn(n, n, |i, j| {
            seed[(i * 7 + j * 3) % seed.len()] + (i == j) as u8 as f64
        });
        let mut q = &a * a.transpose() * (scale * scale) + DMatrix::identity(n, n) * 1e-3;
        q = (&q + q.transpose()) * 0.5;
        q
    }

    /// Every integer vector within ±`r` of `round(â)`, scored: the best three by brute force.
    fn brute(a: &[f64], q: &DMatrix<f64>, r: i64) -> Vec<(Vec<i64>, f64)> {
        let n = a.len();
        let qi = q.clone().try_inverse().unwrap();
        let base: Vec<i64> = a.iter().map(|v| v.round() as i64).collect();
        let mut all = Vec::new();
        let width = (2 * r + 1) as usize;
        for code in 0..width.pow(n as u32) {
            let mut c = code;
            let cand: Vec<i64> = (0..n)
                .map(|i| {
                    let o = (c % width) as i64 - r;
                    c /= width;
                    base[i] + o
                })
                .collect();
            let e = nalgebra::DVector::from_iterator(n, (0..n).map(|i| a[i] - cand[i] as f64));
            all.push((cand, (e.transpose() * &qi * &e)[(0, 0)]));
        }
        all.sort_by(|x, y| x.1.total_cmp(&y.1));
        all.truncate(3);
        all
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The best three integer vectors' norms (and the best itself) are an exhaustive search's
        /// (2 to 4 ambiguities, σ up to 0.6 cycle, strongly correlated, anywhere on the
        /// integer lattice).
        #[test]
        fn lambda_finds_what_an_exhaustive_search_finds(
            n in 2usize..=4,
            seed in prop::collection::vec(-1.0f64..1.0, 12),
            scale in 0.05f64..0.25,
            a in prop::collection::vec(-50.0f64..50.0, 4),
        ) {
            let q = covariance(n, &seed, scale);
            let a = &a[..n];
            let got = solve(a, &q, 3).unwrap();
            let want = brute(a, &q, 4);
            prop_assert_eq!(&got.candidates[0].0, &want[0].0);
            for (g, w) in got.candidates.iter().zip(&want) {
                prop_assert!((g.1 - w.1).abs() <= 1e-6 * (1.0 + w.1), "{:?} against {:?}", g, w);
            }
        }

        /// The reduction is a change of integer basis: `Zᵀ Q Z = Lᵀ D L`, `Z Z⁻¹ = I`,
        /// `Z` integer with `|det Z| = 1`, `L` unit lower triangular with `|L_ij| ≤ ½`,
        /// every `d_k > 0` (up to 8 ambiguities).
        #[test]
        fn the_reduction_is_a_unimodular_change_of_basis(
            n in 1usize..=8,
            seed in prop::collection::vec(-1.0f64..1.0, 12),
            scale in 0.01f64..3.0,
        ) {
            let q = covariance(n, &seed, scale);
            let r = reduce(&q).unwrap();
            let ldl = r.l.transpose() * DMatrix::from_diagonal(&nalgebra::DVector::from_vec(r.d.clone())) * &r.l;
            let zqz = r.z.transpose() * &q * &r.z;
            let tol = 1e-9 * zqz.amax().max(1.0);
            prop_assert!((&ldl - &zqz).amax() <= tol, "{} > {}", (&ldl - &zqz).amax(), tol);
            prop_assert!((&r.z * &r.z_inv - DMatrix::identity(n, n)).amax() < 1e-9);
            prop_assert!(r.z.iter().all(|v| v.fract() == 0.0));
            prop_assert!((r.z.determinant().abs() - 1.0).abs() < 1e-6);
            for i in 0..n {
                prop_assert!(r.d[i] > 0.0);
                prop_assert!((r.l[(i, i)] - 1.0).abs() < 1e-12);
                for j in 0..i {
                    prop_assert!(r.l[(i, j)].abs() <= 0.5 + 1e-9, "L[{i}][{j}] = {}", r.l[(i, j)]);
                }
                for j in i + 1..n {
                    prop_assert!(r.l[(i, j)] == 0.0);
                }
            }
        }

        /// An integer shift of the float ambiguities shifts every candidate by it and
        /// leaves the norms (up to 10 ambiguities).
        #[test]
        fn an_integer_shift_shifts_the_candidates(
            n in 1usize..=10,
            seed in prop::collection::vec(-1.0f64..1.0, 12),
            scale in 0.05f64..1.0,
            a in prop::collection::vec(-5.0f64..5.0, 10),
            shift in prop::collection::vec(-1000i64..1000, 10),
        ) {
            let q = covariance(n, &seed, scale);
            let a = &a[..n];
            let moved: Vec<f64> = a.iter().zip(&shift).map(|(v, s)| v + *s as f64).collect();
            let (p, s) = (solve(a, &q, 3).unwrap(), solve(&moved, &q, 3).unwrap());
            prop_assert_eq!(p.candidates.len(), s.candidates.len());
            for ((x, dx), (y, dy)) in p.candidates.iter().zip(&s.candidates) {
                prop_assert!((dx - dy).abs() <= 1e-6 * (1.0 + dx));
                let back: Vec<i64> = y.iter().zip(&shift).map(|(v, s)| v - s).collect();
                if (dx - dy).abs() <= 1e-9 * (1.0 + dx) {
                    prop_assert_eq!(x, &back);
                }
            }
        }
    }

    /// Float ambiguities near integers with a small σ: the integers are found and the
    /// ratio is large; halfway between two with a large σ: the ratio is near 1.
    #[test]
    fn the_ratio_tells_a_clear_fix_from_an_unclear_one() {
        let q = DMatrix::from_row_slice(
            3,
            3,
            &[0.02, 0.015, 0.01, 0.015, 0.02, 0.012, 0.01, 0.012, 0.02],
        );
        let clear = solve(&[3.03, -7.02, 12.01], &q, 2).unwrap();
        assert_eq!(clear.best(), &[3, -7, 12]);
        assert!(clear.ratio() > 10.0, "{}", clear.ratio());
        let unclear = solve(&[3.5, -7.5, 12.5], &(q * 20.0), 2).unwrap();
        assert!(unclear.ratio() < 2.0, "{}", unclear.ratio());
    }

    /// Refused: a covariance not positive definite, sizes that disagree, NaN.
    #[test]
    fn bad_inputs_are_refused() {
        let q = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert_eq!(solve(&[0.1, 0.2], &q, 2), Err(LambdaError::NotPositiveDefinite));
        assert!(matches!(solve(&[0.1], &q, 2), Err(LambdaError::Shape(_))));
        let q = DMatrix::identity(2, 2);
        assert!(matches!(solve(&[f64::NAN, 0.2], &q, 2), Err(LambdaError::Shape(_))));
    }

    /// Φ against tabulated values, and the bootstrapped success rate of one ambiguity
    /// (σ 0.1 cycle: 2Φ(5) − 1) and of two independent ones (the product).
    #[test]
    fn normal_cdf_and_success_rate() {
        for (x, p) in
            [(0.0, 0.5), (1.0, 0.841_344_746), (-2.0, 0.022_750_132), (3.0, 0.998_650_102)]
        {
            assert!((normal_cdf(x) - p).abs() < 2e-7, "Φ({x}) = {}", normal_cdf(x));
        }
        let one = solve(&[0.3], &DMatrix::from_element(1, 1, 0.01), 2).unwrap();
        assert!((one.success_rate - (2.0 * normal_cdf(5.0) - 1.0)).abs() < 1e-12);
        let q = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.01, 0.25]));
        let two = solve(&[0.3, -1.2], &q, 2).unwrap();
        let expected = (2.0 * normal_cdf(5.0) - 1.0) * (2.0 * normal_cdf(1.0) - 1.0);
        assert!((two.success_rate - expected).abs() < 1e-9, "{}", two.success_rate);
    }

    /// Partial resolution: of two independent ambiguities, one precise (σ 0.05 cycle) and
    /// one not (σ 0.5), only the precise one is fixed at a success rate of 0.999 — its
    /// combination a unit row picking it — to the integer nearest its float value; both
    /// when each is precise; none when neither is.
    #[test]
    fn partial_resolution_fixes_the_precise_subset() {
        let q = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.25, 0.0025]));
        let part = solve_partial(&[3.4, -7.03], &q, 0.999).unwrap().unwrap();
        assert_eq!(part.combinations.nrows(), 1);
        let row: Vec<f64> = part.combinations.row(0).iter().map(|v| v.abs()).collect();
        assert_eq!(row, vec![0.0, 1.0]);
        let value = part.combinations[(0, 1)] * -7.0;
        assert_eq!(part.solution.best(), &[value.round() as i64]);
        assert!(part.solution.success_rate >= 0.999);
        let q = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.0025, 0.0025]));
        assert_eq!(
            solve_partial(&[3.02, -7.03], &q, 0.999).unwrap().unwrap().combinations.nrows(),
            2
        );
        let q = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.25, 0.25]));
        assert!(solve_partial(&[3.4, -7.03], &q, 0.999).unwrap().is_none());
    }
}
