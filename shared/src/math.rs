//! Transcendental maths for `shared`, always through micromath.
//!
//! micromath is plain f32 arithmetic, so the same inputs give the same bits on x86 and on the
//! Cortex-M4F; std's `f32` methods (libm / platform intrinsics) would not. Calling the trait
//! explicitly also keeps `#[cfg(test)]` builds, where std's inherent methods would shadow the
//! trait's, on the same code path as the firmware.

use micromath::F32Ext;

/// `2π`.
pub const TAU: f32 = core::f32::consts::TAU;

#[inline]
pub fn sin(x: f32) -> f32 {
    F32Ext::sin(x)
}

#[inline]
pub fn cos(x: f32) -> f32 {
    F32Ext::cos(x)
}

#[inline]
pub fn tan(x: f32) -> f32 {
    F32Ext::tan(x)
}

/// Square root: micromath's estimate refined by three Newton steps (micromath alone is a
/// bit-trick approximation, percent-level, with `sqrt(0) ≠ 0`). `x ≤ 0` and NaN give 0.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x == f32::INFINITY {
        return x;
    }
    let mut y = F32Ext::sqrt(x);
    y = 0.5 * (y + x / y);
    y = 0.5 * (y + x / y);
    0.5 * (y + x / y)
}

/// Largest integer ≤ `x`. Values of magnitude ≥ 2²³ are already integers and are returned as
/// they are (micromath's floor goes through a saturating `i32` cast); NaN stays NaN.
#[inline]
pub fn floor(x: f32) -> f32 {
    // One compare: false for NaN and for |x| ≥ 2²³ alike.
    if abs(x) < 8_388_608.0 {
        F32Ext::floor(x)
    } else {
        x
    }
}

#[inline]
pub fn abs(x: f32) -> f32 {
    F32Ext::abs(x)
}

/// Fractional part `x − ⌊x⌋`, in `[0, 1)` for finite `x` (may round up to 1.0 for tiny
/// negative `x`).
#[inline]
pub fn frac(x: f32) -> f32 {
    x - floor(x)
}

/// Limits `x` to `[lo, hi]` without the assertion of `f32::clamp` (never panics; a NaN `x`
/// stays NaN, inverted limits give `lo`). Two compares and selects.
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sqrt_is_accurate() {
        assert_eq!(sqrt(0.0), 0.0);
        assert_eq!(sqrt(-1.0), 0.0);
        assert_eq!(sqrt(f32::NAN), 0.0);
        for x in [1e-30f32, 1e-6, 0.5, 2.0, 8.0, 123.456, 1e20] {
            let rel = (sqrt(x) as f64 - (x as f64).sqrt()).abs() / (x as f64).sqrt();
            assert!(rel < 1e-6, "sqrt({x}): rel error {rel}");
        }
    }

    #[test]
    fn floor_and_frac_handle_every_magnitude() {
        assert_eq!(floor(-0.5), -1.0);
        assert_eq!(floor(2.999), 2.0);
        assert_eq!(floor(-1e30), -1e30);
        assert_eq!(floor(3e9), 3e9);
        assert!(floor(f32::NAN).is_nan());
        assert_eq!(frac(-1e30), 0.0);
        assert!((frac(-0.25) - 0.75).abs() < 1e-7);
    }

    #[test]
    fn trig_is_close_enough_for_the_models() {
        // micromath's documented bound is 0.002 absolute.
        for i in -100..100 {
            let x = i as f32 * 0.173;
            assert!((sin(x) - x.sin()).abs() < 2.5e-3);
            assert!((cos(x) - x.cos()).abs() < 2.5e-3);
        }
    }

    #[test]
    fn clamp_never_panics() {
        assert_eq!(clamp(5.0, -1.0, 1.0), 1.0);
        assert_eq!(clamp(-5.0, -1.0, 1.0), -1.0);
        assert_eq!(clamp(0.5, -1.0, 1.0), 0.5);
        assert!(clamp(f32::NAN, -1.0, 1.0).is_nan());
        assert_eq!(clamp(0.0, 1.0, -1.0), 1.0);
    }
}
