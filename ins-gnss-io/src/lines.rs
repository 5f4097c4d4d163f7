//! A streaming reader of numeric text lines with located, typed errors.
//!
//! Lines are split on whitespace and commas; blank lines and lines starting with `#` or
//! `%` are comments. Each record is checked for its column count and for values that
//! are not numbers or not finite. Memory does not grow with the file: one line buffer and
//! one value buffer are reused.

use core::fmt;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// What is wrong with a line (or a file).
#[derive(Clone, Debug, PartialEq)]
pub enum LineErrorKind {
    /// The file could not be opened or read.
    Io(String),
    /// The file has no data line.
    Empty,
    /// The line has a column count the format does not allow.
    ColumnCount {
        /// Allowed counts.
        expected: Vec<usize>,
        /// Found.
        found: usize,
    },
    /// A field is not a number.
    NotNumeric {
        /// 1-based column.
        column: usize,
        /// The text.
        text: String,
    },
    /// A field is NaN or infinite.
    NonFinite {
        /// 1-based column.
        column: usize,
    },
    /// The time is earlier than the previous line's.
    TimeBackwards {
        /// This line's time, s.
        t: f64,
        /// The previous time, s.
        previous: f64,
    },
    /// The time equals the previous line's.
    DuplicateTime {
        /// The time, s.
        t: f64,
    },
    /// The gap to the previous line is longer than allowed.
    Gap {
        /// The gap, s.
        gap: f64,
        /// The largest gap allowed, s.
        allowed: f64,
        /// The line before the gap.
        previous_line: usize,
    },
    /// Values that cannot be what the format says (e.g. rates where increments are
    /// expected).
    WrongUnits(String),
    /// A record that cannot be used, with why (a recording's message: `line` is its
    /// 1-based position).
    Invalid(String),
}

/// A located error: file, 1-based line, what.
#[derive(Clone, Debug, PartialEq)]
pub struct LineError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line number (0 for file-level errors).
    pub line: usize,
    /// What is wrong.
    pub kind: LineErrorKind,
}

impl fmt::Display for LineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = self.path.display();
        let l = self.line;
        match &self.kind {
            LineErrorKind::Io(e) => write!(f, "{p}: cannot read: {e}"),
            LineErrorKind::Empty => write!(f, "{p}: no data lines"),
            LineErrorKind::ColumnCount { expected, found } => {
                let e: Vec<String> = expected.iter().map(|c| c.to_string()).collect();
                write!(f, "{p}:{l}: {found} columns, expected {}", e.join(" or "))
            }
            LineErrorKind::NotNumeric { column, text } => {
                write!(f, "{p}:{l}: column {column} is not a number: `{text}`")
            }
            LineErrorKind::NonFinite { column } => {
                write!(f, "{p}:{l}: column {column} is NaN or infinite")
            }
            LineErrorKind::TimeBackwards { t, previous } => {
                write!(f, "{p}:{l}: time goes backwards ({t} after {previous})")
            }
            LineErrorKind::DuplicateTime { t } => write!(f, "{p}:{l}: duplicate time {t}"),
            LineErrorKind::Gap { gap, allowed, previous_line } => write!(
                f,
                "{p}:{l}: gap of {gap:.6} s between line {previous_line} and this line \
                 (allowed {allowed:.6} s)"
            ),
            LineErrorKind::WrongUnits(m) => write!(f, "{p}:{l}: {m}"),
            LineErrorKind::Invalid(m) => write!(f, "{p}:#{l}: {m}"),
        }
    }
}

impl std::error::Error for LineError {}

/// Reads numeric records from any `BufRead` (fields separated by white space, commas or
/// semicolons).
pub struct NumericLines<R: BufRead> {
    inner: R,
    path: PathBuf,
    line: usize,
    buf: Vec<u8>,
    values: Vec<f64>,
    /// When set, the slot of each 0-based field that is read (`None`: skipped, may hold
    /// anything, text included), up to the last one read.
    select: Option<Vec<Option<usize>>>,
    /// Number of fields read when selecting.
    selected: usize,
    /// Records held in memory (an array's rows) instead of text: see
    /// [`with_rows`](Self::with_rows).
    rows: Option<Rows>,
}

/// The rows of a row-major array of numbers, `width` per row.
struct Rows {
    data: std::sync::Arc<[f64]>,
    width: usize,
}

impl Rows {
    /// Row `k` (0-based), if there is one.
    fn row(&self, k: usize) -> Option<&[f64]> {
        self.data.get(k * self.width..(k + 1) * self.width)
    }
}

impl<R: BufRead> NumericLines<R> {
    /// Wrap a reader; `path` names it in errors.
    pub fn new(inner: R, path: &Path) -> Self {
        Self {
            inner,
            path: path.to_path_buf(),
            line: 0,
            buf: Vec::new(),
            values: Vec::new(),
            select: None,
            selected: 0,
            rows: None,
        }
    }

    /// Read the rows of `data` (row-major, `width` numbers per row) instead of text: the
    /// same records, checks and errors, with the 1-based row number as the line (callers
    /// with arrays: the Python bindings). There are no comment or header lines.
    pub fn with_rows(mut self, data: std::sync::Arc<[f64]>, width: usize) -> Self {
        self.rows = Some(Rows { data, width: width.max(1) });
        self
    }

    /// Read only the 0-based fields `columns` (distinct) of each line from now on, in that
    /// order (a CSV log's columns picked by name: see [`crate::columns`]).
    pub fn select(&mut self, columns: &[usize]) {
        let len = columns.iter().max().map_or(0, |m| m + 1);
        let mut slots = vec![None; len];
        for (slot, &c) in columns.iter().enumerate() {
            slots[c] = Some(slot);
        }
        self.select = Some(slots);
        self.selected = columns.len();
    }

    /// The file name used in errors.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Line number of the last record returned.
    pub fn line(&self) -> usize {
        self.line
    }

    /// An error at the current line.
    pub fn error(&self, kind: LineErrorKind) -> LineError {
        LineError { path: self.path.clone(), line: self.line, kind }
    }

    /// Next raw data line (comments and blank lines skipped), as text.
    pub fn next_text(&mut self) -> Result<Option<&str>, LineError> {
        if self.rows.is_some() {
            return Ok(None);
        }
        if !self.advance()? {
            return Ok(None);
        }
        match std::str::from_utf8(&self.buf) {
            Ok(t) => Ok(Some(t.trim())),
            Err(_) => Err(self
                .error(LineErrorKind::NotNumeric { column: 0, text: "(not UTF-8 text)".into() })),
        }
    }

    /// Reads the comment (`#`, `%`) and blank lines at the start of the file, before any
    /// data line, and returns them (trimmed); the next record is then the first data
    /// line. Called before any record is read.
    pub fn leading_comments(&mut self) -> Result<Vec<String>, LineError> {
        let mut out = Vec::new();
        if self.rows.is_some() {
            return Ok(out);
        }
        loop {
            let io = |e: std::io::Error, line| LineError {
                path: self.path.clone(),
                line,
                kind: LineErrorKind::Io(e.to_string()),
            };
            let line = self.line + 1;
            let buf = self.inner.fill_buf().map_err(|e| io(e, line))?;
            let mut start = 0;
            if self.line == 0 && buf.starts_with(b"\xEF\xBB\xBF") {
                start = 3;
            }
            match buf[start.min(buf.len())..].iter().find(|b| **b != b' ' && **b != b'\t') {
                Some(b'#') | Some(b'%') | Some(b'\n') | Some(b'\r') => {}
                _ => return Ok(out),
            }
            self.buf.clear();
            let n = self.inner.read_until(b'\n', &mut self.buf).map_err(|e| io(e, line))?;
            if n == 0 {
                return Ok(out);
            }
            self.line += 1;
            let text = String::from_utf8_lossy(&self.buf[start.min(self.buf.len())..]);
            let text = text.trim();
            if !text.is_empty() {
                out.push(text.to_string());
            }
        }
    }

    /// The first byte of the next line that is not a space or a tab (without reading
    /// it), `None` at the end of the file.
    pub fn peek_byte(&mut self) -> Result<Option<u8>, LineError> {
        if let Some(rows) = &self.rows {
            return Ok(rows.row(self.line).map(|_| b'0'));
        }
        let line = self.line + 1;
        let buf = self.inner.fill_buf().map_err(|e| LineError {
            path: self.path.clone(),
            line,
            kind: LineErrorKind::Io(e.to_string()),
        })?;
        Ok(buf.iter().copied().find(|b| *b != b' ' && *b != b'\t'))
    }

    /// Move to the next data line; false at the end of the file.
    fn advance(&mut self) -> Result<bool, LineError> {
        loop {
            self.buf.clear();
            let n = self.inner.read_until(b'\n', &mut self.buf).map_err(|e| LineError {
                path: self.path.clone(),
                line: self.line + 1,
                kind: LineErrorKind::Io(e.to_string()),
            })?;
            if n == 0 {
                return Ok(false);
            }
            self.line += 1;
            if self.line == 1 && self.buf.starts_with(b"\xEF\xBB\xBF") {
                // a UTF-8 byte-order mark (editors on Windows write one): not data
                self.buf.drain(..3);
            }
            if is_data(&self.buf) {
                return Ok(true);
            }
        }
    }

    /// The values of the last record returned by [`next_record`](Self::next_record).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Next record of numbers; `Ok(None)` at the end of the file.
    pub fn next_record(&mut self) -> Result<Option<&[f64]>, LineError> {
        if self.rows.is_some() {
            return self.next_row();
        }
        // the common case: a data line whole in the reader's buffer is read where it is
        // (copying each line out first cost as much as finding its end)
        if self.select.is_none() && self.line > 0 {
            let (inner, values) = (&mut self.inner, &mut self.values);
            if let Ok(buffered) = inner.fill_buf()
                && let Some(end) = memchr::memchr(b'\n', buffered)
            {
                let line = &buffered[..=end];
                if is_data(line) {
                    values.clear();
                    let read = parse_line(line, values);
                    inner.consume(end + 1);
                    self.line += 1;
                    return match read {
                        Ok(()) => Ok(Some(&self.values)),
                        Err(kind) => Err(self.error(kind)),
                    };
                }
            }
        }
        if !self.advance()? {
            return Ok(None);
        }
        let values = &mut self.values;
        values.clear();
        if let Some(slots) = &self.select {
            let fields = self.buf.split(|b| is_separator(*b)).filter(|s| !s.is_empty());
            // the selected fields only, each into its slot (no allocation per line)
            values.resize(self.selected, f64::NAN);
            let mut found = 0;
            for (i, bytes) in fields.enumerate().take(slots.len()) {
                found = i + 1;
                let Some(slot) = slots[i] else { continue };
                match parse_field(bytes) {
                    Some(v) if v.is_finite() => values[slot] = v,
                    Some(_) => return Err(self.error(LineErrorKind::NonFinite { column: i + 1 })),
                    None => {
                        let field = std::str::from_utf8(bytes).unwrap_or("");
                        let text = field.chars().take(40).collect();
                        return Err(self.error(LineErrorKind::NotNumeric { column: i + 1, text }));
                    }
                }
            }
            if found < slots.len() {
                return Err(
                    self.error(LineErrorKind::ColumnCount { expected: vec![slots.len()], found })
                );
            }
            return Ok(Some(&self.values));
        }
        match parse_line(&self.buf, values) {
            Err(kind) => Err(self.error(kind)),
            Ok(()) => Ok(Some(&self.values)),
        }
    }

    /// [`next_record`](Self::next_record) in rows mode: the row's values, or the selected
    /// ones, with the text's refusal of NaN and infinity.
    fn next_row(&mut self) -> Result<Option<&[f64]>, LineError> {
        let Some(row) = self.rows.as_ref().and_then(|r| r.row(self.line)) else {
            return Ok(None);
        };
        self.line += 1;
        self.values.clear();
        match &self.select {
            Some(slots) => {
                self.values.resize(self.selected, f64::NAN);
                if row.len() < slots.len() {
                    let (expected, found) = (vec![slots.len()], row.len());
                    return Err(self.error(LineErrorKind::ColumnCount { expected, found }));
                }
                for (&v, slot) in row.iter().zip(slots) {
                    if let Some(slot) = slot {
                        self.values[*slot] = v;
                    }
                }
            }
            None => self.values.extend_from_slice(row),
        }
        match row.iter().position(|v| !v.is_finite()) {
            Some(i) => Err(self.error(LineErrorKind::NonFinite { column: i + 1 })),
            None => Ok(Some(&self.values)),
        }
    }
}
/// One field as a number: fast-float's parser straight on the bytes (no UTF-8 pass). It
/// gives the same correctly rounded value as `str::parse::<f64>` and refuses the same
/// texts (`parse_field_agrees_with_str_parse`); measured faster (`docs/history/benches.md`).
#[inline]
fn parse_field(bytes: &[u8]) -> Option<f64> {
    fast_float2::parse::<f64, _>(bytes).ok()
}

/// Whether a line holds data: not blank, not a comment (`#`, `%`).
fn is_data(line: &[u8]) -> bool {
    line.iter().find(|b| !b.is_ascii_whitespace()).is_some_and(|b| *b != b'#' && *b != b'%')
}

/// A field separator: white space, `,` or `;`.
#[inline(always)]
fn is_separator(b: u8) -> bool {
    b.is_ascii_whitespace() || b == b',' || b == b';'
}

/// The numbers of a line, appended to `values`: every field (a run of bytes between
/// separators) must be a finite number as [`parse_field`] reads it. One pass over the
/// bytes: each number is read where its field starts and must end at a separator (a
/// split into fields first, then a parse of each, read every byte twice).
fn parse_line(line: &[u8], values: &mut Vec<f64>) -> Result<(), LineErrorKind> {
    let mut at = 0;
    let mut column = 0;
    loop {
        while at < line.len() && is_separator(line[at]) {
            at += 1;
        }
        if at == line.len() {
            return Ok(());
        }
        column += 1;
        let rest = &line[at..];
        match fast_float2::parse_partial::<f64, _>(rest) {
            Ok((v, n)) if n > 0 && rest.get(n).is_none_or(|b| is_separator(*b)) => {
                if !v.is_finite() {
                    return Err(LineErrorKind::NonFinite { column });
                }
                values.push(v);
                at += n;
            }
            _ => {
                let end = rest.iter().position(|b| is_separator(*b)).unwrap_or(rest.len());
                let text = match std::str::from_utf8(&rest[..end]) {
                    Ok(field) => field.chars().take(40).collect(),
                    Err(_) => "(not UTF-8 text)".into(),
                };
                return Err(LineErrorKind::NotNumeric { column, text });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{parse_field, parse_line, LineErrorKind};

    /// The line split into fields first, then each field parsed (the reader before
    /// [`parse_line`]).
    fn split_then_parse(line: &[u8]) -> Result<Vec<f64>, LineErrorKind> {
        let mut values = Vec::new();
        let fields = line
            .split(|b| b.is_ascii_whitespace() || *b == b',' || *b == b';')
            .filter(|s| !s.is_empty());
        for (i, bytes) in fields.enumerate() {
            match parse_field(bytes) {
                Some(v) if v.is_finite() => values.push(v),
                Some(_) => return Err(LineErrorKind::NonFinite { column: i + 1 }),
                None => {
                    let text = match std::str::from_utf8(bytes) {
                        Ok(field) => field.chars().take(40).collect(),
                        Err(_) => "(not UTF-8 text)".into(),
                    };
                    return Err(LineErrorKind::NotNumeric { column: i + 1, text });
                }
            }
        }
        Ok(values)
    }

    fn one_pass(line: &[u8]) -> Result<Vec<f64>, LineErrorKind> {
        let mut values = Vec::new();
        parse_line(line, &mut values).map(|()| values)
    }

    fn bits(r: Result<Vec<f64>, LineErrorKind>) -> Result<Vec<u64>, LineErrorKind> {
        r.map(|v| v.iter().map(|x| x.to_bits()).collect())
    }

    #[test]
    fn one_pass_reads_lines_as_split_then_parse() {
        for line in [
            "1 2 3\n",
            "  456300.005 -1.5e-05,2.25;3 \r\n",
            "1e5e 2",
            "1.5-2 3",
            "inf 1",
            "1 nan",
            "infx",
            ". 1",
            "1,,2;;3\t\t4",
            "",
            "   \n",
            "+1 -.5 1. 0x10",
            "1\u{00e9}",
            "\u{0c}1\u{0b}2",
        ] {
            assert_eq!(
                bits(one_pass(line.as_bytes())),
                bits(split_then_parse(line.as_bytes())),
                "{line:?}"
            );
        }
        let bad = [b'1', b' ', 0xff, 0xfe, b'\n'];
        assert_eq!(bits(one_pass(&bad)), bits(split_then_parse(&bad)));
    }

    proptest::proptest! {
        /// Lines of numbers, separators and stray characters read the same either way.
        #[test]
        fn one_pass_agrees_with_split_then_parse(
            line in "[-+0-9.eEinfatyx ,;\t\r\n]{0,60}",
            numbers in proptest::collection::vec(proptest::num::f64::ANY, 0..8),
        ) {
            let (a, b) = (one_pass(line.as_bytes()), split_then_parse(line.as_bytes()));
            proptest::prop_assert_eq!(bits(a), bits(b), "{:?}", line);
            let text: Vec<String> = numbers.iter().map(|v| format!("{v:e}")).collect();
            let line = text.join(" , ");
            let (a, b) = (one_pass(line.as_bytes()), split_then_parse(line.as_bytes()));
            proptest::prop_assert_eq!(bits(a), bits(b), "{:?}", line);
        }
    }

    /// `str::parse`'s verdict on a field: the value's bits, or a refusal.
    fn std_parse(bytes: &[u8]) -> Option<u64> {
        std::str::from_utf8(bytes).ok()?.parse::<f64>().ok().map(f64::to_bits)
    }

    fn same(text: &[u8]) {
        let ours =
            parse_field(text).map(|v| if v.is_nan() { f64::NAN.to_bits() } else { v.to_bits() });
        let std =
            std_parse(text)
                .map(|b| if f64::from_bits(b).is_nan() { f64::NAN.to_bits() } else { b });
        assert_eq!(ours, std, "{:?}", String::from_utf8_lossy(text));
    }

    #[test]
    fn parse_field_agrees_with_str_parse_on_awkward_texts() {
        for t in [
            "0",
            "-0",
            "+1",
            "1.",
            ".5",
            "-.5",
            "1e5",
            "1E-5",
            "1e+5",
            "1e",
            "e5",
            ".",
            "-",
            "+",
            "",
            "1.2.3",
            "1,5",
            "0x10",
            "inf",
            "-inf",
            "Infinity",
            "NaN",
            "nan",
            "1e400",
            "-1e400",
            "1e-400",
            "4.9406564584124654e-324",
            "2.2250738585072011e-308",
            "9007199254740993",
            "0.1000000000000000055511151231257827",
            "1_000",
            " 1",
            "1 ",
            "١",
            "12abc",
            "--1",
            "1e5.5",
            "00012.5000",
            "179769313486231570000000000000000e276",
        ] {
            same(t.as_bytes());
        }
        same(&[0xff, 0x31]);
    }

    proptest::proptest! {
        #[test]
        fn parse_field_agrees_with_str_parse(v in proptest::num::f64::ANY, digits in 0usize..20) {
            for text in [format!("{v}"), format!("{v:e}"), format!("{v:.digits$}"), format!("{v:.digits$e}")] {
                same(text.as_bytes());
            }
        }

        #[test]
        fn parse_field_agrees_on_random_text(text in "[-+0-9.eE]{0,12}") {
            same(text.as_bytes());
        }
    }
}
