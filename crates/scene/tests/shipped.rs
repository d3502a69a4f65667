//! Every shipped descriptor loads from the shared scenes (`../shared/scenes`, or
//! `$RTSIM_SCENE_DIR`) with the triangle count it declares, and its camera and light are
//! sensible: rays through the image hit the scene, not a wall at the lens, and the light is
//! not buried inside geometry.

use rtsim_core::{Pcg32, Vec3};
use rtsim_scene::descriptor::Descriptor;
use rtsim_scene::registry::SHIPPED;
use rtsim_scene::{Scene, SceneRequest, Triangle, load_scene};
use std::path::PathBuf;
use std::time::Instant;

fn scene_dir() -> PathBuf {
    let dir = std::env::var_os("RTSIM_SCENE_DIR")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes")
        });
    assert!(
        dir.join("sibenik").is_dir(),
        "the shared scenes are not at {}: set RTSIM_SCENE_DIR to the directory holding \
         sibenik/, conference/ … (CI has them)",
        dir.display()
    );
    dir
}

fn load(name: &str) -> Scene {
    let dir = scene_dir();
    load_scene(&SceneRequest {
        name,
        size: 1.0,
        seed: 1,
        scene_dir: Some(&dir),
    })
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Möller–Trumbore, brute force: nearest hit distance along `d` (unit) from `o`.
fn nearest(scene: &Scene, o: Vec3, d: Vec3) -> Option<f32> {
    let hit = |t: &Triangle| {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - t[0];
        let u = s.dot(p) * inv;
        let q = s.cross(e1);
        let v = d.dot(q) * inv;
        let h = e2.dot(q) * inv;
        (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && h > 0.0).then_some(h)
    };
    scene
        .triangles
        .iter()
        .filter_map(hit)
        .min_by(|a, b| a.total_cmp(b))
}

#[test]
fn every_shipped_descriptor_loads_with_its_count_and_a_sensible_view() {
    for (name, text) in SHIPPED {
        let expected = Descriptor::parse(text, name.as_ref())
            .unwrap()
            .triangles
            .unwrap();
        let t = Instant::now();
        let s = load(name);
        let secs = t.elapsed().as_secs_f64();
        println!(
            "{name}: {} triangles in {secs:.3} s; {:?}",
            s.triangles.len(),
            s.report.log_lines()
        );
        assert_eq!(s.triangles.len() as u64, expected, "{name}");
        assert_eq!(s.material_ids.len(), s.triangles.len(), "{name}");
        assert!(s.files.iter().all(|f| f.is_file()), "{name}");
        assert!(s.light.intensity.min_component() > 0.0, "{name}");
        check_camera_and_light(name, &s);
        // Every [[viewpoint]] is a sensible view too (the SGRT tables average over them).
        for (i, v) in s.viewpoints.iter().enumerate() {
            let view = Scene {
                camera: *v,
                ..s.clone()
            };
            check_camera_and_light(&format!("{name} viewpoint {}", i + 1), &view);
        }
    }
}

#[test]
fn sibenik_and_conference_ship_five_viewpoints_inside_the_model() {
    for name in ["sibenik", "conference"] {
        let s = load(name);
        assert_eq!(s.viewpoints.len(), 5, "{name}");
        for v in &s.viewpoints {
            assert!(s.bounds().contains(v.eye), "{name}: {v:?}");
        }
    }
}

fn check_camera_and_light(name: &str, s: &Scene) {
    let b = s.bounds();
    let diag = b.extent().length();
    let cam = s.camera;
    let basis = cam.basis();
    // The ray through the image centre hits (the view is on the scene); inside a scene
    // (interiors, boxes) the rays through the four quadrant centres of a 4:3 image hit
    // too; and no hit is closer than 1 % of the scene diagonal (the eye is not in a wall).
    let inside = b.contains(cam.eye);
    let (w, h) = (1024, 768);
    for (x, y) in [
        (0.5, 0.5),
        (0.25, 0.25),
        (0.75, 0.25),
        (0.25, 0.75),
        (0.75, 0.75),
    ] {
        let d = cam
            .direction_through(&basis, x * w as f32, y * h as f32, w, h)
            .normalized();
        match nearest(s, cam.eye, d) {
            Some(t) => assert!(t > 0.01 * diag, "{name}: hit at {t} through ({x}, {y})"),
            None => assert!(
                !inside && (x, y) != (0.5, 0.5),
                "{name}: ray through ({x}, {y}) misses"
            ),
        }
    }
    // The light is not enclosed: in random directions, the median nearest hit is farther
    // than 1 % of the diagonal (or the rays escape).
    let mut rng = Pcg32::new(9, 9);
    let mut dists: Vec<f32> = (0..32)
        .map(|_| {
            let z = 2.0 * rng.next_f32() - 1.0;
            let a = std::f32::consts::TAU * rng.next_f32();
            let r = (1.0 - z * z).sqrt();
            let d = Vec3::new(r * a.cos(), r * a.sin(), z);
            nearest(s, s.light.position, d).unwrap_or(f32::INFINITY)
        })
        .collect();
    dists.sort_by(f32::total_cmp);
    assert!(
        dists[16] > 0.01 * diag,
        "{name}: light enclosed ({dists:?})"
    );
}

#[test]
fn boxed_scenes_put_the_camera_and_light_inside_the_box() {
    for (boxed, model) in [
        ("dragon-box", "stanford-dragon"),
        ("bunny-box", "stanford-bunny"),
    ] {
        let s = load(boxed);
        let m = load(model);
        let n = m.triangles.len();
        assert_eq!(s.triangles.len(), n + 12);
        // Scene order: the model first, unchanged, then the box.
        assert_eq!(s.triangles[..n], m.triangles[..]);
        assert_eq!(s.material_of(n as u32).name, "box");
        let b = s.bounds();
        assert!(
            b.contains(s.camera.eye) && b.contains(s.light.position),
            "{boxed}"
        );
        assert!(b.contains_box(&m.bounds()), "{boxed}");
    }
    let d = load("dragon-box").bounds();
    assert_eq!(d.min, Vec3::new(-0.128813, 0.0382846, -0.119));
    assert_eq!(d.max, Vec3::new(0.117055, 0.2116174, 0.11));
}

#[test]
fn materials_of_the_obj_scenes() {
    let c = load("cornell-box");
    let names: Vec<&str> = c.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["White", "Red", "Green", "Light"]);
    assert_eq!(c.materials[3].emission, Vec3::new(15.0, 15.0, 5.0));
    assert_eq!(c.materials[1].albedo, Vec3::new(0.8, 0.05, 0.05));
    let k = load("crytek-sponza");
    assert_eq!(k.materials.len(), 24);
    assert!(
        k.report
            .warnings
            .iter()
            .any(|w| w.contains("24 material(s) used but no material library"))
    );
}
