//! The chip renders exactly the functional image with exactly the functional counters.

mod support;

use rtsim_trace::WorkloadKind;
use rtsim_trax::Engine;
use support::*;

#[test]
fn cornell_on_one_tm_of_four_tps_is_the_functional_frame() {
    let w = world("cornell", 16, 16).unwrap();
    let p = params(&w, WorkloadKind::Path, 1);
    let pixels = all_pixels(&w);
    let (image, rays) = functional(&w, &p, &pixels);
    let out = simulate(&w, &p, &chip(1, 4), Engine::Fast, &pixels);
    assert_same_image(&out.pixels, &image);
    assert_eq!(out.rays, rays);
    assert!(out.report.complete);
    println!("{}", out.report.summary().join("\n"));
}

#[test]
fn sibenik_at_a_small_resolution_is_the_functional_frame() {
    // Skipped where the shared scenes are absent (`world` returns None).
    let Some(w) = world("sibenik", 12, 12) else {
        return;
    };
    let p = params(&w, WorkloadKind::Path, 1);
    let pixels = all_pixels(&w);
    let (image, rays) = functional(&w, &p, &pixels);
    let out = simulate(&w, &p, &chip(1, 4), Engine::Fast, &pixels);
    assert_same_image(&out.pixels, &image);
    assert_eq!(out.rays, rays);
    assert!(out.report.complete);
}
