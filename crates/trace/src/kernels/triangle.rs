//! Ray–triangle tests.
//!
//! All three report the same hit convention: distance `t` in units of the ray direction's
//! length, accepted when `tmin < t < tmax` (a hit exactly at the origin of a ray with
//! `tmin = 0` is not reported, as in Embree), and barycentrics `(u, v)` where `u` weights the
//! triangle's second vertex and `v` its third (`P = (1-u-v)·v0 + u·v1 + v·v2`). Triangles are
//! two-sided. Away from edges the three agree to float precision (property-tested below); on
//! an edge each may decide either way.
//!
//! Each test is a [`TriKernel`]: `prepare` turns a triangle into the record the kernel reads
//! (what the hardware would store per triangle), `intersect` tests one ray against it.

use rtsim_core::{Ray, Real, Vec3};

/// A hit on one triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// Which way a triangle test ended: [`HIT`] or the kernel's numbered miss (the `exit` module
/// of each kernel lists them). Each exit runs a fixed sequence of operations, published by
/// `crate::ops`, so a hardware model charges exactly what the test did.
pub type Exit = u8;

/// The exit of every kernel that found a hit.
pub const HIT: Exit = 0;

/// A ray–triangle test with its precomputed per-triangle record.
pub trait TriKernel: Send + Sync + 'static {
    type Data: Copy + Send + Sync + std::fmt::Debug;
    /// Short name for reports.
    const NAME: &'static str;
    fn prepare(tri: &[Vec3; 3]) -> Self::Data;
    /// The test, with the exit it took.
    fn test(data: &Self::Data, ray: &Ray, tmin: f32, tmax: f32) -> Result<TriHit, Exit>;
    #[inline(always)]
    fn intersect(data: &Self::Data, ray: &Ray, tmin: f32, tmax: f32) -> Option<TriHit> {
        Self::test(data, ray, tmin, tmax).ok()
    }
}

/// Möller & Trumbore, "Fast, minimum storage ray/triangle intersection", JGT 1997.
/// Record: `v0`, edges `e1 = v1 - v0`, `e2 = v2 - v0`. One divide per test.
#[derive(Clone, Copy, Debug)]
pub struct MollerTrumbore;

/// Plücker-coordinate test (Shevtsov et al. 2007 as used by STRaTA §3.3): three signed
/// volumes decide hit or miss with multiplies and adds only; the divide happens only on a hit.
/// Record: the three vertices.
#[derive(Clone, Copy, Debug)]
pub struct Plucker;

/// Wald's precomputed projection test (Wald, PhD thesis 2004, §7.1; SGRT's IST unit):
/// project onto the plane of the normal's dominant axis `k`; ten floats and `k` per triangle.
#[derive(Clone, Copy, Debug)]
pub struct Wald;

/// Wald's per-triangle record (40 bytes of data: ten 4-byte words).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaldTri {
    /// Plane: `P[k] + n_u·P[ku] + n_v·P[kv] = n_d`.
    pub n_u: f32,
    pub n_v: f32,
    pub n_d: f32,
    /// Dominant axis of the normal (0, 1, 2); `ku = (k+1) % 3`, `kv = (k+2) % 3`.
    /// A degenerate triangle gets `k = 3`, which never hits.
    pub k: u32,
    /// `u = b_nu·h_u + b_nv·h_v + b_d` in the projection plane.
    pub b_nu: f32,
    pub b_nv: f32,
    pub b_d: f32,
    /// `v = c_nu·h_u + c_nv·h_v + c_d`.
    pub c_nu: f32,
    pub c_nv: f32,
    pub c_d: f32,
}

impl WaldTri {
    /// The ten words in field order (`n_u n_v n_d k b_nu b_nv b_d c_nu c_nv c_d`),
    /// little-endian: the data `rtsim_bvh`'s memory image places in its Wald region
    /// (`SceneData::wald`), which arranges them as Wald's 48-byte `TriAccel` (layout in
    /// `docs/MEMORY_IMAGE.md`).
    pub fn to_le_bytes(&self) -> [u8; 40] {
        let words = [
            self.n_u.to_bits(),
            self.n_v.to_bits(),
            self.n_d.to_bits(),
            self.k,
            self.b_nu.to_bits(),
            self.b_nv.to_bits(),
            self.b_d.to_bits(),
            self.c_nu.to_bits(),
            self.c_nv.to_bits(),
            self.c_d.to_bits(),
        ];
        let mut out = [0u8; 40];
        for (chunk, w) in out.chunks_exact_mut(4).zip(words) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
        out
    }
}

/// Exits of [`moller_trumbore_exit`].
pub mod mt_exit {
    /// `det == 0`: the ray is parallel to the plane.
    pub const PARALLEL: u8 = 1;
    /// `u < 0` (one comparison).
    pub const U_LOW: u8 = 2;
    /// `u > 1` (two comparisons).
    pub const U_HIGH: u8 = 3;
    /// `v < 0`.
    pub const V_LOW: u8 = 4;
    /// `u + v > 1`.
    pub const UV_HIGH: u8 = 5;
    /// `t <= tmin` (one comparison).
    pub const T_LOW: u8 = 6;
    /// `t >= tmax` (two comparisons).
    pub const T_HIGH: u8 = 7;
    /// Every exit, [`super::HIT`] first.
    pub const ALL: [u8; 8] = [0, 1, 2, 3, 4, 5, 6, 7];
}

/// Exits of [`plucker_exit`].
pub mod plucker_exit {
    /// The signed volumes have mixed signs: the ray passes outside an edge.
    pub const OUTSIDE: u8 = 1;
    /// `n·d == 0`: parallel to the plane (or a degenerate triangle).
    pub const PARALLEL: u8 = 2;
    /// The plane is hit outside `(tmin, tmax)` (decided without dividing).
    pub const RANGE: u8 = 3;
    /// After the divide, rounding put `t` outside the interval.
    pub const T_ROUNDED: u8 = 4;
    pub const ALL: [u8; 5] = [0, 1, 2, 3, 4];
}

/// Exits of [`wald_exit`].
pub mod wald_exit {
    /// A degenerate triangle (`k = 3`).
    pub const DEGENERATE: u8 = 1;
    /// Parallel to the plane.
    pub const PARALLEL: u8 = 2;
    /// `t <= tmin` (one comparison).
    pub const T_LOW: u8 = 3;
    /// `t >= tmax` (two comparisons).
    pub const T_HIGH: u8 = 4;
    /// `u < 0`.
    pub const U_LOW: u8 = 5;
    /// `v < 0`.
    pub const V_LOW: u8 = 6;
    /// `u + v > 1`.
    pub const UV_HIGH: u8 = 7;
    pub const ALL: [u8; 8] = [0, 1, 2, 3, 4, 5, 6, 7];
}

impl TriKernel for MollerTrumbore {
    type Data = [Vec3; 3];
    const NAME: &'static str = "moller-trumbore";
    #[inline(always)]
    fn prepare(t: &[Vec3; 3]) -> [Vec3; 3] {
        mt_edges(t)
    }
    #[inline(always)]
    fn test(d: &[Vec3; 3], ray: &Ray, tmin: f32, tmax: f32) -> Result<TriHit, Exit> {
        moller_trumbore_exit(d[0], d[1], d[2], ray.origin, ray.direction, tmin, tmax)
            .map(|(t, u, v)| TriHit { t, u, v })
    }
}

/// The Möller–Trumbore record from the vertices (what a TRaX thread computes after loading
/// the vertex record of the memory image: two edge subtractions).
#[inline(always)]
pub fn mt_edges<R: Real>(t: &[Vec3<R>; 3]) -> [Vec3<R>; 3] {
    [t[0], t[1] - t[0], t[2] - t[0]]
}

/// Möller–Trumbore on a prepared record `[v0, e1, e2]`.
#[inline(always)]
pub fn moller_trumbore(rec: &[Vec3; 3], ray: &Ray, tmin: f32, tmax: f32) -> Option<TriHit> {
    MollerTrumbore::intersect(rec, ray, tmin, tmax)
}

/// Möller–Trumbore, generic over the scalar: `(t, u, v)` or the exit taken.
// Negated comparisons on purpose: a NaN must fail each test, as in the accepted interval
// `tmin < t < tmax`.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
pub fn moller_trumbore_exit<R: Real>(
    v0: Vec3<R>,
    e1: Vec3<R>,
    e2: Vec3<R>,
    o: Vec3<R>,
    d: Vec3<R>,
    tmin: R,
    tmax: R,
) -> Result<(R, R, R), Exit> {
    let (zero, one) = (R::from_f32(0.0), R::from_f32(1.0));
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == zero {
        return Err(mt_exit::PARALLEL);
    }
    let inv = one / det;
    let s = o - v0;
    let u = s.dot(p) * inv;
    // `(0.0..=1.0).contains(&u)`, spelt out: a NaN fails the first comparison.
    if !(zero <= u) {
        return Err(mt_exit::U_LOW);
    }
    if !(u <= one) {
        return Err(mt_exit::U_HIGH);
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < zero {
        return Err(mt_exit::V_LOW);
    }
    if u + v > one {
        return Err(mt_exit::UV_HIGH);
    }
    let t = e2.dot(q) * inv;
    if !(t > tmin) {
        return Err(mt_exit::T_LOW);
    }
    if !(t < tmax) {
        return Err(mt_exit::T_HIGH);
    }
    Ok((t, u, v))
}

impl TriKernel for Plucker {
    type Data = [Vec3; 3];
    const NAME: &'static str = "plucker";
    #[inline(always)]
    fn prepare(t: &[Vec3; 3]) -> [Vec3; 3] {
        *t
    }
    #[inline(always)]
    fn test(d: &[Vec3; 3], ray: &Ray, tmin: f32, tmax: f32) -> Result<TriHit, Exit> {
        plucker_exit(d, ray.origin, ray.direction, tmin, tmax).map(|(t, u, v)| TriHit { t, u, v })
    }
}

/// Plücker test on the three vertices.
#[inline(always)]
pub fn plucker(tri: &[Vec3; 3], ray: &Ray, tmin: f32, tmax: f32) -> Option<TriHit> {
    Plucker::intersect(tri, ray, tmin, tmax)
}

/// The Plücker test, generic over the scalar. The three sign tests and the interval test are
/// evaluated in full, as STRaTA's triangle pipeline does (no short-circuit).
#[inline(always)]
pub fn plucker_exit<R: Real>(
    tri: &[Vec3<R>; 3],
    o: Vec3<R>,
    d: Vec3<R>,
    tmin: R,
    tmax: R,
) -> Result<(R, R, R), Exit> {
    let (zero, one) = (R::from_f32(0.0), R::from_f32(1.0));
    let a = tri[0] - o;
    let b = tri[1] - o;
    let c = tri[2] - o;
    // Signed volumes: proportional to the barycentric weights of v0, v1, v2. Mixed signs:
    // the ray passes outside an edge.
    let w0 = d.dot(c.cross(b));
    let w1 = d.dot(a.cross(c));
    let w2 = d.dot(b.cross(a));
    let any_neg = (w0 < zero) | (w1 < zero) | (w2 < zero);
    let any_pos = (w0 > zero) | (w1 > zero) | (w2 > zero);
    if any_neg && any_pos {
        return Err(plucker_exit::OUTSIDE);
    }
    // The plane gives t = n·a / n·d with n = (v1-v0)×(v2-v0) from the edges (the sum of the
    // signed volumes, mathematically -n·d, loses precision when the origin is far from a small
    // triangle).
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let nd = n.dot(d);
    if nd == zero {
        return Err(plucker_exit::PARALLEL);
    }
    let na = n.dot(a);
    // Decide the interval on t·(n·d), so the divide happens only on a hit.
    let (lo, hi) = (tmin * nd, tmax * nd);
    let in_range = if nd > zero {
        (na > lo) & (na < hi)
    } else {
        (na < lo) & (na > hi)
    };
    if !in_range {
        return Err(plucker_exit::RANGE);
    }
    // The one divide, on a hit. Re-check the interval after rounding so all kernels share the
    // exact acceptance rule `tmin < t < tmax`.
    let inv = one / nd;
    let t = na * inv;
    if !((t > tmin) & (t < tmax)) {
        return Err(plucker_exit::T_ROUNDED);
    }
    Ok((t, -w1 * inv, -w2 * inv))
}

impl Wald {
    /// Precompute the record of a triangle.
    pub fn record(t: &[Vec3; 3]) -> WaldTri {
        let a = t[0];
        let c = t[1] - a; // weights u
        let b = t[2] - a; // weights v
        let n = c.cross(b);
        let k = n.abs().max_axis();
        let (ku, kv) = ((k + 1) % 3, (k + 2) % 3);
        let nk = n[k];
        let det2 = c[ku] * b[kv] - c[kv] * b[ku];
        if nk == 0.0 || det2 == 0.0 || !nk.is_finite() || !det2.is_finite() {
            return WaldTri {
                n_u: 0.0,
                n_v: 0.0,
                n_d: 0.0,
                k: 3,
                b_nu: 0.0,
                b_nv: 0.0,
                b_d: 0.0,
                c_nu: 0.0,
                c_nv: 0.0,
                c_d: 0.0,
            };
        }
        let inv_nk = 1.0 / nk;
        let inv2 = 1.0 / det2;
        // Solve h - a = u·c + v·b in the (ku, kv) plane.
        WaldTri {
            n_u: n[ku] * inv_nk,
            n_v: n[kv] * inv_nk,
            n_d: n.dot(a) * inv_nk,
            k: k as u32,
            b_nu: b[kv] * inv2,
            b_nv: -b[ku] * inv2,
            b_d: (b[ku] * a[kv] - b[kv] * a[ku]) * inv2,
            c_nu: -c[kv] * inv2,
            c_nv: c[ku] * inv2,
            c_d: (c[kv] * a[ku] - c[ku] * a[kv]) * inv2,
        }
    }
}

impl TriKernel for Wald {
    type Data = WaldTri;
    const NAME: &'static str = "wald";
    #[inline(always)]
    fn prepare(t: &[Vec3; 3]) -> WaldTri {
        Wald::record(t)
    }
    #[inline(always)]
    fn test(d: &WaldTri, ray: &Ray, tmin: f32, tmax: f32) -> Result<TriHit, Exit> {
        let w = [
            d.n_u, d.n_v, d.n_d, d.b_nu, d.b_nv, d.b_d, d.c_nu, d.c_nv, d.c_d,
        ];
        wald_exit(&w, d.k, ray.origin, ray.direction, tmin, tmax).map(|(t, u, v)| TriHit {
            t,
            u,
            v,
        })
    }
}

/// Wald's test on a precomputed record.
#[inline(always)]
pub fn wald(w: &WaldTri, ray: &Ray, tmin: f32, tmax: f32) -> Option<TriHit> {
    Wald::intersect(w, ray, tmin, tmax)
}

/// Wald's test, generic over the scalar. `w` holds the record's floats in the order
/// `n_u, n_v, n_d, b_nu, b_nv, b_d, c_nu, c_nv, c_d`; `k` its axis.
// Negated comparisons on purpose: a NaN must fail each test, as in the accepted interval
// `tmin < t < tmax`.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
pub fn wald_exit<R: Real>(
    w: &[R; 9],
    k: u32,
    o: Vec3<R>,
    d: Vec3<R>,
    tmin: R,
    tmax: R,
) -> Result<(R, R, R), Exit> {
    const MOD3: [usize; 5] = [0, 1, 2, 0, 1];
    let (zero, one) = (R::from_f32(0.0), R::from_f32(1.0));
    let k = k as usize;
    if k > 2 {
        return Err(wald_exit::DEGENERATE);
    }
    let [n_u, n_v, n_d, b_nu, b_nv, b_d, c_nu, c_nv, c_d] = *w;
    let (ku, kv) = (MOD3[k + 1], MOD3[k + 2]);
    let denom = d[k] + n_u * d[ku] + n_v * d[kv];
    if denom == zero {
        return Err(wald_exit::PARALLEL);
    }
    let nd = one / denom;
    let t = (n_d - o[k] - n_u * o[ku] - n_v * o[kv]) * nd;
    if !(t > tmin) {
        return Err(wald_exit::T_LOW);
    }
    if !(t < tmax) {
        return Err(wald_exit::T_HIGH);
    }
    let hu = o[ku] + t * d[ku];
    let hv = o[kv] + t * d[kv];
    let u = hu * b_nu + hv * b_nv + b_d;
    if u < zero {
        return Err(wald_exit::U_LOW);
    }
    let v = hu * c_nu + hv * c_nv + c_d;
    if v < zero {
        return Err(wald_exit::V_LOW);
    }
    if u + v > one {
        return Err(wald_exit::UV_HIGH);
    }
    Ok((t, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn unit_tri() -> [Vec3; 3] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    fn all(tri: &[Vec3; 3], ray: &Ray) -> [Option<TriHit>; 3] {
        let (lo, hi) = (ray.tmin, ray.tmax);
        [
            MollerTrumbore::intersect(&MollerTrumbore::prepare(tri), ray, lo, hi),
            Plucker::intersect(&Plucker::prepare(tri), ray, lo, hi),
            Wald::intersect(&Wald::prepare(tri), ray, lo, hi),
        ]
    }

    #[test]
    fn known_answer_unit_triangle() {
        // A ray down the z axis onto (0.25, 0.5): t = 2, u = 0.25 (weight of v1 = (1,0,0)), v = 0.5.
        let ray = Ray::new(
            Vec3::new(0.25, 0.5, 2.0),
            Vec3::new(0.0, 0.0, -1.0),
            0.0,
            f32::INFINITY,
        );
        for h in all(&unit_tri(), &ray) {
            let h = h.expect("hit");
            assert!(
                (h.t - 2.0).abs() < 1e-6 && (h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6,
                "{h:?}"
            );
        }
        // Non-normalised direction: t in its units.
        let ray = Ray::new(
            Vec3::new(0.25, 0.5, 2.0),
            Vec3::new(0.0, 0.0, -4.0),
            0.0,
            f32::INFINITY,
        );
        for h in all(&unit_tri(), &ray) {
            assert!((h.unwrap().t - 0.5).abs() < 1e-6);
        }
        // From below (two-sided).
        let ray = Ray::new(
            Vec3::new(0.25, 0.5, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
            0.0,
            f32::INFINITY,
        );
        for h in all(&unit_tri(), &ray) {
            assert!((h.unwrap().t - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn wald_record_bytes_are_the_fields_in_order() {
        let w = Wald::record(&[
            Vec3::new(0.5, -1.0, 2.0),
            Vec3::new(3.0, 0.25, 1.0),
            Vec3::new(-2.0, 1.5, 0.75),
        ]);
        let b = w.to_le_bytes();
        let word = |k: usize| u32::from_le_bytes(b[4 * k..4 * k + 4].try_into().unwrap());
        let f = |k: usize| f32::from_bits(word(k));
        assert_eq!((f(0), f(1), f(2), word(3)), (w.n_u, w.n_v, w.n_d, w.k));
        assert_eq!((f(4), f(5), f(6)), (w.b_nu, w.b_nv, w.b_d));
        assert_eq!((f(7), f(8), f(9)), (w.c_nu, w.c_nv, w.c_d));
        assert!(w.k < 3);
    }

    #[test]
    fn misses_and_interval() {
        let tri = unit_tri();
        let outside = Ray::new(
            Vec3::new(0.8, 0.8, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            0.0,
            f32::INFINITY,
        );
        let behind = Ray::new(
            Vec3::new(0.2, 0.2, 1.0),
            Vec3::new(0.0, 0.0, 1.0),
            0.0,
            f32::INFINITY,
        );
        let short = Ray::new(
            Vec3::new(0.2, 0.2, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            0.0,
            0.5,
        );
        let parallel = Ray::new(
            Vec3::new(-1.0, 0.2, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            0.0,
            f32::INFINITY,
        );
        let late = Ray::new(
            Vec3::new(0.2, 0.2, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            1.5,
            f32::INFINITY,
        );
        for ray in [outside, behind, short, parallel, late] {
            assert_eq!(all(&tri, &ray), [None, None, None], "{ray:?}");
        }
    }

    #[test]
    fn origin_on_the_surface_is_not_a_hit() {
        // tmin < t: a ray leaving the triangle it starts on does not hit it at t = 0.
        let ray = Ray::new(
            Vec3::new(0.25, 0.25, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            0.0,
            f32::INFINITY,
        );
        assert_eq!(all(&unit_tri(), &ray), [None, None, None]);
    }

    #[test]
    fn degenerate_triangle_never_hits() {
        let tri = [
            Vec3::ZERO,
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(2.0, 2.0, 2.0),
        ];
        let ray = Ray::new(
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            0.0,
            f32::INFINITY,
        );
        assert_eq!(all(&tri, &ray), [None, None, None]);
    }

    fn v3() -> impl Strategy<Value = Vec3> {
        (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Rays aimed at a point safely inside a random triangle: every kernel hits, with the
        /// same t and barycentrics; rays aimed safely outside: every kernel misses.
        #[test]
        fn kernels_agree_away_from_edges(
            a in v3(), b in v3(), c in v3(), origin in v3(),
            u in -0.5f32..1.5, v in -0.5f32..1.5, scale in 0.1f32..10.0,
        ) {
            let tri = [a, b, c];
            let n = (b - a).cross(c - a);
            // Skip slivers: area small relative to the edge lengths makes "away from edges" ill-defined.
            let longest = (b - a).length().max((c - a).length()).max((c - b).length());
            prop_assume!(n.length() > 0.05 * longest * longest);
            let inside = u > 0.02 && v > 0.02 && u + v < 0.98;
            let outside = u < -0.02 || v < -0.02 || u + v > 1.02;
            let target = a + (b - a) * u + (c - a) * v;
            let dir = (target - origin) * scale;
            // Grazing rays are edge cases too: require a decent angle to the plane.
            let cosang = (dir.normalized().dot(n.normalized())).abs();
            prop_assume!(cosang > 0.05 && dir.length() > 1e-3);
            let ray = Ray::new(origin, dir, 0.0, f32::INFINITY);
            let hits = all(&tri, &ray);
            if inside {
                for h in hits {
                    let h = h.expect("all kernels hit");
                    let t_expect = 1.0 / scale;
                    prop_assert!((h.t - t_expect).abs() <= 1e-3 * t_expect, "t {} vs {}", h.t, t_expect);
                    prop_assert!((h.u - u).abs() < 2e-3 && (h.v - v).abs() < 2e-3, "{h:?} vs {u} {v}");
                }
            } else if outside {
                prop_assert_eq!(hits, [None, None, None]);
            }
        }
    }
}
