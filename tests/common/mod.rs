//! Helpers for the integration tests that drive the real `rtsim` binary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The binary under test.
pub fn rtsim() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rtsim"));
    c.env("RTSIM_SCENE_DIR", scene_dir());
    c
}

/// `../shared/scenes` beside the repository (CI has it), or `$RTSIM_SCENE_DIR`.
pub fn scene_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("RTSIM_SCENE_DIR").filter(|d| !d.is_empty()) {
        return PathBuf::from(d);
    }
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes");
    assert!(
        d.is_dir(),
        "shared scenes not found at {} (set RTSIM_SCENE_DIR)",
        d.display()
    );
    d
}

/// Run and require success; returns stdout.
pub fn ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("spawn rtsim");
    assert!(
        out.status.success(),
        "rtsim failed ({:?}):\nstdout: {}\nstderr: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Run and require a clean failure: exit code 2, one line on stderr starting with `error:`,
/// no panic. Returns that line.
pub fn fails(cmd: &mut Command) -> String {
    let out: Output = cmd.output().expect("spawn rtsim");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.code(),
        Some(2),
        "expected exit 2, stderr: {stderr}"
    );
    assert!(
        !stderr.contains("panicked") && !stderr.contains("internal error"),
        "{stderr}"
    );
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got: {stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    lines[0].to_string()
}

/// Little-endian rays.bin from (origin, direction, tmin, tmax).
pub fn rays_bin(rays: &[([f32; 3], [f32; 3], f32, f32)]) -> Vec<u8> {
    let mut b = (rays.len() as u64).to_le_bytes().to_vec();
    for (o, d, tmin, tmax) in rays {
        for v in o.iter().chain(d).chain([tmin, tmax]) {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    b
}

/// Parse hits.bin into (t, id, u, v).
pub fn parse_hits(bytes: &[u8]) -> Vec<(f32, i32, f32, f32)> {
    assert_eq!(bytes.len() % 16, 0);
    bytes
        .chunks_exact(16)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes(c[i..i + 4].try_into().unwrap());
            (
                f(0),
                i32::from_le_bytes(c[4..8].try_into().unwrap()),
                f(8),
                f(12),
            )
        })
        .collect()
}

/// Parse tris.bin into triangles.
pub fn parse_tris(bytes: &[u8]) -> Vec<[[f32; 3]; 3]> {
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    assert_eq!(bytes.len(), 8 + n * 36);
    bytes[8..]
        .chunks_exact(36)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes(c[4 * i..4 * i + 4].try_into().unwrap());
            [[f(0), f(1), f(2)], [f(3), f(4), f(5)], [f(6), f(7), f(8)]]
        })
        .collect()
}

/// Rays for checking a tracer on `scene`: even ones from random points of (a margin around) its
/// bounds in random directions, odd ones from the camera through random points of a 64×48
/// image. `bounded`: every sixth ray ends at a tenth of the bounds' diagonal, as shadow and AO
/// rays do; `unit_camera`: camera-ray directions normalised.
pub fn scene_rays(
    scene: &rtsim_scene::Scene,
    n: usize,
    seed: u64,
    stream: u64,
    bounded: bool,
    unit_camera: bool,
) -> Vec<rtsim_core::Ray> {
    use rtsim_core::{Pcg32, Ray, Vec3};
    let b = scene.bounds();
    let (lo, ext) = (b.min - b.extent() * 0.05, b.extent() * 1.1);
    let mut g = Pcg32::new(seed, stream);
    let basis = scene.camera.basis();
    (0..n)
        .map(|i| {
            if i % 2 == 0 {
                let o = lo
                    + Vec3::new(
                        ext.x * g.next_f32(),
                        ext.y * g.next_f32(),
                        ext.z * g.next_f32(),
                    );
                let d = Vec3::new(g.next_f32() - 0.5, g.next_f32() - 0.5, g.next_f32() - 0.5);
                let tmax = if bounded && i % 6 == 0 {
                    ext.length() * 0.1
                } else {
                    f32::INFINITY
                };
                Ray::new(o, d, 0.0, tmax)
            } else {
                let d = scene.camera.direction_through(
                    &basis,
                    g.next_f32() * 64.0,
                    g.next_f32() * 48.0,
                    64,
                    48,
                );
                let d = if unit_camera { d.normalized() } else { d };
                Ray::new(scene.camera.eye, d, 0.0, f32::INFINITY)
            }
        })
        .collect()
}

/// The shared scene `name` at size 1, seed 1, from [`scene_dir`].
pub fn shared_scene(name: &str) -> rtsim_scene::Scene {
    let dir = scene_dir();
    rtsim_scene::load_scene(&rtsim_scene::SceneRequest {
        name,
        size: 1.0,
        seed: 1,
        scene_dir: Some(&dir),
    })
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}
