//! [`Tracer`]: a BVH plus the triangle records of the selected kernel, answering closest-hit
//! and any-hit queries through the configured traversal variant (`trace.traversal`: the
//! closed `stack` loop, or a stepped variant run to its end), with counters; and the stepped
//! interface (`start`/`step`) the hardware models drive.

use crate::config::{TraceConfig, Traversal, TraversalOrder, TriangleTest};
use crate::counters::RayCounters;
use crate::kernels::triangle::{MollerTrumbore, Plucker, TriKernel, Wald, WaldTri};
use crate::step::{self, Data, Query, Step, bitstack, shortstack, stack};
use crate::traverse::{SlotHit, TraverseOptions, traverse};
use rtsim_bvh::Bvh;
use rtsim_core::{Ray, Vec3};

/// No triangle hit.
pub const NO_HIT: u32 = u32::MAX;

/// A closest-hit result in scene terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance in units of the ray direction's length (the ray's `tmax` on a miss).
    pub t: f32,
    /// Scene triangle id, or [`NO_HIT`].
    pub prim: u32,
    /// Barycentrics: `u` weights the triangle's second vertex, `v` its third.
    pub u: f32,
    pub v: f32,
}

impl Hit {
    #[inline(always)]
    pub fn is_hit(&self) -> bool {
        self.prim != NO_HIT
    }
}

/// Triangle records in BVH slot order, in the selected kernel's format.
#[derive(Clone, Debug)]
enum Records {
    MollerTrumbore(Vec<[Vec3; 3]>),
    Plucker(Vec<[Vec3; 3]>),
    Wald(Vec<WaldTri>),
}

/// The reference tracer.
#[derive(Clone, Debug)]
pub struct Tracer {
    bvh: Bvh,
    records: Records,
    opts: TraverseOptions,
    test: TriangleTest,
    traversal: Traversal,
    short_stack_entries: u32,
    /// Parent of every node (`bit-stack` only; empty otherwise).
    parents: Vec<u32>,
    /// Treelet id of every node, or empty (no treelets: no crossings counted).
    treelets: Vec<u32>,
}

/// A ray in flight through the tracer's traversal variant (plain data).
#[derive(Clone, Copy, Debug)]
pub enum TraversalState {
    Stack(stack::State),
    BitStack(bitstack::State),
    ShortStack(shortstack::State),
}

/// A BVH the traversal cannot run.
#[derive(Debug, thiserror::Error)]
pub enum TracerError {
    #[error(
        "the BVH has {levels} levels below the root, more than trace.traversal = {variant} \
         can hold ({limit}, set by {key}); build with bvh.max_depth = {limit} or less"
    )]
    TooDeep {
        levels: usize,
        variant: &'static str,
        limit: usize,
        key: &'static str,
    },
    #[error("BVH references triangle slot {slot} but the scene has {count} triangles")]
    BadSlot { slot: usize, count: usize },
    #[error("{got} treelet ids for a BVH of {nodes} nodes")]
    Treelets { got: usize, nodes: usize },
}

/// Run `$body` with `$d` bound to the tracer's [`Data`] for its kernel.
macro_rules! with_data {
    ($self:expr, $d:ident => $body:expr) => {
        match &$self.records {
            Records::MollerTrumbore(r) => {
                let $d = $self.data::<MollerTrumbore>(r);
                $body
            }
            Records::Plucker(r) => {
                let $d = $self.data::<Plucker>(r);
                $body
            }
            Records::Wald(r) => {
                let $d = $self.data::<Wald>(r);
                $body
            }
        }
    };
}

impl Tracer {
    /// Build the tracer for `triangles` (scene order) and a BVH over them.
    pub fn new(
        triangles: &[[Vec3; 3]],
        bvh: Bvh,
        cfg: &TraceConfig,
    ) -> Result<Tracer, TracerError> {
        // Levels below the root = the most entries a path can defer.
        let levels = bvh_depth(&bvh).saturating_sub(1);
        let (limit, key) = match cfg.traversal {
            Traversal::Stack => (cfg.stack_entries as usize, "trace.stack_entries"),
            Traversal::BitStack => (bitstack::MAX_LEVELS as usize, "the 32-bit bit stack"),
            Traversal::ShortStack => (shortstack::MAX_LEVELS as usize, "the 64-bit restart trail"),
        };
        if levels > limit {
            return Err(TracerError::TooDeep {
                levels,
                variant: cfg.traversal.name(),
                limit,
                key,
            });
        }
        if let Some(&bad) = bvh
            .prim_ids
            .iter()
            .find(|&&id| id as usize >= triangles.len())
        {
            return Err(TracerError::BadSlot {
                slot: bad as usize,
                count: triangles.len(),
            });
        }
        let ordered = bvh.prim_ids.iter().map(|&id| &triangles[id as usize]);
        let records = match cfg.triangle_test {
            TriangleTest::MollerTrumbore => {
                Records::MollerTrumbore(ordered.map(MollerTrumbore::prepare).collect())
            }
            TriangleTest::Plucker => Records::Plucker(ordered.map(Plucker::prepare).collect()),
            TriangleTest::Wald => Records::Wald(ordered.map(Wald::prepare).collect()),
        };
        let opts = TraverseOptions {
            nearest_first: cfg.order == TraversalOrder::NearestFirst,
            early_exit: cfg.early_exit,
        };
        let parents = if cfg.traversal == Traversal::BitStack {
            bvh.parents()
        } else {
            Vec::new()
        };
        Ok(Tracer {
            bvh,
            records,
            opts,
            test: cfg.triangle_test,
            traversal: cfg.traversal,
            short_stack_entries: cfg.short_stack_entries,
            parents,
            treelets: Vec::new(),
        })
    }

    /// Give every node its treelet id, so traversals count (and step through) treelet
    /// crossings. An empty vector removes them.
    pub fn set_treelets(&mut self, ids: Vec<u32>) -> Result<(), TracerError> {
        if !ids.is_empty() && ids.len() != self.bvh.nodes.len() {
            return Err(TracerError::Treelets {
                got: ids.len(),
                nodes: self.bvh.nodes.len(),
            });
        }
        self.treelets = ids;
        Ok(())
    }

    /// The traversal variant.
    pub fn traversal(&self) -> Traversal {
        self.traversal
    }

    #[inline(always)]
    fn data<'a, K: TriKernel>(&'a self, tris: &'a [K::Data]) -> Data<'a, K> {
        Data {
            nodes: &self.bvh.nodes,
            tris,
            parents: &self.parents,
            treelets: &self.treelets,
            opts: self.opts,
        }
    }

    /// Start a stepped traversal of `ray` with the tracer's variant.
    #[inline]
    pub fn start(&self, ray: &Ray, query: Query) -> TraversalState {
        with_data!(self, d => match self.traversal {
            Traversal::Stack => TraversalState::Stack(stack::start(&d, ray, query)),
            Traversal::BitStack => TraversalState::BitStack(bitstack::start(&d, ray, query)),
            Traversal::ShortStack => TraversalState::ShortStack(shortstack::start(
                &d,
                ray,
                query,
                self.short_stack_entries,
            )),
        })
    }

    /// Perform the next unit of work of a stepped traversal (see [`Step`]).
    #[inline]
    pub fn step(&self, st: &mut TraversalState, c: &mut RayCounters) -> Step {
        with_data!(self, d => match st {
            TraversalState::Stack(s) => stack::step(&d, s, c),
            TraversalState::BitStack(s) => bitstack::step(&d, s, c),
            TraversalState::ShortStack(s) => shortstack::step(&d, s, c),
        })
    }

    /// [`Tracer::step`] for a `bit-stack` state held on its own (without the
    /// [`TraversalState`] around it, which is as large as the largest variant's stack).
    #[inline]
    pub fn step_bit_stack(&self, s: &mut bitstack::State, c: &mut RayCounters) -> Step {
        with_data!(self, d => bitstack::step(&d, s, c))
    }

    /// Run a stepped traversal to its end: the slot-level result.
    #[inline]
    pub fn run_stepped(&self, ray: &Ray, query: Query, c: &mut RayCounters) -> SlotHit {
        let mut st = self.start(ray, query);
        with_data!(self, d => match &mut st {
            TraversalState::Stack(s) => step::run(|s| stack::step(&d, s, c), s),
            TraversalState::BitStack(s) => step::run(|s| bitstack::step(&d, s, c), s),
            TraversalState::ShortStack(s) => step::run(|s| shortstack::step(&d, s, c), s),
        })
    }

    /// The slot-level result of a closed traversal (the `stack` closed loop or any variant
    /// stepped to its end) as a scene hit.
    #[inline]
    pub fn slot_to_scene(&self, h: SlotHit) -> Hit {
        self.scene_hit(h)
    }

    /// The scene triangle id stored at BVH slot `slot`.
    #[inline]
    pub fn prim_of_slot(&self, slot: u32) -> u32 {
        self.bvh.prim_ids[slot as usize]
    }

    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    pub fn triangle_test(&self) -> TriangleTest {
        self.test
    }

    pub fn options(&self) -> TraverseOptions {
        self.opts
    }

    /// Trace with the configured variant: the closed loop for `stack`, the stepped
    /// traversal run to its end otherwise.
    #[inline]
    fn run<const ANY: bool>(&self, ray: &Ray, c: &mut RayCounters) -> SlotHit {
        if self.traversal != Traversal::Stack {
            let q = if ANY { Query::Any } else { Query::Closest };
            return self.run_stepped(ray, q, c);
        }
        let (nodes, tl) = (&self.bvh.nodes, &self.treelets);
        match &self.records {
            Records::MollerTrumbore(r) => {
                traverse::<MollerTrumbore, ANY>(nodes, r, tl, ray, self.opts, c)
            }
            Records::Plucker(r) => traverse::<Plucker, ANY>(nodes, r, tl, ray, self.opts, c),
            Records::Wald(r) => traverse::<Wald, ANY>(nodes, r, tl, ray, self.opts, c),
        }
    }

    /// A traversal result in scene terms (BVH slot to scene triangle id).
    #[inline]
    fn scene_hit(&self, h: SlotHit) -> Hit {
        let prim = if h.is_hit() {
            self.bvh.prim_ids[h.slot as usize]
        } else {
            NO_HIT
        };
        Hit {
            t: h.t,
            prim,
            u: h.u,
            v: h.v,
        }
    }

    /// The closest hit with `ray.tmin < t < ray.tmax`.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray, c: &mut RayCounters) -> Hit {
        self.scene_hit(self.run::<false>(ray, c))
    }

    /// Whether anything is hit with `ray.tmin < t < ray.tmax` (occlusion).
    #[inline]
    pub fn any_hit(&self, ray: &Ray, c: &mut RayCounters) -> bool {
        self.run::<true>(ray, c).is_hit()
    }

    /// An any-hit query that also reports which triangle ended it (the first found with early
    /// exit; the closest without).
    #[inline]
    pub fn any_hit_detail(&self, ray: &Ray, c: &mut RayCounters) -> Hit {
        self.scene_hit(self.run::<true>(ray, c))
    }

    /// Answer `query` with the configured variant, in BVH slots.
    #[inline]
    pub fn trace_slots(&self, ray: &Ray, query: Query, c: &mut RayCounters) -> SlotHit {
        match query {
            Query::Closest => self.run::<false>(ray, c),
            Query::Any => self.run::<true>(ray, c),
        }
    }
}

/// Number of levels of the BVH (a single leaf has depth 1; empty has 0).
pub fn bvh_depth(bvh: &Bvh) -> usize {
    if bvh.nodes.is_empty() {
        return 0;
    }
    let mut max = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        max = max.max(d);
        let n = &bvh.nodes[i];
        if !n.is_leaf() {
            stack.push((n.index as usize, d + 1));
            stack.push((n.index as usize + 1, d + 1));
        }
    }
    max
}

/// Brute-force closest hit over all triangles with Möller–Trumbore: the test oracle for the
/// BVH traversal. Ties keep the lowest triangle id.
pub fn brute_force_closest(triangles: &[[Vec3; 3]], ray: &Ray) -> Hit {
    let mut best = Hit {
        t: ray.tmax,
        prim: NO_HIT,
        u: 0.0,
        v: 0.0,
    };
    for (i, t) in triangles.iter().enumerate() {
        if let Some(h) =
            MollerTrumbore::intersect(&MollerTrumbore::prepare(t), ray, ray.tmin, best.t)
        {
            best = Hit {
                t: h.t,
                prim: i as u32,
                u: h.u,
                v: h.v,
            };
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{TraceConfig, Traversal, TraversalOrder, TriangleTest};
    use crate::testutil::{median_bvh, random_rays, random_soup};

    fn configs() -> Vec<TraceConfig> {
        let mut v = Vec::new();
        for test in [
            TriangleTest::MollerTrumbore,
            TriangleTest::Plucker,
            TriangleTest::Wald,
        ] {
            for order in [TraversalOrder::NearestFirst, TraversalOrder::LeftFirst] {
                for early_exit in [true, false] {
                    for traversal in [Traversal::Stack, Traversal::BitStack, Traversal::ShortStack]
                    {
                        v.push(TraceConfig {
                            traversal,
                            triangle_test: test,
                            order,
                            early_exit,
                            fast_path: false,
                            short_stack_entries: 3,
                            ..TraceConfig::default()
                        });
                    }
                }
            }
        }
        v
    }

    #[test]
    fn agrees_with_brute_force_on_random_soups() {
        let tris = random_soup(2000, 11, 1.5);
        let rays = random_rays(3000, 12);
        for cfg in configs() {
            for leaf in [1, 4, 7] {
                let tracer = Tracer::new(&tris, median_bvh(&tris, leaf), &cfg).unwrap();
                let mut mismatches = 0;
                for ray in &rays {
                    let reference = brute_force_closest(&tris, ray);
                    let mut c = RayCounters::default();
                    let h = tracer.closest_hit(ray, &mut c);
                    assert_eq!(h.is_hit(), reference.is_hit(), "{cfg:?} {ray:?}");
                    if h.is_hit() {
                        assert!(
                            (h.t - reference.t).abs() <= 1e-4 * reference.t.abs().max(1.0),
                            "{cfg:?}"
                        );
                        mismatches += (h.prim != reference.prim) as u32;
                    }
                    // Counter identities (the bit stack adds its sibling re-tests).
                    assert_eq!(
                        c.box_tests,
                        1 + 2 * (c.nodes_visited - c.leaves_visited).min(c.nodes_visited)
                            + c.sibling_retests
                    );
                    let mut ca = RayCounters::default();
                    assert_eq!(tracer.any_hit(ray, &mut ca), reference.is_hit(), "{cfg:?}");
                    assert!(ca.nodes_visited <= c.nodes_visited || !cfg.early_exit);
                }
                // Different ids only where two triangles are hit at the same t (coplanar or
                // shared points), which random soups essentially never produce.
                assert!(mismatches <= 2, "{cfg:?}: {mismatches} id mismatches");
            }
        }
    }

    #[test]
    fn empty_scene_misses() {
        let tracer = Tracer::new(&[], median_bvh(&[], 4), &TraceConfig::default()).unwrap();
        let ray = random_rays(1, 1)[0];
        let mut c = RayCounters::default();
        assert!(!tracer.closest_hit(&ray, &mut c).is_hit());
        assert!(!tracer.any_hit(&ray, &mut c));
        assert_eq!(c, RayCounters::default());
    }

    #[test]
    fn nearest_first_visits_no_more_than_left_first_on_average() {
        let tris = random_soup(4000, 21, 1.0);
        let rays = random_rays(2000, 22);
        let visits = |order| {
            let cfg = TraceConfig {
                order,
                ..TraceConfig::default()
            };
            let t = Tracer::new(&tris, median_bvh(&tris, 2), &cfg).unwrap();
            let mut c = RayCounters::default();
            let mut total = 0u64;
            for r in &rays {
                c = RayCounters::default();
                t.closest_hit(r, &mut c);
                total += c.nodes_visited as u64;
            }
            let _ = c;
            total
        };
        assert!(visits(TraversalOrder::NearestFirst) < visits(TraversalOrder::LeftFirst));
    }

    #[test]
    fn rejects_bad_slots() {
        let tris = random_soup(10, 1, 1.0);
        let mut bvh = median_bvh(&tris, 4);
        bvh.prim_ids[0] = 99;
        assert!(matches!(
            Tracer::new(&tris, bvh, &TraceConfig::default()),
            Err(TracerError::BadSlot { .. })
        ));
    }
}
