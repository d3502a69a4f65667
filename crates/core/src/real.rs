//! [`Real`]: the scalar the geometric kernels compute with.
//!
//! Everything rtsim simulates computes in `f32`. The kernels (box and triangle tests, shading,
//! ray generation) are written once, generic over `Real`, so that the same source runs on
//! `f32` in the tracer and on a counting scalar in the operation-count check
//! (`rtsim_trace::ops`), which is how the hardware models learn the operation mix of each
//! kernel from the code that actually runs. `f32`'s implementation is the identity: the
//! generic code compiles to the same instructions.

use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A scalar with the operations the kernels use. Constants come in through
/// [`Real::from_f32`] (free: immediates or per-frame values), everything else is an operation.
pub trait Real:
    Copy
    + Debug
    + Default
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    fn from_f32(v: f32) -> Self;
    /// The value (for indexing decisions in tests; not an operation).
    fn value(self) -> f32;
    fn sqrt(self) -> Self;
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
    fn abs(self) -> Self;
    fn copysign(self, sign: Self) -> Self;
    fn is_finite(self) -> bool;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    /// An integer converted to this type (`u32 as f32`).
    fn from_u32(v: u32) -> Self;
}

impl Real for f32 {
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn value(self) -> f32 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        f32::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        f32::max(self, o)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        f32::copysign(self, sign)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        f32::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        f32::cos(self)
    }
    #[inline(always)]
    fn from_u32(v: u32) -> Self {
        v as f32
    }
}
