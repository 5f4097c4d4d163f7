//! The NEES of a result against the truth, from the σ file beside it.

use super::*;

/// The fraction of epochs beyond the 99 % quantile above which a block's NEES is judged
/// inconsistent: five times its expected 1 %. Errors at successive epochs are strongly
/// correlated (a 100 Hz output drifts for seconds), so no band drawn from the count of
/// epochs applies; the factor leaves room for that correlation and still flags a σ that
/// is too small by 1.3× or more on a long run (at 1.3× a χ²(3) NEES exceeds the 99 %
/// quantile 6 % of the time).
pub const NEES_BEYOND_LIMIT: f64 = 0.05;

/// The normalised estimation error squared of one block (position, velocity or attitude)
/// against a truth: `Σ (e_i / σ_i)²` over its three components, with the result's
/// reported σ (the diagonal of its covariance: `std.txt` holds no correlations).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Nees {
    /// Epochs compared.
    pub epochs: usize,
    /// Degrees of freedom per epoch.
    pub dof: usize,
    /// Mean NEES per degree of freedom (1 for a consistent filter).
    pub mean_per_dof: f64,
    /// Fraction of epochs whose NEES exceeds `χ²_{0.99}(dof)` (0.01 for a consistent
    /// filter).
    pub beyond_99: f64,
    #[serde(skip)]
    sum: f64,
    #[serde(skip)]
    beyond: usize,
}

impl Nees {
    fn push(&mut self, e: &Vector3<f64>, sigma: &[f64], gate: f64) {
        if e.iter().chain(sigma).any(|v| !v.is_finite()) || sigma.iter().any(|s| *s <= 0.0) {
            return;
        }
        let q: f64 = (0..3).map(|i| (e[i] / sigma[i]).powi(2)).sum();
        self.epochs += 1;
        self.dof = 3;
        self.sum += q;
        self.beyond += usize::from(q > gate);
        self.mean_per_dof = self.sum / (3 * self.epochs) as f64;
        self.beyond_99 = self.beyond as f64 / self.epochs as f64;
    }

    /// Whether the block is consistent: at most [`NEES_BEYOND_LIMIT`] of the epochs
    /// beyond the 99 % quantile (`None` when nothing was compared).
    pub fn consistent(&self) -> Option<bool> {
        (self.epochs > 0).then_some(self.beyond_99 <= NEES_BEYOND_LIMIT)
    }
}

/// NEES of a result against a truth, per block.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct NeesSummary {
    /// Position (north, east, down; m).
    pub position: Nees,
    /// Velocity (m/s); empty against a position reference.
    pub velocity: Nees,
    /// Attitude (roll, pitch, yaw; deg); empty against a position reference.
    pub attitude: Nees,
}

impl NeesSummary {
    /// The compared blocks, named.
    pub fn blocks(&self) -> impl Iterator<Item = (&'static str, &Nees)> {
        [("position", &self.position), ("velocity", &self.velocity), ("attitude", &self.attitude)]
            .into_iter()
            .filter(|(_, n)| n.epochs > 0)
    }

    /// Consistent when every compared block is.
    pub fn consistent(&self) -> bool {
        self.blocks().all(|(_, n)| n.consistent() != Some(false))
    }

    /// One line for a summary: each block's mean NEES per degree of freedom and its
    /// fraction beyond the 99 % quantile, and the verdict.
    pub fn line(&self) -> String {
        let blocks: Vec<String> = self
            .blocks()
            .map(|(name, n)| {
                format!(
                    "{name} NEES/dof {:.2}, {:.1} % of {} epochs beyond χ²₀.₉₉({})",
                    n.mean_per_dof,
                    100.0 * n.beyond_99,
                    n.epochs,
                    n.dof
                )
            })
            .collect();
        format!(
            "{} (expected 1.00 and 1 %; judged on at most {:.0} % beyond): {}",
            blocks.join("; "),
            100.0 * NEES_BEYOND_LIMIT,
            if self.consistent() {
                "consistent"
            } else {
                "NOT consistent — the errors against the truth are larger than the reported σ"
            }
        )
    }
}

/// The σ file written beside a result (`nav.txt` → `std.txt`, `nav_smoothed.txt` →
/// `std_smoothed.txt`), when it exists.
pub fn sigma_file(result: &Path) -> Option<std::path::PathBuf> {
    let name = result.file_name()?.to_str()?;
    let std = name.strip_prefix("nav").map(|rest| format!("std{rest}"))?;
    let p = result.with_file_name(std);
    p.is_file().then_some(p)
}

/// The NEES of `result` (with its σ file `sigma`, line for line) against `truth`, at the
/// result's epochs (the truth interpolated, never across a gap longer than
/// [`MAX_REFERENCE_GAP`]), after `skip` seconds.
pub fn nees_with(
    result: &Path,
    sigma: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
    skip: f64,
) -> Result<NeesSummary, LineError> {
    let mut res = NavReader::open(result)?;
    let mut refs = reference_reader(truth, columns)?;
    let mut tru = Bracket::new(|| refs.next_record())?;
    let mut std = ins_gnss_io::NumericLines::new(ins_gnss_io::formats::open(sigma)?, sigma);
    let gate = estimator_core::consistency::chi2_quantile(0.99, 3.0);
    let mut out = NeesSummary::default();
    let mut start = None;
    let mut r = res.next_record()?;
    loop {
        let mut row = [0.0; 10];
        match std.next_record()? {
            None => break,
            Some(v) if v.len() >= 10 => row.copy_from_slice(&v[..10]),
            Some(v) => {
                let column = v.len();
                return Err(std.error(ins_gnss_io::LineErrorKind::NotNumeric {
                    column,
                    text: "a σ file has at least 10 columns (t, position, velocity, attitude)"
                        .into(),
                }));
            }
        }
        // the σ file is written at the GNSS epochs, the result at every IMU epoch
        while r.is_some_and(|r| r.t < row[0] - 1e-6) {
            r = res.next_record()?;
        }
        let Some(here) = r.filter(|r| (r.t - row[0]).abs() <= 1e-6) else { continue };
        let t0 = *start.get_or_insert(here.t);
        if here.t - t0 < skip {
            continue;
        }
        let Some(t) = tru.at(here.t)?.or_else(|| tru.exact(here.t)) else { continue };
        let (dp, dv, da) = errors(&here, &t);
        out.position.push(&dp, &row[1..4], gate);
        out.velocity.push(&dv, &row[4..7], gate);
        out.attitude.push(&da, &row[7..10], gate);
    }
    Ok(out)
}
