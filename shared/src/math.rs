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

#[inline]
pub fn sqrt(x: f32) -> f32 {
    F32Ext::sqrt(x)
}

#[inline]
pub fn floor(x: f32) -> f32 {
    F32Ext::floor(x)
}

#[inline]
pub fn abs(x: f32) -> f32 {
    F32Ext::abs(x)
}

/// Fractional part in `[0, 1)`: `x − ⌊x⌋`.
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
