//! Opening (with decompression) and atomic publishing of files.

use super::*;

/// A buffered input file, decompressed on the fly when its name ends in `.gz`, `.zst` or
/// `.xz`.
pub type Input = BufReader<Box<dyn Read + Send>>;

/// Open a file for buffered reading, with a located error; `.gz`, `.zst` (`.zstd`) and
/// `.xz` files are decompressed as they are read (users' logs are often compressed).
pub fn open(path: &Path) -> Result<Input, LineError> {
    let err =
        |e: String| LineError { path: path.to_path_buf(), line: 0, kind: LineErrorKind::Io(e) };
    let file = File::open(path).map_err(|e| err(e.to_string()))?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let raw = BufReader::with_capacity(1 << 16, file);
    let inner: Box<dyn Read + Send> = match ext.as_str() {
        "gz" | "gzip" => Box::new(flate2::bufread::MultiGzDecoder::new(raw)),
        "zst" | "zstd" => Box::new(
            zstd::stream::read::Decoder::with_buffer(raw)
                .map_err(|e| err(format!("not a zstd file: {e}")))?,
        ),
        "xz" => Box::new(xz_reader(raw)),
        _ => Box::new(raw),
    };
    Ok(BufReader::with_capacity(1 << 16, inner))
}

/// An xz stream decoded by liblzma on a thread of its own into a pipe, so that decoding
/// (xz's own `xz -dc` takes 2.3× the whole plain navego run here) overlaps parsing and
/// filtering. A decoding error is stored before the pipe closes, so the reader reports
/// it instead of a short file.
fn xz_reader(mut raw: BufReader<File>) -> XzInput {
    let (reader, mut writer) = match std::io::pipe() {
        Ok(p) => p,
        Err(e) => {
            return XzInput { pipe: None, failure: Arc::new(Mutex::new(Some(e.to_string()))) }
        }
    };
    let failure = Arc::new(Mutex::new(None));
    let slot = Arc::clone(&failure);
    std::thread::spawn(move || {
        let mut decoder = liblzma::bufread::XzDecoder::new_multi_decoder(&mut raw);
        if let Err(e) = std::io::copy(&mut decoder, &mut writer) {
            if let Ok(mut s) = slot.lock() {
                *s = Some(format!("xz decoding failed: {e}"));
            }
        }
        drop(writer);
    });
    XzInput { pipe: Some(reader), failure }
}

struct XzInput {
    pipe: Option<std::io::PipeReader>,
    failure: Arc<Mutex<Option<String>>>,
}

impl Read for XzInput {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = match &mut self.pipe {
            Some(p) => p.read(buf)?,
            None => 0,
        };
        if n == 0 {
            if let Some(e) = self.failure.lock().ok().and_then(|mut s| s.take()) {
                return Err(std::io::Error::other(e));
            }
        }
        Ok(n)
    }
}

/// `path` with `.partial` appended: where an output is written until it is complete and
/// renamed into place ([`create_partial`], [`publish`]).
pub fn partial_path(path: &Path) -> std::path::PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".partial");
    std::path::PathBuf::from(s)
}

/// Create `path.partial` for writing: the output `path` itself is untouched until
/// [`publish`] renames the finished file over it, so a failed or interrupted run never
/// destroys an earlier result.
pub fn create_partial(path: &Path) -> std::io::Result<BufWriter<File>> {
    create(&partial_path(path))
}

/// Rename the finished `path.partial` over `path` (atomic on one file system).
pub fn publish(path: &Path) -> std::io::Result<()> {
    std::fs::rename(partial_path(path), path)
}

/// Create a file for buffered writing (truncating it).
pub fn create(path: &Path) -> std::io::Result<BufWriter<File>> {
    Ok(BufWriter::with_capacity(1 << 16, File::create(path)?))
}
