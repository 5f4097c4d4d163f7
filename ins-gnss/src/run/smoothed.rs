//! The backward pass: the smoothed files, written backwards and turned around in place.

use super::*;

/// The smoother's scratch file in the output directory (removed when the run ends).
pub(crate) const SMOOTHER_STATES: &str = "smoother-segments.tmp";

/// Predictions per smoother segment at most (the backward pass holds one segment: three
/// `N × N` matrices per prediction, 0.7 MB with 15 states).
pub(crate) const SMOOTHER_SEGMENT: usize = 128;

/// The recorder of a run that smooths: the segment smoother on a scratch file.
pub(crate) type Recorder<S, T = std::fs::File> = estimator_core::SegmentSmoother<S, ImuInput, T>;

/// The backward pass: `nav_smoothed.txt`, `std_smoothed.txt` and `nav_smoothed.pos` (as
/// `.partial`, in the formats of `nav.txt`, `std.txt` and `nav.pos`: the first at every
/// IMU epoch, the others at the epochs of `std.txt`). The smoother hands the segments
/// last to first: each batch's text is appended to its file with its bytes reversed, so
/// each file ends up as its final text backwards, which is then turned around in place
/// ([`reverse_file`]): no scratch file, the disk never holds more than the outputs.
/// Returns the number of rows.
pub(crate) fn write_smoothed<S: RunState>(
    recorder: Recorder<S>,
    nav: &Navigator<RunStrategy, S>,
    dir: &Path,
    floors: &Floors,
) -> Result<usize, RunError>
where
    estimator_core::Cov<S::Dim>: Send,
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let names = Outputs::SMOOTHED.map(|name| partial_path(&dir.join(name)));
    let result = write_smoothed_into(recorder, nav, &names, floors);
    if result.is_err() {
        // half-written, backwards: of no use to anyone
        for path in &names {
            let _ = std::fs::remove_file(path);
        }
    }
    result
}

pub(crate) fn write_smoothed_into<S: RunState>(
    recorder: Recorder<S>,
    nav: &Navigator<RunStrategy, S>,
    names: &[PathBuf; 3],
    floors: &Floors,
) -> Result<usize, RunError>
where
    estimator_core::Cov<S::Dim>: Send,
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |e: std::io::Error| RunError::Output { path: path.clone(), message: e.to_string() }
    };
    let open = |path: &PathBuf| {
        std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)
            .map_err(io(path))
    };
    let files = [open(&names[0])?, open(&names[1])?, open(&names[2])?];
    // The rows are formatted and written by a second thread while the backward pass runs.
    let n = S::SIGMA_COLUMNS;
    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<Row>>(8);
    let writer = std::thread::spawn(move || write_rows_backwards(files, rx, n));
    // segments arrive last to first: their rows are gathered backwards, and a batch of
    // them is turned around and sent as one chunk, in time order
    const BATCH_ROWS: usize = 4096;
    let mut pending: Vec<Row> = Vec::with_capacity(BATCH_ROWS + SMOOTHER_SEGMENT);
    let send = |pending: &mut Vec<Row>| {
        pending.reverse();
        let rows = core::mem::replace(pending, Vec::with_capacity(BATCH_ROWS + SMOOTHER_SEGMENT));
        tx.send(rows).map_err(|_| std::io::Error::other("the row writer stopped"))
    };
    let smoothed =
        recorder.smooth_threaded(nav.filter(), nav.model(), |rows: &[SmoothedRow<S>]| {
            pending.extend(rows.iter().rev().map(|r| smoothed_row(r, floors)));
            if pending.len() >= BATCH_ROWS {
                send(&mut pending)?;
            }
            Ok(())
        });
    let smoothed = smoothed.and_then(|()| send(&mut pending).map_err(Into::into));
    drop(tx);
    let written = writer
        .join()
        .map_err(|_| RunError::NoData("the smoother's writer thread panicked".into()))?;
    let dir = names[0].parent().unwrap_or(Path::new("."));
    // a failed write stops the writer and then the backward pass ("the row writer
    // stopped"): the write's error is the cause, and is reported first
    let (files, count) = written.map_err(|(i, e)| io(&names[i])(e))?;
    smoothed.map_err(|e| RunError::Output {
        path: dir.join(SMOOTHER_STATES),
        message: e.to_string(),
    })?;
    // the three files turned around side by side (a day at 100 Hz is 2.5 GB of text)
    let flipped: Vec<std::io::Result<()>> = std::thread::scope(|scope| {
        let handles: Vec<_> =
            files.into_iter().map(|mut f| scope.spawn(move || reverse_file(&mut f))).collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    for (i, result) in flipped.into_iter().enumerate() {
        result.map_err(io(&names[i]))?;
    }
    Ok(count)
}

/// A smoothed row: time, state, σ of the error states (as many as the state has) where
/// asked.
type Row = (f64, InsState, Option<[f64; 21]>);

/// The smoother's writer thread: each chunk of rows `rx` brings (in time order, the chunks
/// last to first) formatted and written backwards into `nav_smoothed.txt`,
/// `std_smoothed.txt` (`n` σ columns) and `nav_smoothed.pos`, the `.pos` header last; the
/// files and the row count, or the index of the file whose write failed.
#[allow(clippy::type_complexity)]
fn write_rows_backwards(
    files: [std::fs::File; 3],
    rx: std::sync::mpsc::Receiver<Vec<Row>>,
    n: usize,
) -> Result<(Vec<std::fs::File>, usize), (usize, std::io::Error)> {
    let mut out = files.map(|f| std::io::BufWriter::with_capacity(1 << 16, f));
    let mut count = 0usize;
    let mut text: [Vec<u8>; 3] = Default::default();
    let var = |s: &[f64]| -> nalgebra::Matrix3<f64> {
        let z = 0.0;
        nalgebra::Matrix3::new(s[0] * s[0], z, z, z, s[1] * s[1], z, z, z, s[2] * s[2])
    };
    for rows in rx {
        let [nav_text, std_text, pos_text] = &mut text;
        nav_text.clear();
        std_text.clear();
        pos_text.clear();
        for (t, x, sigma) in &rows {
            push_nav(nav_text, &nav_record(*t, x));
            let Some(sigma) = sigma else { continue };
            let (row, len) = sigma_row(*t, &sigma[..n]);
            push_row(std_text, &row[..len]);
            // the smoother keeps the variances only: the .pos covariances are written as 0
            let vel_var = var(&sigma[InsState::VEL.range()]);
            let vel = Some((&x.vel, &vel_var));
            let pos_var = var(&sigma[InsState::POS.range()]);
            ins_gnss_io::rtklib::push_epoch(pos_text, 0.0, *t, &x.pos, &pos_var, vel, 1);
        }
        for (i, (w, t)) in out.iter_mut().zip(text.iter_mut()).enumerate() {
            t.reverse();
            w.write_all(t).map_err(|e| (i, e))?;
        }
        count += rows.len();
    }
    // the .pos header goes first: last, backwards
    let mut header = Vec::new();
    let program = concat!("ins-gnss ", env!("CARGO_PKG_VERSION"), ", smoothed");
    ins_gnss_io::rtklib::write_header(&mut header, program, true).map_err(|e| (2, e))?;
    header.reverse();
    out[2].write_all(&header).map_err(|e| (2, e))?;
    let mut files = Vec::new();
    for (i, w) in out.into_iter().enumerate() {
        files.push(w.into_inner().map_err(|e| (i, e.into_error()))?);
    }
    Ok((files, count))
}

/// Reverse the bytes of `file` in place: blocks from both ends swapped and reversed,
/// moving inwards (one read and one write of every byte, 3 MB of memory).
pub(crate) fn reverse_file(file: &mut std::fs::File) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    const BLOCK: u64 = 1 << 20;
    let (mut lo, mut hi) = (0u64, file.seek(SeekFrom::End(0))?);
    // (`a` holds the middle too, up to two blocks)
    let (mut a, mut b) = (vec![0u8; 2 * BLOCK as usize], vec![0u8; BLOCK as usize]);
    let at = |file: &mut std::fs::File, pos: u64, buf: &mut [u8], write: bool| {
        file.seek(SeekFrom::Start(pos))?;
        if write {
            file.write_all(buf)
        } else {
            file.read_exact(buf)
        }
    };
    while hi - lo >= 2 * BLOCK {
        let a = &mut a[..BLOCK as usize];
        at(file, lo, a, false)?;
        at(file, hi - BLOCK, &mut b, false)?;
        a.reverse();
        b.reverse();
        at(file, lo, &mut b, true)?;
        at(file, hi - BLOCK, a, true)?;
        lo += BLOCK;
        hi -= BLOCK;
    }
    let mid = &mut a[..(hi - lo) as usize];
    at(file, lo, mid, false)?;
    mid.reverse();
    at(file, lo, mid, true)?;
    file.flush()
}

#[cfg(feature = "unit-tests")]
#[doc(hidden)]
pub mod smoothed_tests {
    use super::*;

    /// `reverse_file` turns files of every length around, blocks and middle included.
    pub fn files_are_reversed_in_place() {
        let dir = std::env::temp_dir().join(format!("ins-gnss-reverse-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("f");
        let block = 1usize << 20;
        for len in [0, 1, 2, 1000, 2 * block - 1, 2 * block, 2 * block + 1, 5 * block + 3] {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 7 + i / 251) as u8).collect();
            std::fs::write(&path, &bytes).unwrap();
            let mut file = std::fs::OpenOptions::new().read(true).write(true).open(&path).unwrap();
            reverse_file(&mut file).unwrap();
            drop(file);
            let back = std::fs::read(&path).unwrap();
            let expected: Vec<u8> = bytes.iter().rev().copied().collect();
            assert!(back == expected, "length {len}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
