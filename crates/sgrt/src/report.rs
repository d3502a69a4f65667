//! The figures of the paper's tables, computed from a run's counters: throughput (Mrays/s) per
//! ray kind, TRV and IST utilisation, steps per ray, cache hit rates, RAU occupancy, DRAM
//! bandwidth and row-buffer hit rate, frames per second, area (Table 2) and energy where a
//! basis exists.
//!
//! Definitions (`docs/SGRT.md`):
//!
//! - *utilisation* of a unit: the fraction of cycles in which at least one ray is inside its
//!   pipelines (SGRT §4.2: utilisation falls when rays wait for memory); *issue* utilisation:
//!   the fraction of a pipeline's issue cycles used;
//! - *steps per ray*: TRV steps (passes through a sub-pipeline, SPTRV's bypassed stages
//!   included) and IST steps (one triangle each) over the rays the T&I unit traced;
//! - *Mrays/s*: rays the T&I unit traced over the frame's time at the T&I clock; per kind,
//!   that kind's rays over the same time (in the T&I-only mode only the measured kind is
//!   traced, which is the tables' figure);
//! - *bandwidth*: bytes the DRAM moved over the frame's time.

use crate::chip::SgrtStats;
use crate::config::SgrtConfig;
use crate::stats::{CoreStats, PipeStats};
use crate::units::{Area, IST_UNITS, energy};
use rtsim_cache::CacheStats;
use rtsim_core::stats::ratio;
use serde::Serialize;
use std::collections::BTreeMap;

/// Names of the ray kinds, in `RayKind` order.
pub const KINDS: [&str; 6] = ["primary", "shadow", "bounce", "ao", "diffuse", "specular"];

/// One ray kind's figures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KindReport {
    pub rays: u64,
    pub hits: u64,
    pub mrays_per_second: f64,
    pub trv_steps_per_ray: f64,
    /// Steps that did work (PPTRV: all of them).
    pub trv_active_steps_per_ray: f64,
    /// Passes through the TRV's pipelines (SPTRV: its deep pipeline).
    pub trv_passes_per_ray: f64,
    pub ist_steps_per_ray: f64,
    /// Mean cycles from dispatch to leaving the T&I unit.
    pub latency_cycles: f64,
}

/// Hit rates of the caches (reads).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HitRates {
    pub trv_l1: f64,
    pub trv_l2: f64,
    pub ist_l1: f64,
    /// The SRP's data cache (NaN without the shader).
    pub srp_dcache: f64,
}

/// The DRAM's part.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DramFigures {
    /// Bytes read and written over the frame's time, GB/s (10^9 B).
    pub bandwidth_gbps: f64,
    pub peak_gbps: f64,
    pub row_hit_rate: f64,
    /// Mean read latency from arrival at the controller, T&I cycles.
    pub read_latency_cycles: f64,
    pub energy_nj: f64,
}

/// Energy where a basis exists (the paper reports none): the T&I unit's floating-point
/// operations and cache accesses at SimTRaX's 65 nm energies, and the DRAM's IDD model. The
/// SRP and the register files have no basis and are not charged.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Energy {
    pub ti_operations_nj: f64,
    pub caches_nj: f64,
    pub dram_nj: f64,
    pub total_nj: f64,
    pub basis: &'static str,
}

/// Everything a run reports beyond its raw counters.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    pub organisation: &'static str,
    pub cores: u32,
    pub shader: bool,
    /// T&I cycles of the frame and the time they take.
    pub cycles: u64,
    pub seconds: f64,
    pub complete: bool,
    /// Rays the T&I units traced, and per second.
    pub rays: u64,
    pub mrays_per_second: f64,
    pub kinds: BTreeMap<String, KindReport>,
    pub trv_steps_per_ray: f64,
    pub ist_steps_per_ray: f64,
    /// Fraction of cycles a TRV (mean over all) / the IST has a ray in its pipelines.
    pub trv_utilisation: f64,
    pub ist_utilisation: f64,
    /// Issue utilisation of each pipeline kind (mean over units).
    pub issue_utilisation: BTreeMap<String, f64>,
    pub hit_rates: HitRates,
    /// Mean rays held by a TRV's RAU / the IST's RAU.
    pub trv_rau_occupancy: f64,
    pub ist_rau_occupancy: f64,
    /// Fraction of SRP cycles spent computing (mean over cores).
    pub srp_utilisation: f64,
    pub dram: Option<DramFigures>,
    /// Frames per second at the workload's resolution (a complete, whole frame only).
    pub frames_per_second: Option<f64>,
    pub area: Area,
    pub energy: Energy,
}

fn hit_rate(c: Option<&CacheStats>) -> f64 {
    c.map_or(f64::NAN, |c| ratio(c.read_hits as f64, c.reads as f64))
}

fn issue(p: &PipeStats, cycles: f64) -> f64 {
    ratio(p.issue_cycles as f64, cycles)
}

impl Report {
    /// The figures of `s` on the chip of `c`; `dram` is the DRAM's report when the memory is
    /// the DRAM model; `whole_frame` says the run covered the whole image.
    pub fn new(
        c: &SgrtConfig,
        s: &SgrtStats,
        dram: Option<&rtsim_dram::Report>,
        whole_frame: bool,
    ) -> Report {
        let t: &CoreStats = &s.total;
        let cycles = s.cycles.max(1) as f64;
        let seconds = cycles / (f64::from(c.ti_clock_mhz) * 1e6);
        let rays: u64 = t.kinds.iter().map(|k| k.rays).sum();
        let per_ray = |x: u64| ratio(x as f64, rays as f64);
        let kinds = t
            .kinds
            .iter()
            .zip(KINDS)
            .filter(|(k, _)| k.rays > 0)
            .map(|(k, name)| {
                let n = k.rays as f64;
                (
                    name.to_string(),
                    KindReport {
                        rays: k.rays,
                        hits: k.hits,
                        mrays_per_second: n / seconds / 1e6,
                        trv_steps_per_ray: k.trv_steps as f64 / n,
                        trv_active_steps_per_ray: k.trv_active_steps as f64 / n,
                        trv_passes_per_ray: k.trv_passes as f64 / n,
                        ist_steps_per_ray: k.ist_steps as f64 / n,
                        latency_cycles: k.latency_cycles as f64 / n,
                    },
                )
            })
            .collect();
        let trvs = f64::from(c.trvs * c.cores);
        let cores = f64::from(c.cores);
        let unit_cycles = cycles * trvs;
        let cache = |name: &str| s.caches.iter().find(|(n, _)| n == name).map(|(_, c)| c);
        let mut issue_utilisation = BTreeMap::new();
        for (name, p) in [
            ("trv_pre", &t.trv.pre),
            ("trv_aabb", &t.trv.aabb),
            ("trv_post", &t.trv.post),
            ("trv_deep", &t.trv.deep),
        ] {
            if p.entries > 0 {
                issue_utilisation.insert(name.to_string(), issue(p, unit_cycles));
            }
        }
        issue_utilisation.insert("ist".into(), issue(&t.ist.pipe, cycles * cores));
        let srp_cycles = seconds * f64::from(c.srp_clock_mhz) * 1e6 * cores;
        let dram = dram.map(|d| {
            let bytes =
                (d.stats.column_reads + d.stats.column_writes) * u64::from(d.setup.line_bytes);
            DramFigures {
                bandwidth_gbps: bytes as f64 / seconds / 1e9,
                peak_gbps: d.bandwidth.peak_gbps,
                row_hit_rate: d.row_hit_rate.all,
                read_latency_cycles: d.read_latency.requester_cycles.mean,
                energy_nj: d.energy.total_j * 1e9,
            }
        });
        let energy = Self::energy(c, t, s, dram.as_ref().map_or(0.0, |d| d.energy_nj));
        Report {
            organisation: c.organisation.name(),
            cores: c.cores,
            shader: c.shader,
            cycles: s.cycles,
            seconds,
            complete: s.complete,
            rays,
            mrays_per_second: rays as f64 / seconds / 1e6,
            kinds,
            trv_steps_per_ray: per_ray(t.trv.steps),
            ist_steps_per_ray: per_ray(t.ist.steps),
            trv_utilisation: ratio(t.trv.busy_cycles as f64, unit_cycles),
            ist_utilisation: ratio(t.ist.pipe.busy_cycles as f64, cycles * cores),
            issue_utilisation,
            hit_rates: HitRates {
                trv_l1: hit_rate(cache("trv-l1")),
                trv_l2: hit_rate(cache("l2")),
                ist_l1: hit_rate(cache("ist-l1")),
                srp_dcache: hit_rate(cache("srp-dcache")),
            },
            trv_rau_occupancy: ratio(t.trv.rau.occupancy_sum as f64, unit_cycles),
            ist_rau_occupancy: ratio(t.ist.rau.occupancy_sum as f64, cycles * cores),
            srp_utilisation: if c.shader {
                ratio(t.srp.compute_cycles as f64, srp_cycles)
            } else {
                0.0
            },
            dram,
            frames_per_second: (s.complete && whole_frame).then(|| 1.0 / seconds),
            area: Area::of(c),
            energy,
        }
    }

    fn energy(c: &SgrtConfig, t: &CoreStats, s: &SgrtStats, dram_nj: f64) -> Energy {
        // Box tests: 6 adds, 6 multiplies, 11 comparators each (the slab form of the TRV's
        // units); TRV_POST: one comparison; TRV_PRE: an integer test (not charged).
        let boxes = t.trv.boxes as f64;
        let trv = boxes * (6.0 * energy::FADD_NJ + 6.0 * energy::FMUL_NJ + 11.0 * energy::FCMP_NJ)
            + t.trv.post_ops as f64 * energy::FCMP_NJ;
        let u = IST_UNITS;
        let ist = t.ist.steps as f64
            * (f64::from(u.fadd) * energy::FADD_NJ
                + f64::from(u.fmul) * energy::FMUL_NJ
                + f64::from(u.fcmp) * energy::FCMP_NJ
                + f64::from(u.frcp) * energy::FRCP_NJ);
        let kb = |bytes: u64| bytes as f64 / 1024.0;
        let size = |name: &str| match name {
            "trv-l1" => kb(c.trv.l1.size_bytes),
            "ist-l1" => kb(c.ist.l1.size_bytes),
            "l2" => kb(c.l2.size_bytes),
            _ => kb(c.srp.dcache.size_bytes),
        };
        let caches: f64 = s
            .caches
            .iter()
            .map(|(n, st)| (st.reads + st.writes) as f64 * energy::cache_access_nj(size(n)))
            .sum();
        Energy {
            ti_operations_nj: trv + ist,
            caches_nj: caches,
            dram_nj,
            total_nj: trv + ist + caches + dram_nj,
            basis: "T&I FP operations at SimTRaX's 65 nm per-op energies, cache accesses from \
                    SimTRaX's CACTI points (power law in size: assumed), DRAM from the IDD \
                    model; the SRP and register files are not charged (no basis)",
        }
    }

    /// The terminal summary.
    pub fn summary(&self) -> Vec<String> {
        let mut v = vec![format!(
            "arch             sgrt ({}, {} core{}, {})",
            self.organisation,
            self.cores,
            if self.cores == 1 { "" } else { "s" },
            if self.shader { "T&I + SRP" } else { "T&I only" }
        )];
        v.push(format!(
            "frame            {} T&I cycles ({:.3} ms){}",
            self.cycles,
            self.seconds * 1e3,
            if self.complete {
                String::new()
            } else {
                " — stopped at the cycle limit".into()
            }
        ));
        if let Some(f) = self.frames_per_second {
            v.push(format!("frames/s         {f:.2}"));
        }
        v.push(format!(
            "rays             {} ({:.1} Mrays/s)",
            self.rays, self.mrays_per_second
        ));
        for (k, r) in &self.kinds {
            v.push(format!(
                "  {k:<14} {:>10} rays {:>8.1} Mrays/s  TRV steps {:>6.2}  IST steps {:>5.2}",
                r.rays, r.mrays_per_second, r.trv_steps_per_ray, r.ist_steps_per_ray
            ));
        }
        v.push(format!(
            "utilisation      TRV {:.1} %  IST {:.1} %{}",
            100.0 * self.trv_utilisation,
            100.0 * self.ist_utilisation,
            if self.shader {
                format!("  SRP {:.1} %", 100.0 * self.srp_utilisation)
            } else {
                String::new()
            }
        ));
        let h = &self.hit_rates;
        v.push(format!(
            "hit rates        TRV L1 {:.1} %  TRV L2 {:.1} %  IST L1 {:.1} %",
            100.0 * h.trv_l1,
            100.0 * h.trv_l2,
            100.0 * h.ist_l1
        ));
        v.push(format!(
            "RAU occupancy    TRV {:.2}  IST {:.2} rays",
            self.trv_rau_occupancy, self.ist_rau_occupancy
        ));
        if let Some(d) = &self.dram {
            v.push(format!(
                "DRAM             {:.2} GB/s of {:.1}, row-buffer hits {:.1} %, read latency {:.1} cycles",
                d.bandwidth_gbps,
                d.peak_gbps,
                100.0 * d.row_hit_rate,
                d.read_latency_cycles
            ));
        }
        v.push(format!(
            "area             {:.2} mm² per T&I unit, {:.1} mm² in all",
            self.area.ti_unit_mm2, self.area.total_mm2
        ));
        v.push(format!(
            "energy           {:.3} mJ (T&I ops {:.3}, caches {:.3}, DRAM {:.3}; no SRP)",
            self.energy.total_nj * 1e-6,
            self.energy.ti_operations_nj * 1e-6,
            self.energy.caches_nj * 1e-6,
            self.energy.dram_nj * 1e-6
        ));
        v
    }
}
