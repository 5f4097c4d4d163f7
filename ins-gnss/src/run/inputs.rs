//! A run's inputs: the readers, the reader and check threads, and the first seconds read before the start.

use super::*;

pub(crate) type FileReader = ins_gnss_io::formats::Input;

/// The configured IMU and GNSS readers (format, rate, gap limit, skip policy) on the
/// files or arrays of `inputs`.
pub(crate) fn open_inputs(
    config: &Config,
    inputs: &Inputs,
) -> Result<(ImuReader<FileReader>, AidReader), RunError> {
    if matches!(inputs, Inputs::Files) {
        config.require_inputs().map_err(RunError::Config)?;
    }
    Ok((open_imu(config, inputs)?, open_aid(config, inputs)?))
}

/// The configured IMU reader alone (format, rate, gap limit, skip policy, column map,
/// mounting, time offset) on the file or rows of `inputs`.
pub(crate) fn open_imu(
    config: &Config,
    inputs: &Inputs,
) -> Result<ImuReader<FileReader>, RunError> {
    let (format, rate, gap, policy) =
        (config.imu_format(), config.data.imu_rate, config.data.max_gap, config.bad_lines());
    let mut imu = match inputs {
        Inputs::Files => ImuReader::open(&config.data.imu, format, rate, gap, policy)?,
        Inputs::Arrays { imu, imu_width, .. } | Inputs::Recording { imu, imu_width, .. } => {
            let name = inputs.imu_name(config);
            ImuReader::from_rows(imu.clone(), *imu_width, &name, format, rate, gap, policy)
        }
    }
    .with_max_bridge(config.data.max_bridge)
    .with_time_offset(config.data.imu_time_offset);
    if let Some(c) = &config.data.imu_columns {
        array_refuses(inputs, "data.imu_columns")?;
        let rates = config.imu_format() == ins_gnss_io::ImuFormat::Rates;
        imu = imu.with_columns(c.map(rates).map_err(|e| bad_map("data.imu_columns", e))?);
    }
    if let Some(m) = &config.imu.mounting {
        imu = imu.with_mounting(m.matrix().map_err(|e| bad_map("imu.mounting", e))?);
    }
    Ok(imu)
}

/// The configured GNSS input: fixes, or raw observations (tight coupling, files only).
pub(crate) fn open_aid(config: &Config, inputs: &Inputs) -> Result<AidReader, RunError> {
    if config.gnss.coupling.is_raw() && !matches!(inputs, Inputs::Files) {
        return Err(bad_map(
            "gnss.coupling",
            "tight coupling and RTK read raw observations from `data.gnss` and `data.nav` \
             files; arrays and recordings hold fixes (loose coupling)"
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
    if let Some(path) = &config.data.heading {
        gnss = gnss.with_headings(ins_gnss_io::read_headings(path, policy)?.list);
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
    /// Start reading `imu`. With a `tee`, each batch's samples go to it too, until
    /// [`Checks`] has what it looks at and hangs up.
    pub(crate) fn spawn(mut imu: ImuReader<FileReader>, mut tee: Option<Tee>) -> Self {
        let (tx, batches) = std::sync::mpsc::sync_channel::<ImuBatch>(4);
        let reader = std::thread::spawn(move || {
            let mut batch = Vec::with_capacity(BATCH);
            // (the checks' samples go with the filter's batches: one wake-up of the
            // checks' thread per batch instead of one per sample)
            let mut tee_batch = |batch: &[(ImuSample, usize)]| tee_samples(&mut tee, batch);
            loop {
                match imu.next_sample() {
                    Ok(Some(s)) => {
                        batch.push((s, imu.line()));
                        if batch.len() == BATCH {
                            tee_batch(&batch);
                            let full = std::mem::replace(&mut batch, Vec::with_capacity(BATCH));
                            if tx.send(Ok(full)).is_err() {
                                break;
                            }
                        }
                    }
                    Ok(None) => {
                        tee_batch(&batch);
                        let _ = tx.send(Ok(batch));
                        break;
                    }
                    Err(e) => {
                        tee_batch(&batch);
                        let _ = tx.send(Ok(std::mem::take(&mut batch)));
                        let _ = tx.send(Err(e));
                        break;
                    }
                }
            }
            imu.skipped
        });
        Self { batches, reader }
    }

    /// The messages of a recording, sent as [`spawn`](Self::spawn) sent them when it was
    /// made (the same batches, the same tee, the same skipped lines at the end).
    pub(crate) fn replay(recording: std::sync::Arc<ImuRecording>, mut tee: Option<Tee>) -> Self {
        let (tx, batches) = std::sync::mpsc::sync_channel::<ImuBatch>(4);
        let reader = std::thread::spawn(move || {
            for m in &recording.messages {
                if let Ok(batch) = m {
                    tee_samples(&mut tee, batch);
                }
                if tx.send(m.clone()).is_err() {
                    break;
                }
            }
            recording.skipped
        });
        Self { batches, reader }
    }

    /// Stop reading (if not at the end yet) and return the reader's skipped lines.
    /// (A tee still open closes with the reader: the data ended before the checks' span.)
    pub(crate) fn finish(self) -> Result<SkipCounts, RunError> {
        drop(self.batches);
        self.reader.join().map_err(|_| RunError::NoData("the reader thread panicked".into()))
    }
}

/// A batch's samples to the checks' tee while it listens (closed once it hangs up).
fn tee_samples(tee: &mut Option<Tee>, batch: &[(ImuSample, usize)]) {
    if let Some(to) = tee
        && to.send(batch.iter().map(|(s, _)| *s).collect()).is_err()
    {
        *tee = None;
    }
}

/// The IMU stream as [`ImuFeed`] sends it, message by message, kept in memory for runs
/// that read the same data again (the fix-error bank's passes: [`ImuFeed::replay`]).
pub(crate) struct ImuRecording {
    messages: Vec<ImuBatch>,
    skipped: SkipCounts,
}

/// The most bytes of IMU samples the fix-error bank keeps in memory (about 3 million
/// samples, four hours at 200 Hz); a longer log is read again by each of its passes.
pub const IMU_RECORDING_BYTES: usize = 1 << 28;

impl ImuRecording {
    /// The configured IMU input read whole (`None`: it could not be opened, or it holds
    /// more than [`IMU_RECORDING_BYTES`]).
    pub(crate) fn read(config: &Config, inputs: &Inputs) -> Option<Self> {
        let feed = ImuFeed::spawn(open_imu(config, inputs).ok()?, None);
        let per = std::mem::size_of::<(ImuSample, usize)>();
        let (mut messages, mut bytes) = (Vec::new(), 0);
        while let Ok(m) = feed.batches.recv() {
            bytes += m.as_ref().map_or(0, |b| b.len() * per);
            if bytes > IMU_RECORDING_BYTES {
                let _ = feed.finish();
                return None;
            }
            messages.push(m);
        }
        let skipped = feed.finish().ok()?;
        Some(Self { messages, skipped })
    }
}

/// What the attempts of one run share: the IMU read once into memory (the fix-error
/// bank's passes), and the start decided once ([`StartMemo`]).
#[derive(Clone, Copy, Default)]
pub(crate) struct Shared<'a> {
    pub(crate) replay: Option<&'a std::sync::Arc<ImuRecording>>,
    pub(crate) start: Option<&'a StartMemo>,
}

/// The start an attempt decided, for the later attempts of the same run on the same
/// inputs whose configuration differs from its own only in the fixes' error model and in
/// smoothing, which the start does not read: the fix-error bank's passes and the run
/// after them decide it once instead of once each (on navego without `[init]`, the
/// in-motion alignment was a fifth of the bank's time). It keeps the last start decided:
/// after a time offset is applied, the attempts on the shifted stamps share theirs.
#[derive(Default)]
pub(crate) struct StartMemo {
    kept: std::sync::Mutex<Option<(Config, Start)>>,
    /// Attempts given the start kept.
    hits: std::sync::atomic::AtomicUsize,
}

impl StartMemo {
    /// What of `config` the start reads: all but `gnss.errors` and `filter.smooth`.
    fn key(config: &Config) -> Config {
        let mut key = config.clone();
        key.gnss.errors = Default::default();
        key.filter.smooth = false;
        key
    }

    /// The start `starter` decides for `config`: the one kept, when kept for the same
    /// key; else decided, and kept.
    pub(crate) fn decide(&self, config: &Config, starter: &Starter<'_>) -> Result<Start, String> {
        let key = Self::key(config);
        let kept = self.kept.lock().ok().and_then(|k| {
            k.as_ref().filter(|(kept, _)| *kept == key).map(|(_, start)| start.clone())
        });
        if let Some(start) = kept {
            self.hits.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            return Ok(start);
        }
        let start = starter.decide()?;
        if let Ok(mut k) = self.kept.lock() {
            *k = Some((key, start.clone()));
        }
        Ok(start)
    }

    /// How many attempts were given the start kept.
    #[cfg(feature = "unit-tests")]
    pub(crate) fn hits(&self) -> usize {
        self.hits.load(std::sync::atomic::Ordering::Relaxed)
    }
}

/// The IMU samples for [`Checks`], a batch per message (none if the reader stopped
/// early).
pub(crate) type Tee = std::sync::mpsc::Sender<Vec<ImuSample>>;

/// The start's checks run beside the filter when it only checks (the initial state and
/// noise are given): a [`Starter`] over the whole span ([`Look::Span`]) fed the IMU samples
/// the reader tees to it and the GNSS epochs of the same span, read from a reader of its
/// own, and decided once it holds all it looks at.
pub(crate) struct Checks(std::thread::JoinHandle<Result<Vec<String>, RunError>>);

impl Checks {
    pub(crate) fn spawn(
        config: &Config,
        inputs: &Inputs,
        imu: std::sync::mpsc::Receiver<Vec<ImuSample>>,
    ) -> Result<Self, RunError> {
        let mut gnss = open_aid(config, inputs)?;
        let config = config.clone();
        Ok(Self(std::thread::spawn(move || {
            let (mut starter, mut gnss_t) = (None, f64::NEG_INFINITY);
            while let Ok(chunk) = imu.recv() {
                let Some(first) = chunk.first() else { continue };
                let starter =
                    starter.get_or_insert_with(|| Starter::new(&config, Look::Span, first.t));
                let capped = starter.take_samples(chunk);
                let last = starter.last_sample().unwrap_or(f64::NAN);
                read_gnss_past(&mut gnss, last, &mut gnss_t, |a, _| starter.take_fixes(a.fix))?;
                if capped || starter.has_all() {
                    break;
                }
            }
            // (the reader stops teeing)
            drop(imu);
            let Some(starter) = starter else {
                return Ok(Vec::new());
            };
            starter.decide().map(|start| start.report).map_err(RunError::Start)
        })))
    }

    /// Whether the checks have finished (they can be joined without waiting).
    pub(crate) fn done(&self) -> bool {
        self.0.is_finished()
    }

    /// The checks' verdict: a refusal, or what they report (an offset named, not refused).
    pub(crate) fn join(self) -> Result<Vec<String>, RunError> {
        self.0.join().map_err(|_| RunError::NoData("the checks' thread panicked".into()))?
    }
}

/// The first seconds of the inputs, read before the filter starts: IMU samples and GNSS
/// epochs (with their lines) up to the end of what the start looks at, and the start fed
/// with them ([`Starter`]).
pub struct Prefix<'c> {
    /// IMU batches as the reader sent them (the filter takes them first); they hold the
    /// samples the start looks at and may run on past them.
    pub(crate) batches: Vec<Vec<(ImuSample, usize)>>,
    /// GNSS epochs and their lines.
    pub(crate) gnss: std::collections::VecDeque<(AidEpoch, usize)>,
    /// The start, fed the samples and fixes.
    pub(crate) starter: Starter<'c>,
}

impl Prefix<'_> {
    /// The fixes read with the prefix.
    pub(crate) fn fixes(&self) -> &[GnssEpoch] {
        self.starter.fixes()
    }
}

/// Read the [`Prefix`] the start looks at (`look`): from the first IMU batch up to the
/// first that holds what it needs, and the GNSS epochs up to the first past its last
/// sample.
pub(crate) fn read_prefix<'c>(
    config: &'c Config,
    imu: &mut ImuFeed,
    gnss: &mut AidReader,
    look: Look,
) -> Result<Prefix<'c>, RunError> {
    let (mut batches, mut epochs) = (Vec::new(), std::collections::VecDeque::new());
    let mut starter: Option<Starter<'c>> = None;
    let mut gnss_t = f64::NEG_INFINITY;
    for batch in imu.batches.iter() {
        let batch = batch?;
        let (Some(&(first, _)), Some(&(last, _))) = (batch.first(), batch.last()) else {
            // (the reader's last message before an error, or at the end of the data)
            continue;
        };
        let starter = starter.get_or_insert_with(|| Starter::new(config, look, first.t));
        let capped = starter.take_samples(batch.iter().map(|(s, _)| *s));
        batches.push(batch);
        // (looking at the first sample only: the first epoch)
        let past = if look == Look::First { f64::NEG_INFINITY } else { last.t };
        read_gnss_past(gnss, past, &mut gnss_t, |g, line| {
            starter.take_fixes(g.fix);
            epochs.push_back((g, line));
        })?;
        if capped || starter.has_all() {
            break;
        }
    }
    let starter = starter.ok_or_else(|| RunError::NoData("the IMU file has no samples".into()))?;
    Ok(Prefix { batches, gnss: epochs, starter })
}

/// Read `gnss` on until an epoch past `t` has been read or the stream has ended, each
/// epoch to `keep` with its line. `last` is the time of the last epoch read (−∞ before
/// the first, +∞ once the stream has ended).
fn read_gnss_past(
    gnss: &mut AidReader,
    t: f64,
    last: &mut f64,
    mut keep: impl FnMut(AidEpoch, usize),
) -> Result<(), RunError> {
    while *last <= t {
        match gnss.next_epoch()? {
            Some(g) => {
                *last = g.t;
                keep(g, gnss.line());
            }
            None => *last = f64::INFINITY,
        }
    }
    Ok(())
}

#[cfg(feature = "unit-tests")]
#[doc(hidden)]
pub mod inputs_tests {
    use super::*;
    use crate::scenario::{Scenario, SegmentSpec};

    /// The start as [`Checks`] feeds it: batches of [`BATCH`] samples (up to the first
    /// past the cap), the fixes up to the first epoch past each batch, until it holds all
    /// it looks at; and how many samples it took.
    fn start_as_checks(
        config: &Config,
        imu: &[ImuSample],
        gnss: &[GnssEpoch],
    ) -> (Result<crate::start::Start, String>, usize) {
        let mut starter = Starter::new(config, Look::Span, imu[0].t);
        let g = &mut 0;
        for chunk in imu.chunks(BATCH) {
            let capped = starter.take_samples(chunk.iter().copied());
            let last = starter.last_sample().unwrap();
            let from = *g;
            while *g < gnss.len() && (*g == 0 || gnss[*g - 1].t <= last) {
                *g += 1;
            }
            starter.take_fixes(gnss[from..*g].iter().cloned());
            if capped || starter.has_all() {
                break;
            }
        }
        let last = starter.last_sample().unwrap();
        (starter.decide(), imu.partition_point(|s| s.t <= last))
    }

    /// The start on the span the program reads gives what it gives on the whole span
    /// (as [`crate::run::run_slices`] reads it), over static starts from none to past
    /// the cap, configurations that only check and that fill `[init]` or the noise, and
    /// data a check refuses (GNSS gross errors, an IMU stamped late, increments in g);
    /// and the span read is shorter than the whole wherever the data run on past it.
    pub fn the_start_read_gives_its_answer_on_the_whole_span() {
        let text = include_str!("../../scenarios/drive.toml");
        let base = Scenario::parse(text, "drive.toml").unwrap();
        let seg = |kind: &str, duration: f64| SegmentSpec {
            kind: kind.into(),
            duration,
            rate: if kind == "turn" { 6.0 } else { 0.0 },
            accel: if kind == "stop" || kind == "turn" || kind == "straight" { 0.0 } else { 1.5 },
        };
        let (mut shorter, mut cases) = (0, 0);
        for (k, still) in [0.0, 3.0, 30.0, 650.0, 760.0].into_iter().enumerate() {
            let mut s = base.clone();
            s.imu.rate = 50.0;
            s.seed = 4000 + k as u64;
            s.start.speed = if still > 0.0 { 0.0 } else { 10.0 };
            s.segments = Vec::new();
            if still > 0.0 {
                s.segments.extend([seg("stop", still), seg("accelerate", 6.0)]);
            }
            for _ in 0..3 {
                s.segments.extend([
                    seg("straight", 30.0),
                    seg("turn", 15.0),
                    seg("straight", 30.0),
                ]);
            }
            let traj = s.trajectory().unwrap();
            let data = ins_gnss_sim::simulate(
                &traj,
                s.imu.rate,
                &s.imu_errors(),
                &s.gnss_sim().unwrap(),
                s.seed,
            );
            let given = s.config(&data.truth[0].state, data.truth[0].t);
            let mut no_init = given.clone();
            (no_init.init.attitude, no_init.init.velocity, no_init.init.position) =
                (None, None, None);
            let mut from_static = given.clone();
            from_static.imu_noise.from_static = true;
            let mut outliers = data.gnss.clone();
            for (i, e) in outliers.iter_mut().enumerate() {
                if i % 5 == 2 {
                    e.pos.lat += 1e3 / 6.4e6;
                }
            }
            let late: Vec<ImuSample> =
                data.imu.iter().map(|x| ImuSample { t: x.t + 0.4, ..*x }).collect();
            let in_g: Vec<ImuSample> =
                data.imu.iter().map(|x| ImuSample { dvel: x.dvel / 9.80665, ..*x }).collect();
            let runs: [(&str, &Config, &[ImuSample], &[GnssEpoch]); 6] = [
                ("given", &given, &data.imu, &data.gnss),
                ("no init", &no_init, &data.imu, &data.gnss),
                ("from static", &from_static, &data.imu, &data.gnss),
                ("outliers", &no_init, &data.imu, &outliers),
                ("late", &given, &late, &data.gnss),
                ("in g", &given, &in_g, &data.gnss),
            ];
            for (name, config, imu, gnss) in runs {
                let cap = crate::start::start_time(config, imu[0].t)
                    + config.align.max_time
                    + crate::start::STATIC_ALLOWANCE;
                let n_imu = imu.partition_point(|s| s.t <= cap + 1e-9);
                let whole = crate::start::start_on(config, imu, gnss);
                let (part, read) = start_as_checks(config, imu, gnss);
                assert_eq!(
                    format!("{part:?}"),
                    format!("{whole:?}"),
                    "static {still} s, {name}: {read} of {n_imu} samples read"
                );
                cases += 1;
                shorter += usize::from(read < n_imu);
                if still < 600.0 {
                    // (the motion's 120 s and a static start end well before the data)
                    assert!(read < n_imu, "static {still} s, {name}: the whole span read");
                }
            }
        }
        assert_eq!(cases, 30);
        assert!(shorter >= 18, "{shorter} of {cases} runs read less than the whole span");
    }

    /// A recording replays what the reader sent, message by message: the same batches
    /// (their samples and lines), the same samples to the checks' tee, the same skipped
    /// lines, the same error after the samples before it; and a second replay of it the
    /// same again (IMU rows with a malformed row and a row going back in time, skipped
    /// and counted, or the first of them ending the read with its error).
    pub fn a_recording_replays_the_readers_messages() {
        let n = 2 * BATCH + 300;
        let mut rows = Vec::new();
        for i in 0..n {
            let t = 0.01 * i as f64;
            let row = [t, 1e-4, 2e-4 * (i % 7) as f64, -1e-4, 1e-3, 2e-3, 0.098];
            rows.extend(row.map(|v| if i == 1500 { f64::NAN } else { v }));
            if i == 1800 {
                rows.extend([0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.098]);
            }
        }
        let inputs = Inputs::Arrays {
            imu: rows.into(),
            imu_width: 7,
            gnss: Vec::new().into(),
            gnss_width: 7,
        };
        let drain = |feed: ImuFeed, tee: std::sync::mpsc::Receiver<Vec<ImuSample>>| {
            let messages: Vec<ImuBatch> = feed.batches.iter().collect();
            let skipped = feed.finish().unwrap();
            (messages, tee.iter().collect::<Vec<_>>(), skipped)
        };
        for policy in [crate::config::PolicyName::Skip, crate::config::PolicyName::Error] {
            let text = "[data]\nimu = \"imu\"\ngnss = \"gnss\"\nimu_rate = 100.0\n\
                [imu_noise]\narw = [0.3, 0.3, 0.3]\nvrw = [0.1, 0.1, 0.1]\n\
                gyro_bias_std = [10.0, 10.0, 10.0]\naccel_bias_std = [100.0, 100.0, 100.0]\n\
                corr_time = 1.0\n";
            let mut config =
                Config::parse(text, crate::config::ConfigKind::Toml, std::path::Path::new("."))
                    .unwrap();
            config.data.bad_lines = policy;
            let (tx, tee) = std::sync::mpsc::channel();
            let read = drain(ImuFeed::spawn(open_imu(&config, &inputs).unwrap(), Some(tx)), tee);
            let failed = read.0.last().is_some_and(|m| m.is_err());
            match policy {
                crate::config::PolicyName::Skip => {
                    assert!(!failed && read.0.len() == 3, "{} messages", read.0.len());
                    assert_eq!((read.2.malformed, read.2.backwards), (1, 1));
                }
                crate::config::PolicyName::Error => assert!(failed && read.0.len() == 3),
            }
            let recording = std::sync::Arc::new(ImuRecording::read(&config, &inputs).unwrap());
            for _ in 0..2 {
                let (tx, tee) = std::sync::mpsc::channel();
                assert_eq!(drain(ImuFeed::replay(recording.clone(), Some(tx)), tee), read);
            }
        }
    }
}
