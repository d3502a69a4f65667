//! The memory image: byte addresses of every BVH node and triangle in the simulated address
//! space.
//!
//! This is the interface between the functional tracer and the hardware models. A tracer
//! reports "node 17, triangle slot 40"; a cache or DRAM model asks the image where those live
//! and which lines a fetch touches. The format (record layouts, address rules, config keys) is
//! specified in `docs/MEMORY_IMAGE.md`.
//!
//! Addresses are given per record kind by a [`Placement`]: `Linear` (base + index × stride,
//! what [`MemoryImage::new`] builds) or `Table` (one address per index, for layouts that
//! permute or pad records, such as STRaTA's treelets). Records live in named [`Region`]s, each
//! aligned to `memory.region_alignment`. [`MemoryImage::from_parts`] accepts any placement and
//! checks that records are aligned, inside their regions and non-overlapping.
//!
//! Besides the BVH, the image places the other data a chip reads or writes, sized by
//! [`ImageExtras`]: Wald's precomputed triangle records (SGRT's IST), materials, the
//! framebuffer and spilled per-path state ([`RecordKind`]), each in its own region with
//! `*_addr` / `*_lines` accessors. With `memory.layout = "treelets"` nodes and triangles are
//! placed by [`Treelets`](crate::treelet::Treelets).

use crate::config::{
    Layout, MATERIAL_DATA_BYTES, MATERIAL_RECORD_BYTES, MemoryLayoutConfig, NODE_BYTES_PARENT,
    NODE_BYTES_PLAIN, PATH_STATE_DATA_BYTES, PIXEL_DATA_BYTES, PIXEL_RECORD_BYTES,
    RECORD_BYTES_MAX, TRIANGLE_BYTES_DEFAULT, WALD_DATA_BYTES, WALD_INPUT_BYTES, WALD_RECORD_BYTES,
};
use crate::flat::{Bvh, NO_PARENT, Node};
use crate::treelet::{TreeletError, Treelets};
use rtsim_config::{ConfigError, Validate};
use rtsim_core::{Aabb, Vec3};
use serde::Serialize;

/// Name of the region holding node records.
pub const NODES_REGION: &str = "nodes";
/// Name of the region holding triangle records.
pub const TRIANGLES_REGION: &str = "triangles";
/// Name of the region holding Wald's precomputed triangle records.
pub const WALD_REGION: &str = "wald";
/// Name of the region holding material records.
pub const MATERIALS_REGION: &str = "materials";
/// Name of the region holding the framebuffer.
pub const FRAMEBUFFER_REGION: &str = "framebuffer";
/// Name of the region holding spilled path state.
pub const PATH_STATE_REGION: &str = "path_state";
/// Treelet id written into node records before any treelet layout assigns one.
pub const NO_TREELET: u32 = u32::MAX;
/// Material id written into triangle records when none is supplied.
pub const NO_MATERIAL: u32 = u32::MAX;

/// A contiguous range of the simulated address space.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Region {
    pub name: String,
    pub base: u64,
    pub size_bytes: u64,
}

impl Region {
    /// One past the last byte.
    pub fn end(&self) -> u64 {
        self.base + self.size_bytes
    }
    pub fn contains(&self, addr: u64, bytes: u64) -> bool {
        addr >= self.base && addr.checked_add(bytes).is_some_and(|e| e <= self.end())
    }
}

/// Where the records of one kind live.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Placement {
    /// Record `i` at `base + i × stride`.
    Linear { base: u64, stride: u64 },
    /// Record `i` at `table[i]`.
    Table(Vec<u64>),
}

impl Placement {
    #[inline(always)]
    pub fn addr(&self, i: u32) -> u64 {
        match self {
            Placement::Linear { base, stride } => base + i as u64 * stride,
            Placement::Table(t) => t[i as usize],
        }
    }
}

/// The cache lines one fetch touches: `count` lines of `line_bytes` from address `first`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineSpan {
    pub first: u64,
    pub count: u32,
    pub line_bytes: u32,
}

impl LineSpan {
    /// Line addresses, lowest first.
    pub fn iter(&self) -> impl Iterator<Item = u64> + use<> {
        let (first, step) = (self.first, self.line_bytes as u64);
        (0..self.count as u64).map(move |k| first + k * step)
    }
}

/// The lines of `line_bytes` (> 0; any size, not only powers of two) that the byte range
/// `addr .. addr + bytes` touches. Zero bytes touch no line.
///
/// # Panics
/// If `line_bytes` is 0: cache configurations are validated before they reach this.
pub fn lines_touched(addr: u64, bytes: u32, line_bytes: u32) -> LineSpan {
    assert!(line_bytes > 0, "line size must be positive");
    let l = line_bytes as u64;
    let first = addr / l * l;
    let count = if bytes == 0 {
        0
    } else {
        ((addr + bytes as u64 - 1) / l - addr / l + 1) as u32
    };
    LineSpan {
        first,
        count,
        line_bytes,
    }
}

/// Why an image could not be laid out.
#[derive(Debug, thiserror::Error)]
pub enum MemoryImageError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(
        "the memory image does not fit in a 64-bit address space from memory.base_address = {base:#x}"
    )]
    AddressOverflow { base: u64 },
    #[error("invalid memory layout: {0}")]
    Layout(String),
    #[error(transparent)]
    Treelet(#[from] TreeletError),
}

/// Record kinds beyond nodes and triangles. Record layouts: `docs/MEMORY_IMAGE.md`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RecordKind {
    /// Wald's precomputed triangle record (SGRT's IST), one per triangle slot.
    Wald,
    /// Albedo and emission, one per material id.
    Material,
    /// Framebuffer pixel (`y × width + x`): accumulated RGB radiance.
    Pixel,
    /// Spilled state of one in-flight path (what does not fit STRaTA's 48-byte ray).
    PathState,
}

impl RecordKind {
    /// Every kind, in region order.
    pub const ALL: [RecordKind; 4] = [
        RecordKind::Wald,
        RecordKind::Material,
        RecordKind::Pixel,
        RecordKind::PathState,
    ];

    /// The region holding this kind.
    pub fn region_name(self) -> &'static str {
        match self {
            RecordKind::Wald => WALD_REGION,
            RecordKind::Material => MATERIALS_REGION,
            RecordKind::Pixel => FRAMEBUFFER_REGION,
            RecordKind::PathState => PATH_STATE_REGION,
        }
    }
}

/// The records of one [`RecordKind`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordSet {
    pub kind: RecordKind,
    pub count: u32,
    /// Record stride in bytes.
    pub stride: u32,
    /// Bytes of each record that hold fields (a fetch reads these); ≤ `stride`.
    pub data_bytes: u32,
    pub placement: Placement,
}

/// What the image holds besides the BVH; a count of 0 leaves that region out.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ImageExtras {
    /// Place Wald's precomputed records, one per triangle slot (for `trace.triangle_test =
    /// "wald"`, SGRT's IST).
    pub wald: bool,
    /// Number of materials.
    pub materials: u32,
    /// Framebuffer size in pixels (0 × 0: none).
    pub width: u32,
    pub height: u32,
    /// In-flight path slots (0: no path state region).
    pub path_slots: u32,
    /// Bytes per path state record, `PATH_STATE_DATA_BYTES..=256`, a multiple of 4.
    pub path_state_bytes: u32,
}

impl ImageExtras {
    /// Extras for a run: `materials` and the `width × height` image from the scene and
    /// workload, path slots and record size from `memory.path_slots` (unset: one per pixel)
    /// and `memory.path_state_bytes`.
    pub fn for_run(
        config: &MemoryLayoutConfig,
        wald: bool,
        materials: u32,
        width: u32,
        height: u32,
    ) -> Self {
        // Saturating only to stay a u32: a framebuffer past 2^32 pixels is refused by
        // `MemoryImage::build` (and the workload caps images at 64 M pixels).
        let pixels = (width as u64 * height as u64).min(u32::MAX as u64) as u32;
        ImageExtras {
            wald,
            materials,
            width,
            height,
            path_slots: config.path_slots.unwrap_or(pixels),
            path_state_bytes: config.path_state_bytes,
        }
    }

    /// Framebuffer pixels, if `width × height` fits a `u32` index.
    fn pixels(&self) -> Result<u32, MemoryImageError> {
        u32::try_from(self.width as u64 * self.height as u64).map_err(|_| {
            MemoryImageError::Layout(format!(
                "a {} × {} framebuffer has more than 2^32 pixels",
                self.width, self.height
            ))
        })
    }

    /// `(kind, count, stride, data bytes)` of each region to place.
    fn sets(
        &self,
        triangle_slots: u32,
    ) -> Result<Vec<(RecordKind, u32, u32, u32)>, MemoryImageError> {
        let p = self.path_state_bytes;
        if self.path_slots > 0
            && (!(PATH_STATE_DATA_BYTES..=RECORD_BYTES_MAX).contains(&p) || p % 4 != 0)
        {
            return Err(MemoryImageError::Layout(format!(
                "path_state_bytes = {p}: must be a multiple of 4 in \
                 {PATH_STATE_DATA_BYTES}..={RECORD_BYTES_MAX} (memory.path_state_bytes)"
            )));
        }
        Ok([
            (
                RecordKind::Wald,
                if self.wald { triangle_slots } else { 0 },
                WALD_RECORD_BYTES,
                WALD_DATA_BYTES,
            ),
            (
                RecordKind::Material,
                self.materials,
                MATERIAL_RECORD_BYTES,
                MATERIAL_DATA_BYTES,
            ),
            (
                RecordKind::Pixel,
                self.pixels()?,
                PIXEL_RECORD_BYTES,
                PIXEL_DATA_BYTES,
            ),
            (
                RecordKind::PathState,
                self.path_slots,
                p,
                PATH_STATE_DATA_BYTES,
            ),
        ]
        .into_iter()
        .filter(|s| s.1 > 0)
        .collect())
    }
}

/// Record contents for [`MemoryImage::encode_scene`].
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneData<'a> {
    /// The scene's triangles in scene order.
    pub triangles: &'a [[Vec3; 3]],
    /// Material id per scene triangle, if known.
    pub material_ids: Option<&'a [u32]>,
    /// Albedo and emission (RGB) per material id; needed when the image has materials.
    pub materials: &'a [[Vec3; 2]],
    /// Wald's data per triangle *slot* (`WALD_INPUT_BYTES` each: `n_u n_v n_d k b_nu b_nv
    /// b_d c_nu c_nv c_d`, little-endian, `rtsim_trace`'s `WaldTri::to_le_bytes`); needed
    /// when the image has a Wald region.
    pub wald: Option<&'a [[u8; WALD_INPUT_BYTES as usize]]>,
}

/// The parts of a memory image, for layouts built outside [`MemoryImage::new`] (treelets).
#[derive(Clone, Debug)]
pub struct ImageParts {
    pub node_count: u32,
    pub triangle_count: u32,
    /// Record strides (and the most a record may occupy).
    pub node_bytes: u32,
    pub triangle_bytes: u32,
    /// Bytes of each record that hold fields (the rest is padding); ≤ the record size.
    pub node_data_bytes: u32,
    pub triangle_data_bytes: u32,
    pub regions: Vec<Region>,
    pub nodes: Placement,
    pub triangles: Placement,
    /// Parent index per node ([`NO_PARENT`] for the root), when records carry one.
    pub parents: Option<Vec<u32>>,
    /// Every region's base is a multiple of this (`memory.region_alignment`, a power of two).
    pub region_alignment: u64,
    /// Records beyond nodes and triangles, at most one set per [`RecordKind`].
    pub extras: Vec<RecordSet>,
    /// The treelet partition of a treelet layout (its node and triangle placements must agree).
    pub treelets: Option<Treelets>,
}

/// Byte addresses of every node and triangle record. See the module docs.
#[derive(Clone, Debug)]
pub struct MemoryImage {
    p: ImageParts,
}

/// The bytes of one region, for models that read real data.
#[derive(Clone, Debug)]
pub struct RegionBytes {
    pub region: Region,
    pub bytes: Vec<u8>,
}

impl MemoryImage {
    /// The image of the BVH alone (no [`ImageExtras`]) with the layout `config` selects: by
    /// default nodes in array order (the BVH's depth- or breadth-first order) from
    /// `memory.base_address`, after one record of padding if `align_sibling_pairs`, then the
    /// triangles in slot order from the next multiple of `region_alignment`.
    pub fn new(bvh: &Bvh, config: &MemoryLayoutConfig) -> Result<Self, MemoryImageError> {
        Self::build(bvh, config, &ImageExtras::default())
    }

    /// The image of the BVH and the `extras`: nodes and triangles as `memory.layout` says
    /// (`linear` or `treelets`), then one region per extra kind in [`RecordKind::ALL`] order,
    /// each from the next multiple of `region_alignment`, records in index order.
    pub fn build(
        bvh: &Bvh,
        config: &MemoryLayoutConfig,
        extras: &ImageExtras,
    ) -> Result<Self, MemoryImageError> {
        config.validate()?;
        let node_bytes = config.resolved_node_bytes();
        let triangle_bytes = config.triangle_bytes;
        let node_count = bvh.nodes.len() as u32;
        let triangle_count = bvh.prim_ids.len() as u32;
        let align = config.region_alignment;
        let overflow = || MemoryImageError::AddressOverflow {
            base: config.base_address,
        };
        let region = |name: &str, base: u64, size_bytes: u64| Region {
            name: name.into(),
            base,
            size_bytes,
        };
        let (regions, nodes, triangles, treelets) = match config.layout {
            Layout::Linear => {
                let pad = if config.align_sibling_pairs && node_count > 0 {
                    node_bytes as u64
                } else {
                    0
                };
                let node_base = config.base_address;
                let node_size = (node_count as u64 * node_bytes as u64) + pad;
                let tri_base = align_up(
                    node_base.checked_add(node_size).ok_or_else(overflow)?,
                    align,
                )
                .ok_or_else(overflow)?;
                let tri_size = triangle_count as u64 * triangle_bytes as u64;
                tri_base.checked_add(tri_size).ok_or_else(overflow)?;
                (
                    vec![
                        region(NODES_REGION, node_base, node_size),
                        region(TRIANGLES_REGION, tri_base, tri_size),
                    ],
                    Placement::Linear {
                        base: node_base + pad,
                        stride: node_bytes as u64,
                    },
                    Placement::Linear {
                        base: tri_base,
                        stride: triangle_bytes as u64,
                    },
                    None,
                )
            }
            Layout::Treelets => {
                let t = Treelets::build(bvh, config)?;
                let ((nb, ne), (tb, te)) =
                    t.spans(config.base_address, align).ok_or_else(overflow)?;
                let (na, ta) = t.addresses();
                (
                    vec![
                        region(NODES_REGION, nb, ne - nb),
                        region(TRIANGLES_REGION, tb, te - tb),
                    ],
                    Placement::Table(na),
                    Placement::Table(ta),
                    Some(t),
                )
            }
        };
        let mut regions = regions;
        let mut cursor = regions.iter().map(Region::end).max().unwrap_or(0);
        let mut sets = Vec::new();
        for (kind, count, stride, data_bytes) in extras.sets(triangle_count)? {
            let base = align_up(cursor, align).ok_or_else(overflow)?;
            let size = count as u64 * stride as u64;
            cursor = base.checked_add(size).ok_or_else(overflow)?;
            regions.push(region(kind.region_name(), base, size));
            sets.push(RecordSet {
                kind,
                count,
                stride,
                data_bytes,
                placement: Placement::Linear {
                    base,
                    stride: stride as u64,
                },
            });
        }
        let node_data_bytes = if config.parent_pointers {
            node_bytes.min(NODE_BYTES_PARENT)
        } else {
            NODE_BYTES_PLAIN
        };
        Ok(MemoryImage {
            p: ImageParts {
                node_count,
                triangle_count,
                node_bytes,
                triangle_bytes,
                node_data_bytes,
                triangle_data_bytes: triangle_bytes.min(TRIANGLE_BYTES_DEFAULT),
                regions,
                nodes,
                triangles,
                parents: config.parent_pointers.then(|| bvh.parents()),
                region_alignment: align,
                extras: sets,
                treelets,
            },
        })
    }

    /// An image from explicit parts, checked with [`MemoryImage::check`].
    pub fn from_parts(parts: ImageParts) -> Result<Self, MemoryImageError> {
        let image = MemoryImage { p: parts };
        image.check()?;
        Ok(image)
    }

    pub fn parts(&self) -> &ImageParts {
        &self.p
    }

    /// Byte address of node record `node` (a [`Bvh::nodes`] index).
    #[inline(always)]
    pub fn node_addr(&self, node: u32) -> u64 {
        self.p.nodes.addr(node)
    }

    /// Byte address of triangle record `slot` (a BVH triangle slot, as in leaf ranges).
    #[inline(always)]
    pub fn triangle_addr(&self, slot: u32) -> u64 {
        self.p.triangles.addr(slot)
    }

    /// Node record size (stride) in bytes.
    pub fn node_bytes(&self) -> u32 {
        self.p.node_bytes
    }

    /// Triangle record size (stride) in bytes.
    pub fn triangle_bytes(&self) -> u32 {
        self.p.triangle_bytes
    }

    /// Bytes of a node record that hold fields (a node fetch reads these).
    pub fn node_data_bytes(&self) -> u32 {
        self.p.node_data_bytes
    }

    /// Bytes of a triangle record that hold fields (a triangle fetch reads these).
    pub fn triangle_data_bytes(&self) -> u32 {
        self.p.triangle_data_bytes
    }

    pub fn node_count(&self) -> u32 {
        self.p.node_count
    }

    pub fn triangle_count(&self) -> u32 {
        self.p.triangle_count
    }

    pub fn regions(&self) -> &[Region] {
        &self.p.regions
    }

    pub fn region(&self, name: &str) -> Option<&Region> {
        self.p.regions.iter().find(|r| r.name == name)
    }

    /// Lowest region base and one past the highest region end (`(0, 0)` with no regions).
    pub fn span(&self) -> (u64, u64) {
        let lo = self.p.regions.iter().map(|r| r.base).min().unwrap_or(0);
        let hi = self.p.regions.iter().map(|r| r.end()).max().unwrap_or(0);
        (lo, hi)
    }

    /// Parent of `node` as stored in its record: `None` for the root, or when the image has
    /// no parent pointers (`memory.parent_pointers = false`).
    pub fn parent(&self, node: u32) -> Option<u32> {
        let p = *self.p.parents.as_ref()?.get(node as usize)?;
        (p != NO_PARENT).then_some(p)
    }

    /// All parent pointers, if the records carry them.
    pub fn parents(&self) -> Option<&[u32]> {
        self.p.parents.as_deref()
    }

    /// Lines a node fetch (its data bytes) touches.
    #[inline]
    pub fn node_lines(&self, node: u32, line_bytes: u32) -> LineSpan {
        lines_touched(self.node_addr(node), self.p.node_data_bytes, line_bytes)
    }

    /// Lines a triangle fetch (its data bytes) touches.
    #[inline]
    pub fn triangle_lines(&self, slot: u32, line_bytes: u32) -> LineSpan {
        lines_touched(
            self.triangle_addr(slot),
            self.p.triangle_data_bytes,
            line_bytes,
        )
    }

    /// The treelet partition, with `memory.layout = "treelets"`.
    pub fn treelets(&self) -> Option<&Treelets> {
        self.p.treelets.as_ref()
    }

    /// The records of `kind`, if the image has them.
    pub fn records(&self, kind: RecordKind) -> Option<&RecordSet> {
        self.p.extras.iter().find(|s| s.kind == kind)
    }

    /// # Panics
    /// If the image has no records of `kind`: the model that asks chose the extras.
    fn set(&self, kind: RecordKind) -> &RecordSet {
        self.records(kind)
            .unwrap_or_else(|| panic!("the memory image has no {} region", kind.region_name()))
    }

    /// Byte address of record `i` of `kind`. Panics if the image has no such region.
    #[inline]
    pub fn record_addr(&self, kind: RecordKind, i: u32) -> u64 {
        self.set(kind).placement.addr(i)
    }

    /// Lines a fetch of record `i` of `kind` (its data bytes) touches. Panics if the image has
    /// no such region.
    #[inline]
    pub fn record_lines(&self, kind: RecordKind, i: u32, line_bytes: u32) -> LineSpan {
        let s = self.set(kind);
        lines_touched(s.placement.addr(i), s.data_bytes, line_bytes)
    }

    /// Byte address of the Wald record of triangle slot `slot`.
    pub fn wald_addr(&self, slot: u32) -> u64 {
        self.record_addr(RecordKind::Wald, slot)
    }

    /// Lines a Wald record fetch touches.
    pub fn wald_lines(&self, slot: u32, line_bytes: u32) -> LineSpan {
        self.record_lines(RecordKind::Wald, slot, line_bytes)
    }

    /// Byte address of material `id`'s record.
    pub fn material_addr(&self, id: u32) -> u64 {
        self.record_addr(RecordKind::Material, id)
    }

    /// Lines a material fetch touches.
    pub fn material_lines(&self, id: u32, line_bytes: u32) -> LineSpan {
        self.record_lines(RecordKind::Material, id, line_bytes)
    }

    /// Byte address of framebuffer pixel `pixel` (`y × width + x`).
    pub fn framebuffer_addr(&self, pixel: u32) -> u64 {
        self.record_addr(RecordKind::Pixel, pixel)
    }

    /// Lines a pixel access touches.
    pub fn framebuffer_lines(&self, pixel: u32, line_bytes: u32) -> LineSpan {
        self.record_lines(RecordKind::Pixel, pixel, line_bytes)
    }

    /// Byte address of path slot `slot`'s spilled state.
    pub fn path_state_addr(&self, slot: u32) -> u64 {
        self.record_addr(RecordKind::PathState, slot)
    }

    /// Lines a path state spill or fill touches.
    pub fn path_state_lines(&self, slot: u32, line_bytes: u32) -> LineSpan {
        self.record_lines(RecordKind::PathState, slot, line_bytes)
    }

    /// Check the layout: tables of the right length, data within records, records 4-byte
    /// aligned, inside a region, and pairwise disjoint; regions disjoint and aligned to
    /// `region_alignment`; with treelets, each treelet aligned and holding exactly its
    /// records, and every sibling pair in one treelet and one aligned pair slot.
    pub fn check(&self) -> Result<(), MemoryImageError> {
        let p = &self.p;
        let bad = |m: String| Err(MemoryImageError::Layout(m));
        if p.node_data_bytes > p.node_bytes || p.triangle_data_bytes > p.triangle_bytes {
            return bad("record data larger than the record".into());
        }
        if !p.region_alignment.is_power_of_two() {
            return bad(format!(
                "region alignment {} is not a power of two",
                p.region_alignment
            ));
        }
        for (i, s) in p.extras.iter().enumerate() {
            if s.data_bytes > s.stride {
                return bad(format!("{:?} record data larger than the record", s.kind));
            }
            if p.extras[..i].iter().any(|o| o.kind == s.kind) {
                return bad(format!("two sets of {:?} records", s.kind));
            }
        }
        let extra_tables = p
            .extras
            .iter()
            .map(|s| (s.kind.region_name(), &s.placement, s.count));
        for (what, pl, n) in [
            ("node", &p.nodes, p.node_count),
            ("triangle", &p.triangles, p.triangle_count),
        ]
        .into_iter()
        .chain(extra_tables)
        {
            if let Placement::Table(t) = pl {
                if t.len() != n as usize {
                    return bad(format!(
                        "{what} table has {} entries for {n} records",
                        t.len()
                    ));
                }
            }
        }
        let mut regions: Vec<&Region> = p.regions.iter().collect();
        regions.sort_by_key(|r| r.base);
        for w in regions.windows(2) {
            if w[0]
                .base
                .checked_add(w[0].size_bytes)
                .is_none_or(|e| e > w[1].base)
            {
                return bad(format!("regions {} and {} overlap", w[0].name, w[1].name));
            }
        }
        if let Some(r) = p.regions.iter().find(|r| r.base % p.region_alignment != 0) {
            return bad(format!(
                "region {} at {:#x} is not aligned to {}",
                r.name, r.base, p.region_alignment
            ));
        }
        // (address, size, what, index)
        let mut recs: Vec<(u64, u64, &str, u32)> =
            Vec::with_capacity(p.node_count as usize + p.triangle_count as usize);
        recs.extend((0..p.node_count).map(|i| (p.nodes.addr(i), p.node_bytes as u64, "node", i)));
        recs.extend(
            (0..p.triangle_count)
                .map(|i| (p.triangles.addr(i), p.triangle_bytes as u64, "triangle", i)),
        );
        for s in &p.extras {
            let what = s.kind.region_name();
            recs.extend((0..s.count).map(|i| (s.placement.addr(i), s.stride as u64, what, i)));
        }
        for &(a, s, what, i) in &recs {
            if a % 4 != 0 {
                return bad(format!("{what} {i} at {a:#x} is not 4-byte aligned"));
            }
            if !regions.iter().any(|r| r.contains(a, s)) {
                return bad(format!("{what} {i} at {a:#x} lies outside every region"));
            }
        }
        recs.sort_unstable_by_key(|r| r.0);
        for w in recs.windows(2) {
            if w[0].0 + w[0].1 > w[1].0 {
                return bad(format!(
                    "{} {} at {:#x} overlaps {} {} at {:#x}",
                    w[0].2, w[0].3, w[0].0, w[1].2, w[1].3, w[1].0
                ));
            }
        }
        match &p.treelets {
            Some(t) => self.check_treelets(t),
            None => Ok(()),
        }
    }

    /// The treelet part of [`MemoryImage::check`].
    fn check_treelets(&self, t: &Treelets) -> Result<(), MemoryImageError> {
        let p = &self.p;
        let bad = |m: String| Err(MemoryImageError::Layout(m));
        if t.node_treelet.len() != p.node_count as usize
            || t.triangle_treelet.len() != p.triangle_count as usize
        {
            return bad("treelet ids do not cover every node and triangle slot".into());
        }
        if t.record_bytes() != (p.node_bytes, p.triangle_bytes) {
            return bad("treelets were laid out for other record sizes".into());
        }
        let nb = p.node_bytes as u64;
        for (id, info) in t.treelets.iter().enumerate() {
            // Line-aligned, and never across more rows (alignment units) than its size needs.
            let align = p.region_alignment;
            if info.base % 64 != 0 || info.rows_touched(align) > info.rows_needed(align).max(1) {
                return bad(format!(
                    "treelet {id} at {:#x} ({} B) is not aligned to a line or spans more \
                     {align}-byte rows than it needs",
                    info.base, info.bytes
                ));
            }
            if info.bytes > t.budget_bytes {
                return bad(format!(
                    "treelet {id} holds {} B, over the {} B budget",
                    info.bytes, t.budget_bytes
                ));
            }
            let (ids, stride, pl) = match info.kind {
                crate::treelet::TreeletKind::Node => (&t.node_treelet, nb, &p.nodes),
                crate::treelet::TreeletKind::Triangle => {
                    (&t.triangle_treelet, p.triangle_bytes as u64, &p.triangles)
                }
            };
            for &r in t.members(id as u32) {
                let a = pl.addr(r);
                if ids[r as usize] != id as u32 || a < info.base || a + stride > info.end() {
                    return bad(format!(
                        "{} record {r} at {a:#x} is not inside its treelet {id} ({:#x}..{:#x})",
                        info.kind,
                        info.base,
                        info.end()
                    ));
                }
            }
        }
        // Pairs (2k+1, 2k+2): one treelet, one pair slot aligned to 2 × node_bytes.
        for left in (1..p.node_count.saturating_sub(1)).step_by(2) {
            let (l, r) = (left as usize, left as usize + 1);
            let base = t.treelets[t.node_treelet[l] as usize].base;
            let a = p.nodes.addr(left);
            if t.node_treelet[l] != t.node_treelet[r]
                || p.nodes.addr(left + 1) != a + nb
                || (a - base) % (2 * nb) != 0
            {
                return bad(format!(
                    "sibling pair {l},{r} is split or not in one aligned pair slot"
                ));
            }
        }
        Ok(())
    }

    /// The image's bytes, region by region (little-endian records as in
    /// `docs/MEMORY_IMAGE.md`, zero padding). `triangles` are the scene's triangles in scene
    /// order; `material_ids`, if given, one per scene triangle. For an image with a Wald or
    /// material region use [`MemoryImage::encode_scene`].
    pub fn encode(
        &self,
        bvh: &Bvh,
        triangles: &[[Vec3; 3]],
        material_ids: Option<&[u32]>,
    ) -> Result<Vec<RegionBytes>, MemoryImageError> {
        self.encode_scene(
            bvh,
            &SceneData {
                triangles,
                material_ids,
                ..Default::default()
            },
        )
    }

    /// The image's bytes with every record kind filled from `data`; the framebuffer and path
    /// state regions are zeros (nothing rendered, no path in flight).
    pub fn encode_scene(
        &self,
        bvh: &Bvh,
        data: &SceneData<'_>,
    ) -> Result<Vec<RegionBytes>, MemoryImageError> {
        let p = &self.p;
        let (triangles, material_ids) = (data.triangles, data.material_ids);
        if bvh.nodes.len() != p.node_count as usize
            || bvh.prim_ids.len() != p.triangle_count as usize
            || triangles.len() != bvh.prim_ids.len()
            || material_ids.is_some_and(|m| m.len() != triangles.len())
        {
            return Err(MemoryImageError::Layout(
                "encode: BVH, triangles or materials do not match the image".into(),
            ));
        }
        let wald = self.records(RecordKind::Wald);
        if wald.is_some_and(|s| data.wald.is_none_or(|w| w.len() != s.count as usize)) {
            return Err(MemoryImageError::Layout(
                "encode: the image has a Wald region: give one Wald record per triangle slot"
                    .into(),
            ));
        }
        let mats = self.records(RecordKind::Material);
        if mats.is_some_and(|s| data.materials.len() != s.count as usize) {
            return Err(MemoryImageError::Layout(format!(
                "encode: the image has {} materials, the data {}",
                mats.map_or(0, |s| s.count),
                data.materials.len()
            )));
        }
        let mut out: Vec<RegionBytes> = p
            .regions
            .iter()
            .map(|r| {
                usize::try_from(r.size_bytes)
                    .map(|n| RegionBytes {
                        region: r.clone(),
                        bytes: vec![0; n],
                    })
                    .map_err(|_| MemoryImageError::Layout(format!("region {} too large", r.name)))
            })
            .collect::<Result<_, _>>()?;
        let mut put = |addr: u64, data: &[u8], what: &str| -> Result<(), MemoryImageError> {
            let rb = out
                .iter_mut()
                .find(|rb| rb.region.contains(addr, data.len() as u64))
                .ok_or_else(|| MemoryImageError::Layout(format!("{what} outside every region")))?;
            let off = (addr - rb.region.base) as usize;
            rb.bytes[off..off + data.len()].copy_from_slice(data);
            Ok(())
        };
        let mut rec = Vec::with_capacity(NODE_BYTES_PARENT as usize);
        for (i, n) in bvh.nodes.iter().enumerate() {
            rec.clear();
            encode_node(n, &mut rec);
            if let Some(parents) = &p.parents {
                rec.extend_from_slice(&parents[i].to_le_bytes());
                let treelet = p
                    .treelets
                    .as_ref()
                    .map_or(NO_TREELET, |t| t.node_treelet[i]);
                rec.extend_from_slice(&treelet.to_le_bytes());
            }
            rec.truncate(p.node_data_bytes as usize);
            put(self.node_addr(i as u32), &rec, "node")?;
        }
        for (slot, &id) in bvh.prim_ids.iter().enumerate() {
            rec.clear();
            for v in &triangles[id as usize] {
                for c in v.to_array() {
                    rec.extend_from_slice(&c.to_le_bytes());
                }
            }
            rec.extend_from_slice(&id.to_le_bytes());
            let m = material_ids.map_or(NO_MATERIAL, |m| m[id as usize]);
            rec.extend_from_slice(&m.to_le_bytes());
            rec.truncate(p.triangle_data_bytes as usize);
            put(self.triangle_addr(slot as u32), &rec, "triangle")?;
            if let (Some(set), Some(w)) = (wald, data.wald) {
                // TriAccel's quarters: n_u n_v n_d k | b_nu b_nv b_d id | c_nu c_nv c_d pad.
                let w = &w[slot];
                rec.clear();
                rec.extend_from_slice(&w[..28]);
                rec.extend_from_slice(&id.to_le_bytes());
                rec.extend_from_slice(&w[28..]);
                put(set.placement.addr(slot as u32), &rec, "Wald record")?;
            }
        }
        if let Some(set) = mats {
            for (m, colours) in data.materials.iter().enumerate() {
                rec.clear();
                for c in colours.iter().flat_map(|v| v.to_array()) {
                    rec.extend_from_slice(&c.to_le_bytes());
                }
                put(set.placement.addr(m as u32), &rec, "material")?;
            }
        }
        Ok(out)
    }
}

/// The first 32 bytes of a node record: min xyz, max xyz (f32), index, count (u32), LE.
fn encode_node(n: &Node, out: &mut Vec<u8>) {
    for c in n
        .bounds
        .min
        .to_array()
        .into_iter()
        .chain(n.bounds.max.to_array())
    {
        out.extend_from_slice(&c.to_le_bytes());
    }
    out.extend_from_slice(&n.index.to_le_bytes());
    out.extend_from_slice(&n.count.to_le_bytes());
}

/// Decode the first 32 bytes of a node record (the inverse of the encoding in
/// [`MemoryImage::encode`]). `None` if `record` is shorter than 32 bytes.
pub fn decode_node(record: &[u8]) -> Option<Node> {
    let w = |k: usize| -> Option<[u8; 4]> { record.get(4 * k..4 * k + 4)?.try_into().ok() };
    let f = |k: usize| w(k).map(f32::from_le_bytes);
    let u = |k: usize| w(k).map(u32::from_le_bytes);
    Some(Node {
        bounds: Aabb::new(
            Vec3::new(f(0)?, f(1)?, f(2)?),
            Vec3::new(f(3)?, f(4)?, f(5)?),
        ),
        index: u(6)?,
        count: u(7)?,
    })
}

fn align_up(x: u64, a: u64) -> Option<u64> {
    Some(x.checked_add(a - 1)? / a * a)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_touched_counts_straddles() {
        assert_eq!(lines_touched(0, 32, 64).count, 1);
        assert_eq!(lines_touched(32, 32, 64).count, 1);
        assert_eq!(lines_touched(48, 32, 64).count, 2);
        assert_eq!(lines_touched(60, 4, 64).count, 1);
        assert_eq!(lines_touched(61, 4, 64).count, 2);
        assert_eq!(lines_touched(100, 0, 64).count, 0);
        let s = lines_touched(130, 200, 64);
        assert_eq!(s.first, 128);
        assert_eq!(s.iter().collect::<Vec<_>>(), vec![128, 192, 256, 320]);
        // Non-power-of-two line sizes work too.
        assert_eq!(
            lines_touched(95, 10, 48).iter().collect::<Vec<_>>(),
            vec![48, 96]
        );
    }

    #[test]
    fn align_up_rounds_to_multiples() {
        assert_eq!(align_up(0, 8192), Some(0));
        assert_eq!(align_up(1, 8192), Some(8192));
        assert_eq!(align_up(8192, 8192), Some(8192));
        assert_eq!(align_up(u64::MAX - 5, 8192), None);
    }

    #[test]
    fn node_record_round_trips() {
        let n = Node {
            bounds: Aabb::new(Vec3::new(-1.0, 2.0, 3.5), Vec3::new(4.0, 5.25, 6.0)),
            index: 77,
            count: 3,
        };
        let mut b = Vec::new();
        encode_node(&n, &mut b);
        assert_eq!(b.len(), 32);
        assert_eq!(decode_node(&b), Some(n));
        assert_eq!(decode_node(&b[..31]), None);
    }
}
