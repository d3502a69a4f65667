//! The TP's instruction set as the timing model sees it: an instruction's class (which shared
//! unit, memory or port it uses), its source and destination registers, the record word a load
//! or store touches, and its address in instruction memory.
//!
//! Values are not part of an instruction: the functional kernels compute them, so the image
//! and counters equal the functional tracer's by construction. The registers only carry the
//! dependences the scoreboard enforces.

use serde::Serialize;

/// What an instruction uses. The first [`UNIT_CLASSES`] are the TM's shared execution units
/// (`arch.trax.units.*`, in this order); the rest use the data cache, the TP's local memory or
/// the chip's atomic counter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
#[repr(u8)]
pub enum Class {
    FpAdd = 0,
    FpMul = 1,
    FpMinMax = 2,
    FpCmp = 3,
    IntAdd = 4,
    IntMul = 5,
    DivSqrt = 6,
    Conv = 7,
    Branch = 8,
    Bitwise = 9,
    /// One ray–box test through the TM's fused box pipeline (STRaTA §3.3; the TRaX baseline
    /// has none: its capacity is 0 there).
    BoxTest = 10,
    /// A word load through the TM's L1 data cache.
    Load = 11,
    /// A word store through the L1 (write-around: posted to the L2).
    Store = 12,
    /// A word read from the TP's local memory (the traversal stack).
    LocalLoad = 13,
    /// A word written to local memory.
    LocalStore = 14,
    /// The chip-wide atomic increment (`atominc`) that hands out pixels.
    Atomic = 15,
    /// One ray–triangle test through one of the TM's fused triangle pipelines (STRaTA §3.3).
    /// Its initiation interval is longer than a cycle, so an instance is a resource taken at
    /// the access point like the atomic counter (see `docs/STRATA.md`).
    TriTest = 16,
    /// A read of the ray stream memory: a ray popped from a treelet buffer, or a path-state
    /// record (STRaTA §3.1).
    StreamLoad = 17,
    /// A write to the ray stream memory: a ray pushed onto a treelet buffer, or a path-state
    /// record.
    StreamStore = 18,
}

/// The unit classes configured in `arch.trax.units` (all but the fused box pipeline, whose
/// capacity STRaTA sets).
pub const CONFIGURED_UNITS: usize = 10;
/// Shared execution-unit classes (the calendar's columns).
pub const UNIT_CLASSES: usize = 11;
/// All classes.
pub const CLASSES: usize = 19;

impl Class {
    pub const ALL: [Class; CLASSES] = [
        Class::FpAdd,
        Class::FpMul,
        Class::FpMinMax,
        Class::FpCmp,
        Class::IntAdd,
        Class::IntMul,
        Class::DivSqrt,
        Class::Conv,
        Class::Branch,
        Class::Bitwise,
        Class::BoxTest,
        Class::Load,
        Class::Store,
        Class::LocalLoad,
        Class::LocalStore,
        Class::Atomic,
        Class::TriTest,
        Class::StreamLoad,
        Class::StreamStore,
    ];

    /// Whether the class uses one of the TM's shared units.
    #[inline(always)]
    pub fn is_unit(self) -> bool {
        (self as u8) < UNIT_CLASSES as u8
    }

    /// Whether the instruction talks to shared state outside the TM's issue logic (the data
    /// cache, the atomic counter, a triangle pipeline instance or the stream memory): the
    /// points at which a TP synchronises with the chip.
    #[inline(always)]
    pub fn is_sync(self) -> bool {
        (self as u8) > Class::BoxTest as u8 && !matches!(self, Class::LocalLoad | Class::LocalStore)
    }

    /// Mnemonic used in listings.
    pub fn mnemonic(self) -> &'static str {
        match self {
            Class::FpAdd => "fadd",
            Class::FpMul => "fmul",
            Class::FpMinMax => "fminmax",
            Class::FpCmp => "fcmp",
            Class::IntAdd => "iadd",
            Class::IntMul => "imul",
            Class::DivSqrt => "fdiv/isqrt",
            Class::Conv => "conv",
            Class::Branch => "br",
            Class::Bitwise => "bit",
            Class::BoxTest => "boxtest",
            Class::Load => "load",
            Class::Store => "store",
            Class::LocalLoad => "lload",
            Class::LocalStore => "lstore",
            Class::Atomic => "atominc",
            Class::TriTest => "tritest",
            Class::StreamLoad => "sload",
            Class::StreamStore => "sstore",
        }
    }

    /// Name used in stats (snake case).
    pub fn name(self) -> &'static str {
        match self {
            Class::FpAdd => "fp_add",
            Class::FpMul => "fp_mul",
            Class::FpMinMax => "fp_minmax",
            Class::FpCmp => "fp_cmp",
            Class::IntAdd => "int_add",
            Class::IntMul => "int_mul",
            Class::DivSqrt => "div_sqrt",
            Class::Conv => "conv",
            Class::Branch => "branch",
            Class::Bitwise => "bitwise",
            Class::BoxTest => "box_test",
            Class::Load => "load",
            Class::Store => "store",
            Class::LocalLoad => "local_load",
            Class::LocalStore => "local_store",
            Class::Atomic => "atomic",
            Class::TriTest => "triangle_test",
            Class::StreamLoad => "stream_load",
            Class::StreamStore => "stream_store",
        }
    }
}

/// A register number, or [`NO_REG`].
pub type Reg = u8;
/// No register: an immediate, or a path-state value (see [`crate::program`]).
pub const NO_REG: Reg = 0xFF;

/// Which record a load or store reaches, relative to the dynamic block's bases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Mem {
    /// Not a memory access.
    None,
    /// Word `word` of the record at the block's base `base` (0 or 1): the byte address is
    /// `base[base] + 4 × word`.
    Word { base: u8, word: u8 },
    /// Word `word` of the stack entry at the block's local-memory slot.
    Local { word: u8 },
    /// A stream-memory access (STRaTA §3.1).
    Stream(StreamOp),
}

/// What a stream-memory instruction does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum StreamOp {
    /// Pop a ray from the TM's treelet buffer into the ray registers.
    Pop,
    /// Push the ray in the registers onto the buffer of the treelet it enters.
    Push,
    /// Read the path's state record into registers.
    PathRead,
    /// Write the path's state record from registers.
    PathWrite,
}

/// One static instruction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Inst {
    pub class: Class,
    /// Destination register, or [`NO_REG`] (stores, branches).
    pub dst: Reg,
    /// Source registers ([`NO_REG`] for immediates and path-state values).
    pub src: [Reg; 2],
    pub mem: Mem,
    /// Byte address in instruction memory (4-byte instructions).
    pub pc: u32,
    /// More registers the instruction waits for (a bit per register) besides `src` and `dst`:
    /// the wide instructions of STRaTA (a fused test reads a ray's registers and its input
    /// latches; a stream access moves a whole record). 0 for ordinary instructions.
    pub deps: u32,
    /// Register-file reads and writes, where they differ from the operands' count (wide
    /// instructions; an input intrinsic that writes a pipeline latch, not the register
    /// file). `None`: one read per register source, one write per register destination.
    pub rf: Option<(u8, u8)>,
}

impl Inst {
    /// An ordinary instruction: `class`, destination, two sources, no memory operand.
    pub fn new(class: Class, dst: Reg, src: [Reg; 2]) -> Inst {
        Inst {
            class,
            dst,
            src,
            mem: Mem::None,
            pc: 0,
            deps: 0,
            rf: None,
        }
    }

    /// Register-file reads and writes: `rf` if set, else one read per register source and one
    /// write for a register destination.
    #[inline]
    pub fn register_accesses(&self) -> (u32, u32) {
        if let Some((r, w)) = self.rf {
            return (r as u32, w as u32);
        }
        let reads = self.src.iter().filter(|&&r| r != NO_REG).count() as u32;
        (reads, (self.dst != NO_REG) as u32)
    }
}

/// Bytes per instruction in instruction memory (TRaX's 32-bit instructions).
pub const INST_BYTES: u32 = 4;

/// The registers the program keeps across blocks (the ray and traversal state). The rest,
/// from [`regs::FIRST_TEMP`] up, are temporaries allocated per block. Values of the pixel's
/// path state (throughput, radiance, random state, pixel index, hit barycentrics …) are
/// operands without a register number ([`NO_REG`]): they were computed at least one traversal
/// earlier and are always ready (see `docs/TRAX_PROGRAM.md`).
pub mod regs {
    use super::Reg;
    /// Ray origin x, y, z.
    pub const ORG: [Reg; 3] = [0, 1, 2];
    /// Ray direction.
    pub const DIR: [Reg; 3] = [3, 4, 5];
    /// Inverse direction (box tests).
    pub const INV: [Reg; 3] = [6, 7, 8];
    pub const TMIN: Reg = 9;
    /// Closest hit so far (the ray's `tmax` until a hit).
    pub const THIT: Reg = 10;
    /// Hit triangle slot.
    pub const SLOT: Reg = 11;
    /// Current node index.
    pub const NODE: Reg = 12;
    /// Stack pointer (local-memory address of the next entry).
    pub const SP: Reg = 13;
    /// The child index (inner node) or the current triangle slot (leaf), loaded from the node.
    pub const CHILD: Reg = 14;
    /// The leaf's triangle count (loop bound).
    pub const END: Reg = 15;
    /// Entry distance of the child that may be deferred (pushed).
    pub const TNEAR: Reg = 16;
    /// First temporary; temporaries run to 31.
    pub const FIRST_TEMP: Reg = 17;
    /// Registers the program uses.
    pub const USED: u32 = 32;
}
