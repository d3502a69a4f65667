//! The fast engine against the reference, cycle by cycle: between two of the fast engine's
//! events the reference (which visits every unit every cycle) must change nothing, and after
//! each event both chips must be in the same state. This pins a missed wake-up to its cycle.

mod common;

use common::*;
use rtsim_sgrt::{Input, Organisation, Sgrt, SgrtConfig};
use rtsim_trace::{Integrator, WorkloadKind};

fn lockstep(s: &Setup, c: &SgrtConfig) {
    let integ = Integrator::new(&s.scene, &s.tracer, s.params.clone());
    let pixels: Vec<u32> = (0..s.params.width * s.params.height).collect();
    let timed = Input::timed_kinds(s.params.kind, c.shader);
    let make = || {
        let input = Input::Frame {
            integ: &integ,
            pixels: pixels.clone(),
            timed,
        };
        Sgrt::new(c, &s.tracer, &s.image, input, lpddr3(c), 1).unwrap()
    };
    let (mut fast, mut reference) = (make(), make());
    fast.tick(0, false).unwrap();
    reference.tick(0, true).unwrap();
    let diff = |a: &str, b: &str| {
        a.lines()
            .zip(b.lines())
            .filter(|(x, y)| x != y)
            .map(|(x, y)| format!("fast: {x}\nref:  {y}"))
            .collect::<Vec<_>>()
            .join("\n")
    };
    let mut t = 1;
    while !fast.finished() {
        let next = fast.next_event().expect("work left, so an event");
        while t < next {
            reference.tick(t, true).unwrap();
            let (f, r) = (fast.fingerprint(t), reference.fingerprint(t));
            assert!(
                r == f,
                "{c:?}: the reference changed at cycle {t}, before the fast engine's next event \
                 {next}:\n{}",
                diff(&f, &r)
            );
            t += 1;
        }
        fast.tick(next, false).unwrap();
        reference.tick(next, true).unwrap();
        t = next + 1;
        let (f, r) = (fast.fingerprint(next), reference.fingerprint(next));
        assert!(
            f == r,
            "{c:?}: differ after cycle {next}:\n{}",
            diff(&f, &r)
        );
    }
    assert!(reference.finished());
}

#[test]
fn fast_equals_reference_cycle_by_cycle() {
    for (kind, org, shader, cores) in [
        (WorkloadKind::Primary, Organisation::Sptrv, true, 4),
        (WorkloadKind::Diffuse, Organisation::Pptrv, true, 2),
        (WorkloadKind::Ao, Organisation::Pptrv, false, 1),
        (WorkloadKind::Specular, Organisation::Sptrv, false, 2),
    ] {
        let s = cornell(kind, 12, 8, 4, 3);
        let c = SgrtConfig {
            organisation: org,
            shader,
            cores,
            ..SgrtConfig::default()
        };
        lockstep(&s, &c);
    }
}
