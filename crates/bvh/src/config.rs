//! Configuration of the BVH build (`bvh.*`) and of its memory image (`memory.*`).
//!
//! Both structs are validated before anything is built; errors name the key and the allowed
//! range. The record layouts the `memory.*` keys control are documented in
//! `docs/MEMORY_IMAGE.md`.

use rtsim_config::{ConfigError, Validate, check_positive, check_range};
use serde::{Deserialize, Serialize};

/// Which SAH builder to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Builder {
    /// Full sweep SAH over sorted centroids on all three axes: every object split is evaluated
    /// (best quality; O(n log n) per level with pre-sorted index lists).
    Sweep,
    /// Binned SAH (Wald 2007): `bins` buckets over the centroid bounds per axis.
    Binned,
}

/// BVH build settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BvhConfig {
    /// SAH builder. Default `binned`. `sweep` is several times slower to build and gives
    /// slightly cheaper trees (SGRT used a full-SAH BVH).
    pub builder: Builder,
    /// Bins per axis for the binned builder. Default 32 (assumed; measured: Sibenik's SAH cost
    /// is 1.1 % above the full sweep's with 32 bins, Conference's equal); range 2..=1024. More
    /// bins cost time in the sweep over non-empty bins, not in the per-triangle pass.
    pub bins: u32,
    /// Largest leaf, in triangles. Default 4 (assumed: small leaves suit hardware that tests
    /// one triangle per pipeline pass); range 1..=255. Larger leaves mean fewer nodes and more
    /// triangle tests per ray. A node with more triangles than this is always split,
    /// even where the SAH prefers a leaf.
    pub max_leaf_size: u32,
    /// SAH cost of one traversal step, relative to `intersection_cost`. Default 1.0 (SimTRaX's
    /// `BVH_C_trav`); any finite value > 0.
    pub traversal_cost: f32,
    /// SAH cost of one triangle test. Default 1.0 (SimTRaX's `BVH_C_isec`); any finite value > 0.
    pub intersection_cost: f32,
    /// Maximum depth of any node, counted in edges from the root (root = depth 0). Default 64;
    /// range 1..=128. STRaTA's one-bit-per-level traversal stack is one 32-bit integer (STRaTA
    /// paper §3.2), so a BVH for STRaTA needs 32. Subtrees that would exceed the limit are
    /// built with depth-constrained splits (see `build`).
    pub max_depth: u32,
    /// Subtrees with at least this many triangles are built in parallel, and nodes with at
    /// least 4× this many bin their triangles in parallel chunks of this size. Default 4096
    /// (assumed: about a millisecond of build work per task, far above rayon's per-task
    /// overhead of about a microsecond); range 64..=2^31. The tree is identical whatever the
    /// value and the thread count.
    pub parallel_threshold: u32,
}

impl Default for BvhConfig {
    fn default() -> Self {
        BvhConfig {
            builder: Builder::Binned,
            bins: 32,
            max_leaf_size: 4,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            max_depth: 64,
            parallel_threshold: 4096,
        }
    }
}

impl Validate for BvhConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_range("bvh.bins", self.bins, 2, 1024)?;
        check_range("bvh.max_leaf_size", self.max_leaf_size, 1, 255)?;
        check_range("bvh.max_depth", self.max_depth, 1, 128)?;
        check_positive("bvh.traversal_cost", self.traversal_cost as f64)?;
        check_positive("bvh.intersection_cost", self.intersection_cost as f64)?;
        check_range(
            "bvh.parallel_threshold",
            self.parallel_threshold,
            64,
            1 << 31,
        )?;
        Ok(())
    }
}

/// Order of nodes in the flat array and hence in memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NodeOrder {
    /// Depth-first (default): the root, then sibling pairs in the order a left-first
    /// depth-first walk reaches them; triangles in left-to-right leaf order.
    DepthFirst,
    /// Breadth-first (level order), sibling pairs adjacent; triangles in level order of their
    /// leaves.
    BreadthFirst,
}

/// Node record size without parent pointers: bounds 24 B + index 4 B + count 4 B (SimTRaX
/// `BVHNodeSize` without treelets: 8 words).
pub const NODE_BYTES_PLAIN: u32 = 32;
/// Node record size with parent pointers: the 32-byte node + parent index 4 B + treelet id
/// 4 B (SimTRaX `BVHNodeSize` = 10 words when treelets are on: "Box (6), start_child,
/// num_children, parent, subtree").
pub const NODE_BYTES_PARENT: u32 = 40;
/// Smallest record that holds a node and its parent index.
pub const NODE_BYTES_PARENT_MIN: u32 = 36;
/// Triangle record: three vertices 36 B + triangle id 4 B + material id 4 B (SimTRaX
/// `TriangleSize` = 11 words: "3 Verts (9), material_id, object_id").
pub const TRIANGLE_BYTES_DEFAULT: u32 = 44;
/// Smallest triangle record: the three vertices a triangle test reads.
pub const TRIANGLE_BYTES_MIN: u32 = 36;
/// Largest record of either kind (assumed: four 64-byte lines; anything larger is a typo).
pub const RECORD_BYTES_MAX: u32 = 256;

/// How node and triangle records are placed (`memory.layout`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Layout {
    /// Records in array order, one region per kind (default).
    Linear,
    /// STRaTA's treelets (paper §3.1, after Aila & Karras 2010): node treelets and triangle
    /// treelets of at most `memory.treelet_bytes`, each contiguous and aligned to
    /// `memory.region_alignment` (see `treelet`).
    Treelets,
}

/// What a treelet layout's DRAM row check does with a treelet that spans more DRAM rows than
/// its size needs (`memory.treelet_row_check`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RowCheck {
    /// Report the findings and go on (default).
    Warn,
    /// Refuse the layout, naming the first offending treelet.
    Strict,
}

/// What becomes of the subtrees left on a full node treelet's frontier
/// (`memory.treelet_fringe`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fringe {
    /// Each leftover frontier pair roots a treelet of its own, grown greedily to the budget
    /// (Aila & Karras 2010 as written); most of them are small subtrees, so most treelets hold
    /// a few nodes (Sibenik: 3,170 node treelets filled to 4.5 % on average).
    Separate,
    /// Leftover pairs whose whole subtree fits the budget are packed, whole, into shared
    /// treelets (next fit in node-index order, per full treelet); larger ones grow as before.
    /// Treelets then come close to the budget (Sibenik: 189 filled to 76 %), as STRaTA §3.1
    /// has them: "we assign treelets to be exactly the size of an L1 cache" (default).
    Packed,
}

impl Fringe {
    pub const NAMES: [&'static str; 2] = ["separate", "packed"];
}

/// Node treelet budget by default: the TRaX L1 data cache, 16 KB per TM (STRaTA paper §3.1:
/// "we assign treelets to be exactly the size of an L1 cache"; Table 2 / DESIGN.md §3).
pub const TREELET_BYTES_DEFAULT: u64 = 16 * 1024;
/// Smallest treelet budget: one line (it must also hold a sibling pair, 2 × `node_bytes`,
/// checked separately).
pub const TREELET_BYTES_MIN: u64 = 64;
/// Largest treelet budget (assumed: 64 MiB, four times the largest stream memory STRaTA's
/// Figures 5–6 sweep; anything larger is a typo).
pub const TREELET_BYTES_MAX: u64 = 1 << 26;
/// Treelet budgets are whole cache lines (TRaX's 64-byte line, DESIGN.md §3).
pub const TREELET_BYTES_GRANULE: u64 = 64;
/// Wald's precomputed triangle data for SGRT's IST, as the caller supplies it: ten 4-byte
/// words `n_u n_v n_d k b_nu b_nv b_d c_nu c_nv c_d` (`rtsim_trace`'s `WaldTri`, in field
/// order).
pub const WALD_INPUT_BYTES: u32 = 40;
/// Bytes of a Wald record holding fields: the ten words laid out as Wald's `TriAccel` (PhD
/// thesis, 2004, §7.1) in three 16-byte quarters — `n_u n_v n_d k`, `b_nu b_nv b_d` + the
/// triangle id, `c_nu c_nv c_d` — so a fetch reads 44 bytes.
pub const WALD_DATA_BYTES: u32 = 44;
/// Wald record stride: 48 bytes, `TriAccel`'s size (the last word is padding).
pub const WALD_RECORD_BYTES: u32 = 48;
/// Material record: albedo and emission, RGB `f32` each…
pub const MATERIAL_DATA_BYTES: u32 = 24;
/// …padded to 32 so two materials share a 64-byte line and none straddles one (assumed).
pub const MATERIAL_RECORD_BYTES: u32 = 32;
/// Framebuffer pixel: accumulated radiance, RGB `f32`…
pub const PIXEL_DATA_BYTES: u32 = 12;
/// …padded to 16 so four pixels fill a line (assumed: aligned vector stores).
pub const PIXEL_RECORD_BYTES: u32 = 16;
/// Fields of a spilled path state record (see `docs/MEMORY_IMAGE.md`, "Path state").
pub const PATH_STATE_DATA_BYTES: u32 = 56;
/// Path state record by default: 64, one line per path (assumed: one fetch per spill/fill).
pub const PATH_STATE_BYTES_DEFAULT: u32 = 64;
/// Most path slots: the workload's 64 M-pixel image cap, one path per pixel.
pub const PATH_SLOTS_MAX: u32 = 1 << 26;

/// How the BVH is laid out in the simulated address space (see `MemoryImage` and
/// `docs/MEMORY_IMAGE.md`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MemoryLayoutConfig {
    /// Node order, used by the BVH build when it flattens the tree. Default `depth-first`.
    pub order: NodeOrder,
    /// Store a parent index with every node (STRaTA's bit-stack traversal needs it). Default
    /// false. Makes the default node record 40 B instead of 32 B.
    pub parent_pointers: bool,
    /// First byte address of the scene data. Default 0. Must be a multiple of
    /// `region_alignment`.
    pub base_address: u64,
    /// Bytes per node record (the stride of the node region and the size of one node fetch).
    /// Default: unset, meaning 32 (40 with `parent_pointers`), SimTRaX's node sizes. Range
    /// 32..=256 (36..=256 with parent pointers), a multiple of 4; bytes past the fields are
    /// padding (64 puts every node alone in a 64-byte line).
    pub node_bytes: Option<u32>,
    /// Bytes per triangle record. Default 44 (SimTRaX: 3 vertices, material id, triangle id).
    /// Range 36..=256, a multiple of 4: 36 keeps only the vertices, 40 adds the triangle id,
    /// 44 the material id, more is padding (48 keeps records 16-byte aligned).
    pub triangle_bytes: u32,
    /// Alignment of each region (nodes, triangles) in bytes. Default 8192, one DRAM row of the
    /// STRaTA paper's GDDR5 ("treelets are the size of two DRAM rows" with 16 KB L1s, §3.1 and
    /// §4). A power of two in 64..=2^30.
    pub region_alignment: u64,
    /// Start the node region with one record of padding, so the root sits at the end of a
    /// pair slot and every sibling pair starts at a multiple of 2 × `node_bytes` from the
    /// region base: with 32-byte nodes, each sibling pair is exactly one 64-byte line (SimTRaX
    /// `BVH::LoadIntoMemory`: "root node starts mid-line, so that children are cache
    /// line-aligned"). Default true. Must stay true with `layout = "treelets"`, which grows
    /// treelets by aligned sibling pairs.
    pub align_sibling_pairs: bool,
    /// Placement of node and triangle records: `linear` (default; array order) or `treelets`
    /// (STRaTA §3.1: node and triangle treelets of at most `treelet_bytes`, each contiguous
    /// and aligned to `region_alignment`; treelet ids in node records with parent pointers).
    /// The BVH the tracer traverses is the same; only addresses change.
    pub layout: Layout,
    /// Largest treelet in bytes, padding included. Default 16384, the TRaX L1 (STRaTA §3.1:
    /// treelets are the L1's size, "two DRAM rows"). A multiple of 64 in 64..=67108864, and
    /// at least one sibling pair (2 × the node record).
    /// Smaller treelets mean more of them and more ray-buffer switches; larger ones no longer
    /// fit the L1. Used only with `layout = "treelets"`.
    pub treelet_bytes: u64,
    /// What the DRAM row check does with a treelet that spans more rows than its size needs:
    /// `warn` (default; report and go on) or `strict` (refuse the layout, with the reason).
    pub treelet_row_check: RowCheck,
    /// Pack treelets: each starts on a 64-byte line right after the previous one, and on a
    /// new DRAM row (`region_alignment`) only where it would otherwise touch more rows than
    /// its size needs, so small treelets share rows and the node region stays compact.
    /// `false`: every treelet starts on a new row (STRaTA's Figure 4 drawn literally; the
    /// greedy growth leaves many small fringe treelets, so this multiplies the node region,
    /// about 11× for Sibenik). Either way no treelet touches more rows than it needs.
    /// Default true.
    pub treelet_packing: bool,
    /// `packed` (default) or `separate`: whether the small subtrees left on a full treelet's
    /// frontier share treelets or each make one (see [`Fringe`]).
    pub treelet_fringe: Fringe,
    /// In-flight path slots in the spilled path state region. Default: unset, one per pixel of
    /// the workload image (a software renderer's count); a STRaTA chip sets its stream
    /// memory's ray capacity. Range 1..=67108864.
    pub path_slots: Option<u32>,
    /// Bytes per spilled path state record. Default 64 (one line; the fields take 56). A
    /// multiple of 4 in 56..=256; more is padding.
    pub path_state_bytes: u32,
}

impl Default for MemoryLayoutConfig {
    fn default() -> Self {
        MemoryLayoutConfig {
            order: NodeOrder::DepthFirst,
            parent_pointers: false,
            base_address: 0,
            node_bytes: None,
            triangle_bytes: TRIANGLE_BYTES_DEFAULT,
            region_alignment: 8192,
            align_sibling_pairs: true,
            layout: Layout::Linear,
            treelet_bytes: TREELET_BYTES_DEFAULT,
            treelet_row_check: RowCheck::Warn,
            treelet_packing: true,
            treelet_fringe: Fringe::Packed,
            path_slots: None,
            path_state_bytes: PATH_STATE_BYTES_DEFAULT,
        }
    }
}

impl MemoryLayoutConfig {
    /// The node record size in effect: `node_bytes`, or the default for the parent-pointer
    /// setting.
    pub fn resolved_node_bytes(&self) -> u32 {
        self.node_bytes.unwrap_or(if self.parent_pointers {
            NODE_BYTES_PARENT
        } else {
            NODE_BYTES_PLAIN
        })
    }
}

impl Validate for MemoryLayoutConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        if let Some(n) = self.node_bytes {
            let lo = if self.parent_pointers {
                NODE_BYTES_PARENT_MIN
            } else {
                NODE_BYTES_PLAIN
            };
            if n < lo || n > RECORD_BYTES_MAX || n % 4 != 0 {
                let why = if self.parent_pointers {
                    " (memory.parent_pointers = true needs room for the parent index)"
                } else {
                    ""
                };
                return Err(ConfigError::range(
                    "memory.node_bytes",
                    n,
                    format!("a multiple of 4 in {lo}..={RECORD_BYTES_MAX}{why}"),
                ));
            }
        }
        let t = self.triangle_bytes;
        if !(TRIANGLE_BYTES_MIN..=RECORD_BYTES_MAX).contains(&t) || t % 4 != 0 {
            return Err(ConfigError::range(
                "memory.triangle_bytes",
                t,
                format!("a multiple of 4 in {TRIANGLE_BYTES_MIN}..={RECORD_BYTES_MAX}"),
            ));
        }
        let a = self.region_alignment;
        if !a.is_power_of_two() || !(64..=1 << 30).contains(&a) {
            return Err(ConfigError::range(
                "memory.region_alignment",
                a,
                "a power of two in 64..=1073741824",
            ));
        }
        if self.base_address % a != 0 {
            return Err(ConfigError::key(
                "memory.base_address",
                format!(
                    "{:#x} is not a multiple of memory.region_alignment ({a})",
                    self.base_address
                ),
            ));
        }
        let b = self.treelet_bytes;
        if !(TREELET_BYTES_MIN..=TREELET_BYTES_MAX).contains(&b) || b % TREELET_BYTES_GRANULE != 0 {
            return Err(ConfigError::range(
                "memory.treelet_bytes",
                b,
                format!(
                    "a multiple of {TREELET_BYTES_GRANULE} in \
                     {TREELET_BYTES_MIN}..={TREELET_BYTES_MAX}"
                ),
            ));
        }
        let pair = 2 * self.resolved_node_bytes() as u64;
        if b < pair {
            return Err(ConfigError::range(
                "memory.treelet_bytes",
                b,
                format!("at least one sibling pair, 2 × memory.node_bytes = {pair}"),
            ));
        }
        if self.layout == Layout::Treelets && !self.align_sibling_pairs {
            return Err(ConfigError::key(
                "memory.align_sibling_pairs",
                "must be true with memory.layout = \"treelets\" (treelets grow by aligned \
                 sibling pairs)",
            ));
        }
        if let Some(n) = self.path_slots {
            check_range("memory.path_slots", n, 1, PATH_SLOTS_MAX)?;
        }
        let p = self.path_state_bytes;
        if !(PATH_STATE_DATA_BYTES..=RECORD_BYTES_MAX).contains(&p) || p % 4 != 0 {
            return Err(ConfigError::range(
                "memory.path_state_bytes",
                p,
                format!("a multiple of 4 in {PATH_STATE_DATA_BYTES}..={RECORD_BYTES_MAX}"),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(c: &impl Validate) -> String {
        c.validate().unwrap_err().to_string()
    }

    #[test]
    fn defaults_validate() {
        BvhConfig::default().validate().unwrap();
        MemoryLayoutConfig::default().validate().unwrap();
    }

    #[test]
    fn bvh_errors_name_key_and_range() {
        let c = BvhConfig {
            bins: 1,
            ..Default::default()
        };
        assert!(err(&c).contains("bvh.bins") && err(&c).contains("2..=1024"));
        let c = BvhConfig {
            max_leaf_size: 0,
            ..Default::default()
        };
        assert!(err(&c).contains("bvh.max_leaf_size"));
        let c = BvhConfig {
            traversal_cost: f32::NAN,
            ..Default::default()
        };
        assert!(err(&c).contains("bvh.traversal_cost"));
        let c = BvhConfig {
            intersection_cost: 0.0,
            ..Default::default()
        };
        assert!(err(&c).contains("bvh.intersection_cost"));
        let c = BvhConfig {
            max_depth: 129,
            ..Default::default()
        };
        assert!(err(&c).contains("bvh.max_depth"));
        let c = BvhConfig {
            parallel_threshold: 8,
            ..Default::default()
        };
        assert!(err(&c).contains("bvh.parallel_threshold"));
    }

    #[test]
    fn node_bytes_default_follows_parent_pointers() {
        let mut c = MemoryLayoutConfig::default();
        assert_eq!(c.resolved_node_bytes(), 32);
        c.parent_pointers = true;
        assert_eq!(c.resolved_node_bytes(), 40);
        c.node_bytes = Some(64);
        assert_eq!(c.resolved_node_bytes(), 64);
        c.validate().unwrap();
    }

    #[test]
    fn memory_errors_name_key_and_range() {
        let c = MemoryLayoutConfig {
            parent_pointers: true,
            node_bytes: Some(32),
            ..Default::default()
        };
        let e = err(&c);
        assert!(
            e.contains("memory.node_bytes") && e.contains("36..=256"),
            "{e}"
        );
        let c = MemoryLayoutConfig {
            node_bytes: Some(34),
            ..Default::default()
        };
        assert!(err(&c).contains("memory.node_bytes"));
        let c = MemoryLayoutConfig {
            triangle_bytes: 32,
            ..Default::default()
        };
        assert!(err(&c).contains("memory.triangle_bytes"));
        let c = MemoryLayoutConfig {
            region_alignment: 3000,
            ..Default::default()
        };
        assert!(err(&c).contains("memory.region_alignment"));
        let c = MemoryLayoutConfig {
            base_address: 100,
            ..Default::default()
        };
        assert!(err(&c).contains("memory.base_address"));
        for b in [0, 100, 16384 + 32, (1 << 26) + 64] {
            let c = MemoryLayoutConfig {
                treelet_bytes: b,
                ..Default::default()
            };
            let e = err(&c);
            assert!(
                e.contains("memory.treelet_bytes") && e.contains("64..=67108864"),
                "{b}: {e}"
            );
        }
        let c = MemoryLayoutConfig {
            node_bytes: Some(256),
            treelet_bytes: 448,
            ..Default::default()
        };
        assert!(
            err(&c).contains("2 × memory.node_bytes = 512"),
            "{}",
            err(&c)
        );
        let c = MemoryLayoutConfig {
            layout: Layout::Treelets,
            align_sibling_pairs: false,
            ..Default::default()
        };
        assert!(err(&c).contains("memory.align_sibling_pairs"));
        let c = MemoryLayoutConfig {
            path_slots: Some(0),
            ..Default::default()
        };
        assert!(err(&c).contains("memory.path_slots"));
        for p in [52, 66, 260] {
            let c = MemoryLayoutConfig {
                path_state_bytes: p,
                ..Default::default()
            };
            assert!(err(&c).contains("memory.path_state_bytes") && err(&c).contains("56..=256"));
        }
    }

    #[test]
    fn treelet_keys_parse_from_toml() {
        let c: MemoryLayoutConfig = toml::from_str(
            "layout = \"treelets\"\ntreelet_bytes = 8192\ntreelet_row_check = \"strict\"",
        )
        .unwrap();
        assert_eq!(
            (c.layout, c.treelet_bytes, c.treelet_row_check),
            (Layout::Treelets, 8192, RowCheck::Strict)
        );
        c.validate().unwrap();
        assert!(toml::from_str::<MemoryLayoutConfig>("layout = \"octree\"").is_err());
    }

    #[test]
    fn unset_node_bytes_is_absent_from_toml() {
        // The resolved config must round-trip: an unset `node_bytes` stays unset.
        let c = MemoryLayoutConfig::default();
        let t = toml::to_string(&c).unwrap();
        assert!(!t.contains("node_bytes"), "{t}");
        let back: MemoryLayoutConfig = toml::from_str(&t).unwrap();
        assert_eq!(back, c);
    }
}
