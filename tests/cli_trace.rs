//! `rtsim trace` and `rtsim export-triangles` end to end against a brute-force caster, and
//! bad query files.

mod common;
use common::{fails, ok, parse_hits, parse_tris, rays_bin, rtsim};
use rtsim_core::{Pcg32, Ray, Vec3};
use std::fs;

fn random_rays(n: usize, seed: u64, lo: Vec3, hi: Vec3) -> Vec<([f32; 3], [f32; 3], f32, f32)> {
    let mut g = Pcg32::new(seed, 1);
    (0..n)
        .map(|i| {
            let o = Vec3::new(
                lo.x + (hi.x - lo.x) * g.next_f32(),
                lo.y + (hi.y - lo.y) * g.next_f32(),
                lo.z + (hi.z - lo.z) * g.next_f32(),
            );
            // Unnormalised directions, some finite tmax.
            let d = Vec3::new(g.next_f32() - 0.5, g.next_f32() - 0.5, g.next_f32() - 0.5) * 3.0;
            let tmax = if i % 4 == 0 {
                50.0 * g.next_f32()
            } else {
                f32::INFINITY
            };
            (o.to_array(), d.to_array(), 0.0, tmax)
        })
        .collect()
}

fn as_tris(t: &[[[f32; 3]; 3]]) -> Vec<[Vec3; 3]> {
    t.iter()
        .map(|t| {
            [
                Vec3::from_array(t[0]),
                Vec3::from_array(t[1]),
                Vec3::from_array(t[2]),
            ]
        })
        .collect()
}

#[test]
fn trace_matches_brute_force_on_exported_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let tris_path = dir.path().join("tris.bin");
    ok(rtsim()
        .args(["export-triangles", "--scene", "cornell", "--out"])
        .arg(&tris_path));
    let tris = as_tris(&parse_tris(&fs::read(&tris_path).unwrap()));
    assert!(tris.len() > 10);
    let rays = random_rays(
        5000,
        3,
        Vec3::new(-50.0, -600.0, -50.0),
        Vec3::new(600.0, 600.0, 600.0),
    );
    let rays_path = dir.path().join("rays.bin");
    fs::write(&rays_path, rays_bin(&rays)).unwrap();
    for (any, threads, fast) in [
        (false, "1", "true"),
        (false, "2", "false"),
        (true, "2", "true"),
        (true, "1", "false"),
    ] {
        let hits_path = dir.path().join("hits.bin");
        let mut cmd = rtsim();
        cmd.args(["trace", "--scene", "cornell", "--threads", threads, "--set"])
            .arg(format!("trace.fast_path={fast}"))
            .arg("--rays")
            .arg(&rays_path)
            .arg("--out")
            .arg(&hits_path);
        if any {
            cmd.arg("--any-hit");
        }
        ok(&mut cmd);
        let hits = parse_hits(&fs::read(&hits_path).unwrap());
        assert_eq!(hits.len(), rays.len());
        for (r, h) in rays.iter().zip(&hits) {
            let ray = Ray::new(Vec3::from_array(r.0), Vec3::from_array(r.1), r.2, r.3);
            let b = rtsim_trace::brute_force_closest(&tris, &ray);
            assert_eq!(h.1 >= 0, b.is_hit(), "any={any} {ray:?}");
            if !any && b.is_hit() {
                assert!(
                    (h.0 - b.t).abs() <= 1e-5 * b.t.max(1.0),
                    "t {} vs {}",
                    h.0,
                    b.t
                );
                if h.1 as u32 != b.prim {
                    // Only a tie at the same distance (shared edge) may pick another triangle.
                    assert_eq!(h.0, b.t);
                }
            }
            if h.1 < 0 {
                assert!(h.0.is_infinite() && h.2 == 0.0 && h.3 == 0.0);
            }
        }
    }
}

#[test]
fn degenerate_queries_miss() {
    let dir = tempfile::tempdir().unwrap();
    let rays = [
        ([278.0, -500.0, 274.0], [0.0, 0.0, 0.0], 0.0, f32::INFINITY), // zero direction
        ([278.0, -500.0, 274.0], [0.0, 1.0, 0.0], 5.0, 1.0),           // empty interval
        ([278.0, -500.0, 274.0], [0.0, 1.0, 0.0], 0.0, f32::INFINITY), // hits the back wall
    ];
    fs::write(dir.path().join("r.bin"), rays_bin(&rays)).unwrap();
    ok(rtsim()
        .args(["trace", "--scene", "cornell", "--rays"])
        .arg(dir.path().join("r.bin"))
        .arg("--out")
        .arg(dir.path().join("h.bin")));
    let hits = parse_hits(&fs::read(dir.path().join("h.bin")).unwrap());
    assert_eq!(hits[0].1, -1);
    assert_eq!(hits[1].1, -1);
    assert!(hits[2].1 >= 0);
}

#[test]
fn bad_ray_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, bytes: Option<Vec<u8>>| {
        let p = dir.path().join(name);
        if let Some(b) = bytes {
            fs::write(&p, b).unwrap();
        }
        fails(
            rtsim()
                .args(["trace", "--scene", "cornell", "--rays"])
                .arg(&p)
                .arg("--out")
                .arg(dir.path().join("h.bin")),
        )
    };
    let e = run("missing.bin", None);
    assert!(e.contains("missing.bin"), "{e}");
    let mut short = rays_bin(&[([0.0; 3], [1.0, 0.0, 0.0], 0.0, 1.0)]);
    short.truncate(20);
    let e = run("short.bin", Some(short));
    assert!(
        e.contains("short.bin") && e.contains("header says 1 rays"),
        "{e}"
    );
    let e = run(
        "nan.bin",
        Some(rays_bin(&[([0.0; 3], [f32::NAN, 0.0, 0.0], 0.0, 1.0)])),
    );
    assert!(
        e.contains("nan.bin") && e.contains("ray 0") && e.contains("direction"),
        "{e}"
    );
    assert!(
        !dir.path().join("h.bin").exists(),
        "no partial output on error"
    );
}
