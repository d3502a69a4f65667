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

use crate::config::{
    MemoryLayoutConfig, NODE_BYTES_PARENT, NODE_BYTES_PLAIN, TRIANGLE_BYTES_DEFAULT,
};
use crate::flat::{Bvh, NO_PARENT, Node};
use rtsim_config::{ConfigError, Validate};
use rtsim_core::{Aabb, Vec3};
use serde::Serialize;

/// Name of the region holding node records.
pub const NODES_REGION: &str = "nodes";
/// Name of the region holding triangle records.
pub const TRIANGLES_REGION: &str = "triangles";
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
    /// The default layout: nodes in array order (the BVH's depth- or breadth-first order) from
    /// `memory.base_address`, after one record of padding if `align_sibling_pairs`; then the
    /// triangles in slot order from the next multiple of `region_alignment`.
    pub fn new(bvh: &Bvh, config: &MemoryLayoutConfig) -> Result<Self, MemoryImageError> {
        config.validate()?;
        let node_bytes = config.resolved_node_bytes();
        let triangle_bytes = config.triangle_bytes;
        let node_count = bvh.nodes.len() as u32;
        let triangle_count = bvh.prim_ids.len() as u32;
        let overflow = || MemoryImageError::AddressOverflow {
            base: config.base_address,
        };
        let pad = if config.align_sibling_pairs && node_count > 0 {
            node_bytes as u64
        } else {
            0
        };
        let node_base = config.base_address;
        let node_size = (node_count as u64 * node_bytes as u64) + pad;
        let tri_base = align_up(
            node_base.checked_add(node_size).ok_or_else(overflow)?,
            config.region_alignment,
        )
        .ok_or_else(overflow)?;
        let tri_size = triangle_count as u64 * triangle_bytes as u64;
        tri_base.checked_add(tri_size).ok_or_else(overflow)?;
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
                regions: vec![
                    Region {
                        name: NODES_REGION.into(),
                        base: node_base,
                        size_bytes: node_size,
                    },
                    Region {
                        name: TRIANGLES_REGION.into(),
                        base: tri_base,
                        size_bytes: tri_size,
                    },
                ],
                nodes: Placement::Linear {
                    base: node_base + pad,
                    stride: node_bytes as u64,
                },
                triangles: Placement::Linear {
                    base: tri_base,
                    stride: triangle_bytes as u64,
                },
                parents: config.parent_pointers.then(|| bvh.parents()),
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

    /// Check the layout: tables of the right length, data within records, records 4-byte
    /// aligned, inside a region, and pairwise disjoint; regions disjoint.
    pub fn check(&self) -> Result<(), MemoryImageError> {
        let p = &self.p;
        let bad = |m: String| Err(MemoryImageError::Layout(m));
        if p.node_data_bytes > p.node_bytes || p.triangle_data_bytes > p.triangle_bytes {
            return bad("record data larger than the record".into());
        }
        for (what, pl, n) in [
            ("node", &p.nodes, p.node_count),
            ("triangle", &p.triangles, p.triangle_count),
        ] {
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
        // (address, size, what, index)
        let mut recs: Vec<(u64, u64, &str, u32)> =
            Vec::with_capacity(p.node_count as usize + p.triangle_count as usize);
        recs.extend((0..p.node_count).map(|i| (p.nodes.addr(i), p.node_bytes as u64, "node", i)));
        recs.extend(
            (0..p.triangle_count)
                .map(|i| (p.triangles.addr(i), p.triangle_bytes as u64, "triangle", i)),
        );
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
        Ok(())
    }

    /// The image's bytes, region by region (little-endian records as in
    /// `docs/MEMORY_IMAGE.md`, zero padding). `triangles` are the scene's triangles in scene
    /// order; `material_ids`, if given, one per scene triangle.
    pub fn encode(
        &self,
        bvh: &Bvh,
        triangles: &[[Vec3; 3]],
        material_ids: Option<&[u32]>,
    ) -> Result<Vec<RegionBytes>, MemoryImageError> {
        let p = &self.p;
        if bvh.nodes.len() != p.node_count as usize
            || bvh.prim_ids.len() != p.triangle_count as usize
            || triangles.len() != bvh.prim_ids.len()
            || material_ids.is_some_and(|m| m.len() != triangles.len())
        {
            return Err(MemoryImageError::Layout(
                "encode: BVH, triangles or materials do not match the image".into(),
            ));
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
                rec.extend_from_slice(&NO_TREELET.to_le_bytes());
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
