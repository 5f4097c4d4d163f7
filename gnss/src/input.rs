//! Opening the receivers' files: a buffered reader, decompressed on the fly when the name
//! ends in `.gz`, `.zst` or `.xz` (users' logs are often compressed). The INS's readers
//! open their files the same way.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;
use std::sync::{Arc, Mutex};

/// A buffered input file, decompressed on the fly when its name ends in `.gz`, `.zst` or
/// `.xz`.
pub type Input = BufReader<Box<dyn Read + Send>>;

/// Open a file for buffered reading; `.gz`, `.zst` (`.zstd`) and `.xz` files are
/// decompressed as they are read. The error says what went wrong, without the path.
pub fn open(path: &Path) -> Result<Input, String> {
    let file = File::open(path).map_err(|e| e.to_string())?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let raw = BufReader::with_capacity(1 << 16, file);
    let inner: Box<dyn Read + Send> = match ext.as_str() {
        "gz" | "gzip" => Box::new(flate2::bufread::MultiGzDecoder::new(raw)),
        "zst" | "zstd" => Box::new(
            zstd::stream::read::Decoder::with_buffer(raw)
                .map_err(|e| format!("not a zstd file: {e}"))?,
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
            return XzInput { pipe: None, failure: Arc::new(Mutex::new(Some(e.to_string()))) };
        }
    };
    let failure = Arc::new(Mutex::new(None));
    let slot = Arc::clone(&failure);
    std::thread::spawn(move || {
        let mut decoder = liblzma::bufread::XzDecoder::new_multi_decoder(&mut raw);
        if let Err(e) = std::io::copy(&mut decoder, &mut writer)
            && let Ok(mut s) = slot.lock()
        {
            *s = Some(format!("xz decoding failed: {e}"));
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
        if n == 0
            && let Some(e) = self.failure.lock().ok().and_then(|mut s| s.take())
        {
            return Err(std::io::Error::other(e));
        }
        Ok(n)
    }
}
