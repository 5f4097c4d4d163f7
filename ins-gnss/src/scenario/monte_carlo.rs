//! Monte-Carlo runs of a scenario over seeds.

use super::*;

/// What one seeded run of a scenario did: the evaluation against the truth at every IMU
/// epoch, and the run's summary (GNSS verdict counts).
#[derive(Clone, Debug)]
pub struct SeedRun {
    /// Errors against the truth.
    pub eval: crate::eval::Evaluation,
    /// Epochs and verdicts.
    pub summary: crate::run::RunSummary,
}

/// A scenario prepared for many seeded runs (Monte Carlo): the trajectory and the exact
/// IMU data are computed once; each [`MonteCarlo::run`] draws new sensor errors from its
/// seed and filters them in memory. A run with seed `s` processes the same data as
/// `ins-gnss simulate` (with `seed = s` in the file) followed by `ins-gnss run`, up to
/// the files' printed precision.
#[derive(Clone, Debug)]
pub struct MonteCarlo {
    scenario: Scenario,
    traj: Trajectory,
    exact: ins_gnss_sim::ExactImu,
    gnss: GnssSim,
    errors: ImuErrors,
}

impl MonteCarlo {
    /// Prepare `scenario`.
    pub fn new(scenario: Scenario) -> Result<Self, String> {
        scenario.validate()?;
        let traj = scenario.trajectory()?;
        let gnss = scenario.gnss_sim()?;
        let exact = ins_gnss_sim::ExactImu::new(&traj, scenario.imu.rate);
        let errors = scenario.imu_errors();
        Ok(Self { scenario, traj, exact, gnss, errors })
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// Run `strategy` on the data of `seed`, with the configuration `ins-gnss simulate`
    /// would write; statistics after `skip` seconds and inside `windows`. `each` sees
    /// every `(time, result, truth)` (for plots; pass `|_, _, _| {}` otherwise).
    pub fn run(
        &self,
        seed: u64,
        strategy: adaptive::AnyStrategy,
        skip: f64,
        windows: &[(f64, f64)],
        mut each: impl FnMut(f64, &ins_gnss_io::NavRecord, &ins_gnss_io::NavRecord),
    ) -> Result<SeedRun, String> {
        let data =
            ins_gnss_sim::simulate_from(&self.exact, &self.traj, &self.errors, &self.gnss, seed);
        let t0 = data.truth[0].t;
        // The papers' filters have no gross-error gate: reproductions run with it open
        // (`ins-gnss run --no-gate`), the strategy alone deciding.
        let cfg = self.scenario.config(&data.truth[0].state, t0).with_gate_open();
        let mut ev = crate::eval::Evaluator::new(skip, windows);
        let summary =
            crate::run::run_slices(&cfg, strategy, &data.imu, &data.gnss, |k, t, state| {
                let result = nav_record(t, state);
                let truth = nav_record(t, &data.truth[k + 1].state);
                ev.add(&result, &truth);
                each(t, &result, &truth);
            })
            .map_err(|e| format!("seed {seed}: {e}"))?;
        Ok(SeedRun { eval: ev.finish(), summary })
    }
}
