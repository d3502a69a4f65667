//! [`Crew`]: a few host threads that take one slice of work each, many thousand times a second.
//!
//! A cycle-level engine that splits each simulated cycle between threads hands work over every
//! few tens of microseconds. A general pool (rayon) puts its idle workers to sleep within
//! microseconds, and waking one costs about as much as the work (measured on the 2-core
//! reference machine: the TRaX engine on two rayon threads ran slower than on one). A crew's
//! workers spin between hand-overs instead, for a while ([`SPIN`]), and only then sleep, so a
//! run of busy cycles pays a few hundred nanoseconds per hand-over.
//!
//! Use: [`Crew::scope`] starts `threads - 1` workers for the duration of a closure, which calls
//! [`Crew::for_each`] on a slice of jobs as often as it likes: job 0 runs on the calling thread,
//! job `k` on worker `k`, and `for_each` returns when all are done — so the jobs may borrow
//! anything the caller can (as with `std::thread::scope`). The order in which jobs finish
//! never shows in the results: each job has its own data.

use std::cell::UnsafeCell;
use std::marker::PhantomData;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::thread::{self, Thread};
use std::time::{Duration, Instant};

/// How long an idle worker spins before it sleeps (assumed: longer than a simulated cycle's
/// sequential part, tens of microseconds, and short enough that an idle crew costs little).
pub const SPIN: Duration = Duration::from_micros(200);

/// The work of one hand-over: worker `k` calls it with `k`.
type Task = *const (dyn Fn(usize) + Sync);

struct Inner {
    /// Bumped (Release) once the task is published; workers wait for a new value.
    epoch: AtomicU64,
    task: UnsafeCell<Option<Task>>,
    /// Workers still running the current task.
    pending: AtomicUsize,
    stop: AtomicBool,
    /// Per worker: it may be parked (set before it parks, cleared when it wakes).
    sleeping: Vec<AtomicBool>,
    threads: Mutex<Vec<Thread>>,
    panic: Mutex<Option<Box<dyn std::any::Any + Send>>>,
}

// SAFETY: `task` is written only by the crew's owner between hand-overs, while no worker
// reads it (all have decremented `pending` for the previous task and wait for a new epoch),
// and read by workers only after they see the epoch that published it (Acquire/Release).
unsafe impl Sync for Inner {}

/// Threads that run one job each per [`Crew::for_each`] (see the module docs). Neither
/// `Send` nor `Sync` (the raw-pointer marker): only the thread that made it hands work over,
/// so a job can never call [`Crew::for_each`] while another hand-over runs.
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
// SAFETY: each worker touches only its own element of the slice (`T: Send`), and the caller
// waits for every worker before the slice's borrow ends.
unsafe impl<T: Send> Sync for Jobs<T> {}

impl Crew<'_> {
    /// Run `f` with a crew of `threads - 1` workers besides the calling thread (`threads` ≥ 1;
    /// with 1, `for_each` runs every job on the calling thread). An error if a worker thread
    /// cannot be started (the ones already started are stopped first).
    pub fn scope<R>(threads: usize, f: impl FnOnce(&Crew<'_>) -> R) -> std::io::Result<R> {
        let workers = threads.max(1) - 1;
        let inner = Inner {
            epoch: AtomicU64::new(0),
            task: UnsafeCell::new(None),
            pending: AtomicUsize::new(0),
            stop: AtomicBool::new(false),
            sleeping: (0..workers).map(|_| AtomicBool::new(false)).collect(),
            threads: Mutex::new(Vec::new()),
            panic: Mutex::new(None),
        };
        let stop = |inner: &Inner| {
            inner.stop.store(true, Ordering::Release);
            inner.epoch.fetch_add(1, Ordering::Release);
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

    /// Run `f` on every job, job `k` on thread `k` (job 0 on the caller's; more jobs than
    /// threads: the rest on the caller's too, after job 0), and return when all are done.
    pub fn for_each<T: Send>(&self, jobs: &mut [T], f: impl Fn(&mut T) + Sync) {
        let n = jobs.len().min(self.threads());
        if n <= 1 || self.workers == 0 {
            jobs.iter_mut().for_each(&f);
            return;
        }
        // The threads' jobs, and the rest (this thread's after its own): split first, so that
        // nothing borrows the workers' jobs while they run.
        let (head, tail) = jobs.split_at_mut(n);
        let ptr = Jobs(head.as_mut_ptr());
        let task = |k: usize| {
            let ptr = &ptr;
            if k + 1 < n {
                // SAFETY: worker k alone takes job k + 1 (< n = head.len()); the caller waits
                // for it below, so the slice outlives the access.
                f(unsafe { &mut *ptr.0.add(k + 1) });
            }
        };
        let task: &(dyn Fn(usize) + Sync) = &task;
        // SAFETY: the lifetime is erased only for the time workers can see the pointer: they
        // read it after the epoch below, and this function does not return before every
        // worker has finished with it (`pending` = 0).
        let task: Task = unsafe { std::mem::transmute::<&(dyn Fn(usize) + Sync), Task>(task) };
        let inner = self.inner;
        // SAFETY: no worker reads `task` now (see `Inner`'s Sync).
        unsafe { *inner.task.get() = Some(task) };
        inner.pending.store(self.workers, Ordering::Relaxed);
        // SeqCst with the worker's "sleeping, then the epoch" (a Dekker pair): either it sees
        // the new epoch or this sees it sleeping.
        inner.epoch.fetch_add(1, Ordering::SeqCst);
        for (k, s) in inner.sleeping.iter().enumerate() {
            if s.swap(false, Ordering::SeqCst) {
                inner.threads.lock().expect("not poisoned")[k].unpark();
            }
        }
        // This thread's share: job 0, and any jobs beyond the threads.
        let mine = catch_unwind(AssertUnwindSafe(|| {
            // SAFETY: job 0 is no worker's (they take 1..n), and `head` is not used otherwise
            // while they run.
            f(unsafe { &mut *ptr.0 });
            for j in tail.iter_mut() {
                f(j);
            }
        }));
        let mut spins = 0u32;
        while inner.pending.load(Ordering::Acquire) != 0 {
            relax(&mut spins);
        }
        // A worker's panic, taken now so that it cannot resurface in a later hand-over.
        let theirs = inner.panic.lock().expect("not poisoned").take();
        if let Err(p) = mine {
            resume_unwind(p);
        }
        if let Some(p) = theirs {
            resume_unwind(p);
        }
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

/// Worker `k`'s loop: wait for a new epoch (spinning for [`SPIN`], then parked), run the
/// task with `k`, report, again; until the crew stops.
fn work(inner: &Inner, k: usize) {
    let mut seen = 0;
    loop {
        let start = Instant::now();
        let mut spins = 0u32;
        loop {
            let e = inner.epoch.load(Ordering::Acquire);
            if e != seen {
                seen = e;
                break;
            }
            if spins % 256 != 255 || start.elapsed() < SPIN {
                relax(&mut spins);
                continue;
            }
            inner.sleeping[k].store(true, Ordering::SeqCst);
            if inner.epoch.load(Ordering::SeqCst) == seen {
                thread::park();
            }
            inner.sleeping[k].store(false, Ordering::SeqCst);
        }
        if inner.stop.load(Ordering::Acquire) {
            return;
        }
        // SAFETY: published before the epoch this worker saw; not rewritten until every
        // worker, this one included, has decremented `pending`.
        let task = unsafe { (*inner.task.get()).expect("a task with the epoch") };
        // SAFETY: the owner keeps the task alive until `pending` reaches 0.
        let r = catch_unwind(AssertUnwindSafe(|| unsafe { (*task)(k) }));
        if let Err(p) = r {
            *inner.panic.lock().expect("not poisoned") = Some(p);
        }
        inner.pending.fetch_sub(1, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_job_runs_once_per_hand_over() {
        for threads in [1, 2, 3, 5] {
            Crew::scope(threads, |crew| {
                let mut jobs: Vec<u64> = vec![0; 4];
                for round in 0..2000u64 {
                    crew.for_each(&mut jobs, |j| *j += round);
                }
                let want = (0..2000u64).sum::<u64>();
                assert_eq!(jobs, vec![want; 4], "{threads} threads");
            })
            .unwrap();
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
    fn a_panicking_job_panics_the_caller() {
        let r = std::panic::catch_unwind(|| {
            Crew::scope(2, |crew| {
                let mut jobs = vec![0u32, 1];
                crew.for_each(&mut jobs, |j| assert_eq!(*j, 0, "job {j}"));
            })
        });
        assert!(r.is_err());
    }

    #[test]
    fn a_workers_panic_does_not_resurface_later() {
        Crew::scope(2, |crew| {
            let mut jobs = vec![0u32, 1];
            // Both jobs panic: the caller's panic is raised; the worker's must not wait for
            // the next hand-over.
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

    /// A crew stays on the thread that made it (a job cannot capture it and hand work over
    /// while a hand-over runs): checked at compile time, here for the record.
    #[test]
    fn a_crew_is_neither_send_nor_sync() {
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
