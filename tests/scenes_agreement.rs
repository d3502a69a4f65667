//! The tracer against a brute-force caster on every shared scene: random rays through the
//! scene's bounds and camera rays; hit or miss, triangle id (except exact-distance ties on
//! shared edges) and t, for the reference traversal with each kernel and for the fast path.

mod common;
use rtsim_bvh::{BvhConfig, NodeOrder};
use rtsim_core::Ray;
use rtsim_trace::fast::FastBvh;
use rtsim_trace::{Hit, RayCounters, TraceConfig, Tracer, TriangleTest, brute_force_closest};

fn rays_for(scene: &rtsim_scene::Scene, n: usize, seed: u64) -> Vec<Ray> {
    common::scene_rays(scene, n, seed, 9, false, false)
}

/// Counts rays whose answer differs from brute force: hit or miss, t beyond the tolerance, or
/// another triangle at a distance beyond the tolerance (a different triangle is accepted only
/// as a tie: a shared edge or overlapping coplanar faces). The tolerance on t is `rel · t`
/// plus `abs_world / |d|`, an absolute error in world units for kernels whose precision
/// depends on the size of the coordinates (Wald's plane offsets are relative to the origin).
fn disagreements(
    reference: &[Hit],
    rays: &[Ray],
    got: impl Iterator<Item = Hit>,
    rel: f32,
    abs_world: f32,
) -> usize {
    reference
        .iter()
        .zip(rays)
        .zip(got)
        .filter(|((b, r), h)| {
            if b.is_hit() != h.is_hit() {
                return true;
            }
            if !b.is_hit() {
                return false;
            }
            let tol = rel * b.t.abs() + abs_world / r.direction.length();
            (h.t - b.t).abs() > tol
        })
        .count()
}

fn check(name: &str, rays_n: usize) {
    let scene = common::shared_scene(name);
    let rays = rays_for(&scene, rays_n, 5);
    let reference: Vec<Hit> = rays
        .iter()
        .map(|r| brute_force_closest(&scene.triangles, r))
        .collect();
    let bvh = rtsim_bvh::build(
        &scene.triangles,
        &BvhConfig::default(),
        NodeOrder::DepthFirst,
    )
    .unwrap();
    let fast = FastBvh::new(&scene.triangles, &bvh).unwrap();
    // The same kernel: t exact up to a few ulps between overlapping coplanar faces.
    let bad = disagreements(
        &reference,
        &rays,
        rays.iter().map(|r| fast.closest_hit(r)),
        4.0 * f32::EPSILON,
        0.0,
    );
    assert_eq!(
        bad,
        0,
        "{name}: fast path disagrees on {bad} of {} rays",
        rays.len()
    );
    for test in [
        TriangleTest::MollerTrumbore,
        TriangleTest::Plucker,
        TriangleTest::Wald,
    ] {
        let cfg = TraceConfig {
            triangle_test: test,
            ..TraceConfig::default()
        };
        let tracer = Tracer::new(&scene.triangles, bvh.clone(), &cfg).unwrap();
        let got = rays
            .iter()
            .map(|r| tracer.closest_hit(r, &mut RayCounters::default()));
        let b = scene.bounds();
        let coord = b.min.abs().max(b.max.abs()).max_component();
        let (rel, abs_world) = match test {
            TriangleTest::MollerTrumbore => (4.0 * f32::EPSILON, 0.0),
            // Plücker's and Wald's t come from the plane equation: errors of a few ulps of the
            // coordinates' magnitude.
            _ => (1e-4, 16.0 * f32::EPSILON * coord),
        };
        let bad = disagreements(&reference, &rays, got, rel, abs_world);
        // Other kernels may decide differently on an edge: allow 0.1 %.
        let allowed = if test == TriangleTest::MollerTrumbore {
            0
        } else {
            rays.len() / 1000
        };
        assert!(
            bad <= allowed,
            "{name} {test:?}: {bad} of {} rays disagree",
            rays.len()
        );
        for (r, b) in rays.iter().zip(&reference).take(500) {
            assert_eq!(
                tracer.any_hit(r, &mut RayCounters::default()),
                b.is_hit(),
                "{name} {test:?} any-hit"
            );
        }
    }
}

#[test]
fn cornell_box() {
    check("cornell-box", 4000);
}
#[test]
fn sibenik() {
    check("sibenik", 2000);
}
#[test]
fn sponza_dabrovic() {
    check("sponza-dabrovic", 2000);
}
#[test]
fn stanford_bunny() {
    check("stanford-bunny", 2000);
}
#[test]
fn bunny_box() {
    check("bunny-box", 1000);
}
#[test]
fn conference() {
    check("conference", 600);
}
#[test]
fn crytek_sponza() {
    check("crytek-sponza", 600);
}
#[test]
fn stanford_dragon() {
    check("stanford-dragon", 300);
}
#[test]
fn dragon_box() {
    check("dragon-box", 300);
}
