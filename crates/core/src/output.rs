//! Outputs: every file rtsim writes goes through here.
//!
//! A run's outputs form one [`OutputSet`], planned before the work starts and committed
//! together at the end:
//!
//! 1. **Plan** ([`OutputPlan`]): each target is classified. A regular file (or a name not yet
//!    taken) is *replaced*; a symbolic link is followed and its destination replaced (the link
//!    stays); a character device (`/dev/null`) or a FIFO is *written through*, never replaced;
//!    a directory, block device or socket is refused with the reason. A target that is the
//!    same file as one of the run's inputs is refused. [`OutputPlan::prepare`] then creates one
//!    staging directory, `.rtsim-staging.PID.N`, in each target directory: this is the
//!    writability check, done before any work, so a blocked or read-only `--out` fails in
//!    seconds rather than after an hour of simulation.
//! 2. **Stage**: each file is written into its staging directory (or straight into the device
//!    or FIFO it writes through) and synced.
//! 3. **Commit** ([`OutputSet::commit`]): a `COMMIT` marker is written and synced in every
//!    staging directory, then each staged file is renamed over its target, files this run does
//!    not produce but an older run did ([`OutputPlan::stale`]) are removed, and the staging
//!    directories go.
//!
//! What is left after a failure: an error or a drop before the commit removes the staging
//! directories (so does Ctrl-C, SIGTERM or SIGHUP once [`install_interrupt_cleanup`] has run);
//! the targets keep the previous run's complete set. A run killed with `kill -9` leaves its
//! staging directory behind; the next run into the same directory deletes it if it has no
//! marker (the previous set is intact) and finishes its renames if it has one (the killed run
//! had completed its set and was only moving it into place), before doing anything else. So
//! an output directory never holds a mix of two runs' files except during the few renames of
//! a commit, and a commit interrupted there is completed by the next run.
//!
//! [`AtomicFile`] and [`write_atomic`] are one-file sets with the same guarantees.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// Prefix of staging directories (`.rtsim-staging.PID.N`).
const STAGING_PREFIX: &str = ".rtsim-staging.";
/// Marker that a staging directory holds a complete set being moved into place.
const COMMIT_MARKER: &str = "COMMIT";
/// Subdirectory of staged files (named like their targets).
const FILES: &str = "files";
/// Subdirectory of empty placeholders naming stale targets to remove at commit.
const REMOVE: &str = "remove";
/// Symbolic links followed before giving up (Linux's own limit, `MAXSYMLINKS`).
const MAX_LINK_HOPS: usize = 40;
/// Testing hook: milliseconds to sleep after each rename of a commit, so a test can kill a
/// run inside the commit window. Read once per commit; unset in normal use.
pub const COMMIT_PAUSE_ENV: &str = "RTSIM_TEST_COMMIT_PAUSE_MS";

/// An output that cannot be written: the path and why.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The target is not something rtsim will write (a directory, an input, a block device …).
    #[error("output {path}: {reason}")]
    Refused { path: PathBuf, reason: String },
    #[error("cannot write {path}: {source}")]
    Io { path: PathBuf, source: io::Error },
}

impl OutputError {
    fn refused(path: &Path, reason: impl Into<String>) -> Self {
        OutputError::Refused {
            path: path.to_path_buf(),
            reason: reason.into(),
        }
    }

    fn io(path: &Path, source: io::Error) -> Self {
        OutputError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    /// The path this error is about.
    pub fn path(&self) -> &Path {
        match self {
            OutputError::Refused { path, .. } | OutputError::Io { path, .. } => path,
        }
    }
}

impl From<OutputError> for io::Error {
    fn from(e: OutputError) -> io::Error {
        let kind = match &e {
            OutputError::Refused { .. } => io::ErrorKind::InvalidInput,
            OutputError::Io { source, .. } => source.kind(),
        };
        io::Error::new(kind, e)
    }
}

/// How a target is written.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Mode {
    /// Staged, then renamed over `real` (the target with symbolic links resolved).
    Replace { real: PathBuf },
    /// Opened and written directly (a character device or a FIFO).
    WriteThrough,
}

#[derive(Clone, Debug)]
struct Target {
    /// As the user named it (for messages).
    path: PathBuf,
    mode: Mode,
}

/// The outputs of a run, before the work: targets, the run's inputs (never overwritten) and
/// stale files of older runs to remove at commit.
#[derive(Debug, Default)]
pub struct OutputPlan {
    dirs: Vec<(PathBuf, String)>,
    files: Vec<PathBuf>,
    stale: Vec<PathBuf>,
    inputs: Vec<(String, PathBuf)>,
}

impl OutputPlan {
    pub fn new() -> Self {
        OutputPlan::default()
    }

    /// An output directory given by the user as `what` (e.g. `--out`): created if missing; an
    /// existing non-directory is refused with a message naming `what`.
    pub fn dir(&mut self, dir: impl Into<PathBuf>, what: &str) -> &mut Self {
        self.dirs.push((dir.into(), what.to_string()));
        self
    }

    /// A file this run writes.
    pub fn file(&mut self, path: impl Into<PathBuf>) -> &mut Self {
        self.files.push(path.into());
        self
    }

    /// A file an older run may have left that this run does not write (e.g. `heatmap.png`
    /// with the heat map off): removed at commit, so the directory holds one run's set.
    pub fn stale(&mut self, path: impl Into<PathBuf>) -> &mut Self {
        self.stale.push(path.into());
        self
    }

    /// An input of the run (`what` names it in messages, e.g. `--rays`): no output may be it.
    pub fn input(&mut self, what: &str, path: impl Into<PathBuf>) -> &mut Self {
        self.inputs.push((what.to_string(), path.into()));
        self
    }

    /// Check every target and create the staging directories (cleaning up what killed runs
    /// left in them). Nothing is visible at the targets until [`OutputSet::commit`].
    pub fn prepare(&self) -> Result<OutputSet, OutputError> {
        for (dir, what) in &self.dirs {
            match fs::metadata(dir) {
                Ok(m) if m.is_dir() => {}
                Ok(m) => {
                    return Err(OutputError::refused(
                        dir,
                        format!(
                            "{what} must be a directory, but this is {}",
                            crate::error::describe_file_type(&m.file_type())
                        ),
                    ));
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::NotFound | io::ErrorKind::NotADirectory
                    ) =>
                {
                    create_dir_all(dir)?
                }
                Err(e) => return Err(OutputError::io(dir, e)),
            }
        }
        let mut set = OutputSet {
            targets: Vec::new(),
            stale: Vec::new(),
            staging: Vec::new(),
            written: Vec::new(),
            done: false,
        };
        for path in &self.files {
            if set.targets.iter().any(|t| t.path == *path) {
                continue;
            }
            let mode = classify(path)?;
            for (what, input) in &self.inputs {
                if same_file(path, input) {
                    return Err(OutputError::refused(
                        path,
                        format!(
                            "is the same file as the input {what} {}; it would be overwritten",
                            input.display()
                        ),
                    ));
                }
            }
            if let Mode::Replace { real } = &mode {
                set.staging_for(real)?;
            }
            set.targets.push(Target {
                path: path.clone(),
                mode,
            });
        }
        for path in &self.stale {
            if self.files.contains(path) {
                continue;
            }
            // Only a regular file (or a link to one) is ever removed.
            if let Ok(Mode::Replace { real }) = classify(path)
                && real.is_file()
            {
                set.staging_for(&real)?;
                set.stale.push(real);
            }
        }
        Ok(set)
    }
}

/// One staging directory: where the files of one target directory wait for the commit.
#[derive(Debug)]
struct Staging {
    /// The target directory.
    parent: PathBuf,
    /// `parent/.rtsim-staging.PID.N`.
    dir: PathBuf,
}

/// A prepared set of outputs (see the module docs). Dropping it without
/// [`OutputSet::commit`] removes everything staged.
#[derive(Debug)]
pub struct OutputSet {
    targets: Vec<Target>,
    stale: Vec<PathBuf>,
    staging: Vec<Staging>,
    /// Indices of targets whose file is complete.
    written: Vec<usize>,
    done: bool,
}

impl OutputSet {
    fn staging_for(&mut self, real: &Path) -> Result<usize, OutputError> {
        let parent = parent_of(real);
        if let Some(i) = self.staging.iter().position(|s| s.parent == parent) {
            return Ok(i);
        }
        create_dir_all(&parent)?;
        recover_leftovers(&parent)?;
        static SERIAL: AtomicU64 = AtomicU64::new(0);
        let dir = parent.join(format!(
            "{STAGING_PREFIX}{}.{}",
            std::process::id(),
            SERIAL.fetch_add(1, Ordering::Relaxed)
        ));
        fs::create_dir(&dir)
            .and_then(|()| fs::create_dir(dir.join(FILES)))
            .and_then(|()| fs::create_dir(dir.join(REMOVE)))
            .map_err(|e| {
                let _ = fs::remove_dir_all(&dir);
                OutputError::io(&parent, e)
            })?;
        live_staging().push(dir.clone());
        self.staging.push(Staging { parent, dir });
        Ok(self.staging.len() - 1)
    }

    fn target(&self, path: &Path) -> Result<usize, OutputError> {
        self.targets
            .iter()
            .position(|t| t.path == path)
            .ok_or_else(|| {
                OutputError::refused(path, "was not planned as an output of this run (a bug)")
            })
    }

    /// Start writing planned output `path`. Finish it with [`OutputFile::finish`].
    pub fn create(&mut self, path: &Path) -> Result<OutputFile, OutputError> {
        let i = self.target(path)?;
        let t = &self.targets[i];
        let (file, staged) = match &t.mode {
            Mode::Replace { real } => {
                let s = &self.staging[self.staging_index(real)];
                let staged = s.dir.join(FILES).join(file_name(real)?);
                let f = fs::File::create(&staged).map_err(|e| OutputError::io(&t.path, e))?;
                (f, Some(staged))
            }
            Mode::WriteThrough => {
                // Never create or truncate: the device or FIFO is written as it is.
                let f = fs::OpenOptions::new()
                    .write(true)
                    .open(&t.path)
                    .map_err(|e| OutputError::io(&t.path, e))?;
                (f, None)
            }
        };
        Ok(OutputFile {
            path: t.path.clone(),
            index: i,
            staged,
            writer: Some(BufWriter::with_capacity(1 << 16, file)),
        })
    }

    fn staging_index(&self, real: &Path) -> usize {
        let parent = parent_of(real);
        self.staging
            .iter()
            .position(|s| s.parent == parent)
            .expect("prepare made a staging directory for every replaced target")
    }

    /// Write planned output `path` whole.
    pub fn write(&mut self, path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
        let mut f = self.create(path)?;
        f.write_all(bytes).map_err(|e| OutputError::io(path, e))?;
        self.finish(f)
    }

    /// Complete a file started with [`OutputSet::create`]: flushed and synced, it waits for
    /// the commit.
    pub fn finish(&mut self, mut f: OutputFile) -> Result<(), OutputError> {
        let writer = f.writer.take().expect("writer present until finish");
        let file = writer
            .into_inner()
            .map_err(|e| OutputError::io(&f.path, e.into_error()))?;
        if f.staged.is_some() {
            file.sync_all().map_err(|e| OutputError::io(&f.path, e))?;
        }
        if !self.written.contains(&f.index) {
            self.written.push(f.index);
        }
        Ok(())
    }

    /// Move the whole set into place (see the module docs). Every planned file must have been
    /// written.
    pub fn commit(mut self) -> Result<(), OutputError> {
        if let Some(t) = (0..self.targets.len())
            .find(|i| !self.written.contains(i))
            .map(|i| &self.targets[i])
        {
            return Err(OutputError::refused(
                &t.path,
                "was planned but never written (a bug)",
            ));
        }
        for real in &self.stale {
            let s = &self.staging[self.staging_index(real)];
            let placeholder = s.dir.join(REMOVE).join(file_name(real)?);
            fs::File::create(&placeholder).map_err(|e| OutputError::io(real, e))?;
        }
        // Hold the commit lock so an interrupt's cleanup waits for the renames to finish.
        let _lock = COMMIT_LOCK.lock().unwrap_or_else(|p| p.into_inner());
        for s in &self.staging {
            let marker = s.dir.join(COMMIT_MARKER);
            fs::File::create(&marker)
                .and_then(|f| f.sync_all())
                .and_then(|()| sync_dir(&s.dir))
                .map_err(|e| OutputError::io(&s.parent, e))?;
        }
        self.done = true;
        let pause = std::env::var(COMMIT_PAUSE_ENV)
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
            .map(std::time::Duration::from_millis);
        for s in &self.staging {
            roll_forward(&s.dir, &s.parent, pause)?;
            forget_staging(&s.dir);
        }
        Ok(())
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        if self.done {
            return;
        }
        for s in &self.staging {
            let _ = fs::remove_dir_all(&s.dir);
            forget_staging(&s.dir);
        }
    }
}

/// A file of an [`OutputSet`] being written.
#[derive(Debug)]
pub struct OutputFile {
    path: PathBuf,
    index: usize,
    staged: Option<PathBuf>,
    writer: Option<BufWriter<fs::File>>,
}

impl OutputFile {
    /// The target path, as planned.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn writer(&mut self) -> &mut BufWriter<fs::File> {
        self.writer.as_mut().expect("writer present until finish")
    }
}

impl Write for OutputFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer().write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.writer().write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.writer().flush()
    }
}

/// The directory holding `path` (`.` for a bare name).
fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn file_name(path: &Path) -> Result<&std::ffi::OsStr, OutputError> {
    path.file_name()
        .ok_or_else(|| OutputError::refused(path, "has no file name"))
}

/// `create_dir_all`, naming the component that is in the way when one is a file.
fn create_dir_all(dir: &Path) -> Result<(), OutputError> {
    fs::create_dir_all(dir).map_err(|e| {
        let blocker = dir
            .ancestors()
            .find(|a| fs::metadata(a).is_ok_and(|m| !m.is_dir()));
        match blocker {
            Some(b) => OutputError::refused(
                dir,
                format!(
                    "cannot create this directory: {} is not a directory",
                    b.display()
                ),
            ),
            None => OutputError::io(dir, e),
        }
    })
}

/// How `path` would be written, following symbolic links to what they name.
fn classify(path: &Path) -> Result<Mode, OutputError> {
    let mut cur = path.to_path_buf();
    for _ in 0..MAX_LINK_HOPS {
        let meta = match fs::symlink_metadata(&cur) {
            Ok(m) => m,
            // Missing, or below a file (the directory creation then names the culprit).
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::NotFound | io::ErrorKind::NotADirectory
                ) =>
            {
                file_name(&cur)?;
                return Ok(Mode::Replace { real: cur });
            }
            Err(e) => return Err(OutputError::io(path, e)),
        };
        let ft = meta.file_type();
        if ft.is_symlink() {
            let to = fs::read_link(&cur).map_err(|e| OutputError::io(path, e))?;
            cur = if to.is_absolute() {
                to
            } else {
                parent_of(&cur).join(to)
            };
            continue;
        }
        if ft.is_file() {
            return Ok(Mode::Replace { real: cur });
        }
        if ft.is_dir() {
            return Err(OutputError::refused(
                path,
                "is a directory; give a file name",
            ));
        }
        return special(path, &ft);
    }
    Err(OutputError::refused(
        path,
        format!("more than {MAX_LINK_HOPS} symbolic links to follow (a loop?)"),
    ))
}

#[cfg(unix)]
fn special(path: &Path, ft: &fs::FileType) -> Result<Mode, OutputError> {
    use std::os::unix::fs::FileTypeExt;
    if ft.is_char_device() || ft.is_fifo() {
        Ok(Mode::WriteThrough)
    } else if ft.is_block_device() {
        Err(OutputError::refused(
            path,
            "is a block device; rtsim never writes to block devices",
        ))
    } else {
        Err(OutputError::refused(
            path,
            "is a socket or other special file; give a regular file",
        ))
    }
}

#[cfg(not(unix))]
fn special(path: &Path, _ft: &fs::FileType) -> Result<Mode, OutputError> {
    Err(OutputError::refused(path, "is not a regular file"))
}

/// Whether `a` and `b` name the same existing file (after following links).
#[cfg(unix)]
pub fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (fs::metadata(a), fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (fs::canonicalize(a), fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

fn sync_dir(dir: &Path) -> io::Result<()> {
    // Directories can be opened and synced on Unix; elsewhere renames are made durable by
    // the file system itself.
    #[cfg(unix)]
    fs::File::open(dir)?.sync_all()?;
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}

/// Move a committed staging directory's files into `parent`, remove its stale targets, and
/// delete it.
fn roll_forward(
    staging: &Path,
    parent: &Path,
    pause: Option<std::time::Duration>,
) -> Result<(), OutputError> {
    let entries = |sub: &str| -> Result<Vec<std::ffi::OsString>, OutputError> {
        match fs::read_dir(staging.join(sub)) {
            Ok(rd) => {
                let mut names: Vec<_> = rd.filter_map(|e| e.ok().map(|e| e.file_name())).collect();
                names.sort();
                Ok(names)
            }
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(Vec::new()),
            Err(e) => Err(OutputError::io(staging, e)),
        }
    };
    for name in entries(FILES)? {
        let target = parent.join(&name);
        fs::rename(staging.join(FILES).join(&name), &target)
            .map_err(|e| OutputError::io(&target, e))?;
        if let Some(p) = pause {
            std::thread::sleep(p);
        }
    }
    for name in entries(REMOVE)? {
        let target = parent.join(&name);
        match fs::remove_file(&target) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(OutputError::io(&target, e)),
        }
    }
    sync_dir(parent).map_err(|e| OutputError::io(parent, e))?;
    fs::remove_dir_all(staging).map_err(|e| OutputError::io(staging, e))
}

/// Finish or discard one staging directory left by a run that is gone.
fn recover(staging: &Path, parent: &Path) -> Result<(), OutputError> {
    if staging.join(COMMIT_MARKER).exists() {
        roll_forward(staging, parent, None)
    } else {
        fs::remove_dir_all(staging).map_err(|e| OutputError::io(staging, e))
    }
}

/// Clean up staging directories in `parent` whose process no longer runs.
fn recover_leftovers(parent: &Path) -> Result<(), OutputError> {
    let Ok(rd) = fs::read_dir(parent) else {
        return Ok(());
    };
    for entry in rd.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(STAGING_PREFIX)) else {
            continue;
        };
        let pid = rest.split('.').next().and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|p| p == std::process::id() || process_alive(p)) {
            continue;
        }
        recover(&entry.path(), parent)?;
    }
    Ok(())
}

#[cfg(unix)]
fn process_alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: kill with signal 0 only checks whether the process exists.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

#[cfg(not(unix))]
fn process_alive(_pid: u32) -> bool {
    true
}

/// Held during the renames of a commit and by the interrupt cleanup.
static COMMIT_LOCK: Mutex<()> = Mutex::new(());
/// Staging directories of this process that are not committed yet.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live_staging() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(|p| p.into_inner())
}

fn forget_staging(dir: &Path) {
    live_staging().retain(|d| d != dir);
}

/// Remove (or, past their commit marker, finish) this process's staging directories: what
/// an interrupt does before the process ends.
pub fn cleanup_staging() {
    let _lock = COMMIT_LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let dirs: Vec<PathBuf> = std::mem::take(&mut *live_staging());
    for dir in dirs {
        let _ = recover(&dir, &parent_of(&dir));
    }
}

/// On SIGINT, SIGTERM and SIGHUP, clean up staged outputs ([`cleanup_staging`]) and then die
/// of the signal as if it had not been caught. Call once, early in `main`.
#[cfg(unix)]
pub fn install_interrupt_cleanup() -> io::Result<()> {
    use std::sync::atomic::AtomicI32;
    static WRITE_FD: AtomicI32 = AtomicI32::new(-1);
    extern "C" fn on_signal(sig: libc::c_int) {
        let fd = WRITE_FD.load(Ordering::Relaxed);
        let b = sig as u8;
        // SAFETY: write(2) is async-signal-safe; the buffer is a local byte.
        unsafe {
            libc::write(fd, (&b as *const u8).cast(), 1);
        }
    }
    let mut fds = [0 as libc::c_int; 2];
    // SAFETY: pipe(2) fills the two-element array.
    if unsafe { libc::pipe(fds.as_mut_ptr()) } != 0 {
        return Err(io::Error::last_os_error());
    }
    WRITE_FD.store(fds[1], Ordering::Relaxed);
    let read_fd = fds[0];
    std::thread::Builder::new()
        .name("rtsim-interrupt".into())
        .spawn(move || {
            let mut b = 0u8;
            // SAFETY: reads one byte into a local from the pipe this thread owns.
            let n = unsafe { libc::read(read_fd, (&mut b as *mut u8).cast(), 1) };
            if n != 1 {
                return;
            }
            cleanup_staging();
            let sig = libc::c_int::from(b);
            // SAFETY: restore the default action and re-raise, so the exit status says which
            // signal ended the run.
            unsafe {
                libc::signal(sig, libc::SIG_DFL);
                libc::raise(sig);
            }
        })?;
    for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
        // SAFETY: installs a handler that only calls write(2).
        let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
        if unsafe { libc::signal(sig, handler) } == libc::SIG_ERR {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}

#[cfg(not(unix))]
pub fn install_interrupt_cleanup() -> io::Result<()> {
    Ok(())
}

/// A single output file with the guarantees of an [`OutputSet`]: it becomes visible at
/// `path` only on [`AtomicFile::commit`]; dropping it without committing removes what was
/// staged. Devices and FIFOs are written through, links followed, directories refused.
#[derive(Debug)]
pub struct AtomicFile {
    set: Option<OutputSet>,
    file: Option<OutputFile>,
}

impl AtomicFile {
    /// Start writing `path`. Its parent directory is created if needed.
    pub fn create(path: impl AsRef<Path>) -> io::Result<Self> {
        let path = path.as_ref();
        let mut set = OutputPlan::new().file(path).prepare()?;
        let file = set.create(path)?;
        Ok(AtomicFile {
            set: Some(set),
            file: Some(file),
        })
    }

    /// Flush, sync and move into place.
    pub fn commit(mut self) -> io::Result<()> {
        let mut set = self.set.take().expect("set present until commit");
        set.finish(self.file.take().expect("file present until commit"))?;
        Ok(set.commit()?)
    }

    fn file(&mut self) -> &mut OutputFile {
        self.file.as_mut().expect("file present until commit")
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file().write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.file().write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.file().flush()
    }
}

/// Write `bytes` to `path` atomically.
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn commit_makes_file_visible() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/x.txt");
        write_atomic(&p, b"hello").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"hello");
        assert_eq!(names(p.parent().unwrap()), ["x.txt"]);
    }

    #[test]
    fn drop_without_commit_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.txt");
        {
            let mut f = AtomicFile::create(&p).unwrap();
            f.write_all(b"partial").unwrap();
        }
        assert!(!p.exists());
        assert!(names(dir.path()).is_empty());
    }

    fn set_of(dir: &Path, files: &[&str]) -> OutputSet {
        let mut plan = OutputPlan::new();
        plan.dir(dir, "--out");
        for f in files {
            plan.file(dir.join(f));
        }
        plan.prepare().unwrap()
    }

    #[test]
    fn a_set_appears_together_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut s = set_of(d, &["a", "b"]);
        s.write(&d.join("a"), b"1").unwrap();
        s.write(&d.join("b"), b"1").unwrap();
        s.commit().unwrap();
        // A second run fails half way: the first run's set stays, nothing else.
        let mut s = set_of(d, &["a", "b"]);
        s.write(&d.join("a"), b"2").unwrap();
        drop(s);
        assert_eq!(names(d), ["a", "b"]);
        assert_eq!(fs::read(d.join("a")).unwrap(), b"1");
    }

    #[test]
    fn unwritten_planned_file_fails_the_commit() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut s = set_of(d, &["a", "b"]);
        s.write(&d.join("a"), b"1").unwrap();
        let e = s.commit().unwrap_err().to_string();
        assert!(e.contains("never written"), "{e}");
        assert!(names(d).is_empty());
    }

    #[test]
    fn stale_files_of_older_runs_are_removed_at_commit() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        fs::write(d.join("heatmap.png"), b"old").unwrap();
        let mut plan = OutputPlan::new();
        plan.file(d.join("render.png")).stale(d.join("heatmap.png"));
        let mut s = plan.prepare().unwrap();
        s.write(&d.join("render.png"), b"new").unwrap();
        assert!(d.join("heatmap.png").exists());
        s.commit().unwrap();
        assert_eq!(names(d), ["render.png"]);
    }

    /// A staging directory as a killed run leaves it (a pid that cannot be running).
    fn killed_run(d: &Path, marker: bool, files: &[(&str, &[u8])]) -> PathBuf {
        let s = d.join(format!("{STAGING_PREFIX}{}.0", u32::MAX - 7));
        fs::create_dir_all(s.join(FILES)).unwrap();
        fs::create_dir_all(s.join(REMOVE)).unwrap();
        for (n, b) in files {
            fs::write(s.join(FILES).join(n), b).unwrap();
        }
        if marker {
            fs::write(s.join(COMMIT_MARKER), b"").unwrap();
        }
        s
    }

    #[test]
    fn a_killed_runs_uncommitted_staging_is_discarded() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        fs::write(d.join("a"), b"old").unwrap();
        killed_run(d, false, &[("a", b"half")]);
        let s = set_of(d, &["x"]);
        assert_eq!(fs::read(d.join("a")).unwrap(), b"old");
        drop(s);
        assert_eq!(names(d), ["a"]);
    }

    #[test]
    fn a_killed_runs_committed_staging_is_rolled_forward() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // Killed between its renames: `a` is already new, `b` still old.
        fs::write(d.join("a"), b"new").unwrap();
        fs::write(d.join("b"), b"old").unwrap();
        killed_run(d, true, &[("b", b"new")]);
        let s = set_of(d, &["x"]);
        assert_eq!(fs::read(d.join("b")).unwrap(), b"new");
        drop(s);
        assert_eq!(names(d), ["a", "b"]);
    }

    #[test]
    fn symlinks_are_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        fs::create_dir(d.join("real")).unwrap();
        fs::write(d.join("real/f"), b"old").unwrap();
        std::os::unix::fs::symlink("real/f", d.join("link")).unwrap();
        write_atomic(d.join("link"), b"new").unwrap();
        assert!(
            fs::symlink_metadata(d.join("link"))
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read(d.join("real/f")).unwrap(), b"new");
        // A dangling link creates the file it names.
        std::os::unix::fs::symlink("real/g", d.join("dangling")).unwrap();
        write_atomic(d.join("dangling"), b"g").unwrap();
        assert_eq!(fs::read(d.join("real/g")).unwrap(), b"g");
        assert_eq!(names(&d.join("real")), ["f", "g"]);
    }

    #[test]
    fn devices_are_written_through_and_never_replaced() {
        let dir = tempfile::tempdir().unwrap();
        // A private character device (1,3 = null) when we may create one, else /dev/null.
        let node = dir.path().join("null");
        let c = std::ffi::CString::new(node.to_str().unwrap()).unwrap();
        // SAFETY: mknod on a path in a fresh temporary directory.
        let made = unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) };
        let dev = if made == 0 {
            node
        } else {
            PathBuf::from("/dev/null")
        };
        write_atomic(&dev, b"discarded").unwrap();
        use std::os::unix::fs::FileTypeExt;
        assert!(
            fs::symlink_metadata(&dev)
                .unwrap()
                .file_type()
                .is_char_device()
        );
    }

    #[test]
    fn refusals_say_why() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let e = write_atomic(d, b"x").unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        fs::write(d.join("rays.bin"), b"input").unwrap();
        let mut plan = OutputPlan::new();
        plan.input("--rays", d.join("rays.bin"))
            .file(d.join("./rays.bin"));
        let e = plan.prepare().unwrap_err().to_string();
        assert!(e.contains("same file as the input --rays"), "{e}");
        assert_eq!(fs::read(d.join("rays.bin")).unwrap(), b"input");
        let e = OutputPlan::new()
            .dir(d.join("rays.bin"), "--out")
            .prepare()
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--out must be a directory, but this is a regular file"),
            "{e}"
        );
        let e = write_atomic(d.join("rays.bin/x"), b"x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("rays.bin is not a directory"), "{e}");
    }
}
