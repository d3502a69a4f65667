//! The real `rtsim` binary on scenes: `rtsim scenes`, `rtsim export-triangles`, and bad scene
//! input (truncated OBJ, bad indices, malformed numbers, PLY without faces, missing files,
//! unknown scenes), which must exit with code 2 and one line naming the file and line.

use rtsim_core::Vec3;
use rtsim_scene::export::read_triangles;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn rtsim() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rtsim"));
    // Tests pass --scene-dir where they need one; never pick one up from the environment.
    c.env_remove("RTSIM_SCENE_DIR");
    c
}

fn shared_scenes() -> PathBuf {
    let dir = std::env::var_os("RTSIM_SCENE_DIR")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes"));
    assert!(
        dir.join("cornell-box").is_dir(),
        "the shared scenes are not at {}: set RTSIM_SCENE_DIR (CI has them)",
        dir.display()
    );
    dir
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Run `rtsim export-triangles` on `scene` into `dir/tris.bin`, with extra arguments.
fn export(dir: &Path, scene: &str, extra: &[&str]) -> (Output, PathBuf) {
    let out = dir.join("tris.bin");
    let o = rtsim()
        .args(["export-triangles", "--scene", scene, "--out"])
        .arg(&out)
        .args(extra)
        .output()
        .unwrap();
    (o, out)
}

/// Exit code 2 and exactly one line on stderr that contains every one of `needles`.
fn assert_one_line_error(o: &Output, needles: &[&str]) {
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(!err.contains("internal error"), "{err}");
    for n in needles {
        assert!(err.contains(n), "missing `{n}` in: {err}");
    }
}

#[test]
fn scenes_lists_builtins_and_descriptors_with_counts_and_files() {
    let o = rtsim()
        .arg("scenes")
        .arg("--scene-dir")
        .arg(shared_scenes())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    let line = |name: &str| {
        out.lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("no line for {name} in:\n{out}"))
            .to_string()
    };
    let h = line("hairball");
    assert!(h.contains("built-in") && h.contains("2,880,000"), "{h}");
    let s = line("sibenik");
    assert!(
        s.contains("descriptor") && s.contains("75,275") && s.contains("present"),
        "{s}"
    );
    for name in [
        "cornell",
        "vegetation",
        "conference",
        "crytek-sponza",
        "sponza-dabrovic",
        "stanford-dragon",
        "dragon-box",
        "stanford-bunny",
        "bunny-box",
        "cornell-box",
    ] {
        line(name);
    }

    // With an empty scene directory the descriptor scenes' files are missing.
    let empty = tempfile::tempdir().unwrap();
    let o = rtsim()
        .args(["scenes", "--scene-dir"])
        .arg(empty.path())
        .output()
        .unwrap();
    assert!(o.status.success());
    let out = text(&o.stdout);
    let s = out.lines().find(|l| l.starts_with("sibenik")).unwrap();
    assert!(s.contains("missing"), "{s}");
}

#[test]
fn export_builtin_matches_the_library_scene_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let (o, path) = export(dir.path(), "cornell", &[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(bytes.len(), 8 + 38 * 36);
    assert_eq!(&bytes[..8], &38u64.to_le_bytes());
    let lib = rtsim_scene::procedural::cornell();
    assert_eq!(read_triangles(&bytes).unwrap(), lib.triangles);
}

#[test]
fn export_user_obj_keeps_file_order_and_drops_degenerates() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("m.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
         f 1 2 3 4\n\
         f 1 1 2\n\
         f -1 -2 -4\n",
    )
    .unwrap();
    let (o, path) = export(dir.path(), obj.to_str().unwrap(), &[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("dropped 1 zero-area"),
        "{}",
        text(&o.stderr)
    );
    let v = |x: f32, y: f32| Vec3::new(x, y, 0.0);
    let tris = read_triangles(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(
        tris,
        vec![
            [v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0)],
            [v(0.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)],
            [v(0.0, 1.0), v(1.0, 1.0), v(0.0, 0.0)],
        ]
    );
}

#[test]
fn export_shipped_scene_from_the_scene_dir() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = shared_scenes();
    let (o, path) = export(
        dir.path(),
        "cornell-box",
        &["--scene-dir", scenes.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let tris = read_triangles(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(tris.len(), 32);
    // CornellBox.obj's first face: `f 1/1 2/2 4/4` over `v 0 0 0`, `v 552.8 0 0`,
    // `v 549.6 559.2 0`.
    assert_eq!(
        tris[0],
        [
            Vec3::ZERO,
            Vec3::new(552.8, 0.0, 0.0),
            Vec3::new(549.6, 559.2, 0.0)
        ]
    );
    // The same through RTSIM_SCENE_DIR.
    let (o, _) = {
        let out = dir.path().join("env.bin");
        let o = rtsim()
            .env("RTSIM_SCENE_DIR", &scenes)
            .args(["export-triangles", "--scene", "cornell-box", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        (o, out)
    };
    assert!(o.status.success(), "{}", text(&o.stderr));
}

#[test]
fn procedural_export_is_deterministic_from_the_seed() {
    let dir = tempfile::tempdir().unwrap();
    let run = |seed: &str| {
        let (o, path) = export(
            dir.path(),
            "hairball",
            &["--set", "scene.size=0.01", "--seed", seed],
        );
        assert!(o.status.success(), "{}", text(&o.stderr));
        std::fs::read(path).unwrap()
    };
    let a = run("5");
    assert_eq!(a.len(), 8 + 75 * 384 * 36);
    assert_eq!(a, run("5"));
    assert_ne!(a, run("6"));
    let threads = {
        let (o, path) = export(
            dir.path(),
            "hairball",
            &["--set", "scene.size=0.01", "--seed", "5", "--threads", "1"],
        );
        assert!(o.status.success(), "{}", text(&o.stderr));
        std::fs::read(path).unwrap()
    };
    assert_eq!(a, threads);
}

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

fn bad_file(name: &str, content: &[u8]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, content).unwrap();
    (dir, p)
}

#[test]
fn truncated_obj_is_an_error_naming_file_and_line() {
    let full = format!("{QUAD}f 1 2 3\nf 1 3 4\n");
    let (dir, p) = bad_file("cut.obj", &full.as_bytes()[..full.len() - 5]);
    let (o, out) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(&o, &[&format!("{}:6:", p.display()), "at least 3"]);
    assert!(!out.exists(), "no output on error");
}

#[test]
fn bad_index_is_an_error_naming_file_and_line() {
    let (dir, p) = bad_file("idx.obj", format!("{QUAD}f 1 2 3\nf 1 2 9\n").as_bytes());
    let (o, _) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(
        &o,
        &[&format!("{}:6:", p.display()), "index 9 out of range"],
    );
    let (dir, p) = bad_file("neg.obj", format!("{QUAD}f -1 -2 -7\n").as_bytes());
    let (o, _) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(&o, &[&format!("{}:5:", p.display()), "-7"]);
}

#[test]
fn malformed_number_is_an_error_naming_file_and_line() {
    let (dir, p) = bad_file("num.obj", b"v 0 0 0\nv 1 0 0\nv 0 1e 0\nf 1 2 3\n");
    let (o, _) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(&o, &[&format!("{}:3:", p.display()), "`1e`"]);
}

#[test]
fn ply_without_faces_is_an_error() {
    let (dir, p) = bad_file(
        "points.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n",
    );
    let (o, _) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(&o, &[&p.display().to_string(), "no `face` element"]);
}

#[test]
fn truncated_binary_ply_names_the_element_and_offset() {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    // Too short for the declared vertices: refused from the header, before reading.
    let (dir, p) = bad_file("short.ply", &b);
    let (o, _) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(
        &o,
        &[
            &p.display().to_string(),
            "declares 3 `vertex` element(s)",
            "32 bytes after the header",
        ],
    );
    // Cut inside the face list, past what the header check can see.
    b.extend_from_slice(&0.0f32.to_le_bytes());
    b.push(3);
    b.extend_from_slice(&0i32.to_le_bytes());
    let (dir, p) = bad_file("cut.ply", &b);
    let (o, _) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(
        &o,
        &[
            &p.display().to_string(),
            "element `face` #0",
            "byte offset",
            "truncated",
        ],
    );
}

#[test]
fn missing_file_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nowhere.obj");
    let (o, _) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(&o, &[&p.display().to_string(), "no such scene file"]);
    // A descriptor naming a missing mesh.
    let d = dir.path().join("d.toml");
    std::fs::write(&d, "[[mesh]]\nfile = \"gone.ply\"\n").unwrap();
    let (o, _) = export(dir.path(), d.to_str().unwrap(), &[]);
    assert_one_line_error(&o, &[&dir.path().join("gone.ply").display().to_string()]);
}

#[test]
fn shipped_scene_without_its_files_names_the_remedy() {
    let dir = tempfile::tempdir().unwrap();
    let (o, _) = export(
        dir.path(),
        "sibenik",
        &["--scene-dir", dir.path().to_str().unwrap()],
    );
    assert_one_line_error(
        &o,
        &["sibenik/sibenik.obj.zst", "--scene-dir", "RTSIM_SCENE_DIR"],
    );
}

#[test]
fn unknown_scene_lists_the_known_ones_and_keeps_old_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tris.bin");
    std::fs::write(&out, b"old").unwrap();
    let (o, _) = export(dir.path(), "sibenick", &[]);
    assert_one_line_error(
        &o,
        &[
            "unknown scene `sibenick`",
            "cornell",
            "hairball",
            "sibenik",
            "bunny-box",
        ],
    );
    assert_eq!(std::fs::read(&out).unwrap(), b"old");
}

#[test]
fn bad_descriptor_names_file_line_and_key() {
    let (dir, p) = bad_file(
        "s.toml",
        b"[[mesh]]\nfile = \"m.obj\"\n[camera]\neye = [0, 0, 1]\ndirection = [0, 0, -1]\nfovy = 45\n",
    );
    let (o, _) = export(dir.path(), p.to_str().unwrap(), &[]);
    assert_one_line_error(&o, &[&format!("{}:6:", p.display()), "fovy"]);
}
