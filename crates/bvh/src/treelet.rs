//! STRaTA's treelets: the BVH cut into pieces no larger than a byte budget, each laid out
//! contiguously and aligned to DRAM rows (Kopta et al., "Memory Considerations for Low Energy
//! Ray Tracing", CGF 2015, §3.1 and Figure 4, after Aila & Karras, "Architecture
//! considerations for tracing incoherent rays", HPG 2010).
//!
//! - **Node treelets** are grown greedily from a root by the probability that a ray reaches a
//!   node, which under the surface-area model is the node's surface area relative to the
//!   treelet root (Aila & Karras §3): repeatedly add the frontier unit with the largest area
//!   until the budget is full; the frontier units left over become roots of new treelets.
//!   The unit is a **sibling pair**: the flat BVH stores the children of a node at `index,
//!   index + 1`, the memory image puts them in one aligned slot, and a traversal tests both
//!   boxes at once, so a pair is never split. A pair is fetched exactly when a ray visits its
//!   parent, so its priority is the parent's area. The tree's root is the only unit of one.
//! - **Triangle treelets** are "a collection of triangles in nearby leaf nodes" (STRaTA
//!   Figure 4), separate from node treelets: triangle slots in leaf (slot) order, cut before
//!   a leaf that would overflow the budget, so one leaf's triangles are never split.
//!
//! Treelet ids form one space: node treelets `0 .. node_treelet_count`, then triangle
//! treelets (a STRaTA chip keeps one ray buffer per treelet of either kind). Construction is
//! deterministic: ties in area go to the lower node index, leftover frontier pairs become new
//! treelets in node-index order, and treelets are numbered in the order they are grown
//! (breadth-first over treelets).
//!
//! [`Treelets::build`] also places them: node treelets one after another from
//! `memory.base_address`, then the triangle treelets from the next multiple of
//! `memory.region_alignment` (a DRAM row). Packed (`memory.treelet_packing`, the default), a
//! treelet starts at the next 64-byte line and moves to the next row only if it would
//! otherwise touch more rows than its size needs, so the many small fringe treelets share
//! rows; unpacked, every treelet starts a row. Inside a node treelet, records follow in
//! the order they were added (the top treelet starts with one padding record so the root
//! ends a pair slot, as in the linear layout); inside a triangle treelet, in slot order.
//! [`check_rows`] compares each treelet's DRAM rows with what its size needs.

use crate::config::{Fringe, MemoryLayoutConfig, RowCheck};
use crate::flat::Bvh;
use rtsim_config::{ConfigError, Validate};
use serde::Serialize;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};
use std::fmt;

/// What a treelet holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TreeletKind {
    /// BVH node records (inner nodes and leaves).
    Node,
    /// Triangle records of nearby leaves.
    Triangle,
}

impl fmt::Display for TreeletKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TreeletKind::Node => "node",
            TreeletKind::Triangle => "triangle",
        })
    }
}

/// One treelet.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TreeletInfo {
    pub kind: TreeletKind,
    /// Node treelets: the node the treelet is entered at, node 0 for the top treelet, else
    /// the left child of the entry sibling pair (both children are in the treelet, their
    /// parent in another); a treelet of packed fringe subtrees (`memory.treelet_fringe =
    /// "packed"`) has one entry pair per subtree and names the first. `None` for triangle
    /// treelets.
    pub root: Option<u32>,
    /// Records held: nodes or triangle slots.
    pub records: u32,
    /// Bytes occupied from `base`: the records, plus the top treelet's padding record.
    pub bytes: u64,
    /// First byte address (a 64-byte line; a multiple of `memory.region_alignment` unless
    /// `memory.treelet_packing` let it share a row).
    pub base: u64,
}

impl TreeletInfo {
    /// One past the last byte.
    pub fn end(&self) -> u64 {
        self.base + self.bytes
    }

    /// Fraction of the budget used (`bytes / budget_bytes`).
    pub fn fill(&self, budget_bytes: u64) -> f64 {
        self.bytes as f64 / budget_bytes as f64
    }

    /// DRAM rows the treelet's bytes touch when `row_bytes` aligned, contiguous bytes share
    /// one row (`rtsim_dram`'s `AddressMapper::row_run_bytes`).
    pub fn rows_touched(&self, row_bytes: u64) -> u64 {
        if self.bytes == 0 {
            return 0;
        }
        (self.end() - 1) / row_bytes - self.base / row_bytes + 1
    }

    /// The fewest rows its bytes could occupy: `ceil(bytes / row_bytes)`.
    pub fn rows_needed(&self, row_bytes: u64) -> u64 {
        self.bytes.div_ceil(row_bytes)
    }
}

/// Why a treelet layout could not be built (or was refused).
#[derive(Debug, thiserror::Error)]
pub enum TreeletError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(
        "memory.treelet_bytes = {budget} cannot hold leaf {leaf}: its {count} triangles take \
         {bytes} B at memory.triangle_bytes = {triangle_bytes} (a leaf is never split); raise \
         memory.treelet_bytes to at least {bytes} rounded up to a multiple of 64"
    )]
    LeafTooLarge {
        budget: u64,
        leaf: u32,
        count: u32,
        bytes: u64,
        triangle_bytes: u32,
    },
    #[error(
        "the treelet layout does not fit in a 64-bit address space from memory.base_address = \
         {base:#x}"
    )]
    AddressOverflow { base: u64 },
    #[error(
        "memory.treelet_row_check = \"strict\": {count} treelet(s) span more DRAM rows than \
         their size needs, first {first} (align treelets to the row size: set \
         memory.region_alignment to a multiple of {row_bytes})"
    )]
    RowSpan {
        count: usize,
        first: RowFinding,
        row_bytes: u64,
    },
}

/// A treelet that spans more DRAM rows than its size needs: each extra row is one more
/// activation when the treelet is loaded, which is what treelets are meant to avoid
/// (STRaTA §3.1, Figure 4).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct RowFinding {
    pub treelet: u32,
    pub kind: TreeletKind,
    pub base: u64,
    pub bytes: u64,
    pub rows_touched: u64,
    pub rows_needed: u64,
}

impl fmt::Display for RowFinding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} treelet {} at {:#x} ({} B) spans {} DRAM rows where {} would hold it",
            self.kind, self.treelet, self.base, self.bytes, self.rows_touched, self.rows_needed
        )
    }
}

/// The treelets of one BVH and where they are. See the module docs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Treelets {
    /// The budget they were grown to (`memory.treelet_bytes`).
    pub budget_bytes: u64,
    /// Treelet id of every node (index into `Bvh::nodes`).
    pub node_treelet: Vec<u32>,
    /// Triangle-treelet id of every triangle slot (index into `Bvh::prim_ids`).
    pub triangle_treelet: Vec<u32>,
    /// Per treelet id: node treelets first, then triangle treelets.
    pub treelets: Vec<TreeletInfo>,
    /// Number of node treelets (ids below this are node treelets).
    pub node_treelet_count: u32,
    /// Record indices (nodes, or triangle slots) in placement order, treelet after treelet.
    members: Vec<u32>,
    /// `members[first[t] .. first[t + 1]]` are treelet `t`'s records.
    first: Vec<u32>,
    /// Record strides the layout used.
    node_bytes: u32,
    triangle_bytes: u32,
}

/// A sibling pair on a treelet's frontier: `left`, `left + 1`, with the area of their parent.
#[derive(Clone, Copy, Debug)]
struct Frontier {
    area: f32,
    left: u32,
}

impl PartialEq for Frontier {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Frontier {}
impl PartialOrd for Frontier {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Frontier {
    /// Larger area first; equal areas: lower node index first (the heap pops the maximum).
    fn cmp(&self, o: &Self) -> Ordering {
        self.area
            .total_cmp(&o.area)
            .then_with(|| o.left.cmp(&self.left))
    }
}

/// Nodes in each node's subtree, itself included (children are found through `index`, so
/// no order of the node array is assumed).
fn subtree_sizes(bvh: &Bvh) -> Vec<u32> {
    let mut size = vec![0u32; bvh.nodes.len()];
    // Post-order without recursion: a node is summed after both children.
    let mut stack = vec![(0u32, false)];
    while let Some((i, children_done)) = stack.pop() {
        let n = &bvh.nodes[i as usize];
        if n.is_leaf() {
            size[i as usize] = 1;
        } else if children_done {
            size[i as usize] = 1 + size[n.index as usize] + size[n.index as usize + 1];
        } else {
            stack.push((i, true));
            stack.push((n.index, false));
            stack.push((n.index + 1, false));
        }
    }
    size
}

fn align_up(x: u64, a: u64) -> Option<u64> {
    Some(x.checked_add(a - 1)? / a * a)
}

impl Treelets {
    /// Partition `bvh` into node and triangle treelets of at most `memory.treelet_bytes` and
    /// place them (see the module docs). Uses `config`'s record sizes, base address and
    /// region alignment whatever `memory.layout` says.
    pub fn build(bvh: &Bvh, config: &MemoryLayoutConfig) -> Result<Treelets, TreeletError> {
        config.validate()?;
        let node_bytes = config.resolved_node_bytes();
        let triangle_bytes = config.triangle_bytes;
        let budget = config.treelet_bytes;
        let mut t = Treelets {
            budget_bytes: budget,
            node_treelet: vec![u32::MAX; bvh.nodes.len()],
            triangle_treelet: vec![u32::MAX; bvh.prim_ids.len()],
            treelets: Vec::new(),
            node_treelet_count: 0,
            members: Vec::with_capacity(bvh.nodes.len() + bvh.prim_ids.len()),
            first: vec![0],
            node_bytes,
            triangle_bytes,
        };
        t.grow_node_treelets(bvh, config.treelet_fringe == Fringe::Packed);
        t.node_treelet_count = t.treelets.len() as u32;
        t.fill_triangle_treelets(bvh)?;
        t.place(
            config.base_address,
            config.region_alignment,
            config.treelet_packing,
        )?;
        Ok(t)
    }

    /// Node treelets, grown by sibling pairs in order of their parent's surface area; with
    /// `pack_fringe`, the leftover pairs whose subtrees fit the budget whole are packed into
    /// shared treelets instead of each growing its own.
    fn grow_node_treelets(&mut self, bvh: &Bvh, pack_fringe: bool) {
        if bvh.nodes.is_empty() {
            return;
        }
        let nb = self.node_bytes as u64;
        let pair = 2 * nb;
        // Nodes in each node's subtree (itself included), for the packing.
        let subtree = if pack_fringe {
            subtree_sizes(bvh)
        } else {
            Vec::new()
        };
        // Entry units: 0 is the root alone, anything else the left child of a pair.
        let mut entries = VecDeque::from([0u32]);
        let mut heap = BinaryHeap::new();
        let mut small = Vec::new();
        while let Some(entry) = entries.pop_front() {
            let id = self.treelets.len() as u32;
            let start = self.members.len();
            heap.clear();
            // The top treelet: a padding record, then the root, so pairs start slot-aligned.
            let mut used = pair;
            if entry == 0 {
                self.add_node(bvh, id, 0, &mut heap);
            } else {
                self.add_node(bvh, id, entry, &mut heap);
                self.add_node(bvh, id, entry + 1, &mut heap);
            }
            while heap.peek().is_some() && used + pair <= self.budget_bytes {
                let f = heap.pop().expect("peeked");
                self.add_node(bvh, id, f.left, &mut heap);
                self.add_node(bvh, id, f.left + 1, &mut heap);
                used += pair;
            }
            let mut rest: Vec<u32> = heap.drain().map(|f| f.left).collect();
            rest.sort_unstable();
            self.close_node_treelet(Some(entry), start, used);
            if !pack_fringe {
                entries.extend(rest);
                continue;
            }
            // Whole subtrees that fit the budget share treelets, next fit in node-index order;
            // the others are grown like any entry.
            small.clear();
            for left in rest {
                let n = u64::from(subtree[left as usize] + subtree[left as usize + 1]);
                if n * nb <= self.budget_bytes {
                    small.push(left);
                } else {
                    entries.push_back(left);
                }
            }
            let mut open: Option<(u32, usize, u64)> = None;
            for &left in &small {
                let bytes = u64::from(subtree[left as usize] + subtree[left as usize + 1]) * nb;
                if let Some((first, start, used)) = open
                    && used + bytes > self.budget_bytes
                {
                    self.close_node_treelet(Some(first), start, used);
                    open = None;
                }
                let (first, start, used) = open.unwrap_or((left, self.members.len(), 0));
                let id = self.treelets.len() as u32;
                self.add_subtree(bvh, id, left);
                open = Some((first, start, used + bytes));
            }
            if let Some((first, start, used)) = open {
                self.close_node_treelet(Some(first), start, used);
            }
        }
    }

    /// Put node `node` in treelet `id`; an inner node's children pair joins the frontier.
    fn add_node(&mut self, bvh: &Bvh, id: u32, node: u32, heap: &mut BinaryHeap<Frontier>) {
        self.node_treelet[node as usize] = id;
        self.members.push(node);
        let n = &bvh.nodes[node as usize];
        if !n.is_leaf() {
            heap.push(Frontier {
                area: n.bounds.surface_area(),
                left: n.index,
            });
        }
    }

    /// Put the pair `left`, `left + 1` and everything below it in treelet `id`, pair by pair
    /// (depth first), so every pair stays in one aligned slot.
    fn add_subtree(&mut self, bvh: &Bvh, id: u32, left: u32) {
        let mut stack = vec![left];
        while let Some(l) = stack.pop() {
            for node in [l, l + 1] {
                self.node_treelet[node as usize] = id;
                self.members.push(node);
            }
            for node in [l + 1, l] {
                let n = &bvh.nodes[node as usize];
                if !n.is_leaf() {
                    stack.push(n.index);
                }
            }
        }
    }

    /// End the node treelet whose records start at `members[start]`.
    fn close_node_treelet(&mut self, root: Option<u32>, start: usize, used: u64) {
        let records = (self.members.len() - start) as u32;
        self.treelets.push(TreeletInfo {
            kind: TreeletKind::Node,
            root,
            records,
            bytes: used,
            base: 0,
        });
        self.first.push(self.members.len() as u32);
    }

    /// Triangle treelets: leaves in slot order, a new treelet before a leaf that would
    /// overflow the budget.
    fn fill_triangle_treelets(&mut self, bvh: &Bvh) -> Result<(), TreeletError> {
        let tb = self.triangle_bytes as u64;
        let mut leaves: Vec<(u32, u32, u32)> = bvh
            .nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| n.is_leaf())
            .map(|(i, n)| (n.index, n.count, i as u32))
            .collect();
        leaves.sort_unstable();
        let mut used = 0u64;
        for (start, count, leaf) in leaves {
            let bytes = count as u64 * tb;
            if bytes > self.budget_bytes {
                return Err(TreeletError::LeafTooLarge {
                    budget: self.budget_bytes,
                    leaf,
                    count,
                    bytes,
                    triangle_bytes: self.triangle_bytes,
                });
            }
            let open = self.treelets.len() as u32 > self.node_treelet_count;
            if !open || used + bytes > self.budget_bytes {
                if open {
                    self.first.push(self.members.len() as u32);
                }
                self.treelets.push(TreeletInfo {
                    kind: TreeletKind::Triangle,
                    root: None,
                    records: 0,
                    bytes: 0,
                    base: 0,
                });
                used = 0;
            }
            let id = self.treelets.len() as u32 - 1;
            let info = self.treelets.last_mut().expect("just pushed");
            for slot in start..start + count {
                self.triangle_treelet[slot as usize] = id;
                self.members.push(slot);
            }
            info.records += count;
            used += bytes;
            info.bytes = used;
        }
        if self.treelets.len() as u32 > self.node_treelet_count {
            self.first.push(self.members.len() as u32);
        }
        Ok(())
    }

    /// Give every treelet a base: node treelets from `base`, triangle treelets from the next
    /// multiple of `align` (a DRAM row) after them. Unpacked, each treelet starts at a multiple
    /// of `align`; packed, at the next 64-byte line, moved to the next multiple of `align` only
    /// when it would otherwise touch more rows than its size needs.
    fn place(&mut self, base: u64, align: u64, packed: bool) -> Result<(), TreeletError> {
        /// Cache line (DESIGN §3: 64 B lines in every cache of both chips).
        const LINE: u64 = 64;
        let overflow = || TreeletError::AddressOverflow { base };
        let mut cursor = base;
        let n_nodes = self.node_treelet_count as usize;
        for (k, info) in self.treelets.iter_mut().enumerate() {
            if k == n_nodes {
                cursor = align_up(cursor, align).ok_or_else(overflow)?;
            }
            if packed {
                cursor = align_up(cursor, LINE).ok_or_else(overflow)?;
                let last = cursor
                    .checked_add(info.bytes.max(1) - 1)
                    .ok_or_else(overflow)?;
                let touched = last / align - cursor / align + 1;
                if touched > info.bytes.div_ceil(align).max(1) {
                    cursor = align_up(cursor, align).ok_or_else(overflow)?;
                }
            } else {
                cursor = align_up(cursor, align).ok_or_else(overflow)?;
            }
            info.base = cursor;
            cursor = cursor.checked_add(info.bytes).ok_or_else(overflow)?;
        }
        Ok(())
    }

    /// Number of treelets of both kinds.
    pub fn len(&self) -> usize {
        self.treelets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.treelets.is_empty()
    }

    /// The node treelets (ids `0 .. node_treelet_count`).
    pub fn node_treelets(&self) -> &[TreeletInfo] {
        &self.treelets[..self.node_treelet_count as usize]
    }

    /// The triangle treelets (ids from `node_treelet_count`).
    pub fn triangle_treelets(&self) -> &[TreeletInfo] {
        &self.treelets[self.node_treelet_count as usize..]
    }

    /// Treelet `id`'s records (node indices or triangle slots) in address order.
    pub fn members(&self, id: u32) -> &[u32] {
        let (a, b) = (self.first[id as usize], self.first[id as usize + 1]);
        &self.members[a as usize..b as usize]
    }

    /// Node and triangle strides the layout used.
    pub fn record_bytes(&self) -> (u32, u32) {
        (self.node_bytes, self.triangle_bytes)
    }

    /// `(base, end)` of all node treelets and of all triangle treelets (`(0, 0)`-style empty
    /// ranges at the natural position when a kind has none).
    pub(crate) fn spans(&self, base: u64, align: u64) -> Option<((u64, u64), (u64, u64))> {
        let nodes = match (self.node_treelets().first(), self.node_treelets().last()) {
            (Some(a), Some(b)) => (a.base, b.end()),
            _ => (base, base),
        };
        let tri_base = align_up(nodes.1, align)?;
        let tris = match (
            self.triangle_treelets().first(),
            self.triangle_treelets().last(),
        ) {
            (Some(a), Some(b)) => (a.base, b.end()),
            _ => (tri_base, tri_base),
        };
        Some((nodes, tris))
    }

    /// Address of every node record and every triangle record.
    pub(crate) fn addresses(&self) -> (Vec<u64>, Vec<u64>) {
        let mut nodes = vec![0u64; self.node_treelet.len()];
        let mut tris = vec![0u64; self.triangle_treelet.len()];
        for (id, info) in self.treelets.iter().enumerate() {
            let (table, stride, skip) = match info.kind {
                // The top treelet's first slot is the padding record.
                TreeletKind::Node => (&mut nodes, self.node_bytes as u64, (id == 0) as u64),
                TreeletKind::Triangle => (&mut tris, self.triangle_bytes as u64, 0),
            };
            for (k, &r) in self.members(id as u32).iter().enumerate() {
                table[r as usize] = info.base + (skip + k as u64) * stride;
            }
        }
        (nodes, tris)
    }

    /// Count, bytes and DRAM rows per kind, for reports.
    pub fn summary(&self, row_bytes: u64) -> TreeletSummary {
        let kind = |infos: &[TreeletInfo]| {
            let mut s = KindSummary::default();
            for t in infos {
                s.add(t.bytes, t.rows_touched(row_bytes));
            }
            s
        };
        TreeletSummary {
            budget_bytes: self.budget_bytes,
            row_bytes,
            node: kind(self.node_treelets()),
            triangle: kind(self.triangle_treelets()),
        }
    }
}

/// Treelets that span more DRAM rows than their size needs, when `row_bytes` aligned,
/// contiguous bytes share one row (`rtsim_dram::AddressMapper::row_run_bytes`). Empty when
/// the layout is row-clean. With `gddr5-trax` (8 KB) and the defaults (16 KB treelets at
/// 8 KB alignment) every treelet needs and touches at most two rows.
pub fn check_rows(treelets: &Treelets, row_bytes: u64) -> Vec<RowFinding> {
    treelets
        .treelets
        .iter()
        .enumerate()
        .filter_map(|(id, t)| {
            let (touched, needed) = (t.rows_touched(row_bytes), t.rows_needed(row_bytes));
            (touched > needed).then_some(RowFinding {
                treelet: id as u32,
                kind: t.kind,
                base: t.base,
                bytes: t.bytes,
                rows_touched: touched,
                rows_needed: needed,
            })
        })
        .collect()
}

/// Apply `memory.treelet_row_check` to the findings of [`check_rows`]: `warn` hands them
/// back for the caller to report, `strict` refuses the layout with the first one.
pub fn enforce_row_check(
    findings: Vec<RowFinding>,
    policy: RowCheck,
    row_bytes: u64,
) -> Result<Vec<RowFinding>, TreeletError> {
    match (policy, findings.first()) {
        (RowCheck::Strict, Some(first)) => Err(TreeletError::RowSpan {
            count: findings.len(),
            first: first.clone(),
            row_bytes,
        }),
        _ => Ok(findings),
    }
}

/// Sums over the treelets of one kind (ratios are computed when reported).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct KindSummary {
    pub count: u64,
    pub bytes: u64,
    pub min_bytes: u64,
    pub max_bytes: u64,
    pub rows: u64,
    pub min_rows: u64,
    pub max_rows: u64,
}

impl KindSummary {
    fn add(&mut self, bytes: u64, rows: u64) {
        if self.count == 0 {
            (self.min_bytes, self.min_rows) = (bytes, rows);
        }
        self.count += 1;
        self.bytes += bytes;
        self.rows += rows;
        self.min_bytes = self.min_bytes.min(bytes);
        self.max_bytes = self.max_bytes.max(bytes);
        self.min_rows = self.min_rows.min(rows);
        self.max_rows = self.max_rows.max(rows);
    }

    /// Mean bytes per treelet (0 with none).
    pub fn mean_bytes(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            self.bytes as f64 / self.count as f64
        }
    }

    /// Mean DRAM rows per treelet (0 with none).
    pub fn mean_rows(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            self.rows as f64 / self.count as f64
        }
    }
}

/// Treelet counts, fill and DRAM rows by kind (`rtsim bvh-stats`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TreeletSummary {
    pub budget_bytes: u64,
    pub row_bytes: u64,
    pub node: KindSummary,
    pub triangle: KindSummary,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flat::Node;
    use rtsim_core::{Aabb, Vec3};

    /// A complete binary tree of `levels` levels (root = level 0) in breadth-first order
    /// with pairs at (1, 2), (3, 4) …; leaf `k` covers x in [k, k + 1) with one triangle.
    /// Boxes shrink with depth so areas order the nodes by level.
    fn complete(levels: u32) -> Bvh {
        let n = (1u32 << (levels + 1)) - 1;
        let first_leaf = (1u32 << levels) - 1;
        let mut nodes = vec![
            Node {
                bounds: Aabb::EMPTY,
                index: 0,
                count: 0,
            };
            n as usize
        ];
        for i in (0..n).rev() {
            let node = &mut nodes[i as usize];
            if i >= first_leaf {
                let k = (i - first_leaf) as f32;
                *node = Node {
                    bounds: Aabb::new(Vec3::new(k, 0.0, 0.0), Vec3::new(k + 1.0, 1.0, 1.0)),
                    index: i - first_leaf,
                    count: 1,
                };
            } else {
                let l = 2 * i + 1;
                let b = nodes[l as usize].bounds.union(nodes[l as usize + 1].bounds);
                nodes[i as usize] = Node {
                    bounds: b,
                    index: l,
                    count: 0,
                };
            }
        }
        Bvh {
            nodes,
            prim_ids: (0..(1u32 << levels)).collect(),
        }
    }

    fn cfg(treelet_bytes: u64) -> MemoryLayoutConfig {
        MemoryLayoutConfig {
            treelet_bytes,
            region_alignment: 64,
            ..Default::default()
        }
    }

    #[test]
    fn greedy_growth_by_pairs_fills_the_budget() {
        // 32-byte nodes: the top treelet holds pad + root + 3 pairs in 256 bytes.
        let bvh = complete(4); // 31 nodes
        let t = Treelets::build(&bvh, &cfg(256)).unwrap();
        let top = &t.treelets[0];
        assert_eq!((top.records, top.bytes, top.root), (7, 256, Some(0)));
        // Largest areas first: the root's pair, then both level-1 pairs (equal areas: the
        // lower index first).
        assert_eq!(t.members(0), &[0, 1, 2, 3, 4, 5, 6]);
        // The 4 leftover frontier pairs of level 3 start treelets, in node-index order; each
        // takes its pair and the 2 pairs below it (leaves): 6 nodes, 192 bytes.
        let roots: Vec<_> = t.node_treelets()[1..].iter().map(|i| i.root).collect();
        assert_eq!(roots, [Some(7), Some(9), Some(11), Some(13)]);
        assert_eq!(t.members(1), &[7, 8, 15, 16, 17, 18]);
        assert!(t.node_treelets().iter().all(|i| i.bytes <= 256));
        assert_eq!(t.node_treelet_count, 5);
    }

    #[test]
    fn packing_shares_rows_without_adding_rows_to_any_treelet() {
        let bvh = complete(9);
        let rows = 1024;
        let layout = |packed| {
            Treelets::build(
                &bvh,
                &MemoryLayoutConfig {
                    treelet_bytes: 1536,
                    region_alignment: rows,
                    treelet_packing: packed,
                    ..Default::default()
                },
            )
            .unwrap()
        };
        let (packed, unpacked) = (layout(true), layout(false));
        assert_eq!(packed.node_treelet, unpacked.node_treelet);
        for t in [&packed, &unpacked] {
            let mut prev_end = 0;
            for info in &t.treelets {
                assert_eq!(info.base % 64, 0);
                assert!(info.base >= prev_end, "treelets overlap");
                prev_end = info.end();
                assert!(info.rows_touched(rows) <= info.rows_needed(rows).max(1));
            }
            assert!(check_rows(t, rows).is_empty());
        }
        assert!(unpacked.treelets.iter().all(|i| i.base % rows == 0));
        let span = |t: &Treelets| t.node_treelets().last().unwrap().end();
        assert!(span(&packed) < span(&unpacked));
        // Small treelets share rows when packed.
        assert!(packed.treelets.iter().any(|i| i.base % rows != 0));
    }

    #[test]
    fn triangle_treelets_never_split_a_leaf() {
        // Leaves of 3 triangles at 44 bytes = 132 B; a 320-byte budget takes two per treelet.
        let mut bvh = complete(2);
        for (k, n) in bvh.nodes[3..].iter_mut().enumerate() {
            (n.index, n.count) = (3 * k as u32, 3);
        }
        bvh.prim_ids = (0..12).collect();
        let t = Treelets::build(&bvh, &cfg(320)).unwrap();
        let tris = t.triangle_treelets();
        assert_eq!(tris.len(), 2);
        assert!(tris.iter().all(|i| i.records == 6 && i.bytes == 264));
        let first = t.node_treelet_count;
        assert_eq!(
            t.triangle_treelet,
            [vec![first; 6], vec![first + 1; 6]].concat()
        );
        // A budget below one leaf is an error naming the key.
        let e = Treelets::build(&bvh, &cfg(128)).unwrap_err().to_string();
        assert!(
            e.contains("memory.treelet_bytes = 128") && e.contains("132 B"),
            "{e}"
        );
    }

    #[test]
    fn rows_touched_and_needed() {
        let t = |base, bytes| TreeletInfo {
            kind: TreeletKind::Node,
            root: Some(0),
            records: 1,
            bytes,
            base,
        };
        assert_eq!(t(0, 16384).rows_touched(8192), 2);
        assert_eq!(t(8192, 16384).rows_touched(8192), 2);
        assert_eq!(t(4096, 16384).rows_touched(8192), 3);
        assert_eq!(t(4096, 16384).rows_needed(8192), 2);
        assert_eq!(t(8000, 200).rows_touched(8192), 2);
        assert_eq!(t(8000, 200).rows_needed(8192), 1);
        assert_eq!(t(0, 0).rows_touched(8192), 0);
    }

    #[test]
    fn row_check_finds_misaligned_treelets_and_strict_refuses() {
        let bvh = complete(6);
        // 2 KB treelets at 1 KB alignment from 3 KB: within 1 KB rows they are clean, but
        // under 4 KB rows the full top treelet (3 KB .. 5 KB) straddles a row boundary.
        let c = MemoryLayoutConfig {
            treelet_bytes: 2048,
            region_alignment: 1024,
            base_address: 3072,
            ..Default::default()
        };
        let t = Treelets::build(&bvh, &c).unwrap();
        assert_eq!((t.treelets[0].base, t.treelets[0].bytes), (3072, 2048));
        assert!(check_rows(&t, 1024).is_empty());
        let f = check_rows(&t, 4096);
        assert_eq!(f[0].treelet, 0);
        assert!(f.iter().all(|f| f.rows_touched == f.rows_needed + 1));
        let kept = enforce_row_check(f.clone(), RowCheck::Warn, 4096).unwrap();
        assert_eq!(kept, f);
        let e = enforce_row_check(f, RowCheck::Strict, 4096)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("memory.treelet_row_check") && e.contains("spans 2 DRAM rows"),
            "{e}"
        );
    }
}
