//! The figures of the paper's tables (`Report`) agree with the counters they are computed
//! from, and stay in their ranges, for both organisations with and without the shader.

mod common;

use common::*;
use rtsim_sgrt::{Engine, Organisation, Report, SgrtConfig};
use rtsim_trace::WorkloadKind;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

#[test]
fn report_figures_follow_from_the_counters() {
    let s = cornell(WorkloadKind::Diffuse, 16, 12, 4, 8);
    for org in [Organisation::Pptrv, Organisation::Sptrv] {
        for shader in [false, true] {
            let c = SgrtConfig {
                organisation: org,
                shader,
                ..SgrtConfig::default()
            };
            let what = format!("{org:?} shader {shader}");
            let mut r = run_frame(&s, &c, Engine::Fast);
            let st = &r.stats;
            assert!(st.complete, "{what}");
            let d = r.memory.report(st.cycles);
            let rep = Report::new(&c, st, Some(&d), true);
            let t = &st.total;

            // Throughput: rays over the frame's time at the 500 MHz T&I clock (SGRT §4).
            let seconds = st.cycles as f64 / 500e6;
            let rays: u64 = t.kinds.iter().map(|k| k.rays).sum();
            assert_eq!(rep.rays, rays, "{what}");
            assert!(close(rep.seconds, seconds), "{what}");
            assert!(
                close(rep.mrays_per_second, rays as f64 / seconds / 1e6),
                "{what}"
            );
            let per_kind: u64 = rep.kinds.values().map(|k| k.rays).sum();
            assert_eq!(per_kind, rays, "{what}");
            // T&I only: the diffuse rays alone; with the shader every ray, camera rays too.
            assert_eq!(rep.kinds.contains_key("primary"), shader, "{what}");
            assert!(rep.kinds["diffuse"].rays > 0, "{what}");
            assert!(
                close(rep.frames_per_second.unwrap(), 1.0 / seconds),
                "{what}"
            );

            // Steps: the totals over the traced rays; SPTRV counts three per pass.
            assert!(
                close(rep.trv_steps_per_ray, t.trv.steps as f64 / rays as f64),
                "{what}"
            );
            assert!(
                close(rep.ist_steps_per_ray, t.ist.steps as f64 / rays as f64),
                "{what}"
            );
            let k = &rep.kinds["diffuse"];
            match org {
                Organisation::Pptrv => {
                    assert!(close(k.trv_steps_per_ray, k.trv_passes_per_ray), "{what}")
                }
                Organisation::Sptrv => assert!(
                    close(k.trv_steps_per_ray, 3.0 * k.trv_passes_per_ray),
                    "{what}"
                ),
            }
            assert!(k.trv_active_steps_per_ray <= k.trv_steps_per_ray, "{what}");

            // Utilisations and occupancies in range.
            for u in [
                rep.trv_utilisation,
                rep.ist_utilisation,
                rep.srp_utilisation,
            ] {
                assert!((0.0..=1.0).contains(&u), "{what}: {u}");
            }
            assert!(
                rep.trv_utilisation > 0.0 && rep.ist_utilisation > 0.0,
                "{what}"
            );
            assert_eq!(rep.srp_utilisation > 0.0, shader, "{what}");
            for u in rep.issue_utilisation.values() {
                assert!((0.0..=1.0).contains(u), "{what}: {u}");
            }
            assert!(
                (0.0..=f64::from(c.trv.rau_entries)).contains(&rep.trv_rau_occupancy),
                "{what}"
            );
            assert!(
                (0.0..=f64::from(c.ist.rau_entries)).contains(&rep.ist_rau_occupancy),
                "{what}"
            );

            // Hit rates are the caches' read hits over reads.
            for (name, rate) in [
                ("trv-l1", rep.hit_rates.trv_l1),
                ("l2", rep.hit_rates.trv_l2),
                ("ist-l1", rep.hit_rates.ist_l1),
            ] {
                let cs = &st.caches.iter().find(|(n, _)| n == name).unwrap().1;
                assert!(cs.reads > 0, "{what}: {name}");
                assert!(
                    close(rate, cs.read_hits as f64 / cs.reads as f64),
                    "{what}: {name}"
                );
            }
            assert_eq!(rep.hit_rates.srp_dcache.is_nan(), !shader, "{what}");

            // DRAM: moved bytes over the frame's time, below LPDDR3-1600's 12.8 GB/s peak.
            let dr = rep.dram.as_ref().unwrap();
            assert!(close(dr.peak_gbps, 12.8), "{what}: {}", dr.peak_gbps);
            assert!(
                dr.bandwidth_gbps > 0.0 && dr.bandwidth_gbps <= dr.peak_gbps,
                "{what}"
            );
            assert!((0.0..=1.0).contains(&dr.row_hit_rate), "{what}");

            // Energy: the parts add up; area: Table 2's T&I unit and Table 6's chip.
            let e = &rep.energy;
            assert!(
                close(e.total_nj, e.ti_operations_nj + e.caches_nj + e.dram_nj),
                "{what}"
            );
            assert!(e.ti_operations_nj > 0.0 && e.caches_nj > 0.0 && e.dram_nj > 0.0);
            let ti = match org {
                Organisation::Pptrv => 3.32,
                Organisation::Sptrv => 3.28,
            };
            assert!((rep.area.ti_unit_mm2 - ti).abs() < 0.02, "{what}");
        }
    }
}
