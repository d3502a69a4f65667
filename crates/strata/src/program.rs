//! The STRaTA ray program: the TRaX program ([`rtsim_trax::Program`], whose shading, ray
//! setup, root box, node and child-pair blocks STRaTA runs unchanged) with the blocks STRaTA
//! adds appended, so every TRaX block keeps its address and instruction-cache bank:
//!
//! - the `bit-stack` traversal's own steps (`Parent`, `SiblingRetest`, the bit push and pop),
//!   recorded from the real kernels like the TRaX blocks (`rtsim_trax::program::asm`);
//! - the Plücker triangle test as ordinary instructions (`triangle_test = plucker`, STRaTA
//!   §3.3), for runs without fused pipelines;
//! - the fused blocks of [`crate::pipeline`] as instructions: input intrinsics (loads into
//!   the pipeline's latches), one [`Class::BoxTest`] or [`Class::TriTest`] per test, and
//!   what runs outside the pipeline;
//! - the stream-memory intrinsics: pop a ray, push a ray (with the treelet check that picks
//!   its buffer), read and write the path's state record.
//!
//! Register conventions beyond TRaX's (`rtsim_trax::isa::regs`): the bit stack lives in
//! `SP` (the `stack` pointer's register, unused by `bit-stack`); a fused block's input
//! latches are modelled as the temporaries from `FIRST_TEMP` (so the scoreboard orders the
//! test after its inputs' loads), but an intrinsic that fills a latch writes no register
//! (its `rf` says so), and a test reads its latches without register-file reads.

use crate::pipeline::{self, FusedBlock, Op};
use rtsim_core::Vec3;
use rtsim_trace::kernels::box_entry;
use rtsim_trace::kernels::triangle::{plucker_exit, plucker_exit as exits};
use rtsim_trax::isa::{Class, INST_BYTES, Inst, Mem, NO_REG, Reg, StreamOp, regs};
use rtsim_trax::program::asm::{
    self, Traced, bitwise, branch, imm, int_add, int_mul, last_compare, load, load_value, output,
    record,
};
use rtsim_trax::program::{BlockInfo, Program, Seg};

/// Bit of register `r`.
const fn bit(r: Reg) -> u32 {
    1 << r
}

/// The registers a ray record fills when popped (origin, direction, node, closest t, hit
/// slot, bit stack, and the path id and flags, kept in `CHILD` and `END` until the first
/// step rewrites them): 12 words, 48 B.
pub const RAY_REGS: u32 = bit(regs::ORG[0])
    | bit(regs::ORG[1])
    | bit(regs::ORG[2])
    | bit(regs::DIR[0])
    | bit(regs::DIR[1])
    | bit(regs::DIR[2])
    | bit(regs::NODE)
    | bit(regs::THIT)
    | bit(regs::SLOT)
    | bit(regs::SP)
    | bit(regs::CHILD)
    | bit(regs::END);

/// Words of a ray record (STRaTA §3.1: 48 bytes).
const RAY_WORDS: u8 = (rtsim_trace::step::bitstack::RECORD_BYTES / 4) as u8;

/// What a box test reads besides its latches: origin, inverse direction, tmin, closest hit.
const BOX_READS: u32 = bit(regs::ORG[0])
    | bit(regs::ORG[1])
    | bit(regs::ORG[2])
    | bit(regs::INV[0])
    | bit(regs::INV[1])
    | bit(regs::INV[2])
    | bit(regs::TMIN)
    | bit(regs::THIT);

/// What a triangle test reads besides its latches: origin, direction, tmin, closest hit.
const TRI_READS: u32 = bit(regs::ORG[0])
    | bit(regs::ORG[1])
    | bit(regs::ORG[2])
    | bit(regs::DIR[0])
    | bit(regs::DIR[1])
    | bit(regs::DIR[2])
    | bit(regs::TMIN)
    | bit(regs::THIT);

/// The STRaTA program and where its blocks are.
#[derive(Clone, Debug)]
pub struct StrataProgram {
    /// The TRaX program with STRaTA's blocks appended.
    pub program: Program,
    /// `Step::Parent` (`bit-stack`): the parent pointer (word 8 of the 40-byte node), the
    /// side test on the top bit, its branch.
    pub parent: Seg,
    /// `Step::SiblingRetest`, unfused: the sibling's index, its box test, one branch.
    pub sibling: Seg,
    /// `Step::Push` (`bit-stack`): shift and or.
    pub bit_push: Seg,
    /// `Step::Pop` (`bit-stack`): one shift.
    pub bit_pop: Seg,
    /// Plücker on the vertex record, unfused; `plucker_exit[e]` instructions for exit `e`.
    pub plucker: Seg,
    pub plucker_exit: [u32; 5],
    /// Fused blocks: the child pair (`fused_pair_one` instructions when not both hit), the
    /// root box, the sibling re-test, the triangle test (prefixes per exit: `fused_tri_exit`).
    pub fused_pair: Seg,
    pub fused_pair_one: u32,
    pub fused_root: Seg,
    pub fused_sibling: Seg,
    pub fused_tri: Seg,
    pub fused_tri_exit: [u32; 5],
    /// Stream intrinsics: pop (and the branch on getting a ray), push (the treelet check,
    /// its branch, the push), path-state read and write.
    pub pop: Seg,
    pub push: Seg,
    pub path_read: Seg,
    pub path_write: Seg,
    /// The static fill's next path slot (`arch.strata.fill = static`): `next_pixel` without
    /// the counter.
    pub fill_slot: Seg,
}

struct Builder {
    p: Program,
}

impl Builder {
    fn append(&mut self, name: &'static str, about: &'static str, insts: Vec<Inst>) -> Seg {
        let start = self.p.insts.len() as u32;
        for (k, mut i) in insts.into_iter().enumerate() {
            i.pc = (start + k as u32) * INST_BYTES;
            self.p.insts.push(i);
        }
        let seg = Seg {
            start,
            len: self.p.insts.len() as u32 - start,
        };
        self.p.blocks.push(BlockInfo {
            name,
            about,
            seg,
            exits: Vec::new(),
        });
        seg
    }

    fn recorded(&mut self, name: &'static str, about: &'static str, tape: asm::Tape) -> Seg {
        let c = tape.compile(name);
        self.append(name, about, c.insts)
    }

    fn exits(&mut self, e: Vec<(String, u32)>) {
        self.p.blocks.last_mut().expect("a block").exits = e;
    }
}

fn reg3(r: [Reg; 3], v: Vec3) -> Vec3<Traced> {
    Vec3::xyz(
        Traced::reg(r[0], v.x),
        Traced::reg(r[1], v.y),
        Traced::reg(r[2], v.z),
    )
}

fn load3(base: u8, first: u8, addr: Traced, v: Vec3) -> Vec3<Traced> {
    Vec3::xyz(
        load_value(base, first, addr, v.x),
        load_value(base, first + 1, addr, v.y),
        load_value(base, first + 2, addr, v.z),
    )
}

/// An instruction with an explicit register-file count.
fn wide(class: Class, dst: Reg, src: [Reg; 2], deps: u32, mem: Mem, rf: (u8, u8)) -> Inst {
    Inst {
        mem,
        deps,
        rf: Some(rf),
        ..Inst::new(class, dst, src)
    }
}

/// A fused block of [`crate::pipeline`] as instructions. `inputs` gives each input
/// intrinsic's record (base) and word, in order. Dependences: a test waits for the next
/// box's (6) or triangle's (9) latches in load order and for the ray's registers; what follows a test reads its
/// result (and, for two-operand instructions, the previous test's).
fn fused_insts(f: &FusedBlock, inputs: &[(u8, u8)]) -> Vec<Inst> {
    const LATCH0: Reg = regs::FIRST_TEMP;
    const RESULT0: Reg = regs::FIRST_TEMP + 12;
    const SCRATCH: Reg = regs::FIRST_TEMP + 14;
    let mut out = Vec::with_capacity(f.insts.len());
    let (mut latch, mut first_latch, mut tests) = (0u8, 0u8, 0u8);
    let mut last: [Reg; 2] = [NO_REG, NO_REG];
    for fi in &f.insts {
        let rf = (fi.reads, fi.writes);
        let i = match fi.op {
            Op::LoadInput => {
                let (base, word) = inputs[latch as usize];
                let l = LATCH0 + latch;
                latch += 1;
                // The address comes from the node (or slot) register.
                let addr = if f.name.starts_with("triangle") {
                    regs::CHILD
                } else {
                    regs::NODE
                };
                wide(
                    Class::Load,
                    l,
                    [addr, NO_REG],
                    0,
                    Mem::Word { base, word },
                    rf,
                )
            }
            Op::BoxTest | Op::TriangleTest => {
                let mut deps = if fi.op == Op::BoxTest {
                    BOX_READS
                } else {
                    TRI_READS
                };
                // A box test reads one box (6 words), a triangle test one triangle (9).
                let n = if fi.op == Op::BoxTest { 6 } else { 9 };
                for k in first_latch..(first_latch + n).min(latch) {
                    deps |= bit(LATCH0 + k);
                }
                first_latch += n;
                let r = RESULT0 + tests % 2;
                tests += 1;
                last = [r, last[0]];
                let class = if fi.op == Op::BoxTest {
                    Class::BoxTest
                } else {
                    Class::TriTest
                };
                wide(class, r, [NO_REG, NO_REG], deps, Mem::None, rf)
            }
            Op::Base(class) => {
                let src = if fi.reads >= 2 {
                    [last[0], last[1]]
                } else {
                    [last[0], NO_REG]
                };
                let dst = if fi.writes > 0 { SCRATCH } else { NO_REG };
                let i = wide(class, dst, src, 0, Mem::None, rf);
                if dst != NO_REG {
                    last = [dst, last[0]];
                }
                i
            }
        };
        out.push(i);
    }
    out
}

/// Box words (min, max) of record `base`.
fn box_inputs(base: u8) -> [(u8, u8); 6] {
    std::array::from_fn(|w| (base, w as u8))
}

/// Build the STRaTA program.
pub fn build() -> StrataProgram {
    let mut b = Builder { p: Program::new() };

    // --- `bit-stack` steps, unfused (`ops::step` for `bit-stack`) ------------------------
    let parent = b.recorded(
        "bs_parent",
        "`Step::Parent` (`bit-stack`): load the parent pointer (word 8 of the 40-byte node \
         record), test the top bit against the side of the node left (bitwise and, integer \
         compare) and branch (`ops::step`: load 1, int 1, bitwise 1, branch 1).",
        record(false, || {
            let node = Traced::reg(regs::NODE, 0.0);
            let p = load(0, 8, node);
            output(p, regs::NODE);
            let top = bitwise(Traced::reg(regs::SP, 0.0), imm());
            branch(int_add(top, node));
        }),
    );
    let sibling = b.recorded(
        "bs_sibling_retest",
        "`Step::SiblingRetest` (`bit-stack`): the sibling's index (bitwise), its box (6 \
         loads) tested against the current closest hit, one branch (`ops::BOX_TEST` + \
         bitwise 1 + branch 1).",
        record(false, || {
            let s = bitwise(Traced::reg(regs::NODE, 0.0), imm());
            output(s, regs::NODE);
            let min = load3(0, 0, s, Vec3::splat(1.0));
            let max = load3(0, 3, s, Vec3::splat(2.0));
            box_entry(
                reg3(regs::ORG, Vec3::ZERO),
                reg3(regs::INV, Vec3::ONE),
                min,
                max,
                Traced::reg(regs::TMIN, 0.0),
                Traced::reg(regs::THIT, f32::INFINITY),
            )
            .expect("the recording box is hit");
            branch(last_compare());
        }),
    );
    let bit_push = b.recorded(
        "bs_push",
        "`Step::Push` (`bit-stack`): shift the bit stack and or in the side bit (bitwise 2).",
        record(false, || {
            let s = bitwise(Traced::reg(regs::SP, 0.0), imm());
            output(bitwise(s, imm()), regs::SP);
        }),
    );
    let bit_pop = b.recorded(
        "bs_pop",
        "`Step::Pop` (`bit-stack`): shift the bit stack (bitwise 1).",
        record(false, || {
            output(bitwise(Traced::reg(regs::SP, 0.0), imm()), regs::SP);
        }),
    );
    // Plücker, recorded with a branch after every comparison; only the branches that end an
    // exit (`ops::plucker`: after the 6th, 7th, 10th and 12th comparison) are kept.
    let tape = record(true, || {
        let slot = Traced::reg(regs::CHILD, 0.0);
        let v0 = load3(0, 0, slot, Vec3::ZERO);
        let v1 = load3(0, 3, slot, Vec3::new(1.0, 0.0, 0.0));
        let v2 = load3(0, 6, slot, Vec3::new(0.0, 1.0, 0.0));
        let hit = plucker_exit(
            &[v0, v1, v2],
            reg3(regs::ORG, Vec3::new(0.2, 0.2, 1.0)),
            reg3(regs::DIR, Vec3::new(0.0, 0.0, -1.0)),
            Traced::reg(regs::TMIN, 0.0),
            Traced::reg(regs::THIT, f32::INFINITY),
        );
        assert!(hit.is_ok(), "the recording ray hits the recording triangle");
    });
    // On a triangle treelet the inverse direction and the deferred entry distance are dead.
    let compiled = tape.compile_with(
        "plucker",
        &[
            regs::INV[0],
            regs::INV[1],
            regs::INV[2],
            regs::TNEAR,
            regs::NODE,
            regs::SP,
            regs::SLOT,
            regs::END,
        ],
    );
    let mut insts = Vec::with_capacity(compiled.insts.len());
    let mut compares = 0;
    let mut exit_at = [0u32; 5];
    for i in compiled.insts {
        if i.class == Class::FpCmp {
            compares += 1;
        }
        if i.class == Class::Branch {
            let exit = match compares {
                6 => exits::OUTSIDE,
                7 => exits::PARALLEL,
                10 => exits::RANGE,
                12 => exits::T_ROUNDED,
                _ => continue,
            };
            insts.push(i);
            exit_at[exit as usize] = insts.len() as u32;
            continue;
        }
        insts.push(i);
    }
    exit_at[rtsim_trace::kernels::HIT as usize] = insts.len() as u32;
    let plucker = b.append(
        "plucker",
        "`Step::Triangle` with Plücker (`ops::plucker`), unfused: the 9 vertex words, the \
         signed volumes, the plane, the interval test on t·(n·d), the divide on a hit and \
         the barycentrics; a branch ends each exit (outside, parallel, out of range, \
         rounded out).",
        insts,
    );
    let names = ["hit", "outside", "parallel", "out of range", "rounded out"];
    b.exits(
        exits::ALL
            .iter()
            .map(|&e| (names[e as usize].to_string(), exit_at[e as usize]))
            .collect(),
    );

    // --- Fused blocks (`crate::pipeline`) -------------------------------------------------
    let pair_inputs: Vec<(u8, u8)> = box_inputs(0).into_iter().chain(box_inputs(1)).collect();
    let both = pipeline::child_pair(true);
    let one = pipeline::child_pair(false);
    let fused_pair = b.append(
        "fused_child_pair",
        "`Step::ChildPair` through the box pipeline (`pipeline::child_pair`): 12 input \
         intrinsics, two box tests, the right child's index, a branch per hit; when both are \
         hit, the order comparison and its branch (the last two).",
        fused_insts(&both, &pair_inputs),
    );
    let fused_root = b.append(
        "fused_root_box",
        "`Step::RootBox` through the box pipeline (`pipeline::root_box`).",
        fused_insts(&pipeline::root_box(), &box_inputs(0)),
    );
    let fused_sibling = b.append(
        "fused_sibling_retest",
        "`Step::SiblingRetest` through the box pipeline (`pipeline::sibling_retest`).",
        fused_insts(&pipeline::sibling_retest(), &box_inputs(0)),
    );
    let tri_inputs: Vec<(u8, u8)> = (0..9).map(|w| (0, w)).collect();
    let full = pipeline::triangle(rtsim_trace::kernels::HIT);
    let fused_tri = b.append(
        "fused_triangle",
        "`Step::Triangle` through a triangle pipeline (`pipeline::triangle`): 9 input \
         intrinsics, the Plücker test, its branch; on the way to a hit the divide, t and the \
         interval re-check outside the pipeline; on a hit the barycentrics.",
        fused_insts(&full, &tri_inputs),
    );
    let mut fused_tri_exit = [0u32; 5];
    for e in exits::ALL {
        fused_tri_exit[e as usize] = pipeline::triangle(e).fetches();
    }

    // --- Stream intrinsics ------------------------------------------------------------------
    let pop = b.append(
        "stream_pop",
        "Pop a ray from the TM's treelet buffer into the ray registers (one stream access, 12 \
         register writes), and branch on having got one.",
        vec![
            wide(
                Class::StreamLoad,
                regs::NODE,
                [NO_REG, NO_REG],
                RAY_REGS,
                Mem::Stream(StreamOp::Pop),
                (0, RAY_WORDS),
            ),
            Inst::new(Class::Branch, NO_REG, [regs::NODE, NO_REG]),
        ],
    );
    let push = b.append(
        "stream_push",
        "Leave the treelet: compare the treelet tag of the record entered (word 9 of a node) \
         with the TM's, branch, and push the ray's registers onto that treelet's buffer (one \
         stream access, 12 register reads).",
        vec![
            Inst::new(Class::IntAdd, regs::FIRST_TEMP, [regs::NODE, NO_REG]),
            Inst::new(Class::Branch, NO_REG, [regs::FIRST_TEMP, NO_REG]),
            wide(
                Class::StreamStore,
                NO_REG,
                [NO_REG, NO_REG],
                RAY_REGS,
                Mem::Stream(StreamOp::Push),
                (RAY_WORDS, 0),
            ),
        ],
    );
    let path_read = b.append(
        "path_read",
        "Read the path's state record from the stream memory (one access; a register write \
         per word).",
        vec![wide(
            Class::StreamLoad,
            NO_REG,
            [NO_REG, NO_REG],
            0,
            Mem::Stream(StreamOp::PathRead),
            (0, 16),
        )],
    );
    let path_write = b.append(
        "path_write",
        "Write the path's state record to the stream memory (one access; a register read per \
         word).",
        vec![wide(
            Class::StreamStore,
            NO_REG,
            [NO_REG, NO_REG],
            0,
            Mem::Stream(StreamOp::PathWrite),
            (16, 0),
        )],
    );
    let fill_slot = b.recorded(
        "fill_slot",
        "The static fill's next path slot (`arch.strata.fill = static`): the previous slot \
         plus the TP count (the first is the TP's index, read like any register; assumed), the \
         test against the slot count and its branch, then x and y from the index as \
         `next_pixel` (int add 3, int mul 2, bitwise 1, branch 1: `next_pixel` with an add in \
         place of its `atominc`).",
        record(false, || {
            let s = int_add(Traced::reg(regs::SLOT, 0.0), imm());
            output(s, regs::SLOT);
            branch(int_add(s, imm()));
            let y = bitwise(int_mul(s, imm()), imm());
            let _x = int_add(s, int_mul(y, imm()));
        }),
    );
    StrataProgram {
        program: b.p,
        parent,
        sibling,
        bit_push,
        bit_pop,
        plucker,
        plucker_exit: exit_at,
        fused_pair,
        fused_pair_one: one.fetches(),
        fused_root,
        fused_sibling,
        fused_tri,
        fused_tri_exit,
        pop,
        push,
        path_read,
        path_write,
        fill_slot,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rtsim_trace::ops;
    use rtsim_trax::program::expected_classes;

    fn classes(p: &Program, s: Seg) -> [u64; rtsim_trax::isa::CLASSES] {
        p.class_counts(s).map(u64::from)
    }

    #[test]
    fn the_trax_blocks_keep_their_addresses_and_the_program_fits_the_icache() {
        let sp = build();
        let base = Program::new();
        assert_eq!(&sp.program.insts[..base.insts.len()], &base.insts[..]);
        assert!(
            sp.program.bytes() <= rtsim_trax::TraxConfig::default().icache_bytes,
            "{} bytes",
            sp.program.bytes()
        );
    }

    #[test]
    fn the_static_fill_block_is_next_pixel_without_the_counter() {
        let sp = build();
        let p = &sp.program;
        let mut want = classes(p, p.next_pixel);
        assert_eq!(want[Class::Atomic as usize], 1);
        want[Class::Atomic as usize] = 0;
        want[Class::IntAdd as usize] += 1;
        assert_eq!(classes(p, sp.fill_slot), want);
    }

    #[test]
    fn unfused_blocks_match_the_operation_tables() {
        use rtsim_trace::{Step, Traversal, TriangleTest};
        let sp = build();
        let p = &sp.program;
        let bs =
            |s: &Step| expected_classes(&ops::step(Traversal::BitStack, TriangleTest::Plucker, s));
        assert_eq!(
            classes(p, sp.parent),
            bs(&Step::Parent { node: 3, parent: 1 })
        );
        assert_eq!(
            classes(p, sp.sibling),
            bs(&Step::SiblingRetest { node: 3, hit: true })
        );
        assert_eq!(
            classes(p, sp.bit_push),
            bs(&Step::Push {
                node: 0,
                depth: 0,
                dropped: false
            })
        );
        assert_eq!(
            classes(p, sp.bit_pop),
            bs(&Step::Pop {
                node: 0,
                depth: 0,
                culled: false
            })
        );
        // Plücker: each exit's prefix has exactly `ops::plucker`'s classes.
        for e in exits::ALL {
            let seg = sp.plucker.prefix(sp.plucker_exit[e as usize]);
            assert_eq!(
                classes(p, seg),
                expected_classes(&ops::plucker(e)),
                "exit {e}"
            );
        }
    }

    #[test]
    fn fused_blocks_have_the_hand_counted_fetches_and_register_accesses() {
        let sp = build();
        let p = &sp.program;
        let rf = |s: Seg| {
            p.seg(s).iter().fold((0, 0), |(r, w), i| {
                let (a, b) = i.register_accesses();
                (r + a, w + b)
            })
        };
        let both = pipeline::child_pair(true);
        assert_eq!(sp.fused_pair.len, both.fetches());
        assert_eq!(rf(sp.fused_pair), both.register_accesses());
        let one = pipeline::child_pair(false);
        assert_eq!(
            rf(sp.fused_pair.prefix(sp.fused_pair_one)),
            one.register_accesses()
        );
        for e in exits::ALL {
            let f = pipeline::triangle(e);
            let seg = sp.fused_tri.prefix(sp.fused_tri_exit[e as usize]);
            assert_eq!(rf(seg), f.register_accesses(), "exit {e}");
            assert_eq!(
                p.class_counts(seg)[Class::TriTest as usize],
                1,
                "one fused test per triangle"
            );
        }
        assert_eq!(rf(sp.fused_root), pipeline::root_box().register_accesses());
        assert_eq!(
            rf(sp.fused_sibling),
            pipeline::sibling_retest().register_accesses()
        );
        // The pair's box tests wait for their own six latches.
        let tests: Vec<&Inst> = p
            .seg(sp.fused_pair)
            .iter()
            .filter(|i| i.class == Class::BoxTest)
            .collect();
        assert_eq!(tests.len(), 2);
        assert_eq!((tests[0].deps & !BOX_READS).count_ones(), 6);
        assert_eq!((tests[1].deps & !BOX_READS).count_ones(), 6);
        assert_eq!(tests[0].deps & tests[1].deps & !BOX_READS, 0);
    }
}
