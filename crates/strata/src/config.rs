//! [`StrataConfig`]: the STRaTA additions to the TRaX chip (`arch.strata.*`), each with its
//! default, unit and source, and its validation.
//!
//! Sources: the STRaTA paper (Kopta et al., "Memory Considerations for Low Energy Ray
//! Tracing", CGF 2015) §3.1 and §5.1–5.2 and Table 2. What the paper leaves open is marked
//! "assumed" with the reason. The treelet size is not repeated here: it is
//! `memory.treelet_bytes` (default 16 KB, STRaTA §3.1), which the memory image already uses to
//! cut the BVH; [`StrataConfig::validate_run`] checks it against the L1.

use rtsim_bvh::{Layout, MemoryLayoutConfig};
use rtsim_config::{ConfigError, Validate, check_range};
use rtsim_trace::{TraceConfig, Traversal};
use serde::{Deserialize, Serialize};

/// The key prefix of this section in the run configuration.
pub const PREFIX: &str = "arch.strata";

/// Default stream memory: 4 MB, the baseline's L2 size ("the size of the L2 cache (baseline)
/// and stream memory (STRaTA) are the same", §5.2).
pub const STREAM_BYTES_DEFAULT: u64 = 4 << 20;

/// Default L2 beside the stream memory: 512 KB ("we include a small 512 KB L2 cache in
/// addition to the stream memory", §5.1).
pub const L2_BYTES_DEFAULT: u64 = 512 << 10;

/// Smallest stream memory accepted: 1 KB (room for the head table of a tiny scene and a few
/// rays; tests use it to force the one-for-one replacement with few rays in flight).
pub const STREAM_BYTES_MIN: u64 = 1 << 10;

/// Largest stream memory accepted: 1 GB (Figures 5–6 sweep 512 KB–16 MB; larger is allowed
/// for studies, but slot indices must stay 32-bit).
pub const STREAM_BYTES_MAX: u64 = 1 << 30;

/// Which treelet buffer a TM takes when it needs one (a policy by name, STYLE §4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Policy {
    /// The buffer holding the most unclaimed rays: its count minus one round's worth
    /// (`tps_per_tm` rays) for every TM already on it; ties to the lowest treelet id. Issue
    /// 10 §2's default: the longest stay on one treelet, so the most L1 hits per treelet
    /// load, without piling every TM onto the one fullest buffer.
    #[default]
    MostRays,
    /// The next non-empty buffer after the one last taken, in treelet-id order, wrapping.
    RoundRobin,
    /// Among the buffers `most-rays` may take, the one with the most rays per TM once the
    /// picking TM joins, `count / (holders + 1)`, ties to the lowest id: a buffer's holders
    /// discount it in proportion, so TMs leave a crowded root buffer for smaller ones sooner
    /// (assumed: an alternative for the crowding after a large fill, `docs/VALIDATION.md`).
    RaysPerTm,
}

/// When a TM leaves its treelet (issue 10 §2: "buffer empty, or a threshold").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Switch {
    /// As soon as a pop finds its buffer empty (default).
    #[default]
    Empty,
    /// When the buffer is empty and none of the TM's TPs still holds a ray (rays it is
    /// running may come back to the treelet); until then its idle TPs wait and poll.
    Drained,
}

/// How the TPs fill the stream memory with the first paths before rendering (STRaTA §3.1:
/// "The programmer fills the ray buffers with some initial rays before rendering begins, using
/// provided application programming interface (API) functions to determine maximum stream
/// memory capacity"; the paper does not say how the threads share the fill).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fill {
    /// Each TP takes path slots from the global atomic counter, one grant per slot, as the
    /// baseline takes pixels (default: the TRaX programming model's one shared counter).
    #[default]
    Counter,
    /// TP `i` of `T` fills slots `i`, `i + T`, `i + 2T`, … without the counter (the slot count
    /// is known from the API, so the split needs no communication); the pixels after the fill
    /// still come from the counter.
    Static,
}

impl Policy {
    pub fn name(self) -> &'static str {
        match self {
            Policy::MostRays => "most-rays",
            Policy::RoundRobin => "round-robin",
            Policy::RaysPerTm => "rays-per-tm",
        }
    }
}

/// The ray stream memory: a programmer-managed SRAM beside the L2 holding one LIFO ray buffer
/// per treelet (`docs/STRATA.md` "Ray stream memory").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StreamConfig {
    /// Capacity in bytes, records, links and head table together, a multiple of 64 in
    /// 1024..=2^30. Default 4 MB (STRaTA §5.2: the baseline's L2 size; Figures 5–6 sweep
    /// 512 KB–16 MB). More rays in flight, longer stays per treelet, dearer accesses.
    pub bytes: u64,
    /// Banks, a power of two in 1..=256; slot `s` lives in bank `s mod banks`. Default 16
    /// (assumed: the banking of the 4 MB L2 it replaces, `CacheLevel::trax_l2`).
    pub banks: u32,
    /// Accesses (one push or pop of a 48 B ray) each bank serves per cycle, 1..=8. Default 1
    /// (assumed: single-ported SRAM banks, like the L2's).
    pub ports_per_bank: u32,
    /// Cycles from a pop's issue to its ray being in the TP's registers, 1..=1000. Default 3
    /// (assumed: the L2 hit latency, SimTRaX, for an SRAM of the same size and banking).
    pub latency: u32,
    /// nJ per access (one push or one pop). Unset: STRaTA Table 2 by `bytes` (512 KB 0.524 …
    /// 4 MB 0.901 … 16 MB 1.61 nJ), interpolated as for the L2 — the paper assumes the head
    /// lookup and push/pop circuitry cost what the L2's tag and bank circuitry cost (§3.1).
    pub energy_nj: Option<f64>,
}

impl Default for StreamConfig {
    fn default() -> Self {
        StreamConfig {
            bytes: STREAM_BYTES_DEFAULT,
            banks: 16,
            ports_per_bank: 1,
            latency: 3,
            energy_nj: None,
        }
    }
}

impl StreamConfig {
    /// nJ per push or pop.
    pub fn access_nj(&self) -> f64 {
        self.energy_nj.unwrap_or_else(|| {
            rtsim_trax::energy::interpolate(&rtsim_trax::energy::L2_TABLE, self.bytes)
        })
    }
}

/// The STRaTA additions (`arch.strata`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StrataConfig {
    /// Treelet streaming: rays wait in per-treelet buffers of the stream memory and TMs work
    /// one treelet at a time (STRaTA §3.1). Default true. Off, the chip is the baseline:
    /// no stream memory and the whole `arch.trax.l2` (the paper measures each feature alone).
    pub streaming: bool,
    /// The ray stream memory.
    pub stream: StreamConfig,
    /// Bytes of the L2 beside the stream memory; replaces `arch.trax.l2.size_bytes` when
    /// streaming is on. Default 512 KB (STRaTA §5.1).
    pub l2_bytes: u64,
    /// How a TM picks a treelet buffer: `most-rays` (default, issue 10 §2), `round-robin` or
    /// `rays-per-tm`.
    pub policy: Policy,
    /// Most TMs that may drain one buffer at once, 0..=4096; 0 = no limit. Default 0
    /// (assumed: the paper says nothing of sharing, but every ray starts in the root treelet
    /// and most return to it, so one TM per buffer serialises the chip on the root: on
    /// Sibenik at 320 × 320 the functional flow needs 23× more rounds with 1 than with no
    /// limit, `docs/STRATA.md`). Each TM on a buffer loads the treelet into its own L1.
    pub tms_per_buffer: u32,
    /// When a TM leaves its treelet: `empty` (default: a pop finds the buffer empty) or
    /// `drained` (also none of its TPs holds a ray). Assumed: the paper does not say.
    pub switch: Switch,
    /// Fused box and triangle pipelines (STRaTA §3.3). Default true. Needs streaming: without
    /// treelets a TM would reconfigure for every ray (§5.3: "reconfiguring the pipelines for
    /// individual rays would add significant overhead").
    pub fused: bool,
    /// Triangle pipeline instances per TM, 1..=2. Default 2 (`DESIGN.md` §3: the paper's
    /// "issue width of two" read as two instances, 4 mul + 2 add each).
    pub triangle_pipelines: u32,
    /// Cycles a TM needs to reconfigure its units between the box and the triangle
    /// pipelines, 0..=1000. Default 1 (assumed: the paper gives none; the switch rewrites the
    /// multiplexers' configuration register once the TM has drained).
    pub reconfigure_cycles: u32,
    /// Cycles between a TP's attempts to pop when no buffer it may take holds a ray,
    /// 1..=1024. Default 16 (assumed: the paper's simulator has no such wait; a TP polling
    /// the head table every cycle would only cost simulation time).
    pub poll_cycles: u32,
    /// Bytes of a path's state record (pixel, sample, depth, throughput, radiance, pending
    /// light, random state) kept in the stream memory beside the ray buffers, one per ray slot
    /// (a path has one ray at a time), 32..=256, a multiple of 4. Default 64 (assumed: our
    /// path tracer's state in one line; `docs/STRATA.md` "Path state").
    pub path_bytes: u32,
    /// How the TPs fill the stream memory before rendering: `counter` (default: one atomic
    /// grant per path slot) or `static` (each TP takes every `T`-th slot, no counter).
    /// Assumed: the paper does not say; a large stream memory's fill waits on the counter's
    /// one grant per cycle (`docs/STRATA.md` "The fill").
    pub fill: Fill,
}

impl Default for StrataConfig {
    fn default() -> Self {
        StrataConfig {
            streaming: true,
            stream: StreamConfig::default(),
            l2_bytes: L2_BYTES_DEFAULT,
            policy: Policy::MostRays,
            tms_per_buffer: 0,
            switch: Switch::Empty,
            fused: true,
            triangle_pipelines: 2,
            reconfigure_cycles: 1,
            poll_cycles: 16,
            path_bytes: 64,
            fill: Fill::Counter,
        }
    }
}

fn key(k: &str) -> String {
    format!("{PREFIX}.{k}")
}

impl Validate for StrataConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        let s = &self.stream;
        if !(STREAM_BYTES_MIN..=STREAM_BYTES_MAX).contains(&s.bytes) || s.bytes % 64 != 0 {
            return Err(ConfigError::range(
                &key("stream.bytes"),
                s.bytes,
                format!("a multiple of 64 in {STREAM_BYTES_MIN}..={STREAM_BYTES_MAX}"),
            ));
        }
        if !(1..=256).contains(&s.banks) || !s.banks.is_power_of_two() {
            return Err(ConfigError::range(
                &key("stream.banks"),
                s.banks,
                "a power of two in 1..=256",
            ));
        }
        check_range(&key("stream.ports_per_bank"), s.ports_per_bank, 1, 8)?;
        check_range(&key("stream.latency"), s.latency, 1, 1000)?;
        if let Some(e) = s.energy_nj
            && !(e.is_finite() && e >= 0.0)
        {
            return Err(ConfigError::range(
                &key("stream.energy_nj"),
                e,
                "a finite value ≥ 0 (nJ)",
            ));
        }
        // The L2 model takes power-of-two sizes of at least one line per bank; the cache
        // crate checks the rest when the chip is built.
        if !(64..=(1u64 << 32)).contains(&self.l2_bytes) || !self.l2_bytes.is_power_of_two() {
            return Err(ConfigError::range(
                &key("l2_bytes"),
                self.l2_bytes,
                "a power of two in 64..=2^32",
            ));
        }
        check_range(&key("tms_per_buffer"), self.tms_per_buffer, 0, 4096)?;
        check_range(&key("triangle_pipelines"), self.triangle_pipelines, 1, 2)?;
        check_range(&key("reconfigure_cycles"), self.reconfigure_cycles, 0, 1000)?;
        check_range(&key("poll_cycles"), self.poll_cycles, 1, 1024)?;
        if !(32..=256).contains(&self.path_bytes) || self.path_bytes % 4 != 0 {
            return Err(ConfigError::range(
                &key("path_bytes"),
                self.path_bytes,
                "a multiple of 4 in 32..=256",
            ));
        }
        if self.fused && !self.streaming {
            return Err(ConfigError::key(
                &key("fused"),
                "the fused pipelines need treelet streaming (a TM reconfigures per treelet,                  not per ray; STRaTA §5.3): set arch.strata.streaming = true or                  arch.strata.fused = false",
            ));
        }
        Ok(())
    }
}

impl StrataConfig {
    /// The TRaX chip with STRaTA's changes: with streaming, the L2 is `l2_bytes` (the rest of
    /// the L2 became the stream memory, §5.1).
    pub fn chip(&self, trax: &rtsim_trax::TraxConfig) -> rtsim_trax::TraxConfig {
        let mut c = trax.clone();
        if self.streaming {
            c.l2.size_bytes = self.l2_bytes;
        }
        c
    }

    /// Checks against the rest of the run: streaming needs the `bit-stack` traversal (its ray
    /// state fits the 48-byte record; STRaTA §3.2), the treelet layout with parent pointers,
    /// and treelets no larger than the L1 (§3.1: "we assign treelets to be exactly the size of
    /// an L1 cache").
    pub fn validate_run(
        &self,
        trace: &TraceConfig,
        memory: &MemoryLayoutConfig,
        l1_bytes: u64,
    ) -> Result<(), ConfigError> {
        self.validate()?;
        if !self.streaming {
            return Ok(());
        }
        if trace.traversal != Traversal::BitStack {
            return Err(ConfigError::key(
                "trace.traversal",
                format!(
                    "= {}: STRaTA's streamed rays carry only a 4-byte bit stack (STRaTA §3.2); \
                     set trace.traversal = \"bit-stack\" or {} = false",
                    trace.traversal.name(),
                    key("streaming")
                ),
            ));
        }
        if memory.layout != Layout::Treelets {
            return Err(ConfigError::key(
                "memory.layout",
                format!(
                    "treelet streaming needs the treelet layout (STRaTA §3.1): set \
                     memory.layout = \"treelets\" or {} = false",
                    key("streaming")
                ),
            ));
        }
        if !memory.parent_pointers {
            return Err(ConfigError::key(
                "memory.parent_pointers",
                "the bit-stack traversal walks up through parent pointers: set \
                 memory.parent_pointers = true",
            ));
        }
        if memory.treelet_bytes > l1_bytes {
            return Err(ConfigError::key(
                "memory.treelet_bytes",
                format!(
                    "= {} is larger than the L1 ({l1_bytes} B): a treelet must fit the L1 of \
                     the TM working on it (STRaTA §3.1)",
                    memory.treelet_bytes
                ),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(f: impl FnOnce(&mut StrataConfig)) -> String {
        let mut c = StrataConfig::default();
        f(&mut c);
        c.validate().unwrap_err().to_string()
    }

    #[test]
    fn defaults_are_the_papers() {
        let c = StrataConfig::default();
        c.validate().unwrap();
        assert_eq!(c.stream.bytes, 4 << 20);
        assert_eq!(c.l2_bytes, 512 << 10);
        assert_eq!(c.policy, Policy::MostRays);
        // Table 2: 4 MB → 0.901 nJ, 512 KB → 0.524 nJ (exact at table points).
        assert!((c.stream.access_nj() - 0.901).abs() < 1e-9);
        let small = StreamConfig {
            bytes: 512 << 10,
            ..StreamConfig::default()
        };
        assert!((small.access_nj() - 0.524).abs() < 1e-9);
    }

    #[test]
    fn bad_values_name_their_keys_and_ranges() {
        let e = err(|c| c.stream.bytes = 100);
        assert!(
            e.contains("arch.strata.stream.bytes") && e.contains("1024"),
            "{e}"
        );
        let e = err(|c| c.stream.bytes = 4 << 30);
        assert!(e.contains("arch.strata.stream.bytes"), "{e}");
        let e = err(|c| c.stream.banks = 3);
        assert!(
            e.contains("arch.strata.stream.banks") && e.contains("power of two"),
            "{e}"
        );
        let e = err(|c| c.stream.ports_per_bank = 0);
        assert!(
            e.contains("arch.strata.stream.ports_per_bank") && e.contains("1..=8"),
            "{e}"
        );
        let e = err(|c| c.stream.latency = 0);
        assert!(e.contains("arch.strata.stream.latency"), "{e}");
        let e = err(|c| c.stream.energy_nj = Some(f64::NAN));
        assert!(e.contains("arch.strata.stream.energy_nj"), "{e}");
        let e = err(|c| c.l2_bytes = 1000);
        assert!(e.contains("arch.strata.l2_bytes"), "{e}");
        let e = err(|c| c.tms_per_buffer = 5000);
        assert!(
            e.contains("arch.strata.tms_per_buffer") && e.contains("0..=4096"),
            "{e}"
        );
    }

    #[test]
    fn the_run_must_stream_with_bit_stack_treelets_that_fit_the_l1() {
        let c = StrataConfig::default();
        let trace = TraceConfig {
            traversal: Traversal::BitStack,
            ..TraceConfig::default()
        };
        let mem = MemoryLayoutConfig {
            layout: Layout::Treelets,
            parent_pointers: true,
            ..MemoryLayoutConfig::default()
        };
        c.validate_run(&trace, &mem, 16 << 10).unwrap();
        let e = c
            .validate_run(&TraceConfig::default(), &mem, 16 << 10)
            .unwrap_err()
            .to_string();
        assert!(e.contains("trace.traversal"), "{e}");
        let linear = MemoryLayoutConfig {
            layout: Layout::Linear,
            ..mem.clone()
        };
        let e = c
            .validate_run(&trace, &linear, 16 << 10)
            .unwrap_err()
            .to_string();
        assert!(e.contains("memory.layout"), "{e}");
        let e = c
            .validate_run(&trace, &mem, 8 << 10)
            .unwrap_err()
            .to_string();
        assert!(e.contains("memory.treelet_bytes"), "{e}");
        // Streaming off: the baseline's traversal is fine.
        let off = StrataConfig {
            streaming: false,
            fused: false,
            ..StrataConfig::default()
        };
        off.validate_run(&TraceConfig::default(), &linear, 16 << 10)
            .unwrap();
    }

    #[test]
    fn streaming_shrinks_the_l2_to_l2_bytes() {
        let trax = rtsim_trax::TraxConfig::default();
        let on = StrataConfig::default();
        assert_eq!(on.chip(&trax).l2.size_bytes, 512 << 10);
        assert_eq!(on.chip(&trax).l1, trax.l1);
        let off = StrataConfig {
            streaming: false,
            fused: false,
            ..StrataConfig::default()
        };
        assert_eq!(off.chip(&trax), trax);
    }

    #[test]
    fn unknown_keys_are_refused_and_policies_parse_by_name() {
        let e = toml::from_str::<StrataConfig>("streamin = true\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("streamin"), "{e}");
        let c: StrataConfig =
            toml::from_str("policy = \"round-robin\"\n[stream]\nbytes = 1048576\n").unwrap();
        assert_eq!(c.policy, Policy::RoundRobin);
        assert_eq!(c.stream.bytes, 1 << 20);
        assert_eq!(c.stream.banks, 16);
    }
}
