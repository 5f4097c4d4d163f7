//! Where a run's results go: the [`Sink`] trait and the output files of the forward pass.

use super::*;

/// Called every `every` IMU epochs with the current time, for progress bars.
pub type Progress<'a> = &'a mut dyn FnMut(f64);

/// Where a run's results go: files in a directory ([`Outputs`], the program) or memory
/// ([`Results`], the bindings). The filter thread hands over the σ, IMU-error and update
/// rows ([`Outputs`] formats and writes them on a thread of its own); the navigation rows
/// go to [`Sink::Nav`] on the writer thread.
pub(crate) trait Sink {
    /// What takes the navigation rows, on the writer thread.
    type Nav: NavSink;
    /// The smoother's storage.
    type Store: std::io::Read + std::io::Write + std::io::Seek + Send;
    /// The smoother, recording into this sink's storage.
    fn recorder<S: RunState>(&mut self) -> Result<Recorder<S, Self::Store>, RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>;
    /// The σ and IMU-error rows (and `nav.pos`) at `t`; `quality`: `nav.pos`'s Q (RTKLIB's:
    /// 1 fixed — with loose and tight coupling, a GNSS update used at `t` — 2 float, 5 no
    /// GNSS).
    fn epoch<S: RunState>(
        &mut self,
        t: f64,
        nav: &Navigator<RunStrategy, S>,
        quality: u8,
    ) -> Result<(), RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>;
    /// One update's row.
    fn update(&mut self, u: &UpdateSummary) -> Result<(), RunError>;
    /// The navigation rows' taker back from the writer thread, at the end of the pass.
    fn nav_done(&mut self, nav: Self::Nav);
    /// End of the forward pass.
    fn flush(&mut self) -> Result<(), RunError>;
    /// The backward pass; returns the number of smoothed rows.
    fn smoothed<S: RunState>(
        &mut self,
        recorder: Recorder<S, Self::Store>,
        nav: &Navigator<RunStrategy, S>,
        floors: &Floors,
    ) -> Result<usize, RunError>
    where
        estimator_core::Cov<S::Dim>: Send,
        DefaultAllocator: DimAlloc<S::Dim>;
}

/// Takes the navigation rows (time, state) on the writer thread.
pub(crate) trait NavSink: Send {
    /// A batch of rows, in time order.
    fn rows(&mut self, batch: &[(f64, InsState)]) -> Result<(), RunError>;
    /// After the last batch.
    fn finish(&mut self) -> Result<(), RunError>;
}

/// The output files of the forward pass other than `nav.txt` ([`NavFile`]): `std.txt`,
/// `imu_errors.txt`, `nav.pos` and `updates.csv`. The filter thread only copies each row's
/// numbers ([`Row`]); a thread of their own formats and writes them ([`EpochFiles`]). With
/// an update at every car-aiding epoch (10 Hz) that text was an eighth of the filter
/// thread's time.
pub(crate) struct Outputs {
    pub(crate) dir: PathBuf,
    /// Rows not sent yet.
    pub(crate) rows: Vec<Row>,
    /// To the files' thread (`None` once it has been told to finish).
    pub(crate) tx: Option<std::sync::mpsc::SyncSender<Vec<Row>>>,
    pub(crate) thread: Option<std::thread::JoinHandle<Result<(), RunError>>>,
}

/// Rows the filter thread hands to the files' thread at a time.
pub(crate) const ROWS_BATCH: usize = 256;

/// One row's numbers, formatted on the files' thread.
#[allow(clippy::large_enum_variant)] // (most rows are epochs: boxing them would allocate each)
pub(crate) enum Row {
    /// `std.txt`, `nav.pos` and `imu_errors.txt` at an epoch.
    Epoch(EpochRow),
    /// `updates.csv`.
    Update(UpdateSummary),
}

/// What [`EpochFiles::write_epoch`] writes at an epoch.
pub(crate) struct EpochRow {
    pub(crate) t: f64,
    /// `nav.pos`'s Q.
    pub(crate) quality: u8,
    /// The error states' 1σ, `sigma[..n]`.
    pub(crate) sigma: [f64; 21],
    pub(crate) n: usize,
    pub(crate) x: InsState,
    pub(crate) pos_cov: nalgebra::Matrix3<f64>,
    pub(crate) vel_cov: nalgebra::Matrix3<f64>,
    pub(crate) scale: Option<(Vector3<f64>, Vector3<f64>)>,
}

/// The files of [`Outputs`], on their own thread.
pub(crate) struct EpochFiles {
    pub(crate) dir: PathBuf,
    pub(crate) std: std::io::BufWriter<std::fs::File>,
    pub(crate) imu_err: std::io::BufWriter<std::fs::File>,
    pub(crate) updates: std::io::BufWriter<std::fs::File>,
    pub(crate) pos: std::io::BufWriter<std::fs::File>,
    /// Time of the last `nav.pos` epoch (the end of a run can repeat it).
    pub(crate) pos_last_t: Option<f64>,
    /// A row's text before it is written (reused).
    pub(crate) line: Vec<u8>,
}

/// A write to the output `name` in `dir` (its `.partial` file) failed.
pub(crate) fn partial_error(dir: &Path, name: &str, e: std::io::Error) -> RunError {
    RunError::Output { path: partial_path(&dir.join(name)), message: e.to_string() }
}

/// `nav.txt`, written on the writer thread.
pub(crate) struct NavFile {
    pub(crate) w: std::io::BufWriter<std::fs::File>,
    pub(crate) path: PathBuf,
    /// A batch's text (reused).
    pub(crate) text: Vec<u8>,
}

impl NavSink for NavFile {
    fn rows(&mut self, batch: &[(f64, InsState)]) -> Result<(), RunError> {
        // the batch's text in one buffer, one write
        self.text.clear();
        for (t, x) in batch {
            push_nav(&mut self.text, &nav_record(*t, x));
        }
        let written = self.w.write_all(&self.text);
        written.map_err(|e| self.err(e))
    }

    fn finish(&mut self) -> Result<(), RunError> {
        self.w.flush().map_err(|e| self.err(e))
    }
}

impl NavFile {
    pub(crate) fn err(&self, e: std::io::Error) -> RunError {
        RunError::Output { path: self.path.clone(), message: e.to_string() }
    }
}

impl Outputs {
    /// Create the output directory and files and start the files' thread; returns the
    /// outputs and `nav.txt`.
    pub(crate) fn create(dir: &Path) -> Result<(Self, NavFile), RunError> {
        let out =
            |path: PathBuf, e: std::io::Error| RunError::Output { path, message: e.to_string() };
        std::fs::create_dir_all(dir).map_err(|e| out(dir.to_path_buf(), e))?;
        // Every output is written as `NAME.partial` and renamed into place when the run
        // completes ([`Outputs::publish`]): a failed run never touches earlier results.
        let open = |name: &str| {
            let p = dir.join(name);
            create_partial(&p).map_err(|e| out(partial_path(&p), e))
        };
        let nav = NavFile {
            w: open("nav.txt")?,
            path: partial_path(&dir.join("nav.txt")),
            text: Vec::new(),
        };
        let mut files = EpochFiles {
            dir: dir.to_path_buf(),
            std: open("std.txt")?,
            imu_err: open("imu_errors.txt")?,
            updates: open("updates.csv")?,
            pos: open("nav.pos")?,
            pos_last_t: None,
            line: Vec::with_capacity(256),
        };
        ins_gnss_io::rtklib::write_header(
            &mut files.pos,
            concat!("ins-gnss ", env!("CARGO_PKG_VERSION")),
            true,
        )
        .map_err(|e| out(dir.join("nav.pos"), e))?;
        writeln!(
            files.updates,
            "time,stream,dim,nis,nis_adapted,decision,reason,dom,lambda_p,lambda_r,scaling_fallback,not_helping"
        )
        .map_err(|e| out(dir.join("updates.csv"), e))?;
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<Row>>(4);
        let thread = std::thread::spawn(move || -> Result<(), RunError> {
            for batch in rx {
                for row in &batch {
                    files.write(row)?;
                }
            }
            files.flush()
        });
        let outputs = Outputs {
            dir: dir.to_path_buf(),
            rows: Vec::with_capacity(ROWS_BATCH),
            tx: Some(tx),
            thread: Some(thread),
        };
        Ok((outputs, nav))
    }

    /// Queue a row; a full batch goes to the files' thread. A failed write there stops
    /// the thread, and its error comes back here.
    pub(crate) fn push(&mut self, row: Row) -> Result<(), RunError> {
        self.rows.push(row);
        if self.rows.len() < ROWS_BATCH {
            return Ok(());
        }
        let batch = std::mem::replace(&mut self.rows, Vec::with_capacity(ROWS_BATCH));
        if self.tx.as_ref().is_some_and(|tx| tx.send(batch).is_ok()) {
            return Ok(());
        }
        // the thread stopped on a failed write (its error), or was told to finish before
        // this row (never silently dropped)
        self.finish()?;
        Err(RunError::Output {
            path: self.dir.clone(),
            message: "a row came after the output files were closed".into(),
        })
    }

    /// Send the rows left, let the files' thread finish and flush, and return its error,
    /// if any.
    pub(crate) fn finish(&mut self) -> Result<(), RunError> {
        if let Some(tx) = self.tx.take() {
            // (a thread that stopped early has its error: a failed send is that case)
            let _ = tx.send(std::mem::take(&mut self.rows));
        }
        match self.thread.take() {
            Some(thread) => thread.join().map_err(|_| RunError::Output {
                path: self.dir.clone(),
                message: "the output files' thread panicked".into(),
            })?,
            None => Ok(()),
        }
    }

    /// The names of the outputs.
    pub(crate) const NAMES: [&'static str; 5] =
        ["nav.txt", "std.txt", "imu_errors.txt", "updates.csv", "nav.pos"];

    /// The outputs of the smoother.
    pub(crate) const SMOOTHED: [&'static str; 3] =
        ["nav_smoothed.txt", "std_smoothed.txt", "nav_smoothed.pos"];

    /// Rename every finished `NAME.partial` over `NAME`. A run that did not smooth removes
    /// the smoothed files of an earlier run, which would not match its `nav.txt`.
    pub(crate) fn publish(dir: &Path, smoothed: bool) -> Result<(), RunError> {
        let names = Self::NAMES.iter().chain(Self::SMOOTHED.iter().filter(|_| smoothed));
        for name in names {
            let p = dir.join(name);
            publish(&p).map_err(|e| RunError::Output { path: p, message: e.to_string() })?;
        }
        if !smoothed {
            for name in Self::SMOOTHED {
                let p = dir.join(name);
                if p.exists() {
                    std::fs::remove_file(&p)
                        .map_err(|e| RunError::Output { path: p, message: e.to_string() })?;
                }
            }
        }
        Ok(())
    }
}

impl Drop for Outputs {
    /// A run that failed: what was queued is still written (the `.partial` files keep the
    /// rows up to the failure), and the thread is waited for.
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

impl EpochFiles {
    pub(crate) fn write(&mut self, row: &Row) -> Result<(), RunError> {
        match row {
            Row::Epoch(e) => self.write_epoch(e),
            Row::Update(u) => self.write_update(u),
        }
    }

    pub(crate) fn err(&self, name: &str, e: std::io::Error) -> RunError {
        partial_error(&self.dir, name, e)
    }

    /// `std.txt`, `imu_errors.txt` and `nav.pos` at `t`.
    pub(crate) fn write_epoch(&mut self, e: &EpochRow) -> Result<(), RunError> {
        let (row, n) = sigma_row(e.t, &e.sigma[..e.n]);
        self.line.clear();
        push_row(&mut self.line, &row[..n]);
        self.std.write_all(&self.line).map_err(|err| self.err("std.txt", err))?;
        // nav.pos: the position and velocity with their NED covariance blocks (error
        // states 6–8 and 3–5); Q as the pass says
        if self.pos_last_t == Some(e.t) {
            return Ok(());
        }
        self.pos_last_t = Some(e.t);
        let q = e.quality;
        // (these files were written by `format!`; `push_epoch` and `push_exact_row` write
        // the same bytes, faster)
        self.line.clear();
        let vel = Some((&e.x.vel, &e.vel_cov));
        ins_gnss_io::rtklib::push_epoch(&mut self.line, 0.0, e.t, &e.x.pos, &e.pos_cov, vel, q);
        self.pos.write_all(&self.line).map_err(|err| self.err("nav.pos", err))?;
        let (row, n) = imu_error_row(e.t, &e.x, e.scale);
        self.line.clear();
        push_exact_row(&mut self.line, &row[..n]);
        self.imu_err.write_all(&self.line).map_err(|err| self.err("imu_errors.txt", err))
    }

    pub(crate) fn write_update(&mut self, u: &UpdateSummary) -> Result<(), RunError> {
        let l = &mut self.line;
        l.clear();
        push_exact(l, u.time, 0, 6);
        let _ = write!(l, ",{},{},", u.stream.name(), u.dim);
        push_exact(l, u.nis, 0, 6);
        l.push(b',');
        push_exact(l, u.nis_adapted, 0, 6);
        let _ = write!(l, ",{},\"{}\",", u.verdict.as_str(), u.reason);
        for v in [u.factors.dom, u.factors.lambda_p, u.factors.lambda_r] {
            push_exact(l, v, 0, 6);
            l.push(b',');
        }
        let _ = writeln!(l, "{},{}", u8::from(u.prior_scaling_fallback), u8::from(u.not_helping));
        self.updates.write_all(&self.line).map_err(|e| self.err("updates.csv", e))
    }

    pub(crate) fn flush(&mut self) -> Result<(), RunError> {
        for (w, name) in [
            (&mut self.pos, "nav.pos"),
            (&mut self.std, "std.txt"),
            (&mut self.imu_err, "imu_errors.txt"),
            (&mut self.updates, "updates.csv"),
        ] {
            w.flush().map_err(|e| partial_error(&self.dir, name, e))?;
        }
        Ok(())
    }
}

impl Sink for Outputs {
    type Nav = NavFile;
    type Store = std::fs::File;

    fn recorder<S: RunState>(&mut self) -> Result<Recorder<S, Self::Store>, RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        let path = self.dir.join(SMOOTHER_STATES);
        Recorder::<S, _>::on_file(&path, SMOOTHER_SEGMENT)
            .map_err(|e| RunError::Output { path, message: e.to_string() })
    }

    fn epoch<S: RunState>(
        &mut self,
        t: f64,
        nav: &Navigator<RunStrategy, S>,
        quality: u8,
    ) -> Result<(), RunError>
    where
        DefaultAllocator: DimAlloc<S::Dim>,
    {
        let s = nav.sigma();
        let mut sigma = [0.0; 21];
        let n = S::SIGMA_COLUMNS;
        sigma[..n].copy_from_slice(&s.as_slice()[..n]);
        let p = nav.covariance();
        let block = |i: usize| nalgebra::Matrix3::from_fn(|r, c| p[(i + r, i + c)]);
        let mut pos_cov = block(InsState::POS.start());
        if let Some(f) = S::position_floor(nav) {
            raise_position_sigma(&mut sigma, &f);
            for k in 0..3 {
                pos_cov[(k, k)] = pos_cov[(k, k)].max(f[k]);
            }
        }
        self.push(Row::Epoch(EpochRow {
            t,
            quality,
            sigma,
            n,
            x: nav.nav_state().clone(),
            pos_cov,
            vel_cov: block(InsState::VEL.start()),
            scale: nav.state().scale_factors(),
        }))
    }

    fn update(&mut self, u: &UpdateSummary) -> Result<(), RunError> {
        self.push(Row::Update(*u))
    }

    fn nav_done(&mut self, _nav: NavFile) {}

    fn flush(&mut self) -> Result<(), RunError> {
        self.finish()
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
        write_smoothed(recorder, nav, &self.dir, floors)
    }
}
