//! Operation counts per kernel: what each unit of work costs in arithmetic, control and
//! memory operations.
//!
//! The hardware models charge work from these tables: the TRaX baseline's instruction blocks,
//! STRaTA's fused pipelines and the energy model all count from the same [`OpMix`]es.
//!
//! How the numbers are obtained:
//!
//! - **Floating-point operations** (add/sub, multiply, min/max, compare, divide, square
//!   root, sine/cosine, int→float conversion) are measured: the kernels are written once,
//!   generic over [`rtsim_core::Real`], and the tests below run the very same code on
//!   [`Counted`], a scalar that counts each operation, over many random inputs, and check that
//!   every outcome of every kernel costs exactly what the table says.
//! - **Loads, stores, local-memory accesses, integer, bitwise and branch operations** come
//!   from the record layouts (`docs/MEMORY_IMAGE.md`) and the code paths, by inspection; each
//!   table entry says how. Sign flips, `abs` and `copysign` are bitwise operations.
//!
//! The mixes describe a straightforward scalar program (TRaX's TPs): one instruction per
//! operation, records loaded word by word, ray data in registers.

use crate::config::{Traversal, TriangleTest};
use crate::kernels::triangle::{mt_exit, plucker_exit, wald_exit};
use crate::step::Step;
use crate::workload::Kernel;
use rtsim_core::Real;
use serde::{Deserialize, Serialize};
use std::cell::Cell;
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// Operations by class.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct OpMix {
    /// Floating-point add and subtract.
    pub fadd: u32,
    pub fmul: u32,
    /// Floating-point min and max.
    pub fminmax: u32,
    /// Floating-point comparisons (including finiteness tests).
    pub fcmp: u32,
    pub fdiv: u32,
    /// Square root (TRaX: the unit shared by divide and inverse square root).
    pub fsqrt: u32,
    /// Sine and cosine (software on TRaX: see `docs/TRAX_PROGRAM.md`).
    pub ftrig: u32,
    /// Integer ↔ float conversions.
    pub conv: u32,
    pub int_add: u32,
    pub int_mul: u32,
    /// Bitwise and shift operations, sign flips, `abs`, `copysign`.
    pub bitwise: u32,
    /// Conditional branches.
    pub branch: u32,
    /// Words loaded through the data cache.
    pub load: u32,
    /// Words stored through the data cache.
    pub store: u32,
    /// Local-memory accesses (words).
    pub local: u32,
}

impl OpMix {
    pub const ZERO: OpMix = OpMix {
        fadd: 0,
        fmul: 0,
        fminmax: 0,
        fcmp: 0,
        fdiv: 0,
        fsqrt: 0,
        ftrig: 0,
        conv: 0,
        int_add: 0,
        int_mul: 0,
        bitwise: 0,
        branch: 0,
        load: 0,
        store: 0,
        local: 0,
    };

    /// All operations (instructions, for a one-instruction-per-operation program).
    pub fn total(&self) -> u32 {
        self.fadd
            + self.fmul
            + self.fminmax
            + self.fcmp
            + self.fdiv
            + self.fsqrt
            + self.ftrig
            + self.conv
            + self.int_add
            + self.int_mul
            + self.bitwise
            + self.branch
            + self.load
            + self.store
            + self.local
    }

    /// The floating-point part only (what [`Counted`] measures).
    pub fn float_part(&self) -> OpMix {
        OpMix {
            fadd: self.fadd,
            fmul: self.fmul,
            fminmax: self.fminmax,
            fcmp: self.fcmp,
            fdiv: self.fdiv,
            fsqrt: self.fsqrt,
            ftrig: self.ftrig,
            conv: self.conv,
            bitwise: self.bitwise,
            ..OpMix::ZERO
        }
    }

    /// `self` repeated `n` times.
    pub fn times(&self, n: u32) -> OpMix {
        let mut m = OpMix::ZERO;
        for _ in 0..n {
            m += *self;
        }
        m
    }
}

impl AddAssign for OpMix {
    fn add_assign(&mut self, o: OpMix) {
        self.fadd += o.fadd;
        self.fmul += o.fmul;
        self.fminmax += o.fminmax;
        self.fcmp += o.fcmp;
        self.fdiv += o.fdiv;
        self.fsqrt += o.fsqrt;
        self.ftrig += o.ftrig;
        self.conv += o.conv;
        self.int_add += o.int_add;
        self.int_mul += o.int_mul;
        self.bitwise += o.bitwise;
        self.branch += o.branch;
        self.load += o.load;
        self.store += o.store;
        self.local += o.local;
    }
}

impl Add for OpMix {
    type Output = OpMix;
    fn add(mut self, o: OpMix) -> OpMix {
        self += o;
        self
    }
}

/// Shorthand for the tables.
#[allow(clippy::too_many_arguments)]
const fn fp(fadd: u32, fmul: u32, fminmax: u32, fcmp: u32, fdiv: u32, fsqrt: u32) -> OpMix {
    OpMix {
        fadd,
        fmul,
        fminmax,
        fcmp,
        fdiv,
        fsqrt,
        ..OpMix::ZERO
    }
}

const fn with(m: OpMix, bitwise: u32, branch: u32, load: u32) -> OpMix {
    OpMix {
        bitwise,
        branch,
        load,
        ..m
    }
}

// ---------------------------------------------------------------------------------------
// Box test

/// One slab test (`kernels::box_entry`): 6 subtractions, 6 multiplies, 12 min/max, the final
/// comparison (STRaTA §3.3: "six floating point multiplies and six floating point
/// subtracts, followed by several comparisons"). Loads: the box, 6 words.
pub const BOX_TEST: OpMix = with(fp(6, 6, 12, 1, 0, 0), 0, 0, 6);

/// The per-ray setup of box testing (`kernels::inverse_direction`): three reciprocals, each
/// checked for finiteness (a ±∞ reciprocal is replaced by ±MAX with `copysign`: add
/// [`INVERSE_DIRECTION_FIXUP`] per zero component).
pub const INVERSE_DIRECTION: OpMix = with(fp(0, 0, 0, 3, 3, 0), 0, 3, 0);
/// The `copysign` replacing one infinite reciprocal.
pub const INVERSE_DIRECTION_FIXUP: OpMix = with(OpMix::ZERO, 1, 0, 0);

// ---------------------------------------------------------------------------------------
// Triangle tests

/// Möller–Trumbore from the memory image's vertex record: load 9 words, form the two edges
/// (6 subtractions, `kernels::triangle::mt_edges`), then the test up to `exit`. Branches: one
/// per comparison evaluated (each decides an early return).
pub fn moller_trumbore(exit: u8) -> OpMix {
    // Floating-point work up to each exit, measured (see tests); cumulative along the code.
    let test = match exit {
        mt_exit::PARALLEL => fp(5, 9, 0, 1, 0, 0),
        mt_exit::U_LOW => fp(10, 13, 0, 2, 1, 0),
        mt_exit::U_HIGH => fp(10, 13, 0, 3, 1, 0),
        mt_exit::V_LOW => fp(15, 23, 0, 4, 1, 0),
        mt_exit::UV_HIGH => fp(16, 23, 0, 5, 1, 0),
        mt_exit::T_LOW => fp(18, 27, 0, 6, 1, 0),
        // T_HIGH and HIT run every comparison.
        _ => fp(18, 27, 0, 7, 1, 0),
    };
    let edges = fp(6, 0, 0, 0, 0, 0);
    with(edges + test, 0, test.fcmp, 9)
}

/// Plücker on the vertex record (STRaTA's triangle pipeline): load 9 words; the sign and
/// interval tests are evaluated in full. Branches: the outside test, the parallel test, the
/// interval test, and on the way to a hit the rounded-interval test.
pub fn plucker(exit: u8) -> OpMix {
    let (test, branches) = match exit {
        plucker_exit::OUTSIDE => (fp(24, 27, 0, 6, 0, 0), 1),
        plucker_exit::PARALLEL => (fp(35, 36, 0, 7, 0, 0), 2),
        plucker_exit::RANGE => (fp(37, 41, 0, 10, 0, 0), 3),
        plucker_exit::T_ROUNDED => (fp(37, 42, 0, 12, 1, 0), 4),
        // A hit also scales and negates two signed volumes for the barycentrics.
        _ => (
            OpMix {
                bitwise: 2,
                ..fp(37, 44, 0, 12, 1, 0)
            },
            4,
        ),
    };
    with(test, test.bitwise, branches, 9)
}

/// Wald's test on its precomputed record: load 10 words (9 floats and the axis); the axis
/// check is an integer comparison.
pub fn wald(exit: u8) -> OpMix {
    let test = match exit {
        wald_exit::DEGENERATE => OpMix::ZERO,
        wald_exit::PARALLEL => fp(2, 2, 0, 1, 0, 0),
        wald_exit::T_LOW => fp(5, 5, 0, 2, 1, 0),
        wald_exit::T_HIGH => fp(5, 5, 0, 3, 1, 0),
        wald_exit::U_LOW => fp(9, 9, 0, 4, 1, 0),
        wald_exit::V_LOW => fp(11, 11, 0, 5, 1, 0),
        _ => fp(12, 11, 0, 6, 1, 0),
    };
    OpMix {
        int_add: 1,
        ..with(test, 0, test.fcmp + 1, 10)
    }
}

/// The triangle test of `test` ending at `exit`.
pub fn triangle(test: TriangleTest, exit: u8) -> OpMix {
    match test {
        TriangleTest::MollerTrumbore => moller_trumbore(exit),
        TriangleTest::Plucker => plucker(exit),
        TriangleTest::Wald => wald(exit),
    }
}

// ---------------------------------------------------------------------------------------
// Traversal steps

/// One traversal step of `variant` with triangle test `test`: the kernels it runs plus the
/// control around them (by inspection of `crate::step`):
///
/// | step | operations |
/// |---|---|
/// | `RootBox` | the root's box test, one branch |
/// | `Node` | load index and count (2 words), one integer comparison (leaf?), one branch |
/// | `ChildPair` | two box tests, `left + 1`, two branches on the hits, and when both hit the order comparison and its branch |
/// | `Push` | `stack`/`short-stack`: store node and entry distance to local memory (2 words), stack pointer increment; `short-stack` wraps its ring (one bitwise) and, when full, drops the oldest (one more integer add); `bit-stack`: shift and or (2 bitwise) |
/// | `Pop` | empty test (integer compare and branch); `stack`/`short-stack`: load 2 words from local memory, decrement, cull comparison and branch; `bit-stack`: one shift |
/// | `Triangle` | the triangle test to its exit, the slot increment, loop compare and branch |
/// | `Parent` | `bit-stack`: load the parent word, the side test (bitwise and compare, branch) |
/// | `SiblingRetest` | `bit-stack`: the sibling index (bitwise), a box test, one branch |
/// | `Restart` | `short-stack`: reset node and level (2 integer moves counted as adds) |
/// | `Treelet` | nothing in the core: the ray leaves (the streaming model charges the buffer write) |
/// | `Done` | nothing: the hit is in registers |
pub fn step(variant: Traversal, test: TriangleTest, s: &Step) -> OpMix {
    let int = |n| OpMix {
        int_add: n,
        ..OpMix::ZERO
    };
    let branch = |n| OpMix {
        branch: n,
        ..OpMix::ZERO
    };
    let bits = |n| OpMix {
        bitwise: n,
        ..OpMix::ZERO
    };
    match *s {
        Step::RootBox { .. } => BOX_TEST + branch(1),
        Step::Node { .. } => OpMix {
            load: 2,
            ..int(1) + branch(1)
        },
        Step::ChildPair { hit, .. } => {
            let both = hit[0] && hit[1];
            BOX_TEST.times(2)
                + int(1)
                + branch(2)
                + if both {
                    OpMix {
                        fcmp: 1,
                        branch: 1,
                        ..OpMix::ZERO
                    }
                } else {
                    OpMix::ZERO
                }
        }
        Step::Push { dropped, .. } => match variant {
            Traversal::BitStack => bits(2),
            Traversal::Stack => OpMix { local: 2, ..int(1) },
            Traversal::ShortStack => OpMix {
                local: 2,
                ..int(1 + dropped as u32) + bits(1)
            },
        },
        Step::Pop { .. } => match variant {
            Traversal::BitStack => bits(1),
            _ => OpMix {
                local: 2,
                fcmp: 1,
                ..int(2) + branch(2)
            },
        },
        Step::Triangle { exit, .. } => triangle(test, exit) + int(2) + branch(1),
        Step::Parent { .. } => OpMix {
            load: 1,
            int_add: 1,
            ..bits(1) + branch(1)
        },
        Step::SiblingRetest { .. } => BOX_TEST + bits(1) + branch(1),
        Step::Restart => int(2),
        Step::Treelet { .. } | Step::Done(_) => OpMix::ZERO,
    }
}

// ---------------------------------------------------------------------------------------
// Shading, ray generation, random numbers

/// One uniform random number (`Pcg32::next_f32`, by inspection of `rtsim_core::rng`): the
/// 64-bit LCG step (one multiply, one add), the XSH-RR output (three shifts, one xor, one
/// rotate), the top 24 bits (one shift), conversion and scaling (one multiply).
pub const RANDOM: OpMix = OpMix {
    int_mul: 1,
    int_add: 1,
    bitwise: 6,
    conv: 1,
    fmul: 1,
    ..OpMix::ZERO
};

/// The operations of one run of a shading kernel (see [`Kernel`]), on its costliest path.
/// Floating-point parts are measured on the generic functions in [`crate::shade`] and
/// [`crate::sampling`] (the tests check that no run costs more and some run costs exactly
/// this); branches by inspection. Record reads and the framebuffer write are charged per
/// transition by [`shading`]; the light's position and intensity stay in registers
/// (assumed: per-frame constants).
pub fn kernel(k: Kernel) -> OpMix {
    match k {
        // Pixel coordinates converted and offset, the direction through them, normalised.
        Kernel::CameraRay => OpMix {
            conv: 2,
            branch: 1,
            ..fp(12, 17, 0, 1, 3, 1)
        },
        Kernel::Jitter => RANDOM.times(2),
        // Normal (edges, cross, normalise), facing test and flip (3 sign flips; a surface
        // facing away costs 3 bitwise operations less), interpolated point, offset.
        Kernel::Surface => OpMix {
            branch: 2,
            bitwise: 3,
            ..fp(24, 27, 0, 2, 1, 1)
        },
        Kernel::Headlight => OpMix {
            bitwise: 3,
            ..fp(6, 7, 1, 0, 0, 0)
        },
        Kernel::DirectLight => fp(7, 13, 2, 0, 2, 1),
        Kernel::ShadowRay => fp(3, 0, 0, 0, 0, 0),
        // Two random numbers, the concentric map (a divide, sine and cosine; the second
        // branch of the map costs one subtraction more), the lift to the hemisphere, the
        // basis around the normal, the rotation and normalisation.
        Kernel::CosineBounce => {
            RANDOM.times(2)
                + OpMix {
                    ftrig: 2,
                    bitwise: 6,
                    branch: 3,
                    ..fp(16, 31, 1, 3, 3, 2)
                }
        }
        // The Halton point (`sampling::halton2`, by inspection): base 2 is a bit reversal,
        // a shift, a conversion and a scale; base 3 loops over the index's digits — at most 4
        // for the 32 rays per pixel of the SGRT workloads — each a divide and a remainder by
        // 3 (2 integer multiplies and a subtraction), a conversion, two multiplies, an add
        // and the loop branch, then a conversion and a min; both coordinates are rotated and
        // wrapped (an add, a comparison, at worst a subtraction and a branch each). Then the
        // same cosine warp as a bounce.
        Kernel::HaltonRay => OpMix {
            int_mul: 8,
            int_add: 4,
            conv: 1 + 4 + 1,
            bitwise: 2 + 6,
            ftrig: 2,
            branch: 4 + 1 + 2 + 3,
            ..fp(4 + 4 + 16, 1 + 8 + 31, 1 + 1, 2 + 3, 3, 2)
        },
        Kernel::Reflect => fp(5, 7, 0, 0, 0, 0),
        Kernel::Accumulate => fp(3, 0, 0, 0, 0, 0),
        Kernel::Weighted => fp(3, 3, 0, 0, 0, 0),
        Kernel::Attenuate => fp(0, 3, 0, 0, 0, 0),
        // The sample count converted, one reciprocal and three multiplies.
        Kernel::Finish => OpMix {
            conv: 1,
            ..fp(0, 3, 0, 0, 1, 0)
        },
    }
}

/// Words read from a triangle's vertex record for shading (3 vertices).
pub const TRIANGLE_READ_WORDS: u32 = 9;
/// Words read from a material record (albedo and emission).
pub const MATERIAL_READ_WORDS: u32 = 6;
/// Words written to the framebuffer per pixel (RGB).
pub const FRAMEBUFFER_WRITE_WORDS: u32 = 3;

/// The operations of a whole state-machine transition: its kernels, plus the triangle and
/// material records it read and the framebuffer write.
pub fn shading(sh: &crate::workload::Shading) -> OpMix {
    let mut m = OpMix::ZERO;
    for k in ALL_KERNELS {
        m += kernel(k).times(sh.count(k));
    }
    m.load += TRIANGLE_READ_WORDS * sh.triangle.is_some() as u32
        + MATERIAL_READ_WORDS * sh.material.is_some() as u32;
    m.store += FRAMEBUFFER_WRITE_WORDS * sh.framebuffer.is_some() as u32;
    m
}

/// Every [`Kernel`], in order.
pub const ALL_KERNELS: [Kernel; crate::workload::KERNELS] = [
    Kernel::CameraRay,
    Kernel::Jitter,
    Kernel::Surface,
    Kernel::Headlight,
    Kernel::DirectLight,
    Kernel::ShadowRay,
    Kernel::CosineBounce,
    Kernel::HaltonRay,
    Kernel::Reflect,
    Kernel::Accumulate,
    Kernel::Weighted,
    Kernel::Attenuate,
    Kernel::Finish,
];

// ---------------------------------------------------------------------------------------
// The counting scalar

thread_local! {
    static COUNT: Cell<OpMix> = const { Cell::new(OpMix::ZERO) };
}

#[inline]
fn tally(f: impl FnOnce(&mut OpMix)) {
    COUNT.with(|c| {
        let mut m = c.get();
        f(&mut m);
        c.set(m);
    });
}

#[inline]
fn inc(x: &mut u32) {
    *x += 1;
}

/// Run `f`, counting the operations [`Counted`] values perform in it (on this thread).
pub fn count<T>(f: impl FnOnce() -> T) -> (T, OpMix) {
    let saved = COUNT.with(|c| c.replace(OpMix::ZERO));
    let out = f();
    let m = COUNT.with(|c| c.replace(saved));
    (out, m)
}

/// An `f32` that counts every operation performed on it (see [`count`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Counted(pub f32);

impl PartialEq for Counted {
    fn eq(&self, o: &Self) -> bool {
        tally(|m| m.fcmp += 1);
        self.0 == o.0
    }
}

impl PartialOrd for Counted {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        tally(|m| m.fcmp += 1);
        self.0.partial_cmp(&o.0)
    }
}

macro_rules! counted_binop {
    ($tr:ident, $f:ident, $field:ident, $op:tt) => {
        impl $tr for Counted {
            type Output = Counted;
            fn $f(self, o: Counted) -> Counted {
                tally(|m| inc(&mut m.$field));
                Counted(self.0 $op o.0)
            }
        }
    };
}
counted_binop!(Add, add, fadd, +);
counted_binop!(Sub, sub, fadd, -);
counted_binop!(Mul, mul, fmul, *);
counted_binop!(Div, div, fdiv, /);

impl Neg for Counted {
    type Output = Counted;
    fn neg(self) -> Counted {
        tally(|m| m.bitwise += 1);
        Counted(-self.0)
    }
}

impl Real for Counted {
    fn from_f32(v: f32) -> Self {
        Counted(v)
    }
    fn value(self) -> f32 {
        self.0
    }
    fn sqrt(self) -> Self {
        tally(|m| m.fsqrt += 1);
        Counted(self.0.sqrt())
    }
    fn min(self, o: Self) -> Self {
        tally(|m| m.fminmax += 1);
        Counted(self.0.min(o.0))
    }
    fn max(self, o: Self) -> Self {
        tally(|m| m.fminmax += 1);
        Counted(self.0.max(o.0))
    }
    fn abs(self) -> Self {
        tally(|m| m.bitwise += 1);
        Counted(self.0.abs())
    }
    fn copysign(self, sign: Self) -> Self {
        tally(|m| m.bitwise += 1);
        Counted(self.0.copysign(sign.0))
    }
    fn is_finite(self) -> bool {
        tally(|m| m.fcmp += 1);
        self.0.is_finite()
    }
    fn sin(self) -> Self {
        tally(|m| m.ftrig += 1);
        Counted(self.0.sin())
    }
    fn cos(self) -> Self {
        tally(|m| m.ftrig += 1);
        Counted(self.0.cos())
    }
    fn from_u32(v: u32) -> Self {
        tally(|m| m.conv += 1);
        Counted(v as f32)
    }
}

#[cfg(test)]
mod tests;
