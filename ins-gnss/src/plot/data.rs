//! The run's output files read into series, decimated to what a plot can show.

use super::*;

pub(super) type Series = Vec<(f64, f64)>;

/// Points kept per series: a plot has no use for more, and a day at the IMU rate would
/// not fit in memory as points.
pub(super) const MAX_POINTS: usize = 4000;

/// Every `stride`-th item pushed, the stride doubling (and every other kept item dropped)
/// whenever more than `2 · limit` are kept: between `limit` and `2 · limit` items spread
/// evenly over any number pushed, in bounded memory.
pub(super) struct Decimator<T> {
    pub(super) items: Vec<T>,
    stride: usize,
    seen: usize,
    limit: usize,
}

impl<T> Decimator<T> {
    pub(super) fn new(limit: usize) -> Self {
        Self { items: Vec::new(), stride: 1, seen: 0, limit }
    }

    pub(super) fn push(&mut self, item: T) {
        if self.seen.is_multiple_of(self.stride) {
            self.items.push(item);
            if self.items.len() > 2 * self.limit {
                let mut k = 0;
                self.items.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
        }
        self.seen += 1;
    }
}

pub(super) fn read_columns(path: &Path) -> Result<Vec<Vec<f64>>, String> {
    let mut lines = NumericLines::new(open(path).map_err(|e| e.to_string())?, path);
    let mut out = Decimator::new(MAX_POINTS);
    while let Some(r) = lines.next_record().map_err(|e| e.to_string())? {
        out.push(r.to_vec());
    }
    Ok(out.items)
}

pub(super) fn read_updates(path: &Path) -> Result<Vec<(f64, f64, f64, f64)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() < 10 {
            return Err(format!("{}:{}: expected 10 columns", path.display(), i + 1));
        }
        let num = |s: &str| s.trim().parse::<f64>().unwrap_or(f64::NAN);
        out.push((num(f[0]), num(f[7]), num(f[8]), num(f[9])));
    }
    Ok(out)
}

/// The stationary periods of a run: the spans of its ZUPT updates (rows of stream
/// `zupt` in `updates.csv` less than a second apart form one period).
pub(super) fn stationary_periods(path: &Path) -> Result<Vec<(f64, f64)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out: Vec<(f64, f64)> = Vec::new();
    for line in text.lines().skip(1) {
        let mut f = line.split(',');
        let (Some(t), Some("zupt")) = (f.next(), f.next()) else { continue };
        let Ok(t) = t.trim().parse::<f64>() else { continue };
        match out.last_mut() {
            Some(last) if t - last.1 < 1.0 => last.1 = t,
            _ => out.push((t, t)),
        }
    }
    Ok(out)
}

/// Errors of the result against the truth, decimated to 4,000–8,000 points.
pub(super) fn error_series(
    result: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
) -> Result<[Series; 6], String> {
    let mut res = NavReader::open(result).map_err(|e| e.to_string())?;
    let map = columns.map(TruthColumns::map).transpose()?;
    let mut tru = RefReader::open(truth, map.as_ref()).map_err(|e| e.to_string())?;
    let mut all = Decimator::<(f64, [f64; 6])>::new(MAX_POINTS);
    let mut t_rec = tru.next_record().map_err(|e| e.to_string())?;
    if t_rec.is_some_and(|t| t.vel.x.is_nan()) {
        // a position reference (RTK fixes at a few Hz): the result interpolated at its
        // epochs, as `eval` compares them; no attitude
        let (mut a, mut b) = (res.next_record().map_err(|e| e.to_string())?, None);
        b = b.or(res.next_record().map_err(|e| e.to_string())?);
        while let Some(t) = t_rec {
            while let (Some(_), Some(rb)) = (&a, &b) {
                if rb.t >= t.t {
                    break;
                }
                a = b.take();
                b = res.next_record().map_err(|e| e.to_string())?;
            }
            if let (Some(ra), Some(rb)) = (&a, &b)
                && ra.t <= t.t
                && rb.t >= t.t
                && rb.t - ra.t <= MAX_REFERENCE_GAP
            {
                let (dp, _, _) = errors(&interpolate(ra, rb, t.t), &t);
                all.push((t.t, [dp.x, dp.y, dp.z, f64::NAN, f64::NAN, f64::NAN]));
            }
            t_rec = tru.next_record().map_err(|e| e.to_string())?;
        }
    }
    while let Some(r) = res.next_record().map_err(|e| e.to_string())? {
        while let Some(t) = &t_rec {
            if t.t >= r.t - 1e-6 {
                break;
            }
            t_rec = tru.next_record().map_err(|e| e.to_string())?;
        }
        if let Some(t) = &t_rec
            && (t.t - r.t).abs() < 1e-6
        {
            let (dp, _, da) = errors(&r, t);
            all.push((r.t, [dp.x, dp.y, dp.z, da.x, da.y, da.z]));
        }
    }
    let mut out: [Series; 6] = Default::default();
    for (t, e) in &all.items {
        for k in 0..6 {
            out[k].push((*t, e[k]));
        }
    }
    Ok(out)
}
