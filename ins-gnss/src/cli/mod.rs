//! The subcommands of the `ins-gnss` program, as library functions (the binary only
//! parses arguments). Errors are returned, never `exit`ed.

use std::path::{Path, PathBuf};
use std::time::Instant;

use adaptive::AnyStrategy;

use crate::config::Config;
use crate::eval::{evaluate, evaluate_with, Evaluation, Stats};
use crate::run::{run as run_config, RunSummary};

mod keep;
mod options;
mod print;

pub use keep::*;
pub use options::*;
pub use print::*;

/// Any error of a subcommand, as text for the user.
pub type CliError = Box<dyn std::error::Error>;

/// Parse `T0,T1`.
pub fn parse_window(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or_else(|| format!("window `{s}` must be T0,T1"))?;
    let a: f64 = a.trim().parse().map_err(|_| format!("window start `{a}` is not a number"))?;
    let b: f64 = b.trim().parse().map_err(|_| format!("window end `{b}` is not a number"))?;
    if !(a.is_finite() && b.is_finite()) {
        return Err(format!("window `{s}`: times must be finite"));
    }
    if b <= a {
        return Err(format!("window `{s}`: end must be after start"));
    }
    Ok((a, b))
}

/// Parse `--skip`: finite seconds, at least 0.
pub fn parse_skip(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("--skip `{s}` is not a number"))?;
    if !(v.is_finite() && v >= 0.0) {
        return Err(format!("--skip `{s}` must be finite seconds, at least 0"));
    }
    Ok(v)
}

/// An evaluation that compared no epoch (the result and the truth do not overlap after
/// `skip`) is refused instead of printing a table of zeros.
fn require_overlap(
    ev: &Evaluation,
    result: &Path,
    truth: &Path,
    skip: f64,
) -> Result<(), CliError> {
    if ev.overall.epochs == 0 {
        return Err(format!(
            "no epoch of {} falls inside the time span of {} after skipping {skip} s",
            result.display(),
            truth.display()
        )
        .into());
    }
    Ok(())
}

fn strategy(name: &str) -> Result<AnyStrategy, CliError> {
    Ok(name.parse::<AnyStrategy>()?)
}

/// Where a run's outputs stay by its verdict: an earlier trusted result kept aside
/// (`kept`) is put back when this run is judged untrustworthy (unless `accepted`), its
/// outputs going beside it; the untrusted mark written or removed. The directory the
/// outputs are in.
fn place_outputs(
    verdict: &mut Result<(), crate::health::Unhealthy>,
    kept: Option<PathBuf>,
    out_dir: PathBuf,
    accepted: bool,
) -> Result<PathBuf, CliError> {
    let untrusted = verdict.is_err() && !accepted;
    let out_dir = match kept {
        Some(k) if untrusted => {
            let beside = sibling(&out_dir, "-untrusted");
            put_back(&k, &out_dir, &beside)?;
            if let Err(u) = verdict {
                u.beside = Some((beside.clone(), out_dir.clone()));
            }
            beside
        }
        Some(k) => {
            std::fs::remove_dir_all(&k).map_err(|e| format!("{}: {e}", k.display()))?;
            out_dir
        }
        None => out_dir,
    };
    let mark = out_dir.join(UNTRUSTED_MARK);
    match &*verdict {
        Err(u) if untrusted => std::fs::write(&mark, format!("{u}\n"))
            .map_err(|e| format!("{}: {e}", mark.display()))?,
        _ if mark.exists() => {
            std::fs::remove_file(&mark).map_err(|e| format!("{}: {e}", mark.display()))?
        }
        _ => {}
    }
    Ok(out_dir)
}

/// A run's result against the truth: the evaluation tables (forward, and smoothed when it
/// smoothed) printed, and with `plots` the SVG plots.
#[allow(clippy::type_complexity)]
fn evaluate_run(
    cfg: &Config,
    summary: &RunSummary,
    name: &str,
    truth: &Path,
    skip: f64,
    plots: bool,
) -> Result<(Vec<(String, Evaluation)>, Vec<PathBuf>), CliError> {
    let (mut tables, mut figures) = (Vec::new(), Vec::new());
    let (columns, out_dir) = (cfg.data.truth_columns.as_ref(), &summary.out_dir);
    let ev = evaluate_with(&out_dir.join("nav.txt"), truth, columns, skip, &[])?;
    require_overlap(&ev, &out_dir.join("nav.txt"), truth, skip)?;
    if summary.smoothed.is_some() {
        let smoothed = out_dir.join("nav_smoothed.txt");
        let ev_s = evaluate_with(&smoothed, truth, columns, skip, &[])?;
        require_overlap(&ev_s, &smoothed, truth, skip)?;
        let label = format!("{name}, smoothed");
        print_table(&[(name, &ev.overall), (&label, &ev_s.overall)]);
        print_nees(name, &ev);
        print_nees(&label, &ev_s);
        tables.push((label, ev_s));
    } else {
        print_table(&[(name, &ev.overall)]);
        print_nees(name, &ev);
    }
    tables.insert(0, (name.to_string(), ev));
    if plots {
        let fixes = read_fixes(cfg)?;
        let files = crate::plot::write_all(out_dir, truth, columns, &fixes, skip)?;
        for f in &files {
            out!("plot: {}", f.display());
        }
        figures = files;
    }
    Ok((tables, figures))
}

/// `ins-gnss run`.
pub fn run(config: &Path, o: &RunOptions<'_>) -> Result<(), CliError> {
    let (out, truth, skip, progress, plots) = (o.out, o.truth, o.skip, o.progress, o.plots);
    let (cfg, chosen) = Config::load(config)?.with_options(&o.config)?;
    // (the strategy as the user named it, for the tables)
    let name = o.config.strategy.unwrap_or(&cfg.filter.strategy).to_string();
    let out_dir = out.map(Path::to_path_buf).unwrap_or_else(|| cfg.data.output.clone());
    // refused before the run, not after it
    if plots && truth.is_none() && cfg.data.truth.is_none() {
        return Err("--plots needs a truth file (--truth or data.truth)".into());
    }
    if let Some(t) = truth.filter(|t| !t.is_file()) {
        return Err(format!("--truth {}: no such file", t.display()).into());
    }
    cfg.require_inputs()?;
    let bar = progress.then(|| progress_bar(&cfg));
    let mut tick = |t: f64| {
        if let Some(b) = &bar {
            b.0.set_position(((t - b.1) * 1000.0).max(0.0) as u64);
        }
    };
    // an earlier result in the output directory that was not judged untrustworthy is
    // replaced only by a result that is not either: its files are kept aside (hard links)
    // while the run writes in place, and put back if the run is judged untrustworthy,
    // whose outputs then go beside them
    let earlier_trusted =
        out_dir.join("nav.txt").is_file() && !out_dir.join(UNTRUSTED_MARK).exists();
    let kept = if earlier_trusted { Some(keep_aside(&out_dir)?) } else { None };
    let result = run_config(&cfg, chosen, &out_dir, Some(&mut tick));
    if let Some(b) = bar {
        b.0.finish_and_clear();
    }
    let mut summary = match result {
        Ok(s) => s,
        Err(e) => {
            if let Some(k) = &kept {
                let _ = std::fs::remove_dir_all(k);
            }
            return Err(e.into());
        }
    };
    let mut verdict = crate::health::assess(&summary, &cfg);
    let out_dir = place_outputs(&mut verdict, kept, out_dir, o.accept_inconsistent)?;
    summary.out_dir = out_dir.clone();
    print_summary(&summary);
    let truth = truth.map(Path::to_path_buf).or_else(|| cfg.data.truth.clone());
    let plots = plots || (o.report && truth.is_some());
    let (tables, figures) = match truth {
        Some(truth) => evaluate_run(&cfg, &summary, &name, &truth, skip, plots)?,
        None if plots => return Err("--plots needs a truth file (--truth or data.truth)".into()),
        None => (Vec::new(), Vec::new()),
    };
    if o.report {
        let page = crate::report::write(&out_dir, &summary, &cfg, &tables, &figures)?;
        out!("report: {}", page.display());
    }
    remove_stale(&out_dir, o.report, &figures)?;
    match verdict {
        Err(u) if o.accept_inconsistent => {
            out!("warning (--accept-inconsistent): {u}");
            Ok(())
        }
        Err(u) => Err(Box::new(u)),
        Ok(()) => Ok(()),
    }
}

/// The GNSS fixes of a configuration (time, position), for the plan view.
fn read_fixes(cfg: &Config) -> Result<Vec<(f64, ins_gnss_core::GeoPos)>, CliError> {
    let mut r = ins_gnss_io::GnssReader::open(&cfg.data.gnss, cfg.bad_lines())?
        .with_format(cfg.data.gnss_format.into())
        .with_quality(cfg.gnss.quality.factors()?)
        .with_default_sigma(cfg.gnss.position_std.map(|s| s.into()));
    if let Some(c) = &cfg.data.gnss_columns {
        r = r.with_columns(c.map()?);
    }
    let mut out = Vec::new();
    while let Some(g) = r.next_epoch()? {
        out.push((g.t, g.pos));
    }
    Ok(out)
}

fn progress_bar(cfg: &Config) -> (indicatif::ProgressBar, f64) {
    let start = cfg.data.start_time.unwrap_or(0.0);
    let len = cfg.data.end_time.map(|e| ((e - start) * 1000.0) as u64).unwrap_or(0);
    let bar = if len > 0 {
        indicatif::ProgressBar::new(len)
    } else {
        indicatif::ProgressBar::new_spinner()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos} ms of data",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    (bar, start)
}

/// `ins-gnss eval`.
pub fn eval(
    result: &Path,
    truth: &Path,
    skip: f64,
    windows: &[(f64, f64)],
    json: bool,
    config: Option<&Path>,
) -> Result<(), CliError> {
    // a truth log with a header is read through the configuration's `data.truth_columns`
    let cfg = config.map(Config::load).transpose()?;
    let columns = cfg.as_ref().and_then(|c| c.data.truth_columns.as_ref());
    let outputs: Vec<(&str, PathBuf)> = if result.is_dir() {
        let mut v = vec![("forward", result.join("nav.txt"))];
        if result.join("nav_smoothed.txt").is_file() {
            v.push(("smoothed", result.join("nav_smoothed.txt")));
        }
        v
    } else {
        vec![("", result.to_path_buf())]
    };
    let mut all = serde_json::Map::new();
    for (name, path) in &outputs {
        let ev = evaluate_with(path, truth, columns, skip, windows)?;
        require_overlap(&ev, path, truth, skip)?;
        match (json, name.is_empty()) {
            (true, true) => out!("{}", serde_json::to_string_pretty(&ev)?),
            (true, false) => {
                all.insert(name.to_string(), serde_json::to_value(&ev)?);
            }
            (false, plain) => {
                if !plain {
                    out!("{name} ({})", path.display());
                }
                print_eval(&ev);
            }
        }
    }
    // `eval DIR`: `{"forward": …, "smoothed": …}`
    if json && result.is_dir() {
        out!("{}", serde_json::to_string_pretty(&all)?);
    }
    Ok(())
}

/// `ins-gnss simulate`.
pub fn simulate(scenario: &Path, out: &Path) -> Result<(), CliError> {
    let sc = crate::scenario::Scenario::load(scenario)?;
    let written = sc.write_dataset(out)?;
    for f in written {
        out!("wrote {}", f.display());
    }
    Ok(())
}

/// `ins-gnss compare`.
pub fn compare(
    config: &Path,
    names: &[String],
    truth: Option<&Path>,
    skip: f64,
    out: Option<&Path>,
) -> Result<(), CliError> {
    let cfg = Config::load(config)?;
    let truth = truth
        .map(Path::to_path_buf)
        .or_else(|| cfg.data.truth.clone())
        .ok_or("compare needs a truth file (--truth or data.truth)")?;
    let base = out.map(Path::to_path_buf).unwrap_or_else(|| cfg.data.output.clone());
    let mut evals = Vec::new();
    for name in names {
        let dir = base.join(name);
        let s = run_config(&cfg, strategy(name)?, &dir, None)?;
        print_summary(&s);
        let ev = evaluate_with(
            &dir.join("nav.txt"),
            &truth,
            cfg.data.truth_columns.as_ref(),
            skip,
            &[],
        )?;
        require_overlap(&ev, &dir.join("nav.txt"), &truth, skip)?;
        evals.push((name.clone(), ev));
    }
    let rows: Vec<(&str, &Stats)> = evals.iter().map(|(n, e)| (n.as_str(), &e.overall)).collect();
    print_table(&rows);
    Ok(())
}

/// The built-in demo (no arguments).
pub fn demo() -> Result<(), CliError> {
    let t = Instant::now();
    let dir = PathBuf::from("ins-gnss-demo");
    let written = crate::scenario::Scenario::demo().write_dataset(&dir)?;
    out!(
        "demo: simulated a 600 s drive with a GNSS interference window (200–260 s) and a 60 s outage (400–460 s) into {}",
        dir.display()
    );
    for f in &written {
        out!("  {}", f.display());
    }
    let cfg_path = dir.join("config.toml");
    let cfg = Config::load(&cfg_path)?;
    let truth = dir.join("truth.nav");
    let names = ["fixed", "iae", "afkf", "fused", "iakf", "sage-husa"];
    let windows = [(200.0, 260.0), (400.0, 460.0)];
    // the fixed filter's run is smoothed too (post-processing, with the one-file report)
    let smoothed_cfg = Config {
        filter: crate::config::FilterSection { smooth: true, ..cfg.filter.clone() },
        ..cfg.clone()
    };
    let mut evals = Vec::new();
    let mut fixed = None;
    for name in names {
        let out = dir.join("out").join(name);
        let run_cfg = if name == "fixed" { &smoothed_cfg } else { &cfg };
        let s = run_config(run_cfg, strategy(name)?, &out, None)?;
        print_summary(&s);
        let ev = evaluate(&out.join("nav.txt"), &truth, 30.0, &windows)?;
        if name == "fixed" {
            fixed = Some((s, ev.clone()));
        }
        evals.push((name, ev));
    }
    let fixed_dir = dir.join("out").join("fixed");
    let smoothed = evaluate(&fixed_dir.join("nav_smoothed.txt"), &truth, 30.0, &windows)?;
    evals.push(("fixed, smoothed", smoothed.clone()));
    out!("\nwhole run after 30 s:");
    let rows: Vec<(&str, &Stats)> = evals.iter().map(|(n, e)| (*n, &e.overall)).collect();
    print_table(&rows);
    out!("\ninside the interference window 200–260 s:");
    let rows: Vec<(&str, &Stats)> = evals.iter().map(|(n, e)| (*n, &e.windows[0])).collect();
    print_table(&rows);
    out!("\ninside the outage 400–460 s:");
    let rows: Vec<(&str, &Stats)> = evals.iter().map(|(n, e)| (*n, &e.windows[1])).collect();
    print_table(&rows);
    let fixes = read_fixes(&cfg)?;
    let mut fixed_figures = Vec::new();
    for name in names {
        let out = dir.join("out").join(name);
        let figures = crate::plot::write_all(&out, &truth, None, &fixes, 30.0)?;
        for f in &figures {
            out!("plot: {}", f.display());
        }
        if name == "fixed" {
            fixed_figures = figures;
        }
    }
    if let Some((summary, forward)) = fixed {
        let tables =
            vec![("fixed".to_string(), forward), ("fixed, smoothed".to_string(), smoothed)];
        let page =
            crate::report::write(&fixed_dir, &summary, &smoothed_cfg, &tables, &fixed_figures)?;
        out!("report (the fixed filter, forward and smoothed): {}", page.display());
    }
    out!("demo finished in {:.1} s", t.elapsed().as_secs_f64());
    Ok(())
}
