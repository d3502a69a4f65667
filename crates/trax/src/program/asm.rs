//! Recording instruction blocks from the real kernels, and allocating their registers.
//!
//! The floating-point kernels of `rtsim-trace` are generic over [`rtsim_core::Real`]. Run on
//! [`Traced`], a scalar that carries its `f32` value (so every branch goes the way the real
//! data says) and records each operation with the values it read, they write their own data
//! flow: the blocks' floating-point instructions are the kernels' operations, in the order the
//! code performs them, with their true dependences. Loads, stores, integer, bitwise and branch
//! instructions that the kernels do not perform in floating point are added by hand with the
//! same recorder ([`load`], [`int_add`], [`branch`] …), following `rtsim_trace::ops`' tables.
//!
//! [`record`] runs a closure with a fresh recorder and returns the [`Tape`];
//! [`Tape::compile`] allocates registers (each temporary freed after its last read, the lowest
//! free register taken first) and expands the operations TRaX has no unit for: a square root
//! is an inverse square root and a multiply; sine and cosine are polynomials
//! (see [`SIN`], [`COS`]).

use crate::isa::{Class, Inst, Mem, NO_REG, Reg, regs};
use rtsim_core::Real;
use std::cell::RefCell;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Value ids: 0 is an immediate; [`STATE`] a path-state value (always ready, no register);
/// `FIXED | r` the fixed register `r`; anything else `1 +` the index of the op producing it.
const IMMEDIATE: u32 = 0;
const STATE: u32 = u32::MAX;
const FIXED: u32 = 0x8000_0000;

/// A scalar that records every operation performed on it (see the module docs).
#[derive(Clone, Copy, Debug, Default)]
pub struct Traced {
    id: u32,
    v: f32,
}

impl Traced {
    /// The value in fixed register `r` (an input of the block), with the data value `v`.
    pub fn reg(r: Reg, v: f32) -> Traced {
        Traced {
            id: FIXED | r as u32,
            v,
        }
    }
    /// A path-state value (no register; always ready).
    pub fn state(v: f32) -> Traced {
        Traced { id: STATE, v }
    }
    pub fn value(self) -> f32 {
        self.v
    }
    /// The same value id carrying the data value `v` (for hand-written instructions whose
    /// results steer a kernel down a chosen path).
    pub fn with_value(self, v: f32) -> Traced {
        Traced { v, ..self }
    }
}

/// How an operation expands into instructions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Expand {
    One(Class),
    /// `sqrt(x) = x · invsqrt(x)`: the divide/inverse-square-root unit, then a multiply.
    Sqrt,
    Sin,
    Cos,
}

#[derive(Clone, Copy, Debug)]
struct Op {
    expand: Expand,
    src: [u32; 2],
    mem: Mem,
    /// Whether the op writes a value (its id is `1 + index`).
    writes: bool,
}

/// The operations of one block, in program order.
#[derive(Clone, Debug, Default)]
pub struct Tape {
    ops: Vec<Op>,
    /// Values that must end up in fixed registers.
    outputs: Vec<(u32, Reg)>,
    /// Op counts after which an exit may leave the block (see [`Compiled::marks`]).
    marks: Vec<usize>,
    /// Put a branch on its result after every floating-point comparison.
    branch_on_compare: bool,
    last_compare: u32,
}

thread_local! {
    static TAPE: RefCell<Option<Tape>> = const { RefCell::new(None) };
}

fn with<T>(f: impl FnOnce(&mut Tape) -> T) -> T {
    TAPE.with(|t| {
        let mut t = t.borrow_mut();
        let tape = t
            .as_mut()
            .expect("Traced operations run inside asm::record (a program-construction bug)");
        f(tape)
    })
}

fn push(expand: Expand, src: [u32; 2], mem: Mem, writes: bool) -> u32 {
    with(|t| {
        t.ops.push(Op {
            expand,
            src,
            mem,
            writes,
        });
        t.ops.len() as u32
    })
}

fn op(class: Class, a: Traced, b: Traced, v: f32) -> Traced {
    Traced {
        id: push(Expand::One(class), [a.id, b.id], Mem::None, true),
        v,
    }
}

fn compare(a: Traced, b: Traced) {
    let id = push(Expand::One(Class::FpCmp), [a.id, b.id], Mem::None, true);
    let branch = with(|t| {
        t.last_compare = id;
        t.branch_on_compare
    });
    if branch {
        push(
            Expand::One(Class::Branch),
            [id, IMMEDIATE],
            Mem::None,
            false,
        );
        mark();
    }
}

/// Record the operations `f` performs into a fresh tape. With `branch_on_compare`, every
/// floating-point comparison is followed by a branch on its result and a [`mark`] (the kernels
/// of `rtsim_trace::ops` whose branches are "one per comparison evaluated").
pub fn record(branch_on_compare: bool, f: impl FnOnce()) -> Tape {
    TAPE.with(|t| {
        *t.borrow_mut() = Some(Tape {
            branch_on_compare,
            ..Tape::default()
        })
    });
    f();
    TAPE.with(|t| t.borrow_mut().take()).expect("tape present")
}

/// Mark the current position as a possible exit of the block.
pub fn mark() {
    with(|t| {
        let n = t.ops.len();
        t.marks.push(n);
    });
}

/// The result of the last floating-point comparison (for a branch on it).
pub fn last_compare() -> Traced {
    Traced {
        id: with(|t| t.last_compare),
        v: 0.0,
    }
}

/// Require `v` to be in fixed register `r` at the end of the block.
pub fn output(v: Traced, r: Reg) {
    with(|t| t.outputs.push((v.id, r)));
}

/// A word load from record base `base`, word `word`, whose address is computed from `addr`.
pub fn load(base: u8, word: u8, addr: Traced) -> Traced {
    Traced {
        id: push(
            Expand::One(Class::Load),
            [addr.id, IMMEDIATE],
            Mem::Word { base, word },
            true,
        ),
        v: 0.0,
    }
}

/// A load whose data value is known (so the kernels that read it branch correctly).
pub fn load_value(base: u8, word: u8, addr: Traced, v: f32) -> Traced {
    Traced {
        v,
        ..load(base, word, addr)
    }
}

/// A word store of `data` to record base `base`, word `word`.
pub fn store(base: u8, word: u8, addr: Traced, data: Traced) {
    push(
        Expand::One(Class::Store),
        [addr.id, data.id],
        Mem::Word { base, word },
        false,
    );
}

/// A word read from the stack entry at the block's local slot.
pub fn local_load(word: u8, addr: Traced) -> Traced {
    Traced {
        id: push(
            Expand::One(Class::LocalLoad),
            [addr.id, IMMEDIATE],
            Mem::Local { word },
            true,
        ),
        v: 0.0,
    }
}

/// A word written to the stack entry at the block's local slot.
pub fn local_store(word: u8, addr: Traced, data: Traced) {
    push(
        Expand::One(Class::LocalStore),
        [addr.id, data.id],
        Mem::Local { word },
        false,
    );
}

/// An instruction of `class` reading `a` and `b`, writing a value.
pub fn emit(class: Class, a: Traced, b: Traced) -> Traced {
    op(class, a, b, 0.0)
}

pub fn int_add(a: Traced, b: Traced) -> Traced {
    emit(Class::IntAdd, a, b)
}
pub fn int_mul(a: Traced, b: Traced) -> Traced {
    emit(Class::IntMul, a, b)
}
pub fn bitwise(a: Traced, b: Traced) -> Traced {
    emit(Class::Bitwise, a, b)
}
pub fn conv(a: Traced) -> Traced {
    emit(Class::Conv, a, imm())
}
/// A conditional branch on `cond`.
pub fn branch(cond: Traced) {
    push(
        Expand::One(Class::Branch),
        [cond.id, IMMEDIATE],
        Mem::None,
        false,
    );
}
/// The chip-wide atomic increment; its result is the counter's old value.
pub fn atomic() -> Traced {
    Traced {
        id: push(
            Expand::One(Class::Atomic),
            [IMMEDIATE, IMMEDIATE],
            Mem::None,
            true,
        ),
        v: 0.0,
    }
}

/// An immediate operand.
pub fn imm() -> Traced {
    Traced::default()
}

impl PartialEq for Traced {
    fn eq(&self, o: &Self) -> bool {
        compare(*self, *o);
        self.v == o.v
    }
}

impl PartialOrd for Traced {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        compare(*self, *o);
        self.v.partial_cmp(&o.v)
    }
}

macro_rules! traced_binop {
    ($tr:ident, $f:ident, $class:expr, $op:tt) => {
        impl $tr for Traced {
            type Output = Traced;
            fn $f(self, o: Traced) -> Traced {
                op($class, self, o, self.v $op o.v)
            }
        }
    };
}
traced_binop!(Add, add, Class::FpAdd, +);
traced_binop!(Sub, sub, Class::FpAdd, -);
traced_binop!(Mul, mul, Class::FpMul, *);
traced_binop!(Div, div, Class::DivSqrt, /);

impl Neg for Traced {
    type Output = Traced;
    fn neg(self) -> Traced {
        op(Class::Bitwise, self, imm(), -self.v)
    }
}

impl Real for Traced {
    fn from_f32(v: f32) -> Self {
        Traced { id: IMMEDIATE, v }
    }
    fn value(self) -> f32 {
        self.v
    }
    fn sqrt(self) -> Self {
        Traced {
            id: push(Expand::Sqrt, [self.id, IMMEDIATE], Mem::None, true),
            v: self.v.sqrt(),
        }
    }
    fn min(self, o: Self) -> Self {
        op(Class::FpMinMax, self, o, self.v.min(o.v))
    }
    fn max(self, o: Self) -> Self {
        op(Class::FpMinMax, self, o, self.v.max(o.v))
    }
    fn abs(self) -> Self {
        op(Class::Bitwise, self, imm(), self.v.abs())
    }
    fn copysign(self, sign: Self) -> Self {
        op(Class::Bitwise, self, sign, self.v.copysign(sign.v))
    }
    fn is_finite(self) -> bool {
        compare(self, imm());
        self.v.is_finite()
    }
    fn sin(self) -> Self {
        Traced {
            id: push(Expand::Sin, [self.id, IMMEDIATE], Mem::None, true),
            v: self.v.sin(),
        }
    }
    fn cos(self) -> Self {
        Traced {
            id: push(Expand::Cos, [self.id, IMMEDIATE], Mem::None, true),
            v: self.v.cos(),
        }
    }
    fn from_u32(v: u32) -> Self {
        Traced {
            id: push(
                Expand::One(Class::Conv),
                [STATE, IMMEDIATE],
                Mem::None,
                true,
            ),
            v: v as f32,
        }
    }
}

/// Software sine (assumed; TRaX has no trigonometric unit): `x·(1 + x²(c₁ + x²(c₂ + x²(c₃ +
/// x²c₄))))`, a degree-9 polynomial in Horner form with no range reduction, since the only
/// caller (the concentric disk map of a cosine bounce) passes angles in [−π/4, 3π/4].
/// Instructions: x², four multiply–add steps, the final multiply by x: 6 multiplies, 4 adds.
pub const SIN: (u32, u32) = (6, 4);
/// Software cosine likewise, degree 8: `1 + x²(d₁ + x²(d₂ + x²(d₃ + x²d₄)))`: 5 multiplies,
/// 4 adds.
pub const COS: (u32, u32) = (5, 4);

/// A compiled block: its instructions (with `pc` 0-based within the block) and the
/// instruction counts at each [`mark`].
#[derive(Clone, Debug)]
pub struct Compiled {
    pub insts: Vec<Inst>,
    pub marks: Vec<usize>,
}

/// Registers a block may use as temporaries.
#[derive(Debug)]
struct Temps {
    free: Vec<bool>,
}

impl Temps {
    fn new(extra: &[Reg]) -> Self {
        Temps {
            free: (0..regs::USED)
                .map(|r| r >= regs::FIRST_TEMP as u32 || extra.contains(&(r as Reg)))
                .collect(),
        }
    }
    fn take(&mut self, what: &str) -> Reg {
        let r = self
            .free
            .iter()
            .position(|&f| f)
            .unwrap_or_else(|| panic!("{what}: more than 32 registers live (program bug)"));
        self.free[r] = false;
        r as Reg
    }
    fn give(&mut self, r: Reg, extra: &[Reg]) {
        if r != NO_REG && (r >= regs::FIRST_TEMP || extra.contains(&r)) {
            self.free[r as usize] = true;
        }
    }
}

impl Tape {
    /// Allocate registers and expand into instructions. `name` appears in panics (a block that
    /// needs more than the 32 registers is a bug in the program, caught by its tests).
    pub fn compile(&self, name: &str) -> Compiled {
        self.compile_with(name, &[])
    }

    /// [`Tape::compile`] with the fixed registers `extra` also available as temporaries (the
    /// traversal state, dead while a pixel is shaded).
    pub fn compile_with(&self, name: &str, extra: &[Reg]) -> Compiled {
        let n = self.ops.len();
        let mut last_use = vec![None::<usize>; n + 1];
        for (i, op) in self.ops.iter().enumerate() {
            for &s in &op.src {
                if is_temp(s) {
                    last_use[s as usize] = Some(i);
                }
            }
        }
        let mut fixed_out = vec![NO_REG; n + 1];
        for &(id, r) in &self.outputs {
            assert!(is_temp(id), "{name}: only computed values can be outputs");
            fixed_out[id as usize] = r;
        }
        let mut temps = Temps::new(extra);
        let mut reg_of = vec![NO_REG; n + 1];
        let mut insts = Vec::with_capacity(n + 8);
        let mut op_to_inst = Vec::with_capacity(n + 1);
        let src_reg = |id: u32, reg_of: &[Reg]| -> Reg {
            match id {
                IMMEDIATE | STATE => NO_REG,
                _ if id & FIXED != 0 => (id & !FIXED) as Reg,
                _ => {
                    let r = reg_of[id as usize];
                    assert!(r != NO_REG, "{name}: value {id} read before it is written");
                    r
                }
            }
        };
        for (i, op) in self.ops.iter().enumerate() {
            op_to_inst.push(insts.len());
            let src = [src_reg(op.src[0], &reg_of), src_reg(op.src[1], &reg_of)];
            // Sources read for the last time free their registers before the result takes one.
            for &s in &op.src {
                if is_temp(s) && last_use[s as usize] == Some(i) && fixed_out[s as usize] == NO_REG
                {
                    temps.give(reg_of[s as usize], extra);
                }
            }
            let id = i + 1;
            let dst = if !op.writes {
                NO_REG
            } else if fixed_out[id] != NO_REG {
                fixed_out[id]
            } else {
                temps.take(name)
            };
            if op.writes {
                reg_of[id] = dst;
            }
            let inst = Inst::new;
            match op.expand {
                Expand::One(class) => insts.push(Inst {
                    mem: op.mem,
                    ..inst(class, dst, src)
                }),
                Expand::Sqrt => {
                    let t = temps.take(name);
                    insts.push(inst(Class::DivSqrt, t, [src[0], NO_REG]));
                    insts.push(inst(Class::FpMul, dst, [src[0], t]));
                    temps.give(t, extra);
                }
                Expand::Sin | Expand::Cos => {
                    let sin = op.expand == Expand::Sin;
                    let x2 = temps.take(name);
                    let acc = temps.take(name);
                    insts.push(inst(Class::FpMul, x2, [src[0], src[0]]));
                    // Horner on x²: acc = c₄·x², then (acc + c)·x² …; the sine ends with a
                    // multiply by x, the cosine with the constant term's add.
                    let mut steps = vec![(Class::FpMul, x2)];
                    for k in 0..4 {
                        steps.push((Class::FpAdd, NO_REG));
                        if k < 3 {
                            steps.push((Class::FpMul, x2));
                        } else if sin {
                            steps.push((Class::FpMul, src[0]));
                        }
                    }
                    let last = steps.len() - 1;
                    for (k, &(class, by)) in steps.iter().enumerate() {
                        let into = if k == last { dst } else { acc };
                        let first = if k == 0 { x2 } else { acc };
                        insts.push(inst(class, into, [first, by]));
                    }
                    temps.give(x2, extra);
                    temps.give(acc, extra);
                }
            }
            // A value nobody reads frees its register at once (the write still happens).
            if op.writes && last_use[id].is_none() && fixed_out[id] == NO_REG {
                temps.give(dst, extra);
            }
        }
        op_to_inst.push(insts.len());
        for (k, i) in insts.iter_mut().enumerate() {
            i.pc = k as u32 * crate::isa::INST_BYTES;
        }
        Compiled {
            marks: self.marks.iter().map(|&m| op_to_inst[m]).collect(),
            insts,
        }
    }
}

fn is_temp(id: u32) -> bool {
    id != IMMEDIATE && id != STATE && id & FIXED == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn classes(c: &Compiled) -> Vec<Class> {
        c.insts.iter().map(|i| i.class).collect()
    }

    #[test]
    fn records_dataflow_and_frees_registers_after_the_last_read() {
        let tape = record(false, || {
            let a = Traced::reg(0, 1.0);
            let b = Traced::reg(1, 2.0);
            let s = a + b; // t0
            let p = s * s; // t0 freed after this read, p reuses it
            let q = p - a;
            output(q, 5);
        });
        let c = tape.compile("t");
        assert_eq!(classes(&c), [Class::FpAdd, Class::FpMul, Class::FpAdd]);
        let t0 = regs::FIRST_TEMP;
        assert_eq!((c.insts[0].dst, c.insts[0].src), (t0, [0, 1]));
        assert_eq!((c.insts[1].dst, c.insts[1].src), (t0, [t0, t0]));
        assert_eq!((c.insts[2].dst, c.insts[2].src), (5, [t0, 0]));
        assert_eq!(c.insts[2].pc, 8);
    }

    #[test]
    fn comparisons_branch_and_mark_when_asked() {
        let tape = record(true, || {
            let a = Traced::reg(0, 1.0);
            let _ = a < Traced::from_f32(2.0);
            let _ = a.is_finite();
        });
        let c = tape.compile("t");
        assert_eq!(
            classes(&c),
            [Class::FpCmp, Class::Branch, Class::FpCmp, Class::Branch]
        );
        assert_eq!(c.marks, [2, 4]);
        assert_eq!(c.insts[1].src[0], c.insts[0].dst);
    }

    #[test]
    fn square_roots_and_trigonometry_expand() {
        let c = record(false, || {
            let a = Traced::reg(0, 0.5);
            output(a.sqrt(), 1);
            output(a.sin(), 2);
            output(a.cos(), 3);
        })
        .compile("t");
        let count = |k: Class| c.insts.iter().filter(|i| i.class == k).count() as u32;
        assert_eq!(count(Class::DivSqrt), 1);
        assert_eq!(count(Class::FpMul), 1 + SIN.0 + COS.0);
        assert_eq!(count(Class::FpAdd), SIN.1 + COS.1);
        // Each result lands in its register, written by the expansion's last instruction.
        let writers: Vec<_> = c
            .insts
            .iter()
            .filter(|i| i.dst < 4)
            .map(|i| i.dst)
            .collect();
        assert_eq!(writers, [1, 2, 3]);
        // The sine's last multiply reads x.
        let sin_last = c.insts.iter().find(|i| i.dst == 2).unwrap();
        assert!(sin_last.src.contains(&0));
    }

    #[test]
    #[should_panic(expected = "more than 32 registers")]
    fn running_out_of_registers_is_a_program_bug() {
        record(false, || {
            let a = Traced::reg(0, 1.0);
            let vals: Vec<Traced> = (0..20).map(|_| a + a).collect();
            let sum = vals.into_iter().fold(a, |s, v| s + v);
            output(sum, 1);
        })
        .compile("t");
    }
}
