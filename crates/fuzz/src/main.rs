//! `rtsim-fuzz`: mutate each target's seed corpus for a bounded time and keep every input that
//! crashes, hangs or asks for an oversized allocation in `crates/fuzz/regressions/`.
//!
//! ```text
//! cargo run --release -p rtsim-fuzz -- [--seconds S | --total-seconds T] [--seed N] [TARGET ...]
//! cargo run --release -p rtsim-fuzz -- --list
//! ```
//!
//! Exit status: 0 when no new failure was found, 1 otherwise (the inputs are saved).

use rtsim_fuzz::mutate::Mutator;
use rtsim_fuzz::{
    ALLOC_LIMIT_BYTES, Guard, HANG_SECONDS, LimitedAlloc, TARGETS, corpus_dir, inputs_of,
    regressions_dir, run_one, save_regression,
};
use std::process::ExitCode;
use std::sync::LazyLock;
use std::time::{Duration, Instant};

static GUARD: LazyLock<Guard> = LazyLock::new(Guard::default);

fn on_excess(bytes: usize) {
    let saved = GUARD.save("alloc");
    eprintln!(
        "rtsim-fuzz: an input asked for one allocation of {bytes} bytes (limit \
         {ALLOC_LIMIT_BYTES}); saved as {saved:?}"
    );
}

#[global_allocator]
static ALLOC: LimitedAlloc = LimitedAlloc { on_excess };

fn main() -> ExitCode {
    let mut seconds = 10.0f64;
    let mut total_seconds: Option<f64> = None;
    let mut seed = 1u64;
    let mut names: Vec<String> = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seconds" => match args.next().and_then(|s| s.parse().ok()) {
                Some(s) => seconds = s,
                None => return usage("--seconds takes a number"),
            },
            // A budget for the whole run, split evenly between the targets run (CI's form:
            // adding a target does not lengthen CI).
            "--total-seconds" => match args.next().and_then(|s| s.parse().ok()) {
                Some(s) => total_seconds = Some(s),
                None => return usage("--total-seconds takes a number"),
            },
            "--seed" => match args.next().and_then(|s| s.parse().ok()) {
                Some(s) => seed = s,
                None => return usage("--seed takes a whole number"),
            },
            "--list" => {
                for t in TARGETS {
                    println!("{:<20} {}", t.name, t.about);
                }
                return ExitCode::SUCCESS;
            }
            "-h" | "--help" => return usage(""),
            name => {
                if !TARGETS.iter().any(|t| t.name == name) {
                    return usage(&format!("unknown target `{name}` (see --list)"));
                }
                names.push(name.to_string());
            }
        }
    }
    if let Some(total) = total_seconds {
        let n = if names.is_empty() {
            TARGETS.len()
        } else {
            names.len()
        };
        seconds = total / n as f64;
    }
    // Panics are caught and reported per input; the default hook would flood stderr.
    std::panic::set_hook(Box::new(|_| {}));
    std::thread::spawn(|| {
        loop {
            std::thread::sleep(Duration::from_millis(100));
            if GUARD
                .running_ms()
                .is_some_and(|ms| ms > HANG_SECONDS * 1000)
            {
                let saved = GUARD.save("hang");
                eprintln!(
                    "rtsim-fuzz: an input ran over {HANG_SECONDS} s (a hang); saved as {saved:?}"
                );
                std::process::exit(1);
            }
        }
    });
    let mut failures = 0u64;
    let mut total = 0u64;
    for (ti, t) in TARGETS.iter().enumerate() {
        if !names.is_empty() && !names.iter().any(|n| n == t.name) {
            continue;
        }
        let mut seeds = inputs_of(&corpus_dir(), t.name);
        let regressions = inputs_of(&regressions_dir(), t.name);
        seeds.extend(regressions.iter().cloned());
        if seeds.is_empty() {
            eprintln!(
                "rtsim-fuzz: target {} has no seeds in {}",
                t.name,
                corpus_dir().display()
            );
            return ExitCode::FAILURE;
        }
        let mut m = Mutator::new(seed ^ (ti as u64) << 32);
        let start = Instant::now();
        let deadline = start + Duration::from_secs_f64(seconds);
        let (mut execs, mut failed) = (0u64, 0u64);
        let mut run = |input: &[u8]| {
            GUARD.begin(t.name, input);
            let r = run_one(t, input);
            GUARD.end();
            execs += 1;
            if let Err(msg) = r {
                let saved = save_regression(t.name, "crash", input);
                eprintln!("rtsim-fuzz: {}: panic `{msg}`; saved as {saved:?}", t.name);
                failed += 1;
            }
        };
        // The seeds and known regressions first: they must pass as they are.
        for (_, s) in &seeds {
            run(s);
        }
        let mut i = 0usize;
        while Instant::now() < deadline {
            let base = &seeds[i % seeds.len()].1;
            let other = &seeds[(i * 7 + 3) % seeds.len()].1;
            let input = m.mutate(base, t.dict, other, t.binary);
            run(&input);
            i += 1;
        }
        let secs = start.elapsed().as_secs_f64();
        println!(
            "{:<20} {:>9} inputs in {secs:>5.1} s ({:>7.0}/s), {} seeds, {} regressions, {failed} new failures",
            t.name,
            execs,
            execs as f64 / secs.max(1e-9),
            seeds.len() - regressions.len(),
            regressions.len(),
        );
        failures += failed;
        total += execs;
    }
    let _ = std::fs::remove_dir_all(
        std::env::temp_dir().join(format!("rtsim-fuzz-{}", std::process::id())),
    );
    println!("rtsim-fuzz: {total} inputs, {failures} new failures");
    if failures > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

fn usage(problem: &str) -> ExitCode {
    if !problem.is_empty() {
        eprintln!("rtsim-fuzz: {problem}");
    }
    eprintln!(
        "usage: rtsim-fuzz [--seconds S (per target) | --total-seconds T] [--seed N] [--list] \
         [TARGET ...]"
    );
    if problem.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    }
}
