//! Replays every seed and every saved regression of every fuzz target, under the fuzzer's
//! rules: no panic, no input running over the hang limit, no oversized allocation.

use rtsim_fuzz::{
    ALLOC_LIMIT_BYTES, HANG_SECONDS, LimitedAlloc, TARGETS, corpus_dir, inputs_of, regressions_dir,
    run_one,
};
use std::time::{Duration, Instant};

fn on_excess(bytes: usize) {
    eprintln!("replay: one allocation of {bytes} bytes exceeds the {ALLOC_LIMIT_BYTES} limit");
}

#[global_allocator]
static ALLOC: LimitedAlloc = LimitedAlloc { on_excess };

#[test]
fn every_target_has_seeds() {
    for t in TARGETS {
        assert!(
            !inputs_of(&corpus_dir(), t.name).is_empty(),
            "target {} has no seed corpus in {}",
            t.name,
            corpus_dir().display()
        );
    }
}

#[test]
fn seeds_and_regressions_pass() {
    let mut n = 0;
    for t in TARGETS {
        for dir in [corpus_dir(), regressions_dir()] {
            for (path, input) in inputs_of(&dir, t.name) {
                let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
                let watch = done.clone();
                let name = path.display().to_string();
                // A hang would block the test forever: end the process with its name instead.
                std::thread::spawn(move || {
                    std::thread::sleep(Duration::from_secs(HANG_SECONDS * 10));
                    if !watch.load(std::sync::atomic::Ordering::SeqCst) {
                        eprintln!("replay: {name} hangs");
                        std::process::exit(1);
                    }
                });
                let start = Instant::now();
                let r = run_one(t, &input);
                done.store(true, std::sync::atomic::Ordering::SeqCst);
                assert!(r.is_ok(), "{}: panicked: {:?}", path.display(), r);
                assert!(
                    start.elapsed() < Duration::from_secs(HANG_SECONDS * 5),
                    "{}: took {:?}",
                    path.display(),
                    start.elapsed()
                );
                n += 1;
            }
        }
    }
    assert!(n >= TARGETS.len());
}
