//! Every block against `rtsim_trace::ops`' tables.

use super::*;
use crate::isa::{CLASSES, Mem, NO_REG, regs};
use rtsim_trace::ops::{self, OpMix};
use rtsim_trace::step::{NONE, Step};
use rtsim_trace::traverse::SlotHit;
use rtsim_trace::{Traversal, TriangleTest};

fn counts(p: &Program, segs: &[Seg]) -> [u64; CLASSES] {
    let mut c = [0u64; CLASSES];
    for &s in segs {
        for (k, n) in p.class_counts(s).into_iter().enumerate() {
            c[k] += n as u64;
        }
    }
    fold_local(c)
}

fn step_mix(s: &Step) -> OpMix {
    ops::step(Traversal::Stack, TriangleTest::MollerTrumbore, s)
}

#[test]
fn traversal_blocks_match_the_step_table() {
    let p = Program::new();
    let pair_one = p.pair.prefix(p.pair_one);
    let cases: Vec<(Step, Vec<Seg>)> = vec![
        (Step::RootBox { hit: true }, vec![p.root_box]),
        (
            Step::Node {
                node: 3,
                leaf: false,
            },
            vec![p.node],
        ),
        (
            Step::ChildPair {
                left: 1,
                hit: [true, false],
            },
            vec![pair_one],
        ),
        (
            Step::ChildPair {
                left: 1,
                hit: [false, false],
            },
            vec![pair_one],
        ),
        (
            Step::ChildPair {
                left: 1,
                hit: [true, true],
            },
            vec![p.pair],
        ),
        (
            Step::Push {
                node: 2,
                depth: 0,
                dropped: false,
            },
            vec![p.push],
        ),
        (
            Step::Pop {
                node: 2,
                depth: 0,
                culled: false,
            },
            vec![p.pop],
        ),
        (Step::Done(SlotHit::miss(1.0)), vec![]),
    ];
    for (step, segs) in cases {
        assert_eq!(
            counts(&p, &segs),
            expected_classes(&step_mix(&step)),
            "{step:?}"
        );
    }
    for exit in ALL_EXITS_FOR_TEST {
        let step = Step::Triangle {
            slot: 0,
            hit: exit == 0,
            exit,
        };
        let segs = [p.tri.prefix(p.tri_exit[exit as usize]), p.tri_tail];
        assert_eq!(
            counts(&p, &segs),
            expected_classes(&step_mix(&step)),
            "exit {exit}"
        );
    }
    let _ = NONE;
}

const ALL_EXITS_FOR_TEST: [u8; 8] = rtsim_trace::kernels::triangle::mt_exit::ALL;

#[test]
fn ray_setup_and_records_match_their_tables() {
    let p = Program::new();
    assert_eq!(
        counts(&p, &[p.ray_setup]),
        expected_classes(&ops::INVERSE_DIRECTION)
    );
    assert_eq!(
        counts(&p, &[p.inv_fixup]),
        expected_classes(&ops::INVERSE_DIRECTION_FIXUP)
    );
    let loads = |n| OpMix {
        load: n,
        ..OpMix::ZERO
    };
    assert_eq!(
        counts(&p, &[p.material_read]),
        expected_classes(&loads(ops::MATERIAL_READ_WORDS))
    );
    assert_eq!(
        counts(&p, &[p.framebuffer_write]),
        expected_classes(&OpMix {
            store: ops::FRAMEBUFFER_WRITE_WORDS,
            ..OpMix::ZERO
        })
    );
}

#[test]
fn kernel_blocks_match_the_kernel_table() {
    let p = Program::new();
    for k in ops::ALL_KERNELS {
        let mut want = ops::kernel(k);
        if k == rtsim_trace::Kernel::Surface {
            // The surface block carries the triangle record's reads.
            want.load += ops::TRIANGLE_READ_WORDS;
        }
        assert_eq!(
            counts(&p, &[p.kernels[k as usize]]),
            expected_classes(&want),
            "{k:?}"
        );
    }
}

#[test]
fn the_program_fits_a_4kb_instruction_cache_and_32_registers() {
    let p = Program::new();
    assert!(p.bytes() <= 4096, "{} bytes", p.bytes());
    for (k, i) in p.insts.iter().enumerate() {
        assert_eq!(i.pc, k as u32 * 4);
        assert!(i.dst == NO_REG || (i.dst as u32) < regs::USED);
        for s in i.src {
            assert!(s == NO_REG || (s as u32) < regs::USED);
        }
    }
    // Blocks tile the program.
    let mut next = 0;
    for b in &p.blocks {
        assert_eq!(b.seg.start, next, "{}", b.name);
        next += b.seg.len;
    }
    assert_eq!(next as usize, p.insts.len());
}

#[test]
fn loads_chase_their_addresses() {
    let p = Program::new();
    // The child pair's loads are addressed from the child index the node step loaded.
    for i in p.seg(p.pair) {
        if i.class == crate::isa::Class::Load {
            assert_eq!(i.src[0], regs::CHILD);
            assert!(matches!(
                i.mem,
                Mem::Word {
                    base: 0 | 1,
                    word: 0..=5
                }
            ));
        }
    }
    // The node step writes the child index; the triangle test reads the slot from it.
    assert!(p.seg(p.node).iter().any(|i| i.dst == regs::CHILD));
    assert!(
        p.seg(p.tri)
            .iter()
            .filter(|i| i.class == crate::isa::Class::Load)
            .all(|i| i.src[0] == regs::CHILD)
    );
    // Every comparison of the triangle test is followed by the branch on its result.
    let tri = p.seg(p.tri);
    for w in tri.windows(2) {
        if w[0].class == crate::isa::Class::FpCmp {
            assert_eq!(w[1].class, crate::isa::Class::Branch);
            assert_eq!(w[1].src[0], w[0].dst);
        }
    }
}

#[test]
fn program_listing_is_published() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/TRAX_PROGRAM.md");
    let text = Program::new().listing();
    if std::env::var_os("RTSIM_BLESS").is_some() {
        std::fs::write(&path, &text).unwrap();
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == text,
        "docs/TRAX_PROGRAM.md differs from Program::listing(); rerun with RTSIM_BLESS=1"
    );
}
