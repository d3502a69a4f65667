//! [`Crew`]: a few host threads that share out a handful of jobs, many thousand times a second.
//!
//! A cycle-level engine that splits each simulated cycle between threads hands work over every
//! few tens of microseconds. A general pool (rayon) puts its idle workers to sleep within
//! microseconds, and waking one costs about as much as the work (measured on the 2-core
//! reference machine: the TRaX engine on two rayon threads ran slower than on one). A crew's
//! workers spin between hand-overs instead, for a while ([`SPIN`]), and only then sleep, so a
//! run of busy cycles pays a few hundred nanoseconds per hand-over.
//!
//! Jobs are *claimed*, not assigned: the calling thread and every worker that is awake take
//! the next unclaimed job until none is left, and the caller waits only for jobs a worker has
//! already started. A worker the operating system has not scheduled (a busy machine, more
//! threads than cores, tests side by side) therefore never holds the caller up — the caller
//! does its jobs — and jobs of uneven size balance themselves.
//!
//! Use: [`Crew::scope`] starts `threads - 1` workers for the duration of a closure, which calls
//! [`Crew::for_each`] on a slice of jobs as often as it likes; `for_each` returns when every
//! job is done, so the jobs may borrow anything the caller can (as with `std::thread::scope`).
//! Which thread runs which job never shows in the results: each job has its own data.

use std::marker::PhantomData;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, AtomicUsize, Ordering};
use std::thread::{self, Thread};
use std::time::{Duration, Instant};

/// How long an idle worker spins before it sleeps (assumed: longer than a simulated cycle's
/// sequential part, tens of microseconds, and short enough that an idle crew costs little).
pub const SPIN: Duration = Duration::from_micros(200);

/// Most jobs in one hand-over (the width of the claim word's job fields).
pub const MAX_JOBS: usize = 0xFFFF;

/// The work of one hand-over, on the caller's stack: `run(k)` does job `k`.
struct Slot<'f> {
    run: &'f (dyn Fn(usize) + Sync),
}

/// The claim word: hand-over number (bits 32..64), its jobs (16..32), the next unclaimed job
/// (0..16). One atomic word, so a claim succeeds only in the hand-over it was meant for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Claim(u64);

impl Claim {
    fn new(epoch: u32, jobs: usize, next: usize) -> Claim {
        Claim((epoch as u64) << 32 | (jobs as u64) << 16 | next as u64)
    }
    fn epoch(self) -> u32 {
        (self.0 >> 32) as u32
    }
    fn jobs(self) -> usize {
        (self.0 >> 16 & 0xFFFF) as usize
    }
    fn next(self) -> usize {
        (self.0 & 0xFFFF) as usize
    }
}

struct Inner {
    claim: AtomicU64,
    /// The current hand-over's work: set before its claim word is published, and read only
    /// by a thread holding a claim of it (so the caller, which waits for every claimed job,
    /// keeps it alive).
    slot: AtomicPtr<Slot<'static>>,
    /// Jobs of the current hand-over finished (or given up after a panic).
    done: AtomicUsize,
    stop: AtomicBool,
    /// Per worker: it may be parked (set before it parks, cleared when it wakes).
    sleeping: Vec<AtomicBool>,
    threads: Mutex<Vec<Thread>>,
    panic: Mutex<Option<Box<dyn std::any::Any + Send>>>,
}

/// Threads that share out jobs per [`Crew::for_each`] (see the module docs). Neither `Send`
/// nor `Sync` (the raw-pointer marker): only the thread that made it hands work over, so a job
/// can never start a hand-over while another runs.
pub struct Crew<'s> {
    inner: &'s Inner,
    workers: usize,
    _one_thread: PhantomData<*const ()>,
}

impl std::fmt::Debug for Crew<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Crew")
            .field("workers", &self.workers)
            .finish()
    }
}

/// A raw pointer the jobs' slice is reached through from the workers.
struct Jobs<T>(*mut T);
// SAFETY: a job is reached only by the one thread that claimed it (`T: Send`), and the caller
// waits for every claimed job before the slice's borrow ends.
unsafe impl<T: Send> Sync for Jobs<T> {}

impl Crew<'_> {
    /// Run `f` with a crew of `threads - 1` workers besides the calling thread (`threads` ≥ 1;
    /// with 1, `for_each` runs every job on the calling thread). An error if a worker thread
    /// cannot be started (the ones already started are stopped first).
    pub fn scope<R>(threads: usize, f: impl FnOnce(&Crew<'_>) -> R) -> std::io::Result<R> {
        let workers = threads.max(1) - 1;
        let inner = Inner {
            claim: AtomicU64::new(Claim::new(0, 0, 0).0),
            slot: AtomicPtr::new(std::ptr::null_mut()),
            done: AtomicUsize::new(0),
            stop: AtomicBool::new(false),
            sleeping: (0..workers).map(|_| AtomicBool::new(false)).collect(),
            threads: Mutex::new(Vec::new()),
            panic: Mutex::new(None),
        };
        let stop = |inner: &Inner| {
            inner.stop.store(true, Ordering::SeqCst);
            for t in inner.threads.lock().expect("not poisoned").iter() {
                t.unpark();
            }
        };
        thread::scope(|s| {
            for k in 0..workers {
                let inner = &inner;
                let spawned = thread::Builder::new()
                    .name(format!("rtsim-crew-{}", k + 1))
                    .spawn_scoped(s, move || work(inner, k));
                match spawned {
                    Ok(h) => inner
                        .threads
                        .lock()
                        .expect("not poisoned")
                        .push(h.thread().clone()),
                    Err(e) => {
                        // The scope joins the workers already started: stop them first.
                        stop(inner);
                        return Err(e);
                    }
                }
            }
            let crew = Crew {
                inner: &inner,
                workers,
                _one_thread: PhantomData,
            };
            let out = catch_unwind(AssertUnwindSafe(|| f(&crew)));
            stop(&inner);
            match out {
                Ok(r) => Ok(r),
                Err(p) => resume_unwind(p),
            }
        })
    }

    /// Threads in all (the caller's and the workers).
    pub fn threads(&self) -> usize {
        self.workers + 1
    }

    /// Run `f` on every job (at most [`MAX_JOBS`]), each on whichever thread claims it, and
    /// return when all are done.
    pub fn for_each<T: Send>(&self, jobs: &mut [T], f: impl Fn(&mut T) + Sync) {
        let n = jobs.len();
        assert!(
            n <= MAX_JOBS,
            "at most {MAX_JOBS} jobs a hand-over, not {n}"
        );
        if n <= 1 || self.workers == 0 {
            jobs.iter_mut().for_each(&f);
            return;
        }
        let ptr = Jobs(jobs.as_mut_ptr());
        let run = |k: usize| {
            let ptr = &ptr;
            // SAFETY: job k (< n = jobs.len()) is claimed by exactly one thread, and the
            // caller waits for it below, so the slice outlives the access.
            f(unsafe { &mut *ptr.0.add(k) });
        };
        let slot = Slot { run: &run };
        let inner = self.inner;
        // SAFETY of the lifetime: the slot is read only under a claim of this hand-over, and
        // this function returns only when every claimed job is done.
        let slot_ptr = &slot as *const Slot<'_> as *mut Slot<'static>;
        inner.slot.store(slot_ptr, Ordering::Release);
        inner.done.store(0, Ordering::Relaxed);
        let epoch = Claim(inner.claim.load(Ordering::Relaxed))
            .epoch()
            .wrapping_add(1);
        // SeqCst with the worker's "sleeping, then the claim word" (a Dekker pair): either it
        // sees the new hand-over or this sees it sleeping.
        inner
            .claim
            .store(Claim::new(epoch, n, 0).0, Ordering::SeqCst);
        for (k, s) in inner.sleeping.iter().enumerate() {
            if s.swap(false, Ordering::SeqCst) {
                inner.threads.lock().expect("not poisoned")[k].unpark();
            }
        }
        // This thread claims jobs too; after a panic in one, it gives up the unclaimed rest
        // (counted as done) so that the wait below ends.
        let mine = catch_unwind(AssertUnwindSafe(|| claim_jobs(inner, epoch)));
        if mine.is_err() {
            let left = close(inner, epoch);
            inner.done.fetch_add(left + 1, Ordering::AcqRel);
        }
        let mut spins = 0u32;
        while inner.done.load(Ordering::Acquire) < n {
            relax(&mut spins);
        }
        // A worker's panic, taken now so that it cannot resurface in a later hand-over.
        let theirs = inner.panic.lock().expect("not poisoned").take();
        match (mine, theirs) {
            (Err(p), theirs) => {
                // Dropped before unwinding: a payload's drop that panicked while unwinding
                // would abort.
                if let Some(q) = theirs {
                    drop_payload(q);
                }
                resume_unwind(p);
            }
            (Ok(()), Some(p)) => resume_unwind(p),
            (Ok(()), None) => {}
        }
    }
}

/// Claim and run jobs of hand-over `epoch` until none is left (or the hand-over is over).
fn claim_jobs(inner: &Inner, epoch: u32) {
    loop {
        let c = Claim(inner.claim.load(Ordering::Acquire));
        if c.epoch() != epoch || c.next() >= c.jobs() {
            return;
        }
        let taken = Claim(c.0 + 1);
        if inner
            .claim
            .compare_exchange_weak(c.0, taken.0, Ordering::AcqRel, Ordering::Acquire)
            .is_err()
        {
            continue;
        }
        // SAFETY: published before the claim word (Release/AcqRel), and alive while this
        // claimed job is not done (the caller waits for it).
        let slot = unsafe { &*inner.slot.load(Ordering::Acquire) };
        (slot.run)(c.next());
        inner.done.fetch_add(1, Ordering::AcqRel);
    }
}

/// Claim every job of hand-over `epoch` still unclaimed, without running them; returns how
/// many.
fn close(inner: &Inner, epoch: u32) -> usize {
    loop {
        let c = Claim(inner.claim.load(Ordering::Acquire));
        if c.epoch() != epoch || c.next() >= c.jobs() {
            return 0;
        }
        let all = Claim::new(epoch, c.jobs(), c.jobs());
        if inner
            .claim
            .compare_exchange(c.0, all.0, Ordering::AcqRel, Ordering::Acquire)
            .is_ok()
        {
            return c.jobs() - c.next();
        }
    }
}

/// Drop a panic payload that will not be raised, catching a panic of its drop (whose own
/// payload is leaked rather than dropped in turn).
fn drop_payload(p: Box<dyn std::any::Any + Send>) {
    if let Err(q) = catch_unwind(AssertUnwindSafe(move || drop(p))) {
        std::mem::forget(q);
    }
}

/// One turn of a wait: a pause for the first few, then a yield of the core, so that a waiting
/// thread does not hold a core that a thread it waits for needs (more threads than cores:
/// tests running side by side, a loaded machine).
#[inline]
fn relax(spins: &mut u32) {
    *spins = spins.wrapping_add(1);
    if *spins < 64 {
        std::hint::spin_loop();
    } else {
        thread::yield_now();
    }
}

/// Worker `k`'s loop: wait for a new hand-over (spinning for [`SPIN`], then parked), claim
/// and run its jobs with the others, again; until the crew stops.
fn work(inner: &Inner, k: usize) {
    let mut seen = 0u32;
    loop {
        let start = Instant::now();
        let mut spins = 0u32;
        let epoch = loop {
            if inner.stop.load(Ordering::Acquire) {
                return;
            }
            let e = Claim(inner.claim.load(Ordering::Acquire)).epoch();
            if e != seen {
                break e;
            }
            if spins % 256 != 255 || start.elapsed() < SPIN {
                relax(&mut spins);
                continue;
            }
            inner.sleeping[k].store(true, Ordering::SeqCst);
            if Claim(inner.claim.load(Ordering::SeqCst)).epoch() == seen
                && !inner.stop.load(Ordering::SeqCst)
            {
                thread::park();
            }
            inner.sleeping[k].store(false, Ordering::SeqCst);
        };
        seen = epoch;
        if let Err(p) = catch_unwind(AssertUnwindSafe(|| claim_jobs(inner, epoch))) {
            // The job that panicked counts as done, and so do the ones nobody will claim now.
            let left = close(inner, epoch);
            // The hand-over's first panic is kept; a later one is let go only once counted,
            // as dropping a payload runs foreign code that may panic (here, that would leave
            // the caller waiting for this job forever).
            let extra = {
                let mut kept = inner.panic.lock().expect("not poisoned");
                if kept.is_none() {
                    *kept = Some(p);
                    None
                } else {
                    Some(p)
                }
            };
            inner.done.fetch_add(left + 1, Ordering::AcqRel);
            if let Some(p) = extra {
                drop_payload(p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_job_runs_once_per_hand_over() {
        for threads in [1, 2, 3, 5] {
            for jobs in [1, 2, 4, 9] {
                Crew::scope(threads, |crew| {
                    let mut v: Vec<u64> = vec![0; jobs];
                    for round in 0..2000u64 {
                        crew.for_each(&mut v, |j| *j += round);
                    }
                    let want = (0..2000u64).sum::<u64>();
                    assert_eq!(v, vec![want; jobs], "{threads} threads, {jobs} jobs");
                })
                .unwrap();
            }
        }
    }

    #[test]
    fn sleeping_workers_wake() {
        Crew::scope(2, |crew| {
            let mut jobs = vec![0u32; 2];
            for _ in 0..3 {
                std::thread::sleep(SPIN * 3);
                crew.for_each(&mut jobs, |j| *j += 1);
            }
            assert_eq!(jobs, [3, 3]);
        })
        .unwrap();
    }

    #[test]
    fn the_caller_does_the_jobs_of_a_worker_that_is_not_there() {
        // More threads than this machine may have cores, each hand-over tiny: the caller
        // never waits for a worker that has not claimed anything.
        Crew::scope(8, |crew| {
            let mut jobs = vec![0u32; 3];
            for _ in 0..20_000 {
                crew.for_each(&mut jobs, |j| *j += 1);
            }
            assert_eq!(jobs, [20_000; 3]);
        })
        .unwrap();
    }

    #[test]
    fn a_panicking_job_panics_the_caller() {
        for threads in [2, 3] {
            let r = std::panic::catch_unwind(|| {
                Crew::scope(threads, |crew| {
                    let mut jobs = vec![0u32, 1, 0, 0];
                    crew.for_each(&mut jobs, |j| assert_eq!(*j, 0, "job {j}"));
                })
            });
            assert!(r.is_err());
        }
    }

    #[test]
    fn a_panic_does_not_resurface_later() {
        Crew::scope(2, |crew| {
            let mut jobs = vec![0u32; 2];
            // Both jobs panic (whoever runs them): one panic is raised, none is kept.
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                crew.for_each(&mut jobs, |_| panic!("both"))
            }));
            assert!(r.is_err());
            let mut ok = vec![0u32; 2];
            crew.for_each(&mut ok, |j| *j += 1);
            assert_eq!(ok, [1, 1]);
        })
        .unwrap();
    }

    /// Two workers panic in one hand-over, with payloads whose drop panics too: the caller
    /// gets a panic back instead of waiting forever for the job whose payload was dropped.
    #[test]
    fn two_worker_panics_with_payloads_that_panic_on_drop_do_not_hang() {
        struct Bomb;
        impl Drop for Bomb {
            fn drop(&mut self) {
                panic!("payload dropped");
            }
        }
        let (tx, rx) = std::sync::mpsc::channel();
        // On a thread of its own, so that a hang fails the test instead of stopping it.
        std::thread::spawn(move || {
            let r = std::panic::catch_unwind(|| {
                Crew::scope(3, |crew| {
                    let on_workers = AtomicUsize::new(0);
                    let mut jobs = vec![0u8; 3];
                    crew.for_each(&mut jobs, |_| {
                        let worker = thread::current()
                            .name()
                            .is_some_and(|n| n.starts_with("rtsim-crew"));
                        if !worker {
                            // The caller keeps one job long, so the workers take the others.
                            thread::sleep(Duration::from_millis(100));
                            return;
                        }
                        on_workers.fetch_add(1, Ordering::SeqCst);
                        let t = Instant::now();
                        while on_workers.load(Ordering::SeqCst) < 2
                            && t.elapsed() < Duration::from_millis(500)
                        {
                            thread::yield_now();
                        }
                        std::panic::panic_any(Bomb);
                    });
                })
            });
            let failed = r.is_err();
            if let Err(p) = r {
                std::mem::forget(p); // a Bomb
            }
            let _ = tx.send(failed);
        });
        let got = rx.recv_timeout(Duration::from_secs(10));
        assert_eq!(got, Ok(true), "the hand-over hung, or did not panic");
    }

    #[test]
    fn the_claim_word_keeps_its_fields_apart() {
        let c = Claim::new(u32::MAX, MAX_JOBS, MAX_JOBS - 1);
        assert_eq!(
            (c.epoch(), c.jobs(), c.next()),
            (u32::MAX, MAX_JOBS, MAX_JOBS - 1)
        );
        assert_eq!(Claim(c.0 + 1).next(), MAX_JOBS);
    }

    /// A crew stays on the thread that made it (a job cannot capture it and start a hand-over
    /// while one runs): checked at compile time.
    #[test]
    fn a_crew_is_not_sync() {
        trait NotSync {
            const YES: bool = false;
        }
        impl<T: ?Sized> NotSync for T {}
        struct Probe<T: ?Sized>(PhantomData<T>);
        #[allow(dead_code)]
        impl<T: ?Sized + Sync> Probe<T> {
            const YES: bool = true;
        }
        const { assert!(!<Probe<Crew<'static>>>::YES) };
    }
}

#[cfg(test)]
mod stress {
    use super::*;
    use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering::SeqCst};

    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
    }

    #[derive(Clone, Default)]
    struct Job {
        runs: u64,
        work: u32,
        boom: bool,
    }

    fn spin(n: u32) -> u64 {
        let mut x = 1u64;
        for i in 0..n {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(i as u64));
        }
        x
    }

    /// One run: `rounds` hand-overs on `threads`, each job checks that its hand-over is the
    /// current one at start and end (so no job runs before or after its `for_each`).
    fn run(threads: usize, rounds: u64, seed: u64, panics: bool) -> (u64, u64) {
        let active = AtomicU64::new(u64::MAX);
        let ran = AtomicUsize::new(0);
        let bad = AtomicUsize::new(0);
        let mut rng = Rng(seed | 1);
        let mut panicked_rounds = 0u64;
        let mut slept = 0u64;
        Crew::scope(threads, |crew| {
            let mut jobs: Vec<Job> = Vec::new();
            for round in 0..rounds {
                let n = match rng.below(100) {
                    0 => 200 + rng.below(300) as usize,
                    1..=4 => rng.below(2) as usize,
                    _ => 2 + rng.below(12) as usize,
                };
                jobs.clear();
                let mut want_panic = false;
                for _ in 0..n {
                    let boom = panics && rng.below(200) == 0;
                    want_panic |= boom;
                    let work = match rng.below(10) {
                        0 => rng.below(50_000) as u32,
                        1..=3 => 0,
                        _ => rng.below(2000) as u32,
                    };
                    jobs.push(Job {
                        runs: 0,
                        work,
                        boom,
                    });
                }
                if rng.below(2000) == 0 {
                    // Let the workers fall asleep.
                    std::thread::sleep(SPIN * (1 + rng.below(3) as u32));
                    slept += 1;
                }
                ran.store(0, SeqCst);
                active.store(round, SeqCst);
                let r = std::panic::catch_unwind(AssertUnwindSafe(|| {
                    crew.for_each(&mut jobs, |j| {
                        if active.load(SeqCst) != round {
                            bad.fetch_add(1, SeqCst);
                        }
                        j.runs += 1;
                        spin(j.work);
                        if j.boom {
                            panic!("boom");
                        }
                        if active.load(SeqCst) != round {
                            bad.fetch_add(1, SeqCst);
                        }
                        ran.fetch_add(1, SeqCst);
                    })
                }));
                active.store(u64::MAX, SeqCst);
                assert_eq!(
                    r.is_err(),
                    want_panic,
                    "round {round}: panic propagated iff one happened"
                );
                if r.is_err() {
                    panicked_rounds += 1;
                    assert!(
                        jobs.iter().all(|j| j.runs <= 1),
                        "round {round}: a job ran twice"
                    );
                    assert_eq!(
                        ran.load(SeqCst),
                        jobs.iter().filter(|j| j.runs == 1 && !j.boom).count()
                    );
                } else {
                    assert!(
                        jobs.iter().all(|j| j.runs == 1),
                        "round {round}: {:?}",
                        jobs.iter().map(|j| j.runs).collect::<Vec<_>>()
                    );
                    assert_eq!(ran.load(SeqCst), n);
                }
                // Late touches show up here too: a job touched after return would bump runs.
                std::hint::black_box(&jobs);
            }
        })
        .unwrap();
        assert_eq!(bad.load(SeqCst), 0, "a job ran outside its hand-over");
        (panicked_rounds, slept)
    }

    #[test]
    #[ignore = "stress: cargo test --release -p rtsim-sim stress -- --ignored (CREW_ROUNDS=...)"]
    fn stress_no_panics() {
        let rounds: u64 = std::env::var("CREW_ROUNDS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(20_000);
        for (i, threads) in [2usize, 3, 4, 8].into_iter().enumerate() {
            let r = run(threads, rounds, 0x9E3779B97F4A7C15 ^ i as u64, false);
            eprintln!("threads {threads}: {rounds} rounds, slept {}", r.1);
        }
    }

    #[test]
    #[ignore = "stress: cargo test --release -p rtsim-sim stress -- --ignored (CREW_ROUNDS=...)"]
    fn stress_panics() {
        let prev = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let rounds: u64 = std::env::var("CREW_ROUNDS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(20_000);
        for (i, threads) in [2usize, 3, 5].into_iter().enumerate() {
            let r = run(threads, rounds, 0xD1B54A32D192ED03 ^ i as u64, true);
            eprintln!(
                "threads {threads}: {rounds} rounds, {} panicked, slept {}",
                r.0, r.1
            );
        }
        std::panic::set_hook(prev);
    }

    /// Workers asleep, then woken many times in a row (the park/unpark path only).
    #[test]
    #[ignore = "stress: cargo test --release -p rtsim-sim stress -- --ignored (CREW_ROUNDS=...)"]
    fn stress_sleep_wake() {
        Crew::scope(3, |crew| {
            let mut v = vec![0u32; 4];
            for i in 0..300u32 {
                std::thread::sleep(SPIN + Duration::from_micros(20 * (i % 7) as u64));
                crew.for_each(&mut v, |j| *j += 1);
            }
            assert_eq!(v, [300; 4]);
        })
        .unwrap();
    }
}
