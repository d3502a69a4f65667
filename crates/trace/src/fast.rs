//! A faster path for `rtsim trace` and `rtsim bench`: a 4-wide BVH collapsed from the binary
//! one, with four boxes or four triangles tested per step.
//!
//! It answers exactly the same queries as the reference [`Tracer`](crate::Tracer) with the
//! Möller–Trumbore kernel: each lane performs the same IEEE operations in the same order as
//! [`moller_trumbore`](crate::kernels::moller_trumbore), so hit distances and barycentrics are
//! bit-identical; only which of two triangles hit at exactly the same distance (a shared edge)
//! may differ, since the visiting order differs. It keeps no counters: the reference path is
//! the one whose counters hardware models reproduce.
//!
//! Layout: [`Node4`] holds its children's boxes as structure-of-arrays (one 128-byte record,
//! two cache lines); leaves point at runs of [`Tri4`] packets (four triangles as
//! `v0, e1, e2` in structure-of-arrays, padded with degenerate lanes that never hit).

use crate::kernels::RayBox;
use crate::tracer::{Hit, NO_HIT};
use rtsim_bvh::Bvh;
use rtsim_core::{Aabb, Ray, Vec3};

const EMPTY: u32 = u32::MAX;
const LEAF: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 25;
const COUNT_MASK: u32 = 0x3f;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;

/// Four children's boxes (structure of arrays) and their references.
///
/// `child[i]`: `EMPTY`, an inner node index, or `LEAF | (packets - 1) << 25 | first_packet`.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node4 {
    min: [[f32; 4]; 3],
    max: [[f32; 4]; 3],
    child: [u32; 4],
}

/// Four triangles as `v0`, `e1 = v1 - v0`, `e2 = v2 - v0` in structure of arrays.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct Tri4 {
    v0: [[f32; 4]; 3],
    e1: [[f32; 4]; 3],
    e2: [[f32; 4]; 3],
}

/// The wide BVH.
#[derive(Clone, Debug, Default)]
pub struct FastBvh {
    nodes: Vec<Node4>,
    packets: Vec<Tri4>,
    /// Scene id per packet lane (`NO_HIT` for padding).
    ids: Vec<[u32; 4]>,
    /// The root is a leaf (a scene of one leaf) or there is no geometry.
    root_leaf: Option<u32>,
}

impl FastBvh {
    /// Collapse `bvh` (built over `triangles`, scene order) into a 4-wide BVH.
    pub fn new(triangles: &[[Vec3; 3]], bvh: &Bvh) -> Result<FastBvh, String> {
        let mut f = FastBvh::default();
        if bvh.nodes.is_empty() {
            return Ok(f);
        }
        if bvh.prim_ids.len() >= (FIRST_MASK as usize) * 4 {
            return Err(format!(
                "{} triangles exceed the fast path's limit",
                bvh.prim_ids.len()
            ));
        }
        let root = &bvh.nodes[0];
        if root.is_leaf() {
            f.root_leaf = Some(f.leaf(triangles, bvh, 0)?);
            return Ok(f);
        }
        f.nodes.push(empty_node());
        // (wide node index, binary node whose children it takes)
        let mut work = vec![(0usize, 0usize)];
        while let Some((wi, bi)) = work.pop() {
            let kids = open_children(bvh, bi);
            let mut node = empty_node();
            for (lane, &k) in kids.iter().enumerate() {
                let b = &bvh.nodes[k];
                set_box(&mut node, lane, &b.bounds);
                node.child[lane] = if b.is_leaf() {
                    f.leaf(triangles, bvh, k)?
                } else {
                    let ci = f.nodes.len();
                    f.nodes.push(empty_node());
                    work.push((ci, k));
                    ci as u32
                };
            }
            f.nodes[wi] = node;
        }
        Ok(f)
    }

    /// Pack leaf `k`'s triangles into consecutive packets; returns the child reference.
    fn leaf(&mut self, triangles: &[[Vec3; 3]], bvh: &Bvh, k: usize) -> Result<u32, String> {
        let n = &bvh.nodes[k];
        let first = self.packets.len();
        let slots: Vec<u32> = (n.index..n.index + n.count).collect();
        for chunk in slots.chunks(4) {
            let mut p = Tri4 {
                v0: [[0.0; 4]; 3],
                e1: [[0.0; 4]; 3],
                e2: [[0.0; 4]; 3],
            };
            let mut ids = [NO_HIT; 4];
            for (lane, &slot) in chunk.iter().enumerate() {
                let id = bvh.prim_ids[slot as usize];
                let t = &triangles[id as usize];
                let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
                for a in 0..3 {
                    p.v0[a][lane] = t[0][a];
                    p.e1[a][lane] = e1[a];
                    p.e2[a][lane] = e2[a];
                }
                ids[lane] = id;
            }
            self.packets.push(p);
            self.ids.push(ids);
        }
        let count = self.packets.len() - first;
        if count == 0 || count > COUNT_MASK as usize + 1 {
            return Err(format!(
                "leaf of {} triangles does not fit the fast path",
                n.count
            ));
        }
        Ok(LEAF | ((count as u32 - 1) << COUNT_SHIFT) | first as u32)
    }

    /// Closest hit in `[tmin, tmax)`.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray) -> Hit {
        self.traverse::<false>(ray)
    }

    /// Any hit in `[tmin, tmax)`.
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.traverse::<true>(ray).is_hit()
    }

    /// Any-hit query reporting the triangle that ended it.
    #[inline]
    pub fn any_hit_detail(&self, ray: &Ray) -> Hit {
        self.traverse::<true>(ray)
    }

    #[inline]
    fn traverse<const ANY: bool>(&self, ray: &Ray) -> Hit {
        let mut hit = Hit {
            t: ray.tmax,
            prim: NO_HIT,
            u: 0.0,
            v: 0.0,
        };
        if let Some(leaf) = self.root_leaf {
            self.leaf_test::<ANY>(leaf, ray, &mut hit);
            return hit;
        }
        if self.nodes.is_empty() {
            return hit;
        }
        let rb = RayBox::new(ray);
        let mut stack = [(0u32, 0f32); 256];
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            // Inner node: four box tests, then descend into the nearest hit child and push
            // the others far-to-near.
            let node = &self.nodes[cur as usize];
            let (mask, tnear) = box4(node, &rb, ray.tmin, hit.t);
            let mut next = None;
            if mask != 0 {
                let mut order = [(0f32, 0u32); 4];
                let mut n = 0;
                for (lane, &t) in tnear.iter().enumerate() {
                    if mask & (1 << lane) != 0 {
                        // Insertion sort, nearest first.
                        let mut j = n;
                        while j > 0 && order[j - 1].0 > t {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = (t, node.child[lane]);
                        n += 1;
                    }
                }
                for &(t, c) in order[1..n].iter().rev() {
                    stack[sp] = (c, t);
                    sp += 1;
                }
                next = Some(order[0].1);
            }
            let mut candidate = next;
            loop {
                let c = match candidate.take() {
                    Some(c) => c,
                    None => loop {
                        if sp == 0 {
                            return hit;
                        }
                        sp -= 1;
                        let (c, t) = stack[sp];
                        if t < hit.t {
                            break c;
                        }
                    },
                };
                if c & LEAF == 0 {
                    cur = c;
                    break;
                }
                self.leaf_test::<ANY>(c, ray, &mut hit);
                if ANY && hit.is_hit() {
                    return hit;
                }
            }
        }
    }

    #[inline(always)]
    fn leaf_test<const ANY: bool>(&self, c: u32, ray: &Ray, hit: &mut Hit) {
        let first = (c & FIRST_MASK) as usize;
        let count = ((c >> COUNT_SHIFT) & COUNT_MASK) as usize + 1;
        for p in first..first + count {
            if let Some((lane, t, u, v)) = tri4(&self.packets[p], ray, ray.tmin, hit.t) {
                *hit = Hit {
                    t,
                    prim: self.ids[p][lane],
                    u,
                    v,
                };
                if ANY {
                    return;
                }
            }
        }
    }
}

fn empty_node() -> Node4 {
    Node4 {
        min: [[f32::INFINITY; 4]; 3],
        max: [[f32::NEG_INFINITY; 4]; 3],
        child: [EMPTY; 4],
    }
}

fn set_box(n: &mut Node4, lane: usize, b: &Aabb) {
    for a in 0..3 {
        n.min[a][lane] = b.min[a];
        n.max[a][lane] = b.max[a];
    }
}

/// Up to four binary nodes covering the children of inner node `bi`: open the inner child
/// with the largest surface area until there are four or only leaves remain. Children keep
/// their binary order.
fn open_children(bvh: &Bvh, bi: usize) -> Vec<usize> {
    let n = &bvh.nodes[bi];
    let mut kids = vec![n.index as usize, n.index as usize + 1];
    while kids.len() < 4 {
        let best = kids
            .iter()
            .enumerate()
            .filter(|(_, k)| !bvh.nodes[**k].is_leaf())
            .max_by(|a, b| {
                bvh.nodes[*a.1]
                    .bounds
                    .surface_area()
                    .total_cmp(&bvh.nodes[*b.1].bounds.surface_area())
            })
            .map(|(i, _)| i);
        let Some(i) = best else { break };
        let k = kids[i];
        let c = bvh.nodes[k].index as usize;
        kids.splice(i..=i, [c, c + 1]);
    }
    kids
}

/// Four slab tests; returns the hit mask and entry distances.
#[inline(always)]
fn box4(n: &Node4, r: &RayBox, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
    let mut near = [tmin; 4];
    let mut far = [tmax; 4];
    for a in 0..3 {
        let (o, inv) = (r.origin[a], r.inv_dir[a]);
        for l in 0..4 {
            let t0 = (n.min[a][l] - o) * inv;
            let t1 = (n.max[a][l] - o) * inv;
            near[l] = near[l].max(t0.min(t1));
            far[l] = far[l].min(t0.max(t1));
        }
    }
    let mut mask = 0;
    for l in 0..4 {
        // Empty lanes have inverted boxes, which the slab test would see as everything.
        mask |= ((near[l] <= far[l] && n.child[l] != EMPTY) as u32) << l;
    }
    (mask, near)
}

/// Möller–Trumbore on four triangles; the nearest valid lane (lowest lane on ties).
#[inline(always)]
fn tri4(p: &Tri4, ray: &Ray, tmin: f32, tmax: f32) -> Option<(usize, f32, f32, f32)> {
    let (o, d) = (ray.origin, ray.direction);
    let mut t = [0f32; 4];
    let mut u = [0f32; 4];
    let mut v = [0f32; 4];
    let mut ok = [false; 4];
    for l in 0..4 {
        // Same operations, same order as `moller_trumbore`.
        let (e1x, e1y, e1z) = (p.e1[0][l], p.e1[1][l], p.e1[2][l]);
        let (e2x, e2y, e2z) = (p.e2[0][l], p.e2[1][l], p.e2[2][l]);
        let px = d.y * e2z - d.z * e2y;
        let py = d.z * e2x - d.x * e2z;
        let pz = d.x * e2y - d.y * e2x;
        let det = e1x * px + e1y * py + e1z * pz;
        let inv = 1.0 / det;
        let sx = o.x - p.v0[0][l];
        let sy = o.y - p.v0[1][l];
        let sz = o.z - p.v0[2][l];
        let ul = (sx * px + sy * py + sz * pz) * inv;
        let qx = sy * e1z - sz * e1y;
        let qy = sz * e1x - sx * e1z;
        let qz = sx * e1y - sy * e1x;
        let vl = (d.x * qx + d.y * qy + d.z * qz) * inv;
        let tl = (e2x * qx + e2y * qy + e2z * qz) * inv;
        ok[l] = det != 0.0
            && (0.0..=1.0).contains(&ul)
            && vl >= 0.0
            && ul + vl <= 1.0
            && tl >= tmin
            && tl < tmax;
        t[l] = tl;
        u[l] = ul;
        v[l] = vl;
    }
    let mut best: Option<usize> = None;
    for l in 0..4 {
        if ok[l] && best.is_none_or(|b| t[l] < t[b]) {
            best = Some(l);
        }
    }
    best.map(|l| (l, t[l], u[l], v[l]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TraceConfig;
    use crate::counters::RayCounters;
    use crate::testutil::{median_bvh, random_rays, random_soup};
    use crate::tracer::Tracer;

    #[test]
    fn matches_reference_bit_for_bit() {
        let tris = random_soup(3000, 31, 1.5);
        let rays = random_rays(4000, 32);
        for leaf in [1, 3, 4, 9] {
            let bvh = median_bvh(&tris, leaf);
            let fast = FastBvh::new(&tris, &bvh).unwrap();
            let reference = Tracer::new(&tris, bvh, &TraceConfig::default()).unwrap();
            for r in &rays {
                let a = reference.closest_hit(r, &mut RayCounters::default());
                let b = fast.closest_hit(r);
                assert_eq!(a.is_hit(), b.is_hit());
                if a.is_hit() {
                    assert_eq!(a.t.to_bits(), b.t.to_bits(), "leaf {leaf}");
                    if a.prim == b.prim {
                        assert_eq!(
                            (a.u.to_bits(), a.v.to_bits()),
                            (b.u.to_bits(), b.v.to_bits())
                        );
                    }
                }
                assert_eq!(
                    reference.any_hit(r, &mut RayCounters::default()),
                    fast.any_hit(r)
                );
            }
        }
    }

    #[test]
    fn tiny_scenes() {
        let tris = random_soup(3, 1, 5.0);
        let rays = random_rays(500, 2);
        let bvh = median_bvh(&tris, 4); // a single leaf
        let fast = FastBvh::new(&tris, &bvh).unwrap();
        let reference = Tracer::new(&tris, bvh, &TraceConfig::default()).unwrap();
        for r in &rays {
            assert_eq!(
                fast.closest_hit(r),
                reference.closest_hit(r, &mut RayCounters::default())
            );
        }
        let empty = FastBvh::new(&[], &median_bvh(&[], 4)).unwrap();
        assert!(!empty.closest_hit(&rays[0]).is_hit());
    }
}
