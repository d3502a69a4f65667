//! [`FileError`]: the one error type for "this input file is wrong here" — trace readers, scene
//! loaders and query files all report a path, a line where there is one, and what is wrong.

use std::path::PathBuf;

/// An input file that cannot be read, or a line of it that is wrong.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {message}")]
    Parse {
        path: PathBuf,
        line: u64,
        message: String,
    },
}

impl FileError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> FileError {
        FileError::Io {
            path: path.into(),
            source,
        }
    }

    /// Line `line` (1-based) of `path` is wrong: `message` says how (any error's text).
    pub fn at(path: impl Into<PathBuf>, line: u64, message: impl std::fmt::Display) -> FileError {
        FileError::Parse {
            path: path.into(),
            line,
            message: message.to_string(),
        }
    }
}

/// What a file is, for messages ("a regular file", "a FIFO" …).
pub fn describe_file_type(ft: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_char_device() {
            return "a character device";
        }
        if ft.is_block_device() {
            return "a block device";
        }
        if ft.is_fifo() {
            return "a FIFO";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    if ft.is_dir() {
        "a directory"
    } else if ft.is_symlink() {
        "a symbolic link"
    } else {
        "a regular file"
    }
}
