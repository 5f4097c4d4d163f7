//! The `ins-gnss` program: run a dataset, evaluate a result, simulate a dataset, compare
//! strategies; with no arguments, a built-in demo. See `ins-gnss --help`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use ins_gnss::cli;

#[derive(Parser)]
#[command(
    name = "ins-gnss",
    version,
    about = "15-state INS/GNSS navigation with adaptive noise strategies"
)]
struct Args {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Run a dataset from a TOML or KF-GINS YAML configuration.
    Run(RunArgs),
    /// Evaluate a navigation result against a truth file.
    Eval {
        /// Result (11 columns), or a run's output directory: its `nav.txt` and, when the
        /// run smoothed, `nav_smoothed.txt`.
        result: PathBuf,
        /// Truth or reference (11 columns).
        truth: PathBuf,
        /// Seconds skipped at the start.
        #[arg(long, default_value_t = 0.0, value_parser = cli::parse_skip)]
        skip: f64,
        /// Extra statistics inside `T0,T1` (absolute seconds); repeatable.
        #[arg(long = "window", value_parser = cli::parse_window)]
        windows: Vec<(f64, f64)>,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Read a truth log with a header through this configuration's
        /// `[data.truth_columns]`.
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// The IMU's noise from a static record by the overlapping Allan deviation: per axis
    /// white noise, bias instability and rate random walk with their 1σ, an SVG of the
    /// curves, and the `[imu_noise]` block to paste.
    Allan {
        /// A configuration (its IMU input: file, column map or ROS recording), or an IMU
        /// file in KF-GINS's format (with --rate).
        input: PathBuf,
        /// The IMU file's rate, Hz (a configuration gives its own).
        #[arg(long)]
        rate: Option<f64>,
        /// The IMU file holds rates (rad/s, m/s²) instead of increments.
        #[arg(long)]
        rates: bool,
        /// Write the curves with the fitted model here (SVG).
        #[arg(long)]
        svg: Option<PathBuf>,
        /// Only the first SECONDS of the record (a static start).
        #[arg(long, value_name = "SECONDS")]
        first: Option<f64>,
    },
    /// Simulate a dataset (IMU, GNSS, truth, config) from a scenario file.
    Simulate {
        /// Scenario file (TOML; see `ins-gnss/scenarios/`).
        scenario: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Single-point positions of a RINEX observation file from broadcast ephemerides,
    /// written as an RTKLIB `.pos`.
    Spp(SppArgs),
    /// RTK positions of a rover against a base station from double-differenced code and
    /// carrier phase (integer ambiguities by LAMBDA with the ratio test), written as an
    /// RTKLIB `.pos` (Q = 1 fixed, 2 float).
    Rtk(RtkArgs),
    /// Print every configuration key: a complete commented configuration (default), or
    /// the Markdown reference with units, defaults and examples. Both are generated from
    /// the configuration types.
    Config {
        /// A complete commented configuration file (TOML).
        #[arg(long, conflicts_with = "reference")]
        example: bool,
        /// The reference in Markdown (`docs/configuration.md`).
        #[arg(long)]
        reference: bool,
    },
    /// Copy a ROS 1 bag's messages into an MCAP file: as ROS 1 messages, or (`--cdr`) the
    /// IMU, NavSatFix and Odometry messages as ROS 2 CDR messages (what `ros2 bag record`
    /// writes). `ins-gnss run` reads either through `[data.ros]`.
    Mcap {
        /// The ROS 1 bag (or an MCAP file of ROS 1 messages).
        input: PathBuf,
        /// The MCAP file to write (an existing one is replaced only once the copy is
        /// complete).
        output: PathBuf,
        /// Write ROS 2 CDR messages (the types a run reads; other topics left out).
        #[arg(long)]
        cdr: bool,
        /// A static transform to add on `/tf_static`, as `static_transform_publisher`
        /// takes it: "X Y Z YAW PITCH ROLL PARENT CHILD" (m, rad) or "X Y Z QX QY QZ QW
        /// PARENT CHILD" (repeatable). A run finds the IMU's mounting and the lever arms
        /// from these.
        #[arg(long = "static-transform", value_name = "TRANSFORM")]
        static_transforms: Vec<String>,
    },
    /// Run several strategies on one dataset and print one table.
    Compare {
        /// Configuration file.
        config: PathBuf,
        /// Comma-separated strategy names.
        #[arg(long, value_delimiter = ',', default_value = "fixed,iae,afkf,fused,iakf,sage-husa")]
        strategies: Vec<String>,
        /// Truth file (default: the configuration's `data.truth`).
        #[arg(long)]
        truth: Option<PathBuf>,
        /// Seconds skipped at the start of the evaluation.
        #[arg(long, default_value_t = 0.0, value_parser = cli::parse_skip)]
        skip: f64,
        /// Output directory (one sub-directory per strategy).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

// (`ins-gnss run`'s arguments; the subcommand's description is the variant's)
#[derive(clap::Args)]
struct RunArgs {
    /// Configuration file (.toml, or KF-GINS .yaml).
    config: PathBuf,
    /// Noise strategy: fixed, iae, iae-qr, afkf, fused (fused-nominal, fused-window-test,
    /// fused-uncensored, fused-nominal-uncensored), iakf, iakf-raw, sage-husa, chi2-gate;
    /// iae-qr-faithful, afkf-faithful, afkf-xia-faithful, fused-faithful (unguarded).
    #[arg(long)]
    strategy: Option<String>,
    /// Output directory (default: the configuration's output path).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Evaluate against this truth file at the end (11 columns).
    #[arg(long)]
    truth: Option<PathBuf>,
    /// Seconds skipped at the start of the evaluation.
    #[arg(long, default_value_t = 0.0, value_parser = cli::parse_skip)]
    skip: f64,
    /// Open the gross-error gate (every fix used, as KF-GINS does).
    #[arg(long)]
    no_gate: bool,
    /// Keep every GNSS stream's declared noise instead of learning it from the data
    /// (sets `filter.gate.learn = false`).
    #[arg(long)]
    declared_noise: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Write SVG plots into the output directory (needs a truth file).
    #[arg(long)]
    plots: bool,
    /// Override the bias model: random-walk, gauss-markov, gauss-markov-held.
    #[arg(long)]
    bias_model: Option<String>,
    /// Land vehicle: apply the non-holonomic constraint (lateral and vertical velocity
    /// zero), with the configuration's `[vehicle.nhc]` settings or the defaults.
    #[arg(long)]
    nhc: bool,
    /// Land vehicle: ZUPT and ZARU on stops found by the stationary detector, with the
    /// configuration's `[vehicle.zupt]` settings or the defaults.
    #[arg(long)]
    zupt: bool,
    /// Error states: 15, or 21 with gyro and accelerometer scale factors (overrides
    /// `filter.states`; KF-GINS YAML scale-factor keys set their values).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["15", "21"]))]
    states: Option<String>,
    /// Propagate the covariance at most once per this many seconds, over the IMU
    /// samples combined, and before every update; 0: at every sample (overrides
    /// `filter.covariance_interval`; a smoothed run too).
    #[arg(long, value_name = "SECONDS")]
    covariance_interval: Option<f64>,
    /// Smooth with one covariance per update in the scratch file instead of two (the
    /// backward pass replays the other; the same smoothed files, byte for byte; sets
    /// `filter.smooth_low_scratch`).
    #[arg(long)]
    smooth_low_scratch: bool,
    /// Land vehicle: the odometer speed of the IMU file's 8th column, with the
    /// configuration's `[vehicle.odometer]` settings or the defaults.
    #[arg(long)]
    odometer: bool,
    /// Turn off every vehicle aiding the configuration enables.
    #[arg(long, conflicts_with_all = ["nhc", "zupt", "odometer"])]
    no_vehicle: bool,
    /// Post-process: smooth the whole run (fixed-interval RTS) and write
    /// `nav_smoothed.txt` and `std_smoothed.txt` next to `nav.txt` (sets
    /// `filter.smooth`).
    #[arg(long)]
    smooth: bool,
    /// Write `report.html`: summary, consistency, error tables and plots (with a
    /// truth), the configuration used; one self-contained file.
    #[arg(long)]
    report: bool,
    /// Keep a result the end-of-run check judges untrustworthy (a GNSS stream mostly
    /// refused, or innovations far from their χ² distribution): a warning and exit
    /// status 0 instead of the diagnosis and exit status 3
    #[arg(long)]
    accept_inconsistent: bool,
    /// Estimate the rig's calibration as states of the filter: `lever-arm`,
    /// `time-offset`, `mounting` (with NHC or the odometer), `odometer` (its scale and
    /// wheel point), several separated by commas (sets `[calibrate]`; loose coupling,
    /// 15 states).
    #[arg(long, value_delimiter = ',', value_parser = clap::builder::PossibleValuesParser::new(["lever-arm", "time-offset", "mounting", "odometer"]))]
    calibrate: Vec<String>,
    /// A moving-base receiver's headings (RTKLIB's moving-base ENU solution, NMEA
    /// HDT/THS, a u-blox log's NAV-RELPOSNED, or columns `t heading [σ [pitch σ]]`;
    /// sets `data.heading`; the baseline is `[gnss.heading]`'s).
    #[arg(long, value_name = "FILE")]
    heading: Option<PathBuf>,
    /// Leave the configuration's `[init]` out: the start finds the initial state from
    /// the data (as a configuration without one).
    #[arg(long)]
    no_init: bool,
}

// (`ins-gnss spp`'s arguments; the subcommand's description is the variant's)
#[derive(clap::Args)]
struct SppArgs {
    /// RINEX observation file (2.xx or 3.xx), or a u-blox log (`.ubx`: RXM-RAWX and
    /// RXM-SFRBX); `.gz`/`.zst`/`.xz` read as they are.
    obs: PathBuf,
    /// RINEX navigation file(s) (optional for a u-blox log with its navigation messages).
    nav: Vec<PathBuf>,
    /// Output `.pos` file.
    #[arg(long, short)]
    out: Option<PathBuf>,
    /// Ionosphere: off, klobuchar, iono-free.
    #[arg(long, default_value = "klobuchar", value_parser = ins_gnss::spp::parse_iono)]
    iono: gnss::spp::Ionosphere,
    /// Troposphere: off, saastamoinen (mapped by 1/sin(el)), niell (Saastamoinen mapped by
    /// Niell's functions).
    #[arg(long, default_value = "saastamoinen", value_parser = ins_gnss::spp::parse_tropo)]
    tropo: gnss::spp::Troposphere,
    /// Elevation mask, degrees.
    #[arg(long, default_value_t = 15.0)]
    mask: f64,
    /// Satellites RAIM may exclude per epoch (0: none).
    #[arg(long, default_value_t = 2)]
    raim: usize,
    /// Systems used, comma-separated RINEX letters or names: G (GPS), E (Galileo), C
    /// (BeiDou), J (QZSS) [default: all four].
    #[arg(long, value_delimiter = ',', value_parser = ins_gnss::spp::parse_system)]
    systems: Vec<gnss::System>,
    /// Compare with another solution of the same file (an RTKLIB `.pos`, GPST).
    #[arg(long)]
    against: Option<PathBuf>,
}

// (`ins-gnss rtk`'s arguments; the subcommand's description is the variant's)
#[derive(clap::Args)]
struct RtkArgs {
    /// The rover's RINEX observation file (or a u-blox log).
    rover: PathBuf,
    /// The base station's observations, at the rover's instants: RINEX, a u-blox log, or
    /// RTCM 3 (a name with `.rtcm`: MSM4/MSM7, its 1005/1006 position)
    base: PathBuf,
    /// RINEX navigation file(s).
    nav: Vec<PathBuf>,
    /// Output `.pos` file.
    #[arg(long, short)]
    out: Option<PathBuf>,
    /// The base's ECEF position, m (X,Y,Z) [default: the base file's APPROX POSITION XYZ].
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    base_position: Option<Vec<f64>>,
    /// The rover stands still (its position a constant state).
    #[arg(long = "static")]
    fixed_rover: bool,
    /// Frequencies: 1 (L1) or 2 (L1 and L2).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=2))]
    frequencies: u8,
    /// Elevation mask at the base, degrees.
    #[arg(long, default_value_t = 15.0)]
    mask: f64,
    /// The ratio test's threshold.
    #[arg(long, default_value_t = 3.0)]
    ratio: f64,
    /// The oldest a base epoch may be against the rover's, s (older pairs cost
    /// centimetres and, kinematic, wrong fixes: see `docs/results.md`).
    #[arg(long, default_value_t = 1.0)]
    max_age: f64,
    /// Fix only when the float ambiguities' covariance promises at least this success
    /// rate of integer bootstrapping, beside the ratio test (0: the ratio test alone,
    /// as RTKLIB). Default: 0.999 with one frequency, 0 with two.
    #[arg(long, value_parser = probability)]
    min_success_rate: Option<f64>,
    /// When all the ambiguities cannot be fixed, fix the largest decorrelated subset
    /// that promises `--min-success-rate` (0.999 when 0) and passes the ratio test.
    #[arg(long)]
    partial: bool,
    /// σ (m) of each satellite and frequency's single-differenced code bias (multipath,
    /// persisting from epoch to epoch), a state beside the ambiguities; 0: the code's
    /// errors taken as white, as RTKLIB takes them.
    #[arg(long, default_value_t = 0.3, value_parser = non_negative)]
    code_bias_sigma: f64,
    /// The code biases' correlation time, s (first-order Gauss–Markov; `inf`: constant).
    #[arg(long, default_value_t = 60.0, value_parser = positive)]
    code_bias_tau: f64,
    /// Fix-and-hold after this many consecutive fixed epochs (two frequencies, the fix's
    /// float covariance promising a success rate of 0.999); 0: never.
    #[arg(long, default_value_t = 5)]
    hold: usize,
    /// Compare with another solution of the same rover (an RTKLIB `.pos`, GPST).
    #[arg(long)]
    against: Option<PathBuf>,
    /// Write an HTML report: the summary, the fix's metrics, the ratio, σ and offsets
    /// plotted (one self-contained file).
    #[arg(long, value_name = "FILE.html")]
    report: Option<PathBuf>,
}

impl RunArgs {
    /// The options of the run, as the library takes them.
    fn options(&self) -> cli::RunOptions<'_> {
        let has = |c: &str| self.calibrate.iter().any(|x| x == c);
        cli::RunOptions {
            config: cli::Overrides {
                strategy: self.strategy.as_deref(),
                bias_model: self.bias_model.as_deref(),
                no_gate: self.no_gate,
                declared_noise: self.declared_noise,
                nhc: self.nhc,
                zupt: self.zupt,
                odometer: self.odometer,
                no_vehicle: self.no_vehicle,
                states: self.states.as_deref().and_then(|s| s.parse().ok()),
                covariance_interval: self.covariance_interval,
                smooth_low_scratch: self.smooth_low_scratch,
                smooth: self.smooth,
                calibrate_lever_arm: has("lever-arm"),
                calibrate_time_offset: has("time-offset"),
                calibrate_mounting: has("mounting"),
                calibrate_odometer: has("odometer"),
                heading: self.heading.as_deref(),
                no_init: self.no_init,
            },
            out: self.out.as_deref(),
            truth: self.truth.as_deref(),
            skip: self.skip,
            progress: !self.quiet,
            plots: self.plots,
            report: self.report,
            accept_inconsistent: self.accept_inconsistent,
        }
    }
}

impl SppArgs {
    /// `ins-gnss spp`.
    fn run(self) -> Result<(), cli::CliError> {
        let opt = gnss::SppOptions {
            ionosphere: self.iono,
            troposphere: self.tropo,
            elevation_mask: self.mask.to_radians(),
            max_exclusions: self.raim,
            ..Default::default()
        };
        let opt = if self.systems.is_empty() {
            opt
        } else {
            gnss::SppOptions { systems: self.systems, ..opt }
        };
        let navs: Vec<&std::path::Path> = self.nav.iter().map(PathBuf::as_path).collect();
        ins_gnss::spp::run(&self.obs, &navs, self.out.as_deref(), &opt, self.against.as_deref())
    }
}

impl RtkArgs {
    /// `ins-gnss rtk`.
    fn run(self) -> Result<(), cli::CliError> {
        let settings = ins_gnss::rtk::RtkSettings {
            static_rover: self.fixed_rover,
            frequencies: self.frequencies as usize,
            mask: self.mask,
            ratio: self.ratio,
            max_age: self.max_age,
            min_success_rate: self.min_success_rate,
            partial: self.partial,
            code_bias_sigma: self.code_bias_sigma,
            code_bias_tau: self.code_bias_tau,
            hold: self.hold,
        };
        let opt = settings.options().map_err(|(name, why)| {
            let flag = if name == "static_rover" { "static" } else { name };
            format!("--{} {why}", flag.replace('_', "-"))
        })?;
        let base_pos = self
            .base_position
            .map(|v| ins_gnss::rtk::base_position(&v))
            .transpose()
            .map_err(|e| format!("--base-position: {e}"))?;
        ins_gnss::rtk::run(
            &self.rover,
            &self.base,
            &self.nav,
            base_pos,
            self.out.as_deref(),
            &opt,
            self.against.as_deref(),
            self.report.as_deref(),
        )
    }
}

/// The exit status of a run that finished with outputs that cannot be trusted
/// ([`ins_gnss::health::assess`]); input and configuration errors exit with 1, argument
/// errors with 2.
const UNTRUSTED: u8 = 3;

fn main() -> ExitCode {
    let args = Args::parse();
    let result = match args.command {
        None => cli::demo(),
        Some(Command::Run(a)) => cli::run(&a.config, &a.options()),
        Some(Command::Eval { result, truth, skip, windows, json, config }) => {
            cli::eval(&result, &truth, skip, &windows, json, config.as_deref())
        }
        Some(Command::Simulate { scenario, out }) => cli::simulate(&scenario, &out),
        Some(Command::Allan { input, rate, rates, svg, first }) => {
            ins_gnss::allan::run(&input, rate, rates, first, svg.as_deref())
                .map(|text| print!("{text}"))
                .map_err(Into::into)
        }
        Some(Command::Spp(a)) => a.run(),
        Some(Command::Rtk(a)) => a.run(),
        Some(Command::Config { example: _, reference }) => {
            let text = if reference {
                ins_gnss::config::reference::reference()
            } else {
                ins_gnss::config::reference::example()
            };
            text.map(|t| print!("{t}")).map_err(Into::into)
        }
        Some(Command::Mcap { input, output, cdr, static_transforms }) => {
            use ins_gnss_io::ros::{write_mcap, Encoding, StaticTransform};
            let encoding = if cdr { Encoding::Cdr } else { Encoding::Ros1 };
            let transforms: Result<Vec<_>, String> =
                static_transforms.iter().map(|t| StaticTransform::from_publisher_args(t)).collect();
            let written: Result<(usize, usize), cli::CliError> = transforms
                .map_err(Into::into)
                .and_then(|t| write_mcap(&input, &output, encoding, &t).map_err(Into::into));
            written.map(|(written, left)| {
                println!(
                    "{}: {written} messages written{}",
                    output.display(),
                    if left > 0 {
                        format!(", {left} of other types left out")
                    } else {
                        String::new()
                    }
                )
            })
        }
        Some(Command::Compare { config, strategies, truth, skip, out }) => {
            cli::compare(&config, &strategies, truth.as_deref(), skip, out.as_deref())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            // a finished run whose result cannot be trusted, apart from the input errors
            if e.downcast_ref::<ins_gnss::health::Unhealthy>().is_some() {
                ExitCode::from(UNTRUSTED)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// A probability, 0–1 (`--min-success-rate`).
fn probability(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("{s:?} is not a probability between 0 and 1")),
    }
}

/// A finite number at least 0.
fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v >= 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("{s:?} is not a finite number at least 0")),
    }
}

/// A number above 0 (`inf` allowed).
fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 => Ok(v),
        _ => Err(format!("{s:?} is not a number above 0")),
    }
}
