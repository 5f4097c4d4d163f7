//! A run's results kept in memory ([`Results`]), for the bindings and in-memory runs.

use super::*;

/// A run's results in memory ([`run_in_memory`]): the rows of the output files, as
/// numbers in the files' units, without `nav.pos`.
#[derive(Clone, Debug, Default)]
pub struct Results {
    /// `nav.txt` without the week: `t`, latitude and longitude (deg), height (m), velocity
    /// N E D (m/s), roll, pitch, yaw (deg), at every IMU epoch.
    pub nav: Vec<[f64; 10]>,
    /// `std.txt`, row-major, [`std_width`](Self::std_width) numbers per row.
    pub std: Vec<f64>,
    /// Numbers per row of [`std`](Self::std) and [`smoothed_std`](Self::smoothed_std):
    /// 16 with 15 states, 22 with 21.
    pub std_width: usize,
    /// `imu_errors.txt`, row-major, [`imu_errors_width`](Self::imu_errors_width) per row.
    pub imu_errors: Vec<f64>,
    /// Numbers per row of [`imu_errors`](Self::imu_errors): 7, or 13 with 21 states.
    pub imu_errors_width: usize,
    /// Every update (`updates.csv`).
    pub updates: Vec<UpdateSummary>,
    /// `nav_smoothed.txt` in the layout of [`nav`](Self::nav), when the run smoothed.
    pub smoothed_nav: Vec<[f64; 10]>,
    /// `std_smoothed.txt` in the layout of [`std`](Self::std), when the run smoothed.
    pub smoothed_std: Vec<f64>,
}

/// The navigation rows in memory, on the writer thread.
#[derive(Default)]
pub(crate) struct NavRows(Vec<[f64; 10]>);

impl NavSink for NavRows {
    fn rows(&mut self, batch: &[(f64, InsState)]) -> Result<(), RunError> {
        self.0.extend(batch.iter().map(|(t, x)| nav_values(*t, x)));
        Ok(())
    }

    fn finish(&mut self) -> Result<(), RunError> {
        Ok(())
    }
}

/// `nav.txt`'s numbers without the week.
pub(crate) fn nav_values(t: f64, x: &InsState) -> [f64; 10] {
    let v = nav_record(t, x).values();
    core::array::from_fn(|i| v[i + 1])
}

/// A smoother's recording kept in memory.
fn memory_recorder<S: RunState>() -> Recorder<S, std::io::Cursor<Vec<u8>>>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    Recorder::<S, _>::new(Default::default(), SMOOTHER_SEGMENT)
}

impl Sink for Results {
    type Nav = NavRows;
    type Store = std::io::Cursor<Vec<u8>>;

    fn recorder<S: RunState>(&mut self) -> Result<Recorder<S, Self::Store>, RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        Ok(memory_recorder())
    }

    fn epoch<S: RunState>(
        &mut self,
        t: f64,
        nav: &Navigator<RunStrategy, S>,
        _quality: u8,
    ) -> Result<(), RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        let mut sigma = nav.sigma();
        if let Some(f) = S::position_floor(nav) {
            raise_position_sigma(sigma.as_mut_slice(), &f);
        }
        let (row, n) = sigma_row(t, &sigma.as_slice()[..S::SIGMA_COLUMNS]);
        self.std.extend(row[..n].iter().map(|r| r.0));
        self.std_width = n;
        // (like `imu_errors.txt`: not twice at the same time, which the run's end can
        // repeat)
        let w = self.imu_errors_width;
        if w > 0 && self.imu_errors.len() >= w && self.imu_errors[self.imu_errors.len() - w] == t {
            return Ok(());
        }
        let (row, n) = imu_error_row(t, nav.nav_state(), nav.state().scale_factors());
        self.imu_errors.extend(row[..n].iter().map(|r| r.0));
        self.imu_errors_width = n;
        Ok(())
    }

    fn update(&mut self, u: &UpdateSummary) -> Result<(), RunError> {
        self.updates.push(*u);
        Ok(())
    }

    fn nav_done(&mut self, nav: NavRows) {
        self.nav = nav.0;
    }

    fn flush(&mut self) -> Result<(), RunError> {
        Ok(())
    }

    fn smoothed<S: RunState>(
        &mut self,
        recorder: Recorder<S, Self::Store>,
        nav: &Navigator<RunStrategy, S>,
        floors: &Floors,
    ) -> Result<usize, RunError>
    where
        estimator_core::Cov<S::Dim>: Send,
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        let n = S::SIGMA_COLUMNS;
        // segments arrive last to first, each in time order
        let mut segments: Vec<(Vec<[f64; 10]>, Vec<f64>)> = Vec::new();
        recorder
            .smooth_threaded(nav.filter(), nav.model(), |rows: &[SmoothedRow<S>]| {
                let mut navs = Vec::with_capacity(rows.len());
                let mut stds = Vec::with_capacity(rows.len() * (n + 1));
                for r in rows {
                    let (t, x, sigma) = smoothed_row(r, floors);
                    navs.push(nav_values(t, &x));
                    if let Some(sigma) = sigma {
                        let (row, len) = sigma_row(t, &sigma[..n]);
                        stds.extend(row[..len].iter().map(|v| v.0));
                    }
                }
                segments.push((navs, stds));
                Ok(())
            })
            .map_err(|e| RunError::Output {
                path: PathBuf::from("(the smoother's memory)"),
                message: e.to_string(),
            })?;
        for (navs, stds) in segments.into_iter().rev() {
            self.smoothed_nav.extend(navs);
            self.smoothed_std.extend(stds);
        }
        Ok(self.smoothed_nav.len())
    }
}

/// A sink that keeps nothing: the runs that only judge a hypothesis by the filter's
/// likelihood ([`judge_fix_errors`]); their summary is all they give.
#[derive(Default)]
pub(crate) struct Discard;

/// The navigation rows dropped.
#[derive(Default)]
pub(crate) struct DiscardRows;

impl NavSink for DiscardRows {
    fn rows(&mut self, _batch: &[(f64, InsState)]) -> Result<(), RunError> {
        Ok(())
    }

    fn finish(&mut self) -> Result<(), RunError> {
        Ok(())
    }
}

impl Sink for Discard {
    type Nav = DiscardRows;
    type Store = std::io::Cursor<Vec<u8>>;

    fn recorder<S: RunState>(&mut self) -> Result<Recorder<S, Self::Store>, RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        Ok(memory_recorder())
    }

    fn epoch<S: RunState>(
        &mut self,
        _t: f64,
        _nav: &Navigator<RunStrategy, S>,
        _quality: u8,
    ) -> Result<(), RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        Ok(())
    }

    fn update(&mut self, _u: &UpdateSummary) -> Result<(), RunError> {
        Ok(())
    }

    fn nav_done(&mut self, _nav: DiscardRows) {}

    fn flush(&mut self) -> Result<(), RunError> {
        Ok(())
    }

    fn smoothed<S: RunState>(
        &mut self,
        _recorder: Recorder<S, Self::Store>,
        _nav: &Navigator<RunStrategy, S>,
        _floors: &Floors,
    ) -> Result<usize, RunError>
    where
        estimator_core::Cov<S::Dim>: Send,
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        Ok(0)
    }
}
