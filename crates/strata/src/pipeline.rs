//! Fused pipelines (STRaTA paper §3.3): a TM working on a node treelet configures six FP
//! multipliers and six FP adders, with comparators, into a box-test pipeline; on a triangle
//! treelet, Plücker triangle-test pipelines of four multipliers and two adders each. A test is
//! one instruction: its inputs are loaded by intrinsics into the pipeline's special input
//! registers, and its intermediate values pass between stages instead of through the
//! register file.
//!
//! This module holds the pipelines' shapes ([`PipelineSpec`]) and the instruction blocks of
//! the two fused steps — a child-pair test ([`child_pair`]) and a Plücker triangle test
//! ([`triangle`]) — with their instruction fetches, register-file reads and writes and
//! execution-unit operations, so the energy model sees what fusing saves. The blocks are not
//! yet run by a timing engine (`docs/STRATA.md`, "Not yet built").
//!
//! Register-file conventions (assumed, `docs/STRATA.md`): an input intrinsic is a load whose
//! destination is the pipeline's input latch, so it reads its address register and writes no
//! register; a fused test reads the ray's registers it needs (origin, inverse direction or
//! direction, tmin, closest hit: 8) because 32 TPs share one pipeline and keep their rays in
//! their own register files; it writes its results (box: hit flag and entry distance;
//! triangle: hit flag, `n·a`, `n·d` and the two signed volumes the barycentrics need).

use rtsim_trace::kernels::triangle::plucker_exit;
use rtsim_trace::ops::{self, OpMix};
use rtsim_trax::isa::Class;
use serde::Serialize;

/// The shape of one fused pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct PipelineSpec {
    pub name: &'static str,
    /// FP multipliers and adders one instance takes from the TM's shared units.
    pub fp_mul: u32,
    pub fp_add: u32,
    /// Cycles between two tests entering one instance.
    pub initiation_interval: u32,
    /// Cycles from a test entering to its result being readable.
    pub latency: u32,
    /// Instances per TM.
    pub instances: u32,
}

/// The box pipeline: 6 mul + 6 add/sub plus comparators, initiation interval 1, latency 8
/// (STRaTA §3.3: "six multipliers and six add/subtract units, leaving two of each for general
/// purpose use … fully pipelined with an initiation interval of one and a latency of eight
/// cycles").
pub const BOX: PipelineSpec = PipelineSpec {
    name: "box",
    fp_mul: 6,
    fp_add: 6,
    initiation_interval: 1,
    latency: 8,
    instances: 1,
};

/// The Plücker triangle pipeline: 4 mul + 2 add, initiation interval 18, latency 31, "an
/// issue width of two" (STRaTA §3.3), read as two instances per TM (`DESIGN.md` §3), which
/// takes all 8 multipliers and 4 of the 8 adders.
pub const TRIANGLE: PipelineSpec = PipelineSpec {
    name: "triangle",
    fp_mul: 4,
    fp_add: 2,
    initiation_interval: 18,
    latency: 31,
    instances: 2,
};

impl PipelineSpec {
    /// FP multipliers and adders all instances take.
    pub fn units(&self) -> (u32, u32) {
        (self.fp_mul * self.instances, self.fp_add * self.instances)
    }

    /// Multiplies and additions one instance can perform per test (units × interval).
    pub fn slots_per_test(&self) -> (u32, u32) {
        (
            self.fp_mul * self.initiation_interval,
            self.fp_add * self.initiation_interval,
        )
    }

    /// Tests per cycle the TM's instances accept.
    pub fn tests_per_cycle(&self) -> f64 {
        self.instances as f64 / self.initiation_interval as f64
    }
}

/// What an instruction of a fused block is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Op {
    /// An ordinary TRaX instruction.
    Base(Class),
    /// A load into a pipeline's input latch (the input intrinsic): a data-cache load.
    LoadInput,
    /// One box test through the box pipeline.
    BoxTest,
    /// One triangle test through a triangle pipeline.
    TriangleTest,
}

/// One static instruction of a fused block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct FusedInst {
    pub op: Op,
    /// Register-file reads and writes.
    pub reads: u8,
    pub writes: u8,
    /// What it is, for listings.
    pub what: &'static str,
}

const fn inst(op: Op, reads: u8, writes: u8, what: &'static str) -> FusedInst {
    FusedInst {
        op,
        reads,
        writes,
        what,
    }
}

/// A fused block: its instructions and the execution-unit operations its pipeline tests
/// perform (charged per operation like any other, STRaTA §3.3: the XUs do the work).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FusedBlock {
    pub name: &'static str,
    pub insts: Vec<FusedInst>,
    /// Operations inside the pipelines (not instructions: no fetch, no register access).
    pub pipeline_ops: OpMix,
}

impl FusedBlock {
    /// Instruction fetches (one per instruction, fused tests included).
    pub fn fetches(&self) -> u32 {
        self.insts.len() as u32
    }

    /// Register-file reads and writes.
    pub fn register_accesses(&self) -> (u32, u32) {
        self.insts.iter().fold((0, 0), |(r, w), i| {
            (r + i.reads as u32, w + i.writes as u32)
        })
    }

    /// Instructions of kind `op`.
    pub fn count(&self, op: Op) -> u32 {
        self.insts.iter().filter(|i| i.op == op).count() as u32
    }
}

/// The fused `Step::ChildPair`: both children's boxes (6 words each) loaded into the box
/// pipeline's inputs, two back-to-back box tests, the right child's index, a branch on each
/// hit; when both are hit, the order comparison of the entry distances and its branch (as in
/// the TRaX program's `child_pair` block, whose arithmetic the pipeline replaces).
pub fn child_pair(both_hit: bool) -> FusedBlock {
    let mut insts = Vec::new();
    for _ in 0..2 {
        for _ in 0..6 {
            insts.push(inst(Op::LoadInput, 1, 0, "box word → input latch [child]"));
        }
    }
    for _ in 0..2 {
        insts.push(inst(
            Op::BoxTest,
            8,
            2,
            "box test: org, inv, tmin, thit → hit, tnear",
        ));
    }
    insts.push(inst(
        Op::Base(Class::IntAdd),
        1,
        1,
        "node ← child (+1 right)",
    ));
    insts.push(inst(Op::Base(Class::Branch), 1, 0, "branch on left hit"));
    insts.push(inst(Op::Base(Class::Branch), 1, 0, "branch on right hit"));
    if both_hit {
        insts.push(inst(
            Op::Base(Class::FpCmp),
            2,
            1,
            "order: tnear left < right",
        ));
        insts.push(inst(Op::Base(Class::Branch), 1, 0, "branch on order"));
    }
    FusedBlock {
        name: "child_pair (fused)",
        insts,
        // Two slab tests' arithmetic; their loads are the input intrinsics above.
        pipeline_ops: box_ops() + box_ops(),
    }
}

/// One box's inputs and its test: 6 input loads, the fused test, a branch on its flag.
fn one_box(insts: &mut Vec<FusedInst>) {
    for _ in 0..6 {
        insts.push(inst(Op::LoadInput, 1, 0, "box word → input latch [node]"));
    }
    insts.push(inst(
        Op::BoxTest,
        8,
        2,
        "box test: org, inv, tmin, thit → hit, tnear",
    ));
    insts.push(inst(Op::Base(Class::Branch), 1, 0, "branch on the hit"));
}

/// The box arithmetic of one slab test (its loads are the input intrinsics).
fn box_ops() -> OpMix {
    OpMix {
        load: 0,
        ..ops::BOX_TEST
    }
}

/// The fused `Step::RootBox`: the root's box through the box pipeline, one branch.
pub fn root_box() -> FusedBlock {
    let mut insts = Vec::new();
    one_box(&mut insts);
    FusedBlock {
        name: "root_box (fused)",
        insts,
        pipeline_ops: box_ops(),
    }
}

/// The fused `Step::SiblingRetest` (`bit-stack`): the sibling's index (one bitwise), its box
/// through the box pipeline, one branch.
pub fn sibling_retest() -> FusedBlock {
    let mut insts = vec![inst(Op::Base(Class::Bitwise), 1, 1, "sibling ← node ^ 3 …")];
    one_box(&mut insts);
    FusedBlock {
        name: "sibling_retest (fused)",
        insts,
        pipeline_ops: box_ops(),
    }
}

/// Instruction fetches of a traversal step with fused pipelines (`None`: the step uses no
/// pipeline and runs as ordinary instructions, `ops::step`). A triangle step includes the
/// leaf loop's tail (slot increment, loop compare, branch), as `ops::step` does.
pub fn fused_fetches(step: &rtsim_trace::Step) -> Option<u32> {
    use rtsim_trace::Step;
    Some(match *step {
        Step::RootBox { .. } => root_box().fetches(),
        Step::ChildPair { hit, .. } => child_pair(hit[0] && hit[1]).fetches(),
        Step::SiblingRetest { .. } => sibling_retest().fetches(),
        Step::Triangle { exit, .. } => triangle(exit).fetches() + 3,
        _ => return None,
    })
}

/// The fused `Step::Triangle` (Plücker) ending at `exit` (`plucker_exit`, `HIT` = 0): the 9
/// vertex words loaded into a triangle pipeline's inputs, the test, a branch on its flag;
/// on the way to a hit, the divide outside the pipeline (§3.3: "we perform the divide as a
/// separate operation outside of the pipeline") and the interval re-check after rounding; on
/// a hit, the barycentrics. The pipeline evaluates the whole test whatever the exit, so it
/// performs the kernel's operations up to the interval test every time.
pub fn triangle(exit: u8) -> FusedBlock {
    let mut insts = Vec::new();
    for _ in 0..9 {
        insts.push(inst(
            Op::LoadInput,
            1,
            0,
            "vertex word → input latch [slot]",
        ));
    }
    insts.push(inst(
        Op::TriangleTest,
        8,
        5,
        "Plücker test: org, dir, tmin, thit → hit, n·a, n·d, w1, w2",
    ));
    insts.push(inst(Op::Base(Class::Branch), 1, 0, "branch on the flag"));
    if matches!(exit, plucker_exit::T_ROUNDED | rtsim_trace::kernels::HIT) {
        insts.push(inst(Op::Base(Class::DivSqrt), 1, 1, "inv ← 1 / n·d"));
        insts.push(inst(Op::Base(Class::FpMul), 2, 1, "t ← n·a × inv"));
        insts.push(inst(Op::Base(Class::FpCmp), 2, 1, "t > tmin"));
        insts.push(inst(Op::Base(Class::FpCmp), 2, 1, "t < thit"));
        insts.push(inst(
            Op::Base(Class::Branch),
            1,
            0,
            "branch on the interval",
        ));
    }
    if exit == rtsim_trace::kernels::HIT {
        insts.push(inst(Op::Base(Class::FpMul), 2, 1, "u' ← w1 × inv"));
        insts.push(inst(Op::Base(Class::FpMul), 2, 1, "v' ← w2 × inv"));
        insts.push(inst(Op::Base(Class::Bitwise), 1, 1, "u ← −u'"));
        insts.push(inst(Op::Base(Class::Bitwise), 1, 1, "v ← −v'"));
    }
    let full = ops::plucker(plucker_exit::RANGE);
    FusedBlock {
        name: "triangle (fused Plücker)",
        insts,
        pipeline_ops: OpMix {
            fadd: full.fadd,
            fmul: full.fmul,
            fcmp: full.fcmp,
            ..OpMix::ZERO
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rtsim_trace::kernels::HIT;
    use rtsim_trax::Program;

    fn baseline(p: &Program, seg: rtsim_trax::Seg) -> (u32, u32, u32) {
        let (mut r, mut w) = (0, 0);
        for i in p.seg(seg) {
            let (a, b) = i.register_accesses();
            r += a;
            w += b;
        }
        (seg.len, r, w)
    }

    #[test]
    fn the_pipelines_take_what_the_paper_says() {
        // §3.3: the box pipeline leaves two of the TM's 8 multipliers and 8 adders.
        assert_eq!(BOX.units(), (6, 6));
        assert_eq!(BOX.tests_per_cycle(), 1.0);
        // Two triangle instances: all 8 multipliers, 4 adders.
        assert_eq!(TRIANGLE.units(), (8, 4));
        assert_eq!(TRIANGLE.slots_per_test(), (72, 36));
        // A box test's multiplies and adds fit the pipeline's units in one interval.
        let b = ops::BOX_TEST;
        assert_eq!((b.fmul, b.fadd), (BOX.fp_mul, BOX.fp_add));
        // The substrate's Plücker kernel up to its interval test: 41 multiplies fit the 72
        // slots, but its 37 additions are one more than the 36 slots of two adders over 18
        // cycles (its plane normal comes from the edges, for precision). Recorded, not hidden.
        let t = ops::plucker(plucker_exit::RANGE);
        assert_eq!((t.fmul, t.fadd), (41, 37));
        assert!(t.fmul <= TRIANGLE.slots_per_test().0);
        assert_eq!(t.fadd, TRIANGLE.slots_per_test().1 + 1);
    }

    #[test]
    fn fused_child_pair_matches_the_hand_count() {
        // Both hit: 12 input loads (12 reads) + 2 box tests (2 × 8 reads, 2 × 2 writes) +
        // iadd (1 r, 1 w) + 2 br (2 r) + fcmp (2 r, 1 w) + br (1 r).
        let f = child_pair(true);
        assert_eq!(f.fetches(), 19);
        assert_eq!(f.register_accesses(), (12 + 16 + 1 + 2 + 2 + 1, 4 + 1 + 1));
        assert_eq!(f.count(Op::BoxTest), 2);
        assert_eq!(f.count(Op::LoadInput), 12);
        // One or none hit: no order comparison.
        let f1 = child_pair(false);
        assert_eq!(f1.fetches(), 17);
        assert_eq!(f1.register_accesses(), (31, 5));
        // The pipeline does the arithmetic of two slab tests.
        assert_eq!(
            (
                f.pipeline_ops.fadd,
                f.pipeline_ops.fmul,
                f.pipeline_ops.fminmax
            ),
            (12, 12, 24)
        );
        // Against the TRaX program's child_pair block: 67 instructions with both hit.
        let p = Program::new();
        let (n, r, w) = baseline(&p, p.pair);
        assert_eq!(n, 67);
        let (fr, fw) = f.register_accesses();
        assert!(f.fetches() * 3 < n, "{} vs {n}", f.fetches());
        assert!(2 * (fr + fw) < r + w, "{} vs {}", fr + fw, r + w);
    }

    #[test]
    fn fused_single_boxes_match_the_hand_count_and_ops() {
        use rtsim_trace::{Step, Traversal, TriangleTest};
        // Root: 6 input loads (6 r) + test (8 r, 2 w) + br (1 r).
        let r = root_box();
        assert_eq!((r.fetches(), r.register_accesses()), (8, (15, 2)));
        // Sibling re-test: + the sibling index (1 r, 1 w).
        let s = sibling_retest();
        assert_eq!((s.fetches(), s.register_accesses()), (9, (16, 3)));
        // Outside the pipeline, each fused step runs what ops::step counts besides the
        // arithmetic the pipeline took: scalar fetches − pipeline ops = fused − fused tests.
        let bs = |st: &Step| ops::step(Traversal::BitStack, TriangleTest::Plucker, st).total();
        let root = Step::RootBox { hit: true };
        assert_eq!(bs(&root) - box_ops().total(), r.fetches() - 1);
        let sib = Step::SiblingRetest { node: 3, hit: true };
        assert_eq!(bs(&sib) - box_ops().total(), s.fetches() - 1);
        for both in [true, false] {
            let pair = Step::ChildPair {
                left: 1,
                hit: [true, both],
            };
            let f = child_pair(both);
            assert_eq!(bs(&pair) - f.pipeline_ops.total(), f.fetches() - 2);
            assert_eq!(fused_fetches(&pair), Some(f.fetches()));
        }
        assert_eq!(fused_fetches(&Step::Parent { node: 3, parent: 1 }), None);
    }

    #[test]
    fn fused_triangle_matches_the_hand_count() {
        // Misses (outside, parallel, out of range): 9 input loads (9 r) + test (8 r, 5 w) +
        // br (1 r).
        for exit in [
            plucker_exit::OUTSIDE,
            plucker_exit::PARALLEL,
            plucker_exit::RANGE,
        ] {
            let f = triangle(exit);
            assert_eq!(f.fetches(), 11);
            assert_eq!(f.register_accesses(), (18, 5));
        }
        // Rounded out after the divide: + fdiv (1 r, 1 w), fmul (2, 1), 2 fcmp (2, 1), br (1).
        let f = triangle(plucker_exit::T_ROUNDED);
        assert_eq!(f.fetches(), 16);
        assert_eq!(f.register_accesses(), (18 + 1 + 2 + 2 + 2 + 1, 5 + 4));
        // A hit: + 2 fmul (2, 1) and 2 sign flips (1, 1) for the barycentrics.
        let f = triangle(HIT);
        assert_eq!(f.fetches(), 20);
        assert_eq!(f.register_accesses(), (26 + 4 + 2, 9 + 4));
        // The instructions outside the pipeline are exactly the kernel's after its interval
        // test (ops: T_ROUNDED and HIT against RANGE).
        let extra = |e: u8| {
            let (a, b) = (ops::plucker(e), ops::plucker(plucker_exit::RANGE));
            (a.fmul - b.fmul, a.fcmp - b.fcmp, a.fdiv, a.bitwise)
        };
        let outside = |f: &FusedBlock| {
            (
                f.count(Op::Base(Class::FpMul)),
                f.count(Op::Base(Class::FpCmp)),
                f.count(Op::Base(Class::DivSqrt)),
                f.count(Op::Base(Class::Bitwise)),
            )
        };
        assert_eq!(outside(&triangle(HIT)), extra(HIT));
        assert_eq!(
            outside(&triangle(plucker_exit::T_ROUNDED)),
            extra(plucker_exit::T_ROUNDED)
        );
        // Against the TRaX program's Möller–Trumbore block on a hit (75 instructions).
        let p = Program::new();
        let (n, _, _) = baseline(&p, p.tri);
        assert_eq!(n, 75);
        assert!(f.fetches() * 3 < n);
    }
}
