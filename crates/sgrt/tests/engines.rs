//! The chip reproduces the functional tracer's image and counters, and the fast engine equals
//! the cycle-by-cycle reference.

mod common;

use common::*;
use rtsim_sgrt::{Engine, Organisation, SgrtConfig};
use rtsim_trace::WorkloadKind;

#[test]
fn images_and_counters_equal_the_functional_tracer() {
    for kind in [
        WorkloadKind::Primary,
        WorkloadKind::Ao,
        WorkloadKind::Diffuse,
        WorkloadKind::Specular,
        WorkloadKind::Path,
    ] {
        let s = cornell(kind, 24, 16, 4, 8);
        let (px, stats) = functional(&s);
        for org in [Organisation::Pptrv, Organisation::Sptrv] {
            for shader in [true, false] {
                let c = SgrtConfig {
                    organisation: org,
                    shader,
                    cores: 2,
                    ..SgrtConfig::default()
                };
                let r = run_frame(&s, &c, Engine::Fast);
                assert!(r.stats.complete);
                assert_eq!(
                    bits(&r.pixels),
                    bits(&px),
                    "{kind:?} {org:?} shader {shader}"
                );
                assert_eq!(r.frame, stats, "{kind:?} {org:?} shader {shader}");
            }
        }
    }
}

#[test]
fn fast_engine_equals_reference() {
    for (kind, org, shader) in [
        (WorkloadKind::Diffuse, Organisation::Pptrv, true),
        (WorkloadKind::Ao, Organisation::Sptrv, false),
        (WorkloadKind::Primary, Organisation::Sptrv, true),
        (WorkloadKind::Path, Organisation::Pptrv, false),
    ] {
        let s = cornell(kind, 16, 12, 4, 4);
        let c = SgrtConfig {
            organisation: org,
            shader,
            ..SgrtConfig::default()
        };
        let mut a = run_frame(&s, &c, Engine::Fast);
        let mut b = run_frame(&s, &c, Engine::Reference);
        assert_eq!(a.stats, b.stats, "{kind:?} {org:?}");
        assert_eq!(a.heat, b.heat);
        assert_eq!(bits(&a.pixels), bits(&b.pixels));
        let end = a.stats.cycles;
        assert_eq!(a.memory.report(end), b.memory.report(end));
    }
}
