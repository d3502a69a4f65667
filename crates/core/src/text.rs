//! Reading input text safely, and echoing it back in messages.
//!
//! - [`echo`] quotes a piece of input for an error message: control characters escaped (a
//!   terminal never sees raw escape sequences from a file), invalid UTF-8 shown as `\xNN`,
//!   and anything longer than [`ECHO_CHARS`] cut with a note of its full length, so a 50 MB
//!   bad token is still a one-line message. [`escape_controls`] does the escaping alone, for
//!   whole messages.
//! - [`read_line_bounded`] reads one line into a buffer of at most a given length: a file
//!   without newlines (`/dev/zero`) is an error, not a 4 GB allocation.
//! - [`read_text_file`] reads a whole text file of bounded size and checks it is UTF-8,
//!   naming the line and column of the first bad byte.

use crate::FileError;
use std::fmt::Write as _;
use std::io::{self, BufRead, Read};
use std::path::Path;

/// Characters of input quoted in a message before it is cut (assumed: enough for any real
/// token, number or key, and short enough to keep a message on one line).
pub const ECHO_CHARS: usize = 64;

/// Longest line the text readers accept (assumed: 1 MiB; the longest line of the shipped
/// scenes is under 200 bytes, and a real polygon of 10^5 vertices still fits).
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Largest configuration or descriptor file read whole (assumed: 16 MiB, thousands of times
/// any real one).
pub const MAX_TEXT_FILE_BYTES: u64 = 16 << 20;

/// `input` quoted for a message: escaped, and cut after [`ECHO_CHARS`] characters.
pub fn echo(input: impl AsRef<[u8]>) -> String {
    let bytes = input.as_ref();
    let mut out = String::new();
    let mut shown = 0;
    let mut rest = bytes;
    while !rest.is_empty() {
        if shown == ECHO_CHARS {
            let _ = write!(out, "… ({} bytes in all)", bytes.len());
            break;
        }
        match std::str::from_utf8(rest) {
            Ok(s) => {
                let c = s.chars().next().expect("non-empty");
                push_escaped(&mut out, c);
                rest = &rest[c.len_utf8()..];
            }
            Err(e) if e.valid_up_to() > 0 => {
                let s = std::str::from_utf8(&rest[..e.valid_up_to()]).expect("valid prefix");
                let c = s.chars().next().expect("non-empty");
                push_escaped(&mut out, c);
                rest = &rest[c.len_utf8()..];
            }
            Err(_) => {
                let _ = write!(out, "\\x{:02x}", rest[0]);
                rest = &rest[1..];
            }
        }
        shown += 1;
    }
    out
}

fn push_escaped(out: &mut String, c: char) {
    match c {
        '\n' => out.push_str("\\n"),
        '\r' => out.push_str("\\r"),
        '\t' => out.push_str("\\t"),
        c if c.is_control() => {
            let _ = write!(out, "\\u{{{:x}}}", c as u32);
        }
        c => out.push(c),
    }
}

/// `message` (from a library that quotes input raw, such as serde or clap) with each span
/// between two `quote` characters that is too long or holds control characters replaced by
/// its [`echo`]; other spans are left alone.
pub fn echo_quoted(message: &str, quote: char) -> String {
    let parts: Vec<&str> = message.split(quote).collect();
    let mut out = String::with_capacity(message.len().min(1024));
    for (i, part) in parts.iter().enumerate() {
        if i > 0 {
            out.push(quote);
        }
        // Odd parts are inside a pair of quotes (when a closing quote follows).
        let quoted = i % 2 == 1 && i + 1 < parts.len();
        if quoted && (part.chars().count() > ECHO_CHARS || part.chars().any(char::is_control)) {
            out.push_str(&echo(part));
        } else {
            out.push_str(part);
        }
    }
    out
}

/// `s` with every control character escaped (`\n`, `\u{1b}` …); nothing is cut.
pub fn escape_controls(s: &str) -> String {
    if !s.chars().any(char::is_control) {
        return s.to_string();
    }
    let mut out = String::with_capacity(s.len() + 16);
    for c in s.chars() {
        push_escaped(&mut out, c);
    }
    out
}

/// Result of [`read_line_bounded`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Line {
    /// End of input: nothing was read.
    Eof,
    /// A line of this many bytes was read (terminator included, if any).
    Read(usize),
    /// The line is longer than the limit; the buffer holds its first `max` bytes.
    TooLong,
}

/// Append the next line (up to and including `\n`) to `buf`, reading at most `max` bytes.
pub fn read_line_bounded<R: BufRead + ?Sized>(
    reader: &mut R,
    buf: &mut Vec<u8>,
    max: usize,
) -> io::Result<Line> {
    let start = buf.len();
    let n = reader.take(max as u64 + 1).read_until(b'\n', buf)?;
    if n == 0 {
        return Ok(Line::Eof);
    }
    if n == max + 1 && buf.last() != Some(&b'\n') {
        buf.truncate(start + max);
        return Ok(Line::TooLong);
    }
    Ok(Line::Read(n))
}

/// The message for a line over the limit.
pub fn line_too_long(max: usize) -> String {
    format!("line longer than {max} bytes (not a text file of this format, or no line breaks?)")
}

/// `bytes` as UTF-8, or a message naming the column (1-based, in bytes) of the first bad byte.
pub fn utf8(bytes: &[u8]) -> Result<&str, String> {
    std::str::from_utf8(bytes).map_err(|e| {
        format!(
            "not valid UTF-8 text (byte 0x{:02x} at column {})",
            bytes[e.valid_up_to()],
            e.valid_up_to() + 1
        )
    })
}

/// Read a whole text file of at most [`MAX_TEXT_FILE_BYTES`]; errors name the file, and for
/// invalid UTF-8 the line and column.
pub fn read_text_file(path: &Path) -> Result<String, FileError> {
    let file = std::fs::File::open(path).map_err(|e| FileError::io(path, e))?;
    if let Ok(m) = file.metadata()
        && m.is_dir()
    {
        return Err(FileError::io(
            path,
            io::Error::new(io::ErrorKind::InvalidInput, "is a directory, not a file"),
        ));
    }
    let mut bytes = Vec::new();
    file.take(MAX_TEXT_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| FileError::io(path, e))?;
    if bytes.len() as u64 > MAX_TEXT_FILE_BYTES {
        return Err(FileError::io(
            path,
            io::Error::new(
                io::ErrorKind::InvalidData,
                format!("larger than the {MAX_TEXT_FILE_BYTES} bytes a text file may have"),
            ),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let at = e.utf8_error().valid_up_to();
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() as u64 + 1;
        let col = at
            - bytes[..at]
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |i| i + 1)
            + 1;
        FileError::at(
            path,
            line,
            format!(
                "not valid UTF-8 text (byte 0x{:02x} at column {col})",
                bytes[at]
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn echo_escapes_and_cuts() {
        assert_eq!(echo("1.5x"), "1.5x");
        assert_eq!(echo("a\u{1b}[2Jb\n"), "a\\u{1b}[2Jb\\n");
        assert_eq!(echo(b"\xffok"), "\\xffok");
        let long = "x".repeat(10_000);
        let e = echo(&long);
        assert!(e.starts_with(&"x".repeat(ECHO_CHARS)), "{e}");
        assert!(e.ends_with("… (10000 bytes in all)"), "{e}");
        assert!(e.chars().count() < ECHO_CHARS + 30);
        assert_eq!(escape_controls("a\tb\u{7}"), "a\\tb\\u{7}");
        let m = format!("unknown field `{long}`, expected `a` or `b\u{7}`");
        let e = echo_quoted(&m, '`');
        assert!(e.starts_with("unknown field `xxx") && e.contains("(10000 bytes in all)`"));
        assert!(e.ends_with(", expected `a` or `b\\u{7}`"), "{e}");
        assert_eq!(echo_quoted("it's `ok`", '`'), "it's `ok`");
    }

    #[test]
    fn bounded_lines() {
        let mut r: &[u8] = b"ab\ncdefg\ngh";
        let mut buf = Vec::new();
        assert_eq!(
            read_line_bounded(&mut r, &mut buf, 4).unwrap(),
            Line::Read(3)
        );
        buf.clear();
        assert_eq!(
            read_line_bounded(&mut r, &mut buf, 4).unwrap(),
            Line::TooLong
        );
        assert_eq!(buf, b"cdef");
        let mut r: &[u8] = b"abcd\n";
        buf.clear();
        assert_eq!(
            read_line_bounded(&mut r, &mut buf, 4).unwrap(),
            Line::Read(5)
        );
        let mut r: &[u8] = b"abcd";
        buf.clear();
        assert_eq!(
            read_line_bounded(&mut r, &mut buf, 4).unwrap(),
            Line::Read(4)
        );
        buf.clear();
        assert_eq!(read_line_bounded(&mut r, &mut buf, 4).unwrap(), Line::Eof);
        // A newline-free stream stops at the limit.
        let mut zeros = io::BufReader::new(io::repeat(0));
        buf.clear();
        assert_eq!(
            read_line_bounded(&mut zeros, &mut buf, 1000).unwrap(),
            Line::TooLong
        );
        assert_eq!(buf.len(), 1000);
    }

    #[test]
    fn text_files_locate_bad_utf8() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.toml");
        std::fs::write(&p, b"a = 1\nb = \"\xe9\"\n").unwrap();
        let e = read_text_file(&p).unwrap_err().to_string();
        assert!(e.contains("c.toml:2:") && e.contains("column 6"), "{e}");
        let e = read_text_file(dir.path()).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
    }
}
