//! The chip renders exactly the functional image with exactly the functional counters.

mod support;

use rtsim_trace::WorkloadKind;
use rtsim_trax::{Engine, Output};
use support::*;

/// Path tracing `scene` at `width`×`height` on 1 TM × 4 TPs: the functional image and ray
/// counters, a complete frame. `None` where the shared scenes are absent.
fn on_one_tm_of_four_tps(scene: &str, width: u32, height: u32) -> Option<Output> {
    let w = world(scene, width, height)?;
    let p = params(&w, WorkloadKind::Path, 1);
    let pixels = all_pixels(&w);
    let (image, rays) = functional(&w, &p, &pixels);
    let out = simulate(&w, &p, &chip(1, 4), Engine::Fast, &pixels);
    assert_same_image(&out.pixels, &image);
    assert_eq!(out.rays, rays);
    assert!(out.report.complete);
    Some(out)
}

#[test]
fn cornell_on_one_tm_of_four_tps_is_the_functional_frame() {
    let out = on_one_tm_of_four_tps("cornell", 16, 16).expect("cornell is built in");
    println!("{}", out.report.summary().join("\n"));
}

#[test]
fn sibenik_at_a_small_resolution_is_the_functional_frame() {
    on_one_tm_of_four_tps("sibenik", 12, 12);
}
