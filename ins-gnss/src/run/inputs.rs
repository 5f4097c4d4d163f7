//! A run's inputs: the readers, the reader and check threads, and the first seconds read before the start.

use super::*;

pub(crate) type FileReader = ins_gnss_core::io::formats::Input;

/// The configured IMU and GNSS readers (format, rate, gap limit, skip policy) on the
/// files or arrays of `inputs`.
pub(crate) fn open_inputs(
    config: &Config,
    inputs: &Inputs,
) -> Result<(ImuReader<FileReader>, AidReader), RunError> {
    let (format, rate, gap, policy) =
        (config.imu_format(), config.data.imu_rate, config.data.max_gap, config.bad_lines());
    let mut imu = match inputs {
        Inputs::Files => {
            config.require_inputs().map_err(RunError::Config)?;
            ImuReader::open(&config.data.imu, format, rate, gap, policy)?
        }
        Inputs::Arrays { imu, imu_width, .. } | Inputs::Recording { imu, imu_width, .. } => {
            let name = inputs.imu_name(config);
            ImuReader::from_rows(imu.clone(), *imu_width, &name, format, rate, gap, policy)
        }
    }
    .with_max_bridge(config.data.max_bridge)
    .with_time_offset(config.data.imu_time_offset);
    if let Some(c) = &config.data.imu_columns {
        array_refuses(inputs, "data.imu_columns")?;
        let rates = config.imu_format() == ins_gnss_core::io::ImuFormat::Rates;
        imu = imu.with_columns(c.map(rates).map_err(|e| bad_map("data.imu_columns", e))?);
    }
    if let Some(m) = &config.imu.mounting {
        imu = imu.with_mounting(m.matrix().map_err(|e| bad_map("imu.mounting", e))?);
    }
    Ok((imu, open_aid(config, inputs)?))
}

/// The configured GNSS input: fixes, or raw observations (tight coupling, files only).
pub(crate) fn open_aid(config: &Config, inputs: &Inputs) -> Result<AidReader, RunError> {
    if config.gnss.coupling == crate::config::Coupling::Tight && !matches!(inputs, Inputs::Files) {
        return Err(bad_map(
            "gnss.coupling",
            "tight coupling reads raw observations from `data.gnss` and `data.nav` files; \
             arrays and recordings hold fixes (loose coupling)"
                .into(),
        ));
    }
    AidReader::open(config, || open_gnss(config, inputs))
}

/// A column map with arrays: it names a file's columns and units, which an array does
/// not have (its columns are in the file format's order and units), so it is refused
/// rather than ignored.
pub(crate) fn array_refuses(inputs: &Inputs, key: &str) -> Result<(), RunError> {
    match inputs {
        Inputs::Files => Ok(()),
        Inputs::Recording { .. } => Err(bad_map(
            key,
            "a column map names a file's columns; a recording's messages are read by their \
             types (`[data.ros]`)"
                .into(),
        )),
        Inputs::Arrays { .. } => Err(bad_map(
            key,
            "a column map applies to a file's header; arrays are read in the file format's \
             column order and units (convert the columns before the call, and remove the map)"
                .into(),
        )),
    }
}

/// A column map or mounting the reader cannot take (they were checked when the
/// configuration was loaded).
pub(crate) fn bad_map(key: &str, message: String) -> RunError {
    RunError::Config(crate::config::ConfigError { path: PathBuf::from(key), message })
}

/// The configured GNSS file, or array, open.
pub(crate) fn open_gnss(
    config: &Config,
    inputs: &Inputs,
) -> Result<GnssReader<FileReader>, RunError> {
    let policy = config.bad_lines();
    let gnss = match inputs {
        Inputs::Files => {
            GnssReader::open(&config.data.gnss, policy)?.with_format(config.data.gnss_format.into())
        }
        Inputs::Arrays { gnss, gnss_width, .. } => {
            GnssReader::from_rows(gnss.clone(), *gnss_width, Path::new(GNSS_ARRAY), policy)
        }
        Inputs::Recording { gnss, names, .. } => {
            GnssReader::from_rows(gnss.clone(), 7, &names.1, policy)
        }
    };
    let mut gnss = gnss
        .with_quality(config.gnss.quality.factors().map_err(|e| bad_map("gnss.quality", e))?)
        .with_default_sigma(config.gnss.position_std.map(|s| s.into()));
    if let Some(c) = &config.data.gnss_columns {
        array_refuses(inputs, "data.gnss_columns")?;
        gnss = gnss.with_columns(c.map().map_err(|e| bad_map("data.gnss_columns", e))?);
    }
    Ok(gnss)
}

/// Where a run's inputs come from.
#[derive(Clone, Debug, Default)]
pub enum Inputs {
    /// The configuration's `data.imu` and `data.gnss` files.
    #[default]
    Files,
    /// Arrays in memory, row-major, in the files' column order and units
    /// ([`ImuReader::from_rows`], [`GnssReader::from_rows`]); errors name them
    /// [`IMU_ARRAY`] and [`GNSS_ARRAY`], with the 1-based row as the line. The
    /// configuration's IMU format (increments or rates), rate, mounting and GNSS settings
    /// apply; its column maps, which name a file's header, are refused.
    Arrays {
        /// The IMU rows.
        imu: std::sync::Arc<[f64]>,
        /// Numbers per IMU row: 7, or 8 with the odometer speed.
        imu_width: usize,
        /// The GNSS rows.
        gnss: std::sync::Arc<[f64]>,
        /// Numbers per GNSS row: 7 (position), or 13 (with velocity).
        gnss_width: usize,
    },
    /// A ROS recording's messages as the formats' rows (rates, then the odometer speed;
    /// 7-column fixes), read once for `[data.ros]`; errors name the
    /// recording and topic, with the message's position on the topic as the line.
    Recording {
        /// The IMU rows.
        imu: std::sync::Arc<[f64]>,
        /// Numbers per IMU row: 7, or 8 with the odometer speed.
        imu_width: usize,
        /// The fixes, 7 numbers each.
        gnss: std::sync::Arc<[f64]>,
        /// The names of the IMU and fix rows in errors.
        names: (PathBuf, PathBuf),
        /// What was read, for the run summary.
        notes: Vec<String>,
    },
}

/// The name of an IMU array in errors (the line is the 1-based row).
pub const IMU_ARRAY: &str = "imu array row";
/// The name of a GNSS array in errors (the line is the 1-based row).
pub const GNSS_ARRAY: &str = "gnss array row";

impl Inputs {
    pub(crate) fn imu_name(&self, config: &Config) -> PathBuf {
        match self {
            Inputs::Files => config.data.imu.clone(),
            Inputs::Arrays { .. } => PathBuf::from(IMU_ARRAY),
            Inputs::Recording { names, .. } => names.0.clone(),
        }
    }

    pub(crate) fn gnss_name(&self, config: &Config) -> PathBuf {
        match self {
            Inputs::Files => config.data.gnss.clone(),
            Inputs::Arrays { .. } => PathBuf::from(GNSS_ARRAY),
            Inputs::Recording { names, .. } => names.1.clone(),
        }
    }
}

/// Batches of parsed IMU samples (with their lines) from the reader thread.
pub(crate) type ImuBatch = Result<Vec<(ImuSample, usize)>, LineError>;

/// The IMU file parsed on a thread of its own, [`BATCH`] samples per message over a
/// bounded channel; a parse error ends the stream after the samples before it.
pub(crate) struct ImuFeed {
    pub(crate) batches: std::sync::mpsc::Receiver<ImuBatch>,
    pub(crate) reader: std::thread::JoinHandle<SkipCounts>,
}

impl ImuFeed {
    /// Start reading `imu`. With a `tee`, the samples up to the first after
    /// `align.max_time` from the start go to it too (for [`Checks`]).
    pub(crate) fn spawn(mut imu: ImuReader<FileReader>, tee: Option<(Tee, Config)>) -> Self {
        let (tx, batches) = std::sync::mpsc::sync_channel::<ImuBatch>(4);
        let reader = std::thread::spawn(move || {
            let mut batch = Vec::with_capacity(BATCH);
            // the checks' samples go in one message when their span ends (or the data
            // does): one wake-up of the checks' thread instead of one per sample
            let mut tee = tee.map(|(to, config)| (to, config, Vec::new()));
            let mut t_end = f64::NAN;
            loop {
                match imu.next_sample() {
                    Ok(Some(s)) => {
                        if let Some((_, config, span)) = &mut tee {
                            if t_end.is_nan() {
                                t_end = start_span(config, s.t).1;
                            }
                            span.push(s);
                            if s.t > t_end {
                                if let Some((to, _, span)) = tee.take() {
                                    let _ = to.send(span);
                                }
                            }
                        }
                        batch.push((s, imu.line()));
                        if batch.len() == BATCH
                            && tx
                                .send(Ok(std::mem::replace(&mut batch, Vec::with_capacity(BATCH))))
                                .is_err()
                        {
                            break;
                        }
                    }
                    Ok(None) => {
                        let _ = tx.send(Ok(batch));
                        break;
                    }
                    Err(e) => {
                        let _ = tx.send(Ok(std::mem::take(&mut batch)));
                        let _ = tx.send(Err(e));
                        break;
                    }
                }
            }
            if let Some((to, _, span)) = tee {
                let _ = to.send(span);
            }
            imu.skipped
        });
        Self { batches, reader }
    }

    /// Stop reading (if not at the end yet) and return the reader's skipped lines.
    /// (A tee still open closes with the reader: the data ended before `align.max_time`.)
    pub(crate) fn finish(self) -> Result<SkipCounts, RunError> {
        drop(self.batches);
        self.reader.join().map_err(|_| RunError::NoData("the reader thread panicked".into()))
    }
}

/// The IMU samples [`Checks`] look at, in one message (none if the reader stopped early).
pub(crate) type Tee = std::sync::mpsc::Sender<Vec<ImuSample>>;

/// [`crate::start::prepare`] run beside the filter when it only checks (the initial state
/// and noise are given): on the IMU samples the reader tees to it and the GNSS epochs of
/// the same span, read from a reader of its own.
pub(crate) struct Checks(std::thread::JoinHandle<Result<(), RunError>>);

impl Checks {
    pub(crate) fn spawn(
        config: &Config,
        inputs: &Inputs,
        imu: std::sync::mpsc::Receiver<Vec<ImuSample>>,
    ) -> Result<Self, RunError> {
        let mut gnss = open_aid(config, inputs)?;
        let config = config.clone();
        Ok(Self(std::thread::spawn(move || {
            let samples = imu.recv().unwrap_or_default();
            let Some(first) = samples.first() else {
                return Ok(());
            };
            let (t0, t_end) = start_span(&config, first.t);
            let mut epochs = Vec::new();
            while let Some(a) = gnss.next_epoch()? {
                epochs.extend(a.fix);
                if a.t > t_end {
                    break;
                }
            }
            crate::start::prepare(&config, &samples, &epochs, t0)
                .map(|_| ())
                .map_err(RunError::Start)
        })))
    }

    /// Whether the checks have finished (they can be joined without waiting).
    pub(crate) fn done(&self) -> bool {
        self.0.is_finished()
    }

    pub(crate) fn join(self) -> Result<(), RunError> {
        self.0.join().map_err(|_| RunError::NoData("the checks' thread panicked".into()))?
    }
}

/// The first seconds of the inputs, read before the filter starts ([`crate::start`]):
/// IMU samples and GNSS epochs (with their lines) up to `align.max_time` after the start.
pub struct Prefix {
    /// IMU batches as the reader sent them (the filter takes them first); they hold the
    /// samples [`crate::start::prepare`] looks at and may run on past them.
    pub(crate) batches: Vec<Vec<(ImuSample, usize)>>,
    /// How many of the batches' samples `prepare` looks at.
    pub(crate) looked_at: usize,
    /// GNSS epochs and their lines.
    pub(crate) gnss: std::collections::VecDeque<(AidEpoch, usize)>,
}

/// How much of the data's start [`run`] reads before the filter starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Look {
    /// The first sample (nothing to find from the data).
    First,
    /// Until the static start ends ([`crate::start::prepare_floor`]).
    StaticStart,
    /// `align.max_time` ([`crate::start::prepare`]).
    Span,
}

/// Read the [`Prefix`] (`look`): from the start time up to the first IMU sample past
/// its end, and the GNSS epochs up to the first past that sample.
pub(crate) fn read_prefix(
    config: &Config,
    imu: &mut ImuFeed,
    gnss: &mut AidReader,
    look: Look,
) -> Result<Prefix, RunError> {
    let mut p = Prefix { batches: Vec::new(), looked_at: 0, gnss: Default::default() };
    let mut span = None;
    let mut read_gnss = |p: &mut Prefix, t: f64| -> Result<(), RunError> {
        while p.gnss.back().is_none_or(|(g, _)| g.t <= t) {
            match gnss.next_epoch()? {
                Some(g) => p.gnss.push_back((g, gnss.line())),
                None => break,
            }
        }
        Ok(())
    };
    'batches: for batch in imu.batches.iter() {
        let batch = batch?;
        if batch.is_empty() {
            // (the reader's last message before an error, or at the end of the data)
            continue;
        }
        let (t0, t_end) = *span.get_or_insert_with(|| {
            let first = batch.first().map_or(f64::NAN, |(s, _)| s.t);
            let (t0, t_end) = start_span(config, first);
            (t0, if look == Look::First { f64::NEG_INFINITY } else { t_end })
        });
        for (s, _) in &batch {
            p.looked_at += 1;
            if s.t > t_end {
                p.batches.push(batch);
                break 'batches;
            }
        }
        p.batches.push(batch);
        if look == Look::StaticStart {
            // stop once the static start has ended inside what was read
            let last = p.batches.iter().flatten().last().map_or(f64::NAN, |(s, _)| s.t);
            read_gnss(&mut p, last)?;
            let (imu, gnss) = p.samples();
            let (still, _) = crate::start::static_start(config, &imu, &gnss, t0);
            if still.samples == 0 || still.span.1 < last - config.align.static_window {
                break;
            }
        }
    }
    let Some((_, t_end)) = span else {
        return Err(RunError::NoData("the IMU file has no samples".into()));
    };
    let t_gnss = match look {
        Look::StaticStart => p.batches.iter().flatten().last().map_or(t_end, |(s, _)| s.t),
        _ => t_end,
    };
    read_gnss(&mut p, t_gnss)?;
    Ok(p)
}

impl Prefix {
    /// The IMU samples looked at, and the GNSS epochs.
    pub(crate) fn samples(&self) -> (Vec<ImuSample>, Vec<GnssEpoch>) {
        let imu = self.batches.iter().flatten().take(self.looked_at).map(|(s, _)| *s).collect();
        (imu, self.gnss.iter().filter_map(|(g, _)| g.fix).collect())
    }
}

/// The run's start time (the configured one, or the first IMU sample's `first_t`) and the
/// end of the data [`crate::start::prepare`] looks at (`align.max_time` later, and a
/// static start's [`crate::start::STATIC_ALLOWANCE`]: the alignment's span counts from
/// the motion's start).
pub(crate) fn start_span(config: &Config, first_t: f64) -> (f64, f64) {
    let t0 = config.data.start_time.unwrap_or(first_t);
    (t0, t0 + config.align.max_time + crate::start::STATIC_ALLOWANCE)
}

/// [`crate::start::prepare`] (or its part `look` calls for) on a prefix.
pub(crate) fn prepare_start(
    config: &Config,
    prefix: &Prefix,
    look: Look,
) -> Result<crate::start::Start, RunError> {
    let (imu, gnss) = prefix.samples();
    let (t0, _) = start_span(config, imu.first().map_or(0.0, |s| s.t));
    match look {
        Look::Span => crate::start::prepare(config, &imu, &gnss, t0).map_err(RunError::Start),
        Look::StaticStart => Ok(crate::start::prepare_floor(config, &imu, &gnss, t0)),
        Look::First => Ok(crate::start::Start { config: config.clone(), report: Vec::new() }),
    }
}
