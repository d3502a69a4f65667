//! Settings of the functional tracer and its workloads.

use rtsim_config::{ConfigError, Validate, check_range};
use serde::{Deserialize, Serialize};

/// Ray–triangle test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TriangleTest {
    /// Möller–Trumbore (1997): the baseline TRaX kernel.
    MollerTrumbore,
    /// Plücker coordinates (STRaTA's triangle pipeline): hit/miss without a divide, one
    /// divide only on a hit.
    Plucker,
    /// Wald's precomputed projection test (2004), SGRT's IST unit.
    Wald,
}

/// Child visiting order of the baseline stack traversal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TraversalOrder {
    /// Visit the child whose box entry distance is smaller first (default).
    NearestFirst,
    /// Always the left child first (SimTRaX's sample tracer).
    LeftFirst,
}

/// Traversal variant (see `docs/TRAVERSAL.md` and [`crate::step`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Traversal {
    /// Full stack of (node, entry distance) in the TP's local memory: the TRaX baseline and
    /// the reference.
    Stack,
    /// One bit per level plus parent pointers (STRaTA paper §3.2); needs a BVH of at most 32
    /// levels below the root.
    BitStack,
    /// A short stack with a restart trail (SGRT's TRV).
    ShortStack,
}

impl Traversal {
    pub fn name(self) -> &'static str {
        match self {
            Traversal::Stack => "stack",
            Traversal::BitStack => "bit-stack",
            Traversal::ShortStack => "short-stack",
        }
    }
}

/// Traversal settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TraceConfig {
    /// Traversal variant: `stack` (default), `bit-stack`, `short-stack`.
    pub traversal: Traversal,
    /// `stack`: entries the stack may hold; 8 bytes each in the TRaX TP's 512-byte local
    /// memory, so at most 64 (default 64). A BVH deeper than this is refused.
    pub stack_entries: u32,
    /// `short-stack`: entries of the short stack, 1..=64. Default 8 (assumed; the SGRT paper
    /// gives 16 stacks per TRV but not their depth — see `docs/TRAVERSAL.md`).
    pub short_stack_entries: u32,
    /// Triangle test used by the reference traversal. Default `moller-trumbore`.
    pub triangle_test: TriangleTest,
    /// Child order. Default `nearest-first`.
    pub order: TraversalOrder,
    /// Any-hit (shadow/AO) rays stop at the first hit. Default true; SimTRaX's sample tracer
    /// used `order = "left-first"` with `early_exit = false`.
    pub early_exit: bool,
    /// `rtsim trace` and `rtsim bench` use the 8-wide fast path when the kernel is
    /// `moller-trumbore` (same hits, bit-identical t/u/v, no counters). Default true.
    pub fast_path: bool,
}

impl Default for TraceConfig {
    fn default() -> Self {
        TraceConfig {
            traversal: Traversal::Stack,
            stack_entries: crate::step::stack::STACK_CAPACITY as u32,
            short_stack_entries: 8,
            triangle_test: TriangleTest::MollerTrumbore,
            order: TraversalOrder::NearestFirst,
            early_exit: true,
            fast_path: true,
        }
    }
}

impl Validate for TraceConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_range(
            "trace.stack_entries",
            self.stack_entries,
            1,
            crate::step::stack::STACK_CAPACITY as u32,
        )?;
        check_range(
            "trace.short_stack_entries",
            self.short_stack_entries,
            1,
            crate::step::shortstack::MAX_ENTRIES as u32,
        )?;
        Ok(())
    }
}

/// Which rays a frame consists of.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WorkloadKind {
    /// Camera rays only.
    Primary,
    /// Ambient occlusion: per primary hit, `spp` cosine-weighted any-hit rays of length
    /// `ao_radius` (Halton directions).
    Ao,
    /// One-bounce diffuse inter-reflection: per primary hit, `spp` cosine-weighted
    /// closest-hit rays (Halton directions).
    Diffuse,
    /// Path tracing with a point light: shadow ray per hit, cosine bounce, `max_depth` hits.
    Path,
    /// Forced specular: mirror reflection at every hit, `specular_bounces` bounces.
    Specular,
}

/// Workload settings. Unset image size and samples take the papers' defaults for the kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WorkloadConfig {
    /// Default `path`.
    pub kind: WorkloadKind,
    /// Image width in pixels. Default: 1024 (path tracing: STRaTA §5; AO/diffuse: SGRT §4).
    pub width: Option<u32>,
    /// Image height. Default: 1024 for `path` (STRaTA §5), 768 otherwise (SGRT Table 4).
    pub height: Option<u32>,
    /// Samples per pixel. Default: 32 for `ao` and `diffuse` (SGRT Tables 4–5), else 1.
    pub spp: Option<u32>,
    /// Path tracing: maximum hits per path (5 = primary ray plus 4 bounces; STRaTA §5).
    pub max_depth: u32,
    /// Forced specular: number of bounces after the primary hit (SGRT Table 3: 2).
    pub specular_bounces: u32,
    /// AO ray length in scene units. Default: the scene descriptor's value, else 10 % of the
    /// scene's bounding-box diagonal (assumed: Aila–Laine use a per-scene constant).
    pub ao_radius: Option<f32>,
}

impl Default for WorkloadConfig {
    fn default() -> Self {
        WorkloadConfig {
            kind: WorkloadKind::Path,
            width: None,
            height: None,
            spp: None,
            max_depth: 5,
            specular_bounces: 2,
            ao_radius: None,
        }
    }
}

impl WorkloadConfig {
    /// Image size and samples with the per-kind defaults filled in.
    pub fn resolved_size(&self) -> (u32, u32, u32) {
        let (w, h, s) = match self.kind {
            WorkloadKind::Path => (1024, 1024, 1),
            WorkloadKind::Ao | WorkloadKind::Diffuse => (1024, 768, 32),
            WorkloadKind::Primary | WorkloadKind::Specular => (1024, 768, 1),
        };
        (
            self.width.unwrap_or(w),
            self.height.unwrap_or(h),
            self.spp.unwrap_or(s),
        )
    }
}

impl Validate for WorkloadConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        let (w, h, s) = self.resolved_size();
        check_range("workload.width", w, 1, 16384)?;
        check_range("workload.height", h, 1, 16384)?;
        check_range("workload.spp", s, 1, 4096)?;
        // Assumed limit: 64 M pixels (8192²) keeps the frame buffers (16 B per pixel) around
        // 1 GB; larger images are better rendered in tiles by separate runs.
        let pixels = w as u64 * h as u64;
        if pixels > 1 << 26 {
            return Err(ConfigError::range(
                "workload.width × workload.height",
                pixels,
                "at most 67108864 (8192²)",
            ));
        }
        check_range("workload.max_depth", self.max_depth, 1, 64)?;
        check_range("workload.specular_bounces", self.specular_bounces, 0, 64)?;
        if let Some(r) = self.ao_radius {
            rtsim_config::check_positive("workload.ao_radius", r as f64)?;
        }
        Ok(())
    }
}
