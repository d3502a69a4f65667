//! The ray program every TP runs, written once as instruction blocks.
//!
//! One block per unit of work of the substrate: each step of the `stack` traversal
//! ([`rtsim_trace::Step`]), the per-ray setup of box testing, each shading kernel of the
//! workload ([`rtsim_trace::Kernel`]) with the record reads and the framebuffer write, and the
//! `atominc` that hands out the next pixel. Blocks are recorded from the real kernels
//! ([`asm`]): their floating-point instructions are exactly the operations the functional
//! kernels perform, so the instruction counts agree with `rtsim_trace::ops`' tables by
//! construction (a test checks every class of every block), and the data flow between them is
//! the kernels' own.
//!
//! The program is laid out contiguously from address 0 (4-byte instructions) and is resident
//! in each instruction cache. A dynamic block ([`Run`]) is one segment of the program (a block,
//! or a prefix of it where a kernel exits early: the triangle test's exits, a child pair whose
//! boxes are not both hit) plus the byte addresses of the records its loads and stores reach
//! and the stack slot its local-memory accesses use.
//!
//! `docs/TRAX_PROGRAM.md` is [`Program::listing`]'s output (a test keeps it current).

pub mod asm;
mod blocks;
mod listing;

use crate::isa::{Class, INST_BYTES, Inst};
use rtsim_trace::workload::{KERNELS, Kernel};

/// The order in which a transition's shading blocks run (each as often as
/// `Shading::count` says); the material read follows `Surface`, the framebuffer write
/// `Finish`. It follows the data flow of `Integrator::resume`: the surface before what shades
/// it, the next ray's direction last.
pub const SHADING_ORDER: [Kernel; KERNELS] = [
    Kernel::Surface,
    Kernel::Headlight,
    Kernel::DirectLight,
    Kernel::Weighted,
    Kernel::Attenuate,
    Kernel::ShadowRay,
    Kernel::CosineBounce,
    Kernel::HaltonRay,
    Kernel::Reflect,
    Kernel::Accumulate,
    Kernel::Finish,
    Kernel::Jitter,
    Kernel::CameraRay,
];

/// A run of consecutive instructions of the program.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Seg {
    /// Index of the first instruction (its address is `start × 4`).
    pub start: u32,
    pub len: u32,
}

impl Seg {
    /// The first `len` instructions of this segment.
    #[inline]
    pub fn prefix(self, len: u32) -> Seg {
        debug_assert!(len <= self.len);
        Seg {
            start: self.start,
            len,
        }
    }
    #[inline]
    pub fn range(self) -> std::ops::Range<usize> {
        self.start as usize..(self.start + self.len) as usize
    }
}

/// One dynamic block: the instructions a TP executes for one unit of work, with the addresses
/// its memory instructions reach.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Run {
    pub seg: Seg,
    /// Byte addresses of the records the block's loads and stores reach (`Mem::Word { base }`).
    pub base: [u64; 2],
    /// Local-memory byte address of the stack entry (`Mem::Local`).
    pub local: u32,
}

impl Run {
    pub fn new(seg: Seg) -> Run {
        Run {
            seg,
            base: [0; 2],
            local: 0,
        }
    }
    pub fn at(seg: Seg, base0: u64) -> Run {
        Run {
            seg,
            base: [base0, 0],
            local: 0,
        }
    }
}

/// A named block of the program, for listings.
#[derive(Clone, Debug)]
pub struct BlockInfo {
    pub name: &'static str,
    /// What it does and where its operation counts come from.
    pub about: &'static str,
    pub seg: Seg,
    /// Early exits: (name, instructions executed).
    pub exits: Vec<(String, u32)>,
}

/// The whole ray program.
#[derive(Clone, Debug)]
pub struct Program {
    pub insts: Vec<Inst>,
    pub blocks: Vec<BlockInfo>,
    /// Per-ray setup: the three reciprocals of the direction with their finiteness checks.
    pub ray_setup: Seg,
    /// The `copysign` replacing an infinite reciprocal (once per zero direction component).
    pub inv_fixup: Seg,
    pub root_box: Seg,
    pub node: Seg,
    /// The child pair test; its first `pair_one` instructions when the boxes are not both
    /// hit (the full block adds the order comparison and its branch).
    pub pair: Seg,
    pub pair_one: u32,
    pub push: Seg,
    pub pop: Seg,
    /// Möller–Trumbore on the vertex record; `tri_exit[e]` instructions run for exit `e`
    /// (`rtsim_trace::kernels::triangle::mt_exit`, `HIT` = 0).
    pub tri: Seg,
    pub tri_exit: [u32; 8],
    /// The leaf loop's tail after every triangle test (slot increment, loop test, branch).
    pub tri_tail: Seg,
    /// One block per shading kernel (`Kernel as usize`); `Surface` includes the triangle
    /// record's loads.
    pub kernels: [Seg; KERNELS],
    pub material_read: Seg,
    pub framebuffer_write: Seg,
    pub next_pixel: Seg,
}

impl Program {
    /// Build the program (deterministic; a few hundred instructions).
    pub fn new() -> Program {
        blocks::build()
    }

    /// Bytes of instruction memory the program occupies.
    pub fn bytes(&self) -> u32 {
        self.insts.len() as u32 * INST_BYTES
    }

    /// The instructions of a segment.
    #[inline]
    pub fn seg(&self, s: Seg) -> &[Inst] {
        &self.insts[s.range()]
    }

    /// Instruction count by class of a segment.
    pub fn class_counts(&self, s: Seg) -> [u32; crate::isa::CLASSES] {
        let mut c = [0; crate::isa::CLASSES];
        for i in self.seg(s) {
            c[i.class as usize] += 1;
        }
        c
    }

    /// The Markdown listing published as `docs/TRAX_PROGRAM.md`.
    pub fn listing(&self) -> String {
        listing::markdown(self)
    }

    /// The class of every instruction (for tests and listings).
    pub fn classes(&self, s: Seg) -> Vec<Class> {
        self.seg(s).iter().map(|i| i.class).collect()
    }
}

impl Default for Program {
    fn default() -> Self {
        Program::new()
    }
}

/// The instructions by class that an operation mix of `rtsim_trace::ops` becomes in this
/// program: a square root is an inverse square root and a multiply, sines and cosines (which
/// `ops` counts together as `ftrig`, always in pairs) their polynomials ([`asm::SIN`],
/// [`asm::COS`]). Local-memory words are reported under [`Class::LocalLoad`] (loads and stores
/// together; see [`fold_local`]).
pub fn expected_classes(m: &rtsim_trace::ops::OpMix) -> [u64; crate::isa::CLASSES] {
    assert!(m.ftrig % 2 == 0, "ops counts sine and cosine in pairs");
    let pairs = (m.ftrig / 2) as u64;
    let mut c = [0u64; crate::isa::CLASSES];
    c[Class::FpAdd as usize] = m.fadd as u64 + pairs * (asm::SIN.1 + asm::COS.1) as u64;
    c[Class::FpMul as usize] =
        m.fmul as u64 + m.fsqrt as u64 + pairs * (asm::SIN.0 + asm::COS.0) as u64;
    c[Class::FpMinMax as usize] = m.fminmax as u64;
    c[Class::FpCmp as usize] = m.fcmp as u64;
    c[Class::IntAdd as usize] = m.int_add as u64;
    c[Class::IntMul as usize] = m.int_mul as u64;
    c[Class::DivSqrt as usize] = m.fdiv as u64 + m.fsqrt as u64;
    c[Class::Conv as usize] = m.conv as u64;
    c[Class::Branch as usize] = m.branch as u64;
    c[Class::Bitwise as usize] = m.bitwise as u64;
    c[Class::Load as usize] = m.load as u64;
    c[Class::Store as usize] = m.store as u64;
    c[Class::LocalLoad as usize] = m.local as u64;
    c
}

/// Local-memory loads and stores reported together under [`Class::LocalLoad`], as
/// [`expected_classes`] does.
pub fn fold_local(mut c: [u64; crate::isa::CLASSES]) -> [u64; crate::isa::CLASSES] {
    c[Class::LocalLoad as usize] += c[Class::LocalStore as usize];
    c[Class::LocalStore as usize] = 0;
    c
}

#[cfg(test)]
mod tests;
