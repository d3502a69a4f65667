//! Sample sequences and warps.
//!
//! AO and diffuse rays use the Halton sequence (bases 2 and 3), as in the SGRT paper's
//! Aila–Laine style benchmark rays, decorrelated between pixels by a per-pixel
//! Cranley–Patterson rotation drawn from the pixel's own seeded stream. Path tracing draws its
//! bounce directions from the pixel's [`Pcg32`](rtsim_core::Pcg32) stream.

use rtsim_core::{Real, Vec3};

/// Radical inverse of `i` in base 2 (van der Corput), exact in f32.
#[inline]
pub fn radical_inverse_2(i: u32) -> f32 {
    (i.reverse_bits() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Radical inverse of `i` in base 3.
#[inline]
pub fn radical_inverse_3(mut i: u32) -> f32 {
    let mut inv_base = 1.0f64 / 3.0;
    let mut result = 0.0f64;
    let mut f = inv_base;
    while i > 0 {
        result += (i % 3) as f64 * f;
        i /= 3;
        f *= inv_base;
    }
    inv_base = result;
    // Keep strictly below 1 in f32.
    (inv_base as f32).min(1.0 - f32::EPSILON / 2.0)
}

/// The `i`-th 2-D Halton point rotated by `offset` (each component in [0, 1)).
#[inline]
pub fn halton2(i: u32, offset: (f32, f32)) -> (f32, f32) {
    let wrap = |x: f32| if x >= 1.0 { x - 1.0 } else { x };
    (
        wrap(radical_inverse_2(i) + offset.0),
        wrap(radical_inverse_3(i) + offset.1),
    )
}

/// Cosine-weighted direction in the hemisphere around unit normal `n` from a point of the
/// unit square (Shirley–Chiu concentric mapping, then lifting to the hemisphere).
#[inline]
pub fn cosine_hemisphere<R: Real>(n: Vec3<R>, u: R, v: R) -> Vec3<R> {
    let (dx, dy) = concentric_disk(u, v);
    let dz = (R::from_f32(1.0) - dx * dx - dy * dy)
        .max(R::from_f32(0.0))
        .sqrt();
    let (t, b) = n.orthonormal_basis();
    (t * dx + b * dy + n * dz).normalized()
}

/// Shirley & Chiu's concentric square-to-disk map (JGT 1997).
#[inline]
fn concentric_disk<R: Real>(u: R, v: R) -> (R, R) {
    let (zero, one, two) = (R::from_f32(0.0), R::from_f32(1.0), R::from_f32(2.0));
    let (a, b) = (two * u - one, two * v - one);
    if a == zero && b == zero {
        return (zero, zero);
    }
    let quarter_pi = R::from_f32(std::f32::consts::FRAC_PI_4);
    let (r, theta) = if a.abs() > b.abs() {
        (a, quarter_pi * (b / a))
    } else {
        (
            b,
            R::from_f32(std::f32::consts::FRAC_PI_2) - quarter_pi * (a / b),
        )
    };
    (r * theta.cos(), r * theta.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radical_inverses() {
        assert_eq!(radical_inverse_2(1), 0.5);
        assert_eq!(radical_inverse_2(2), 0.25);
        assert_eq!(radical_inverse_2(3), 0.75);
        assert!((radical_inverse_3(1) - 1.0 / 3.0).abs() < 1e-7);
        assert!((radical_inverse_3(5) - (2.0 / 3.0 + 1.0 / 9.0)).abs() < 1e-7);
    }

    #[test]
    fn cosine_directions_are_in_hemisphere_with_cosine_mean() {
        let n = Vec3::new(0.3, 0.4, -0.5).normalized();
        let mut sum_cos = 0.0f64;
        let count = 4096;
        for i in 0..count {
            let (u, v) = halton2(i, (0.1, 0.7));
            let d = cosine_hemisphere(n, u, v);
            assert!((d.length() - 1.0).abs() < 1e-5);
            let c = d.dot(n);
            assert!(c >= -1e-6);
            sum_cos += c as f64;
        }
        // E[cos θ] under a cosine-weighted density is 2/3.
        assert!(
            (sum_cos / count as f64 - 2.0 / 3.0).abs() < 0.01,
            "{}",
            sum_cos / count as f64
        );
    }
}
