//! Known answers on the built-in Cornell box: pixels whose camera rays hit the ceiling, the
//! floor and the back wall (planes z = 548.8, z = 0, y = 559.2 of the box data), checked
//! against the ray–plane distance and the `primary` workload's shading formula, and an AO
//! pixel with nothing within the radius.

use rtsim_bvh::{BvhConfig, NodeOrder};
use rtsim_core::{Ray, Vec3};
use rtsim_scene::{SceneRequest, load_scene};
use rtsim_trace::{
    FrameStats, Integrator, RayCounters, TraceConfig, Tracer, WorkloadKind, WorkloadParams,
};

const W: u32 = 64;
const H: u32 = 64;

fn setup() -> (rtsim_scene::Scene, Tracer) {
    let scene = load_scene(&SceneRequest {
        name: "cornell",
        size: 1.0,
        seed: 1,
        scene_dir: None,
    })
    .unwrap();
    let bvh = rtsim_bvh::build(
        &scene.triangles,
        &BvhConfig::default(),
        NodeOrder::DepthFirst,
    )
    .unwrap();
    let tracer = Tracer::new(&scene.triangles, bvh, &TraceConfig::default()).unwrap();
    (scene, tracer)
}

fn params(kind: WorkloadKind, ao_radius: f32) -> WorkloadParams {
    WorkloadParams {
        kind,
        width: W,
        height: H,
        spp: 1,
        max_depth: 5,
        specular_bounces: 2,
        ao_radius,
        seed: 1,
    }
}

/// Camera-ray direction through pixel centre (i, j), from the camera definition alone:
/// eye (278, −549, 274), forward +y, up +z, right +x, vertical FOV 2·atan(1/2).
fn analytic_dir(i: u32, j: u32) -> Vec3 {
    let tan_half = 0.5f32;
    let sx = (2.0 * (i as f32 + 0.5) / W as f32 - 1.0) * tan_half;
    let sy = (1.0 - 2.0 * (j as f32 + 0.5) / H as f32) * tan_half;
    Vec3::new(sx, 1.0, sy).normalized()
}

#[test]
fn camera_rays_hit_the_box_planes_at_the_analytic_distance() {
    let (scene, tracer) = setup();
    let eye = Vec3::new(278.0, -549.0, 274.0);
    assert_eq!(scene.camera.eye, eye);
    let integ = Integrator::new(&scene, &tracer, params(WorkloadKind::Primary, 1.0));
    // (pixel, plane axis, plane value, outward normal facing the camera, material name)
    let cases = [
        ((32, 2), 2, 548.8, Vec3::new(0.0, 0.0, -1.0), "white"),
        ((20, 62), 2, 0.0, Vec3::new(0.0, 0.0, 1.0), "white"),
        ((32, 18), 1, 559.2, Vec3::new(0.0, -1.0, 0.0), "white"),
    ];
    for ((i, j), axis, plane, n, material) in cases {
        let d = analytic_dir(i, j);
        let t = (plane - eye[axis]) / d[axis];
        let ray: Ray = integ.camera_ray(i, j, (0.5, 0.5));
        assert!(
            (ray.direction - d).length() < 1e-6,
            "camera basis differs at ({i},{j})"
        );
        let hit = tracer.closest_hit(&ray, &mut RayCounters::default());
        assert!(hit.is_hit(), "pixel ({i},{j}) misses");
        assert!(
            (hit.t - t).abs() <= 1e-5 * t,
            "pixel ({i},{j}): t {} vs analytic {t}",
            hit.t
        );
        let tri = scene.triangles[hit.prim as usize];
        assert!(
            tri.iter().all(|v| (v[axis] - plane).abs() < 1e-3),
            "pixel ({i},{j}) hit {tri:?}"
        );
        let m = scene.material_of(hit.prim);
        assert!(m.name.to_lowercase().contains(material), "{}", m.name);
        // The primary workload's headlight shading: albedo · (0.2 + 0.8 cos θ).
        let px = integ.pixel(i, j, &mut FrameStats::default());
        let expect = m.albedo * (0.2 + 0.8 * n.dot(-d)) + m.emission;
        assert!(
            (px.color - expect).length() < 1e-5,
            "pixel ({i},{j}): {:?} vs {expect:?}",
            px.color
        );
    }
}

#[test]
fn ao_is_one_where_nothing_is_within_the_radius() {
    let (scene, tracer) = setup();
    // Pixel (20, 62) sees the floor far from walls and blocks; with a 5 mm radius every AO
    // ray escapes: the value is exactly 1, and exactly spp AO rays were traced.
    let mut p = params(WorkloadKind::Ao, 5.0);
    p.spp = 16;
    let integ = Integrator::new(&scene, &tracer, p);
    let mut st = FrameStats::default();
    let px = integ.pixel(20, 62, &mut st);
    assert_eq!(px.color, Vec3::ONE);
    assert_eq!((st.primary.rays, st.ao.rays, st.ao.hits), (1, 16, 0));
    // With a radius longer than the box, only rays leaving through the open front (y = 0)
    // escape: for this floor point, 26 mm behind the front edge, most rays are occluded.
    let mut p = params(WorkloadKind::Ao, 5000.0);
    p.spp = 64;
    let integ = Integrator::new(&scene, &tracer, p);
    let mut st = FrameStats::default();
    let px = integ.pixel(20, 62, &mut st);
    assert!(px.color.x < 0.9 && st.ao.hits > 32, "{px:?} {st:?}");
}
