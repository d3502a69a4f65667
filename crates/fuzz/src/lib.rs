//! Fuzzing of every input format rtsim reads, on stable Rust.
//!
//! `cargo fuzz` needs a nightly toolchain and its own install, which CI machines do not keep;
//! this crate is a seeded mutation harness instead. Its parts:
//!
//! - [`TARGETS`]: one [`Target`] per parser and input format — OBJ, MTL, PLY, gzip and zstd
//!   meshes, scene descriptors, run and DRAM configurations, DRAM traces in the `rtsim`,
//!   `dramsim3` and `usimm` formats, cache traces, `rays.bin` and `tris.bin`. A target feeds
//!   bytes to the real parser and checks it returns (a value or an error) without panicking.
//! - [`mutate::Mutator`]: seeded byte-level and token-level mutations (bit flips, interesting
//!   numbers, dictionary tokens, splices, truncations), so a run is repeatable from its seed.
//! - [`Guard`]: what counts as a failure besides a panic: an input that runs longer than
//!   [`HANG_SECONDS`] (a hang) or asks for one allocation over [`ALLOC_LIMIT_BYTES`]
//!   (an allocation sized by the input; the runner's allocator enforces it).
//! - The corpora, in the repository: `crates/fuzz/corpus/<target>/` holds the seeds, and
//!   `crates/fuzz/regressions/<target>/` every input that ever crashed, hung or aborted.
//!   `tests/replay.rs` replays both on every `cargo test`; the `rtsim-fuzz` binary mutates
//!   the seeds for a bounded time per target and saves new failures into `regressions/`.
//!
//! See `docs/HARDENING.md`.

pub mod mutate;
pub mod targets;

pub use targets::{TARGETS, Target};

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// An input taking longer than this is a hang (assumed: 2 s, a thousand times what any seed
/// takes; the 2^62-record PLY took years).
pub const HANG_SECONDS: u64 = 2;

/// One allocation larger than this, from inputs of a few kilobytes, is an allocation sized by
/// the input without a bound (assumed: 256 MiB; the largest legitimate buffer of a parser is
/// the 12 MB PLY reservation).
pub const ALLOC_LIMIT_BYTES: usize = 256 << 20;

/// The corpus directories of the crate.
pub fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus")
}

/// Where failing inputs are kept.
pub fn regressions_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("regressions")
}

/// The files of `dir/<target>/`, sorted (none if the directory is missing).
pub fn inputs_of(dir: &Path, target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir.join(target))
        .map(|rd| {
            rd.flatten()
                .filter(|e| e.path().is_file())
                .filter_map(|e| std::fs::read(e.path()).ok().map(|b| (e.path(), b)))
                .collect()
        })
        .unwrap_or_default();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// The input being run, and since when: read by the hang watchdog and the allocation limit
/// to save it before the process ends.
#[derive(Debug)]
pub struct Guard {
    current: Mutex<(String, Vec<u8>)>,
    started_ms: AtomicU64,
    epoch: Instant,
}

impl Default for Guard {
    fn default() -> Self {
        Guard {
            current: Mutex::new((String::new(), Vec::new())),
            started_ms: AtomicU64::new(u64::MAX),
            epoch: Instant::now(),
        }
    }
}

impl Guard {
    /// Record `input` of `target` as running from now.
    pub fn begin(&self, target: &str, input: &[u8]) {
        let mut c = self.current.lock().unwrap_or_else(|p| p.into_inner());
        c.0.clear();
        c.0.push_str(target);
        c.1.clear();
        c.1.extend_from_slice(input);
        drop(c);
        self.started_ms
            .store(self.epoch.elapsed().as_millis() as u64, Ordering::SeqCst);
    }

    /// The input is done.
    pub fn end(&self) {
        self.started_ms.store(u64::MAX, Ordering::SeqCst);
    }

    /// How long the current input has run, if one is running.
    pub fn running_ms(&self) -> Option<u64> {
        let s = self.started_ms.load(Ordering::SeqCst);
        (s != u64::MAX).then(|| (self.epoch.elapsed().as_millis() as u64).saturating_sub(s))
    }

    /// Save the current input as `regressions/<target>/<kind>-<hash>`; returns its path.
    pub fn save(&self, kind: &str) -> Option<PathBuf> {
        let c = self.current.lock().unwrap_or_else(|p| p.into_inner());
        save_regression(&c.0, kind, &c.1)
    }
}

/// Save `input` of `target` into the regression corpus under a name from its content.
pub fn save_regression(target: &str, kind: &str, input: &[u8]) -> Option<PathBuf> {
    let dir = regressions_dir().join(target);
    std::fs::create_dir_all(&dir).ok()?;
    let p = dir.join(format!("{kind}-{:016x}", fnv1a(input)));
    std::fs::write(&p, input).ok()?;
    Some(p)
}

/// FNV-1a, to name saved inputs by their content.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Run one input through `target`, catching a panic: `Err` holds the panic message.
pub fn run_one(target: &Target, input: &[u8]) -> Result<(), String> {
    std::panic::catch_unwind(|| (target.run)(input)).map_err(|p| {
        p.downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "panic".into())
    })
}

/// An allocator that refuses single allocations over [`ALLOC_LIMIT_BYTES`]: it calls
/// `on_excess` (which saves the input) and aborts, as the process would under a memory limit.
#[derive(Debug)]
pub struct LimitedAlloc {
    pub on_excess: fn(usize),
}

// SAFETY: forwards to the system allocator; only refuses (by aborting) oversized requests.
unsafe impl std::alloc::GlobalAlloc for LimitedAlloc {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        if layout.size() > ALLOC_LIMIT_BYTES {
            (self.on_excess)(layout.size());
            std::process::abort();
        }
        // SAFETY: same layout contract as the caller's.
        unsafe { std::alloc::System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: `ptr` came from `alloc` with this layout.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new: usize) -> *mut u8 {
        if new > ALLOC_LIMIT_BYTES {
            (self.on_excess)(new);
            std::process::abort();
        }
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { std::alloc::System.realloc(ptr, layout, new) }
    }
}
