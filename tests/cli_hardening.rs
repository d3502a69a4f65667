//! Bad input and hostile outputs, one test per class of issue 11: special files as outputs,
//! outputs that are inputs, an unwritable `--out` found before the work, runs killed or
//! interrupted while writing, the PLY that hung, allocations sized by input, and control
//! characters echoed from input. Each drives the real binary on a temporary directory.

mod common;

use common::{fails, ok, rays_bin, rtsim};
use std::fs;
use std::os::unix::fs::FileTypeExt;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A character device of our own (the null device, 1:3) when we may create one, else
/// `/dev/null` itself: the same code path, without putting the machine's at risk.
fn null_device(dir: &Path) -> PathBuf {
    let node = dir.join("null");
    let c = std::ffi::CString::new(node.to_str().unwrap()).unwrap();
    // SAFETY: mknod on a path in a fresh temporary directory.
    let made = unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) };
    if made == 0 {
        node
    } else {
        PathBuf::from("/dev/null")
    }
}

fn is_char_device(p: &Path) -> bool {
    fs::symlink_metadata(p)
        .map(|m| m.file_type().is_char_device())
        .unwrap_or(false)
}

fn one_ray(dir: &Path) -> PathBuf {
    let p = dir.join("rays.bin");
    fs::write(
        &p,
        rays_bin(&[([0.0, 1.0, 3.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY)]),
    )
    .unwrap();
    p
}

/// Files a run left besides its outputs: staging directories of killed or failed runs.
fn leftovers(dir: &Path) -> Vec<String> {
    fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".rtsim-staging."))
        .collect()
}

#[test]
fn devices_fifos_and_links_are_written_through_never_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rays = one_ray(d);
    let dev = null_device(d);
    for args in [
        vec!["export-triangles", "--out"],
        vec!["trace", "--rays", rays.to_str().unwrap(), "--out"],
    ] {
        ok(rtsim().args(&args).arg(&dev).current_dir(d));
        assert!(is_char_device(&dev), "{args:?} replaced {}", dev.display());
    }

    // A FIFO: written through to its reader, and still a FIFO afterwards.
    let fifo = d.join("hits.fifo");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: mkfifo on a path in a fresh temporary directory.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || fs::read(fifo).unwrap())
    };
    ok(rtsim()
        .args(["trace", "--rays"])
        .arg(&rays)
        .arg("--out")
        .arg(&fifo)
        .current_dir(d));
    assert_eq!(
        reader.join().unwrap().len(),
        16,
        "one hit record through the FIFO"
    );
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());

    // A symbolic link: its destination gets the new content, the link stays a link.
    fs::create_dir(d.join("real")).unwrap();
    fs::write(d.join("real/tris.bin"), b"old").unwrap();
    std::os::unix::fs::symlink("real/tris.bin", d.join("tris.bin")).unwrap();
    ok(rtsim()
        .args(["export-triangles", "--out", "tris.bin"])
        .current_dir(d));
    assert!(
        fs::symlink_metadata(d.join("tris.bin"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(fs::read(d.join("real/tris.bin")).unwrap().len() > 8);

    // A directory where a file is wanted is refused with the reason.
    let e = fails(
        rtsim()
            .args(["export-triangles", "--out"])
            .arg(d.join("real"))
            .current_dir(d),
    );
    assert!(e.contains("is a directory"), "{e}");
    assert!(leftovers(d).is_empty() && leftovers(&d.join("real")).is_empty());
}

#[test]
fn an_output_that_is_an_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rays = one_ray(d);
    let before = fs::read(&rays).unwrap();
    std::os::unix::fs::symlink("rays.bin", d.join("alias.bin")).unwrap();
    for out in ["rays.bin", "./rays.bin", "alias.bin"] {
        let e = fails(
            rtsim()
                .args(["trace", "--rays", "rays.bin", "--out", out])
                .current_dir(d),
        );
        assert!(e.contains("same file as the input --rays"), "{out}: {e}");
    }
    assert_eq!(fs::read(&rays).unwrap(), before);
    // The same for a mesh given as the scene.
    fs::write(d.join("m.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let e = fails(
        rtsim()
            .args(["export-triangles", "--scene", "m.obj", "--out", "m.obj"])
            .current_dir(d),
    );
    assert!(e.contains("same file as the input"), "{e}");
}

#[test]
fn an_unwritable_out_fails_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("file"), b"x").unwrap();
    // Work that would take minutes; the error must come at once, before the render starts
    // (which `fails` checks too: the render's first line would be a second line on stderr).
    let start = Instant::now();
    let e = fails(
        rtsim()
            .args([
                "render", "--width", "4096", "--height", "4096", "--spp", "64", "--out", "file/sub",
            ])
            .current_dir(d),
    );
    assert!(
        e.contains("file/sub") && e.contains("file is not a directory"),
        "{e}"
    );
    let e = fails(
        rtsim()
            .args([
                "simulate",
                "--arch",
                "functional",
                "--width",
                "4096",
                "--height",
                "4096",
                "--spp",
                "64",
                "--out",
                "file",
            ])
            .current_dir(d),
    );
    assert!(
        e.contains("must be a directory, but this is a regular file"),
        "{e}"
    );
    let e = fails(
        rtsim()
            .args([
                "dram",
                "--synthetic",
                "random",
                "--requests",
                "100000000",
                "--out",
                "file",
            ])
            .current_dir(d),
    );
    assert!(e.contains("--out must be a directory"), "{e}");
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );
    assert_eq!(fs::read(d.join("file")).unwrap(), b"x");
}

/// The files of a render set, with their contents (timing.json differs between identical
/// runs, so only its presence is compared).
fn render_set(dir: &Path) -> Vec<(String, Option<Vec<u8>>)> {
    [
        "render.png",
        "heatmap.png",
        "stats.json",
        "config.resolved.toml",
        "timing.json",
    ]
    .iter()
    .map(|f| {
        let bytes = fs::read(dir.join(f)).ok();
        let bytes = if *f == "timing.json" {
            bytes.map(|_| Vec::new())
        } else {
            bytes
        };
        (f.to_string(), bytes)
    })
    .collect()
}

/// A render into `cwd/out`, named relatively so that `config.resolved.toml` (which records
/// `--out`) is the same for the same seed whatever `cwd` is.
fn render(seed: &str, cwd: &Path) -> Command {
    let mut c = rtsim();
    c.args([
        "render",
        "--threads",
        "1",
        "--width",
        "256",
        "--height",
        "256",
        "--spp",
        "16",
        "--seed",
        seed,
        "--out",
        "out",
    ])
    .current_dir(cwd)
    .stdout(Stdio::null())
    .stderr(Stdio::null());
    c
}

/// Wait until `pred` holds (polling), at most `limit`.
fn wait_for(limit: Duration, mut pred: impl FnMut() -> bool) -> bool {
    let start = Instant::now();
    while start.elapsed() < limit {
        if pred() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    false
}

#[test]
fn killed_and_interrupted_runs_leave_one_complete_set() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (out, ref_b) = (d.join("out"), d.join("b"));
    fs::create_dir(&ref_b).unwrap();
    ok(&mut render("1", d));
    ok(&mut render("2", &ref_b));
    let set_a = render_set(&out);
    let set_b = render_set(&ref_b.join("out"));
    assert!(set_a.iter().all(|(_, b)| b.is_some()));
    assert_ne!(set_a, set_b, "the two runs must be told apart");

    // kill -9 during the render: the previous set stays whole; the staging is left behind.
    let mut child = render("2", d).spawn().unwrap();
    assert!(wait_for(Duration::from_secs(20), || !leftovers(&out).is_empty()));
    std::thread::sleep(Duration::from_millis(200));
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(
        render_set(&out),
        set_a,
        "a killed run changed the output set"
    );

    // Ctrl-C (SIGINT) during the render: staged files are removed and the set stays whole.
    let mut child = render("2", d).spawn().unwrap();
    let mine = format!(".rtsim-staging.{}.", child.id());
    assert!(wait_for(Duration::from_secs(20), || {
        leftovers(&out).iter().any(|n| n.starts_with(&mine))
    }));
    std::thread::sleep(Duration::from_millis(100));
    // SAFETY: signals our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert!(
        !leftovers(&out).iter().any(|n| n.starts_with(&mine)),
        "SIGINT left {:?}",
        leftovers(&out)
    );
    assert_eq!(render_set(&out), set_a);

    // kill -9 inside the commit (slowed down by the test hook): the staged set carries its
    // commit marker, and the next run into the directory completes it before its own work.
    let mut child = render("2", d)
        .env("RTSIM_TEST_COMMIT_PAUSE_MS", "300")
        .spawn()
        .unwrap();
    let committing = wait_for(Duration::from_secs(30), || {
        leftovers(&out)
            .iter()
            .any(|n| out.join(n).join("COMMIT").exists())
    });
    assert!(committing, "the run never reached its commit");
    std::thread::sleep(Duration::from_millis(100));
    child.kill().unwrap();
    child.wait().unwrap();
    // Every file is the old run's or the new run's, never anything else.
    for ((f, now), ((_, a), (_, b))) in render_set(&out).into_iter().zip(set_a.iter().zip(&set_b)) {
        assert!(now == *a || now == *b, "{f} is from neither run");
    }
    let rays = one_ray(d);
    ok(rtsim()
        .args(["trace", "--rays"])
        .arg(&rays)
        .arg("--out")
        .arg(out.join("hits.bin")));
    assert_eq!(
        render_set(&out),
        set_b,
        "the interrupted commit was not completed"
    );
    assert!(leftovers(&out).is_empty(), "{:?}", leftovers(&out));
}

/// Run with a time limit; `None` if it had to be killed.
fn run_within(cmd: &mut Command, limit: Duration) -> Option<std::process::Output> {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    if !wait_for(limit, || child.try_wait().unwrap().is_some()) {
        child.kill().unwrap();
        child.wait().unwrap();
        return None;
    }
    Some(child.wait_with_output().unwrap())
}

#[test]
fn the_ply_that_hung_loads_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let hang = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("crates/fuzz/regressions/ply/hang-empty-records-2pow62");
    let bytes = fs::read(&hang).unwrap();
    assert_eq!(bytes.len(), 251);
    fs::write(d.join("h.ply"), &bytes).unwrap();
    let out = run_within(
        rtsim()
            .args(["export-triangles", "--scene", "h.ply", "--out", "t.bin"])
            .current_dir(d),
        Duration::from_secs(30),
    )
    .expect("the 2^62-record PLY hangs again");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // A vertex count the file cannot hold is refused before anything is read.
    let big = String::from_utf8_lossy(&bytes).replace("vertex 3", "vertex 3000000000");
    fs::write(d.join("big.ply"), big.as_bytes()).unwrap();
    let e = fails(
        rtsim()
            .args(["export-triangles", "--scene", "big.ply", "--out", "t.bin"])
            .current_dir(d),
    );
    assert!(e.contains("3000000000 `vertex` element(s)"), "{e}");
}

/// `cmd` under an address-space limit of `bytes`, as a memory-limited batch job runs it.
fn limited(cmd: &mut Command, bytes: u64) -> &mut Command {
    // SAFETY: setrlimit is async-signal-safe and only affects the child.
    unsafe {
        cmd.pre_exec(move || {
            let lim = libc::rlimit {
                rlim_cur: bytes,
                rlim_max: bytes,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        })
    }
}

#[test]
fn allocations_sized_by_input_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    const GB: u64 = 1 << 30;
    let e = fails(limited(
        rtsim()
            .args(["dram", "--trace", "/dev/zero", "--out", "o"])
            .current_dir(d),
        GB,
    ));
    assert!(e.contains("/dev/zero:1: line longer than"), "{e}");
    let e = fails(limited(
        rtsim()
            .args(["cache", "--trace", "/dev/zero", "--out", "o"])
            .current_dir(d),
        GB,
    ));
    assert!(e.contains("/dev/zero:1: line longer than"), "{e}");
    let e = fails(limited(
        rtsim().args(["bench", "--rays", "50000000"]).current_dir(d),
        4 * GB,
    ));
    assert!(e.contains("--rays") && e.contains("1..=16777216"), "{e}");
    for args in [
        vec!["render", "--set", "threads=4096"],
        vec!["render", "--threads", "4096"],
    ] {
        let e = fails(limited(rtsim().args(&args).current_dir(d), 4 * GB));
        assert!(e.contains("0..=256"), "{args:?}: {e}");
    }
    // A mesh without line breaks is a located error, not an unbounded line.
    fs::write(d.join("long.obj"), vec![b'v'; 3 << 20]).unwrap();
    let e = fails(limited(
        rtsim()
            .args(["export-triangles", "--scene", "long.obj", "--out", "t.bin"])
            .current_dir(d),
        GB,
    ));
    assert!(e.contains("long.obj:1: line longer than"), "{e}");
}

#[test]
fn echoed_input_is_escaped_and_cut() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let token = format!("\u{1b}[2J\u{1b}]0;pwned\u{7}{}", "9".repeat(50_000));
    // An OBJ with control characters is refused as binary; a long bad number is echoed cut.
    let long = format!("1{}", "x".repeat(50_000));
    fs::write(
        d.join("bad.obj"),
        format!("v 0 0 0\nv 1 {long} 0\nf 1 2 3\n"),
    )
    .unwrap();
    fs::write(
        d.join("bin.obj"),
        format!("v 0 0 0\nv 1 {token} 0\nf 1 2 3\n"),
    )
    .unwrap();
    fs::write(d.join("bad.trc"), format!("0 R 0x{token}\n")).unwrap();
    fs::write(d.join("bad.ctrc"), format!("R 0x{token}\n")).unwrap();
    fs::write(
        d.join("bad.toml"),
        format!("[[mesh]]\nfile = \"{token}.obj\"\n"),
    )
    .unwrap();
    let set_name = format!("scene.name={token}");
    let set_key = format!("{token}=1");
    let set_variant = format!("workload.kind=\"{token}\"");
    for args in [
        vec!["export-triangles", "--scene", "bad.obj", "--out", "t.bin"],
        vec!["export-triangles", "--scene", "bin.obj", "--out", "t.bin"],
        vec!["dram", "--trace", "bad.trc", "--out", "o"],
        vec!["cache", "--trace", "bad.ctrc", "--out", "o"],
        vec!["export-triangles", "--scene", "bad.toml", "--out", "t.bin"],
        vec!["render", "--set", &set_name, "--out", "o"],
        vec!["render", "--set", &set_key, "--out", "o"],
        vec!["render", "--set", &set_variant, "--out", "o"],
        // Command-line errors (clap's own messages) too.
        vec!["render", "--width", &token],
        vec!["render", &token],
        vec![&token],
    ] {
        let out = rtsim().args(&args).current_dir(d).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        let what = &args[..2.min(args.len())];
        assert_eq!(out.status.code(), Some(2), "{what:?}");
        assert!(
            !stderr.chars().any(|c| c.is_control() && c != '\n'),
            "{what:?}: raw control characters in {stderr:?}"
        );
        assert!(
            stderr.len() < 1000,
            "{what:?}: {} bytes of error",
            stderr.len()
        );
        assert!(!stderr.contains(&"9".repeat(100)) && !stderr.contains(&"x".repeat(100)));
    }
}

#[test]
fn a_failure_while_writing_names_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rays = one_ray(d);
    // /dev/full: written through (a device), and every write fails with ENOSPC.
    let e = fails(
        rtsim()
            .args(["trace", "--rays"])
            .arg(&rays)
            .args(["--out", "/dev/full"])
            .current_dir(d),
    );
    assert!(
        e.contains("/dev/full") && e.contains("No space left"),
        "{e}"
    );
    assert!(leftovers(d).is_empty());
}

/// `rtsim ARGS` in `d` fails; its message contains every one of `want`.
fn says(d: &Path, args: &[&str], want: &[&str]) {
    let e = fails(rtsim().args(args).current_dir(d));
    for w in want {
        assert!(e.contains(w), "{args:?}: `{w}` missing from {e}");
    }
}

/// Issue 11 §3: each message names the real problem and where it is.
#[test]
fn messages_point_at_the_right_thing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let w = |name: &str, bytes: &[u8]| fs::write(d.join(name), bytes).unwrap();
    w("exists", b"x");
    w("ok.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    w("cr.obj", b"v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r");
    w("junk.obj", b"\x04\x9f\x00\x13binary");
    w("bad.obj.gz", b"\x1f\x8b\x08\x00junkjunkjunk");
    let ply = fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/fuzz/corpus/ply/le.ply"))
        .unwrap();
    w("mesh.obj", &ply);
    w("dupkey.toml", b"[workload]\nspp = 1\nspp = 2\n");
    w("latin1.toml", b"[workload]\n# caf\xe9\n");
    w(
        "wl.toml",
        b"[[mesh]]\nfile = \"ok.obj\"\n[workload]\nspp = -3\n",
    );
    w("zero.toml", b"[[mesh]]\nfile = \"ok.obj\"\n\nscale = 0\n");
    fs::create_dir(d.join("adir")).unwrap();
    let out = ["--out", "o"];
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec![
                "dram",
                "--synthetic",
                "random",
                "--set",
                "timing.clock_mhz=0",
                "--out",
                "o",
            ],
            vec!["timing.clock_mhz", "0.001..="],
        ),
        (
            vec!["dram", "--synthetic", "random", "--out", "exists"],
            vec!["exists", "must be a directory, but this is a regular file"],
        ),
        (
            vec!["render", "--out", "exists"],
            vec!["exists", "must be a directory"],
        ),
        (
            vec!["export-triangles", "--scene", "adir", "--out", "t.bin"],
            vec!["adir", "is a directory, not a scene file"],
        ),
        (
            vec!["export-triangles", "--scene", "/dev/null", "--out", "t.bin"],
            vec!["character device, not a scene file"],
        ),
        (
            vec!["export-triangles", "--scene", "mesh.obj", "--out", "t.bin"],
            vec!["mesh.obj:1", "PLY", "name it .ply"],
        ),
        (
            vec!["export-triangles", "--scene", "cr.obj", "--out", "t.bin"],
            vec!["cr.obj:1", "CR-only"],
        ),
        (
            vec!["export-triangles", "--scene", "junk.obj", "--out", "t.bin"],
            vec!["junk.obj:1", "binary data"],
        ),
        (
            vec![
                "export-triangles",
                "--scene",
                "bad.obj.gz",
                "--out",
                "t.bin",
            ],
            vec!["bad.obj.gz", "corrupt gzip data"],
        ),
        (
            [&["render", "--config", "dupkey.toml"][..], &out].concat(),
            vec!["dupkey.toml:3", "duplicate key `spp`"],
        ),
        (
            [&["render", "--config", "latin1.toml"][..], &out].concat(),
            vec!["latin1.toml:2", "not valid UTF-8", "column 6"],
        ),
        (
            [&["render", "--scene", "wl.toml"][..], &out].concat(),
            vec!["wl.toml", "[workload]", "workload.spp"],
        ),
        (
            [&["render", "--scene", "zero.toml"][..], &out].concat(),
            vec!["zero.toml:4", "mesh[0].scale"],
        ),
        (
            [&["render", "--set", "seed=18446744073709551615"][..], &out].concat(),
            vec![
                "18446744073709551615",
                "-9223372036854775808..=9223372036854775807",
            ],
        ),
        (
            [&["render", "--seed", "18446744073709551615"][..], &out].concat(),
            vec!["seed", "0..=9223372036854775807"],
        ),
    ];
    for (args, want) in &cases {
        says(d, args, want);
    }
    // A negative value for an unsigned flag: the range, not "unexpected argument '-1'".
    let o = rtsim().args(["render", "--spp", "-1"]).output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("must not be negative (allowed 0..=4294967295)"),
        "{e}"
    );
    // Image sizes state their own range, the one `workload.width` allows.
    let o = rtsim().args(["render", "--width", "-1"]).output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("must not be negative (allowed 1..=16384)"),
        "{e}"
    );
    assert!(!d.join("o").exists(), "a failed run left its --out behind");
}

/// Issue 11 §4: input that is probably wrong is an error or a warning, never silent.
#[test]
fn probably_wrong_input_is_not_accepted_silently() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let w = |name: &str, bytes: &[u8]| fs::write(d.join(name), bytes).unwrap();
    w("empty.trc", b"# only a comment\n\n");
    w("empty.ctrc", b"# only a comment\n");
    let header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                  property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                  end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    w("tail.ply", format!("{header}garbage\n").as_bytes());
    w(
        "dupprop.ply",
        header
            .replace("property float y\n", "property float x\n")
            .as_bytes(),
    );
    w(
        "twovertex.ply",
        header
            .replace(
                "element face",
                "element vertex 1\nproperty float x\nelement face",
            )
            .as_bytes(),
    );
    w(
        "huge.obj",
        b"v -3e38 -3e38 -3e38\nv 3e38 -3e38 -3e38\nv 0 3e38 3e38\nf 1 2 3\n",
    );
    says(
        d,
        &["dram", "--trace", "empty.trc", "--out", "o"],
        &["empty.trc", "no requests"],
    );
    says(
        d,
        &["cache", "--trace", "empty.ctrc", "--out", "o"],
        &["no accesses"],
    );
    says(
        d,
        &[
            "dram",
            "--synthetic",
            "random",
            "--requests",
            "0",
            "--out",
            "o",
        ],
        &["--requests", "1..="],
    );
    says(
        d,
        &["export-triangles", "--scene", "tail.ply", "--out", "t.bin"],
        &["tail.ply:14", "data after the last element"],
    );
    says(
        d,
        &[
            "export-triangles",
            "--scene",
            "dupprop.ply",
            "--out",
            "t.bin",
        ],
        &["dupprop.ply:5", "declared twice"],
    );
    says(
        d,
        &[
            "export-triangles",
            "--scene",
            "twovertex.ply",
            "--out",
            "t.bin",
        ],
        &["element `vertex` is declared twice"],
    );
    says(
        d,
        &["render", "--scene", "huge.obj", "--out", "o"],
        &["huge.obj", "beyond the ±1e18"],
    );
    // A light outside the closed box the camera is in: a black image, and a warning.
    let lit = fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/fuzz/corpus/descriptor/box-only.toml"),
    )
    .unwrap();
    w(
        "dark.toml",
        lit.replace("position = [0, 0.5, 0]", "position = [0, 5, 0]")
            .as_bytes(),
    );
    let o = rtsim()
        .args([
            "render",
            "--scene",
            "dark.toml",
            "--workload",
            "path",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "1",
            "--out",
            "o",
        ])
        .current_dir(d)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("warning: the image is entirely black"), "{e}");
}
