//! The T&I unit's hardware as the paper counts it (Tables 1–2), the 65 nm operation latencies
//! the pipeline timings are derived from, area (Table 2) and the energy basis.
//!
//! The paper gives unit counts and areas but no latencies. Every default pipeline latency and
//! initiation interval in [`crate::config`] is computed here from the unit counts and the
//! operation latencies the STRaTA paper uses at the same 65 nm node (FP add and multiply 2
//! cycles, comparators 1 cycle, divide/reciprocal 16 cycles: `../shared/DESIGN.md` §3), so the
//! documented derivation (`docs/SGRT.md`) and the defaults cannot drift apart (a test checks).

use crate::config::{Organisation, SgrtConfig};
use serde::Serialize;

/// 65 nm operation latencies in cycles (STRaTA paper §3 via DESIGN.md §3; SimTRaX's defaults).
pub mod latency {
    /// FP add/subtract.
    pub const FADD: u32 = 2;
    /// FP multiply.
    pub const FMUL: u32 = 2;
    /// FP comparator (min, max, compare).
    pub const FCMP: u32 = 1;
    /// FP reciprocal (the divide unit's 16 cycles).
    pub const FRCP: u32 = 16;
}

/// Arithmetic units of one TRV: Tables 1–2 count 24 adders, 24 multipliers and 44 comparators
/// for four TRVs. (The text of §3.3 says 4 / 4 / 11; the tables' 6 / 6 / 11 is what one slab
/// test needs, so they are taken.)
pub const TRV_UNITS: Units = Units {
    fadd: 6,
    fmul: 6,
    fcmp: 11,
    frcp: 0,
};

/// Arithmetic units of the IST (§3.3, Table 1): Wald's test.
pub const IST_UNITS: Units = Units {
    fadd: 12,
    fmul: 10,
    fcmp: 5,
    frcp: 1,
};

/// Floating-point units of one pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Units {
    pub fadd: u32,
    pub fmul: u32,
    pub fcmp: u32,
    pub frcp: u32,
}

/// Operations of one slab test in the form the TRV's units implement: per axis two
/// subtractions and two multiplies, then comparators — per-axis min and max (6), the largest
/// entry and smallest exit distance (2 + 2), and entry ≤ exit (1): exactly 6 / 6 / 11, one box
/// per cycle. (The functional kernel also clamps to the ray's interval, two comparisons more,
/// `rtsim_trace::ops::BOX_TEST`; they are assumed folded into the last comparator level.)
pub const SLAB_TEST: Units = Units {
    fadd: 6,
    fmul: 6,
    fcmp: 11,
    frcp: 0,
};

/// Initiation interval of a pass that runs `ops` on `units`: the most-used class decides.
pub fn interval(ops: Units, units: Units) -> u32 {
    let c = |o: u32, u: u32| if o == 0 { 1 } else { o.div_ceil(u.max(1)) };
    c(ops.fadd, units.fadd)
        .max(c(ops.fmul, units.fmul))
        .max(c(ops.fcmp, units.fcmp))
        .max(c(ops.frcp, units.frcp))
}

/// TRV_AABB tests one child pair per pass (siblings are stored side by side, one 64-byte line):
/// two slab tests on the TRV's units.
pub fn aabb_interval() -> u32 {
    let pair = Units {
        fadd: 2 * SLAB_TEST.fadd,
        fmul: 2 * SLAB_TEST.fmul,
        fcmp: 2 * SLAB_TEST.fcmp,
        frcp: 0,
    };
    interval(pair, TRV_UNITS)
}

/// One slab test's critical path: subtract, multiply, per-axis min/max, the two levels of the
/// three-input max (and min), entry ≤ exit.
pub fn slab_latency() -> u32 {
    latency::FADD + latency::FMUL + 4 * latency::FCMP
}

/// TRV_AABB latency: the first box's slab test; the second box enters one cycle later (one box
/// per cycle) and decides the pass's end.
pub fn aabb_latency() -> u32 {
    slab_latency() + 1
}

/// TRV_PRE: the node record's count is compared with zero (leaf or inner), one cycle.
pub fn pre_latency() -> u32 {
    latency::FCMP
}

/// TRV_POST: the near/far comparison of the entry distances, then one short-stack register
/// file access (read for a pop, write for a push).
pub fn post_latency() -> u32 {
    latency::FCMP + 1
}

/// Wald's test (`rtsim_trace::kernels::triangle::wald_exit`), critical path:
/// denominator `d_k + n_u d_u + n_v d_v` (multiply, add, add), its reciprocal, `t = f · nd`
/// (multiply; the numerator `f` is ready earlier), the hit point `h_u = o_u + t d_u`
/// (multiply, add), the barycentric `u = h_u b_nu + h_v b_nv + b_d` (multiply, add, add),
/// `u + v` (add) and `u + v ≤ 1` (comparator).
pub fn ist_latency() -> u32 {
    let denominator = latency::FMUL + 2 * latency::FADD;
    let t = latency::FRCP + latency::FMUL;
    let hit_point = latency::FMUL + latency::FADD;
    let barycentric = latency::FMUL + 2 * latency::FADD;
    let sum = latency::FADD + latency::FCMP;
    denominator + t + hit_point + barycentric + sum
}

/// Wald's test in the units' form: 12 adds, 10 multiplies, 1 reciprocal, 5 comparators (§3.3):
/// one test per cycle on the IST. (The functional kernel's measured mix has 11 multiplies and
/// 6 comparisons, `rtsim_trace::ops::wald`; the paper's count is taken as the design point.)
pub fn ist_interval() -> u32 {
    interval(IST_UNITS, IST_UNITS)
}

// ---------------------------------------------------------------------------------------
// Area (Table 2, 65 nm)

/// Areas of Table 2 in mm².
pub mod area {
    pub const FADD: f64 = 0.003;
    pub const FMUL: f64 = 0.01;
    pub const FRCP: f64 = 0.11;
    pub const FCMP: f64 = 0.00072;
    pub const INT_ADD: f64 = 0.00066;
    /// Integer adders of a T&I unit (Table 2's count).
    pub const INT_ADDS: u32 = 20;
    /// 16 KB TRV L1.
    pub const TRV_L1_16K: f64 = 0.06;
    /// 128 KB L2 (and the 128 KB IST L1).
    pub const CACHE_128K: f64 = 0.64;
    /// Register files: 15 of 4 KB at 0.019 mm².
    pub const RF: f64 = 15.0 * 0.019;
    /// Control, stack and RAU logic: 23.3 % of the arithmetic (§4.1, after Mahesri et al.).
    pub const CONTROL_SHARE: f64 = 0.233;
    /// Wiring overhead: 30 % (§4.1).
    pub const WIRING_SHARE: f64 = 0.30;
    /// PPTRV's two 16-entry FIFOs per T&I unit: 3.32 − 3.28 mm² (§4.2).
    pub const PPTRV_FIFOS: f64 = 0.04;
    /// One SRP core (§3.4: 2.9 mm² at 65 nm).
    pub const SRP: f64 = 2.9;
}

/// Area estimate in mm² at 65 nm, following Table 2 for the configured unit and cache counts
/// (caches scaled linearly with capacity from Table 2's sizes: assumed).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Area {
    pub arithmetic_mm2: f64,
    pub control_mm2: f64,
    pub memories_mm2: f64,
    pub wiring_mm2: f64,
    /// One T&I unit (Table 2: 3.32 for PPTRV, §4.2: 3.28 for SPTRV).
    pub ti_unit_mm2: f64,
    /// One SRP.
    pub srp_mm2: f64,
    /// All cores: T&I units and SRPs (Table 6: 25 mm² for four).
    pub total_mm2: f64,
}

impl Area {
    pub fn of(c: &SgrtConfig) -> Area {
        let trvs = f64::from(c.trvs);
        let arithmetic = trvs
            * (f64::from(TRV_UNITS.fadd) * area::FADD
                + f64::from(TRV_UNITS.fmul) * area::FMUL
                + f64::from(TRV_UNITS.fcmp) * area::FCMP)
            + f64::from(IST_UNITS.fadd) * area::FADD
            + f64::from(IST_UNITS.fmul) * area::FMUL
            + f64::from(IST_UNITS.fcmp) * area::FCMP
            + f64::from(IST_UNITS.frcp) * area::FRCP
            + f64::from(area::INT_ADDS) * area::INT_ADD;
        let kb = |bytes: u64| bytes as f64 / 1024.0;
        let memories = trvs * area::TRV_L1_16K * kb(c.trv.l1.size_bytes) / 16.0
            + area::CACHE_128K * kb(c.l2.size_bytes) / 128.0
            + area::CACHE_128K * kb(c.ist.l1.size_bytes) / 128.0
            + area::RF;
        let control = area::CONTROL_SHARE * arithmetic;
        let wiring = area::WIRING_SHARE * (arithmetic + control + memories);
        let fifos = match c.organisation {
            Organisation::Pptrv => 0.0,
            Organisation::Sptrv => -area::PPTRV_FIFOS,
        };
        let ti = arithmetic + control + memories + wiring + fifos;
        let srp = if c.shader { area::SRP } else { 0.0 };
        Area {
            arithmetic_mm2: arithmetic,
            control_mm2: control,
            memories_mm2: memories,
            wiring_mm2: wiring,
            ti_unit_mm2: ti,
            srp_mm2: srp,
            total_mm2: f64::from(c.cores) * (ti + srp),
        }
    }
}

// ---------------------------------------------------------------------------------------
// Energy basis (the paper reports none)

/// Energies per event in nJ, for the parts of the chip where a basis exists: SimTRaX's 65 nm
/// per-operation energies (the node SGRT was estimated at) and its CACTI cache table
/// (DESIGN.md §3). The SRP has no basis and is not charged.
pub mod energy {
    pub const FADD_NJ: f64 = 0.0074;
    pub const FMUL_NJ: f64 = 0.0142;
    pub const FCMP_NJ: f64 = 0.000536;
    pub const FRCP_NJ: f64 = 0.1563;
    /// CACTI points of SimTRaX's table: 32 KB → 0.165 nJ, 128 KB → 0.364 nJ per access.
    const SMALL: (f64, f64) = (32.0, 0.165);
    const LARGE: (f64, f64) = (128.0, 0.364);

    /// Energy per access of a cache of `kb` KB: a power law through SimTRaX's 32 KB and 128 KB
    /// points (assumed: interpolation below and extrapolation outside them; banks ignored).
    pub fn cache_access_nj(kb: f64) -> f64 {
        let a = (LARGE.1 / SMALL.1).ln() / (LARGE.0 / SMALL.0).ln();
        SMALL.1 * (kb / SMALL.0).powf(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::SgrtConfig;

    #[test]
    fn pipeline_defaults_are_the_derived_values() {
        let c = SgrtConfig::default();
        assert_eq!(slab_latency(), 8, "STRaTA's box pipeline: latency 8");
        assert_eq!(c.trv.aabb_latency, aabb_latency());
        assert_eq!(c.trv.aabb_interval, aabb_interval());
        assert_eq!(aabb_interval(), 2);
        assert_eq!(c.trv.pre_latency, pre_latency());
        assert_eq!(c.trv.post_latency, post_latency());
        assert_eq!(c.ist.latency, ist_latency());
        assert_eq!(ist_latency(), 37);
        assert_eq!(c.ist.interval, ist_interval());
        assert_eq!(ist_interval(), 1);
        // The text's 4 adders and 4 multipliers would need two cycles per box.
        let text = Units {
            fadd: 4,
            fmul: 4,
            fcmp: 11,
            frcp: 0,
        };
        assert_eq!(interval(SLAB_TEST, text), 2);
    }

    #[test]
    fn area_follows_table_2() {
        let c = SgrtConfig::default();
        let a = Area::of(&c);
        // Table 2: 3.32 mm² per T&I unit (rounded entries); Table 6: 25 mm² for four cores.
        assert!((a.ti_unit_mm2 - 3.32).abs() < 0.02, "{a:?}");
        assert!((a.total_mm2 - 25.0).abs() < 0.2, "{a:?}");
        let sp = Area::of(&SgrtConfig {
            organisation: Organisation::Sptrv,
            ..c
        });
        assert!((sp.ti_unit_mm2 - 3.28).abs() < 0.02, "{sp:?}");
    }

    #[test]
    fn cache_energy_passes_through_its_points() {
        assert!((energy::cache_access_nj(32.0) - 0.165).abs() < 1e-12);
        assert!((energy::cache_access_nj(128.0) - 0.364).abs() < 1e-12);
        assert!(energy::cache_access_nj(16.0) < 0.165);
    }
}
