//! Transcendental maths for `shared`: f32 through micromath, f64 from IEEE operations only.
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

/// `sin(2π·u)` for `u` in turns: micromath's parabolic approximation (absolute error
/// ≤ 0.002, the same as [`sin`]) evaluated on turns directly, with a branch-free floor, so a
/// phase kept in turns needs no multiplication by 2π and back. Any finite `u`; |u| < 2²³.
#[inline(always)]
pub fn sin_turns(u: f32) -> f32 {
    // sin(2πu) = cos(2π(u − ¼)); micromath's cos on turns x: x − ¼ − ⌊x + ¼⌋, then the
    // parabola and its correction.
    let x = u - 0.25;
    let y = x + 0.25;
    let t = y as i32;
    let floor = t.saturating_sub(i32::from(y < t as f32)) as f32;
    let mut x = x - (0.25 + floor);
    x *= 16.0 * (abs(x) - 0.5);
    x + 0.225 * x * (abs(x) - 1.0)
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

/// `e^x` in f64 from IEEE operations only (range reduction by ln 2, degree-13 Taylor
/// polynomial, exponent bits), so it gives the same bits on every target; relative error
/// below 1e-15. `x` is clamped to `[−700, 700]` (no overflow to infinity); NaN gives NaN.
pub fn exp64(x: f64) -> f64 {
    exp64_series(Exp64::reduced(x), 13).value()
}

/// [`exp64`] in steps, for a controller's idle time: the future pauses after the series'
/// fifth and ninth terms (a soft-f64 division each on the Cortex-M4F). The same bits and
/// the same code as [`exp64`], in three calls.
pub async fn exp64_stepwise(x: f64) -> f64 {
    let mut at = exp64_series(Exp64::reduced(x), 5);
    crate::base::steps::pause().await;
    at = exp64_series(at, 9);
    crate::base::steps::pause().await;
    exp64_series(at, 13).value()
}

/// [`exp64`] under way: `x` reduced to `r` (with `x = k·ln 2 + r`) and the Taylor
/// polynomial's Horner sum `p` over its terms above `n`.
#[derive(Clone, Copy)]
struct Exp64 {
    /// NaN in, NaN out.
    nan: bool,
    k: i32,
    r: f64,
    p: f64,
    n: f64,
}

impl Exp64 {
    /// The range reduction of `x` (clamped to `[−700, 700]`), no term summed yet.
    fn reduced(x: f64) -> Self {
        // ln 2 split (fdlibm): the high part has trailing zero bits, so k·LN2_HI is exact.
        const LN2_HI: f64 = f64::from_bits(0x3FE6_2E42_FEE0_0000);
        const LN2_LO: f64 = f64::from_bits(0x3DEA_39EF_3579_3C76);
        if x.is_nan() {
            return Self {
                nan: true,
                k: 0,
                r: x,
                p: x,
                n: 0.0,
            };
        }
        let x = x.clamp(-700.0, 700.0);
        // k = x·log₂e rounded half away from zero, |k| ≤ 1010: its size truncated as an
        // unsigned (the conversions the trend already links; an i64 pair costs 284 B of flash).
        let negative = x < 0.0;
        let size = (x * core::f64::consts::LOG2_E).abs() + 0.5;
        let m = size as u32;
        let (k, kf) = if negative {
            (-(m as i32), -f64::from(m))
        } else {
            (m as i32, f64::from(m))
        };
        Self {
            nan: false,
            k,
            r: (x - kf * LN2_HI) - kf * LN2_LO,
            p: 1.0,
            n: 13.0,
        }
    }

    /// `e^x`: the sum times `2^k` (|k| ≤ 1010: a normal power of two).
    fn value(self) -> f64 {
        if self.nan {
            return self.p;
        }
        self.p * f64::from_bits(((self.k + 1023) as u64) << 52)
    }
}

/// `at` with the degree-13 series' terms summed down to the one after the `done`-th
/// (Horner's `p = 1 + p·r/n`, from n = 13). O(terms).
#[inline(never)]
fn exp64_series(mut at: Exp64, done: u32) -> Exp64 {
    let stop = 13.0 - done as f64;
    while at.n > 0.5 && at.n > stop {
        at.p = 1.0 + at.p * at.r / at.n;
        at.n -= 1.0;
    }
    at
}

/// Natural logarithm of `x` > 0: `2·atanh(z)`, `z = (x − 1)/(x + 1)`, after taking out the
/// power of two (so `x` in [√½, √2], |z| ≤ 0.172): 8 odd terms, f32 operations only (the
/// same bits on every target), relative error below 1e-6. `x ≤ 0` or NaN give NaN.
pub fn ln(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 || x == f32::INFINITY {
        return if x == f32::INFINITY { x } else { f32::NAN };
    }
    let bits = x.to_bits();
    // Subnormals are out of any range this crate uses; read them as the smallest normal.
    let exponent = ((bits >> 23) & 0xff) as i32 - 127;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let mut e = exponent.max(-126);
    if m > core::f32::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    let z = (m - 1.0) / (m + 1.0);
    let z2 = z * z;
    let mut sum = 0.0f32;
    let mut k = 15.0f32;
    while k > 0.5 {
        sum = 1.0 / k + z2 * sum;
        k -= 2.0;
    }
    2.0 * z * sum + e as f32 * core::f32::consts::LN_2
}

/// `e^x` in f32 through [`exp64`].
#[inline(never)]
pub fn exp(x: f32) -> f32 {
    exp64(f64::from(x)) as f32
}

/// Square root in f64 from IEEE operations only (exponent-halving seed, six Newton steps);
/// `x ≤ 0` and NaN give 0, +∞ gives +∞.
pub fn sqrt64(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x == f64::INFINITY {
        return x;
    }
    let mut y = f64::from_bits((x.to_bits() >> 1) + 0x1FF8_0000_0000_0000);
    for _ in 0..6 {
        y = 0.5 * (y + x / y);
    }
    y
}

/// Order of [`invert`]'s matrices: the fault vector's 9 components (checked where the
/// uncertainty uses it; a smaller system is padded with an identity block).
pub const INVERT_N: usize = 9;

/// Inverse of a regular N×N matrix (Gauss–Jordan, partial pivoting); `None` if singular.
/// O(N³), no allocation. One copy of the 9×9 ([`INVERT_N`]) for the uncertainty, the polish
/// and the grease's fit; the window's nuisances use their own size (host only).
#[inline(never)]
pub fn invert<const N: usize>(m: &[[f64; N]; N]) -> Option<[[f64; N]; N]> {
    let mut g = GaussJordan::start(m);
    for col in 0..N {
        let d = g.pivot(col)?;
        g.divide(col, d, 0..N);
        for r in 0..N {
            g.eliminate(col, r);
        }
    }
    Some(g.inv)
}

/// [`invert`] in steps, for a controller's idle time, the same pieces: the future pauses
/// first, after copying the matrix, after each pivot's search and swap, after each quarter
/// of the pivot row's division and after each row's elimination (O(N) soft-f64 operations on
/// the Cortex-M4F). The same bits.
pub async fn invert_stepwise<const N: usize>(m: &[[f64; N]; N]) -> Option<[[f64; N]; N]> {
    use crate::base::steps::pause;
    // What the caller did (building the matrix) ends its poll here.
    pause().await;
    let mut g = GaussJordan::start(m);
    pause().await;
    for col in 0..N {
        let d = g.pivot(col)?;
        pause().await;
        for quarter in 0..4 {
            g.divide(col, d, quarter * N / 4..(quarter + 1) * N / 4);
            pause().await;
        }
        for r in 0..N {
            if g.eliminate(col, r) {
                pause().await;
            }
        }
    }
    Some(g.inv)
}

/// Gauss–Jordan elimination under way: the matrix being reduced and the inverse being
/// built, in pieces that [`invert`] and [`invert_stepwise`] share. Each piece works on the
/// two matrices as flat row-major slices of any order (one copy of the code for every
/// size the firmware inverts).
struct GaussJordan<const N: usize> {
    a: [[f64; N]; N],
    inv: [[f64; N]; N],
}

impl<const N: usize> GaussJordan<N> {
    fn start(m: &[[f64; N]; N]) -> Self {
        let mut inv = [[0.0f64; N]; N];
        for (i, row) in inv.iter_mut().enumerate() {
            if let Some(x) = row.get_mut(i) {
                *x = 1.0;
            }
        }
        Self { a: *m, inv }
    }

    /// Column `col`'s pivot (partial pivoting) swapped into row `col`, and its value; `None`
    /// if singular (or `col` is not a column).
    fn pivot(&mut self, col: usize) -> Option<f64> {
        pivot_rows(
            self.a.as_flattened_mut(),
            self.inv.as_flattened_mut(),
            N,
            col,
        )
    }

    /// The pivot row's entries `columns` of both matrices divided by `d` (the pivot, read
    /// before the first division: the row's own pivot entry becomes 1 on the way).
    fn divide(&mut self, col: usize, d: f64, columns: core::ops::Range<usize>) {
        divide_row(
            self.a.as_flattened_mut(),
            self.inv.as_flattened_mut(),
            N,
            col,
            d,
            columns,
        );
    }

    /// Row `r` (not the pivot's) cleared in column `col`. Whether it did any work.
    fn eliminate(&mut self, col: usize, r: usize) -> bool {
        eliminate_row(
            self.a.as_flattened_mut(),
            self.inv.as_flattened_mut(),
            N,
            col,
            r,
        )
    }
}

/// Row `i` of the flat row-major `n`-column matrix `m`. O(1).
fn row_mut(m: &mut [f64], n: usize, i: usize) -> Option<&mut [f64]> {
    m.get_mut(i.checked_mul(n)?..i.checked_add(1)?.checked_mul(n)?)
}

/// Rows `i` and `j` (`i ≠ j`) of the flat row-major `n`-column matrix `m`. O(1).
fn two_rows_mut(m: &mut [f64], n: usize, i: usize, j: usize) -> Option<(&mut [f64], &mut [f64])> {
    let (lo, hi) = (i.min(j), i.max(j));
    if lo == hi {
        return None;
    }
    let (head, tail) = m.split_at_mut_checked(hi.checked_mul(n)?)?;
    let low = head.get_mut(lo.checked_mul(n)?..lo.checked_add(1)?.checked_mul(n)?)?;
    let high = tail.get_mut(..n)?;
    Some(if i < j { (low, high) } else { (high, low) })
}

/// [`GaussJordan::pivot`] on the flat `n`×`n` matrices `a` and `inv`. O(n).
#[inline(never)]
fn pivot_rows(a: &mut [f64], inv: &mut [f64], n: usize, col: usize) -> Option<f64> {
    if col >= n {
        return None;
    }
    let at = |a: &[f64], r: usize| a.get(r * n + col).map_or(f64::NAN, |x| x.abs());
    let mut pivot = col;
    for r in col + 1..n {
        if at(a, r) > at(a, pivot) {
            pivot = r;
        }
    }
    if at(a, pivot) < 1e-300 {
        return None;
    }
    // Element by element: a whole-row `swap` links a 1.6 kB `memmove` into the firmware.
    for m in [&mut *a, &mut *inv] {
        if let Some((top, other)) = two_rows_mut(m, n, col, pivot) {
            for (x, y) in top.iter_mut().zip(other) {
                core::mem::swap(x, y);
            }
        }
    }
    // `None` too for matrices shorter than n².
    a.get(col * n + col).copied()
}

/// [`GaussJordan::divide`] on the flat `n`×`n` matrices `a` and `inv`. O(n).
#[inline(never)]
fn divide_row(
    a: &mut [f64],
    inv: &mut [f64],
    n: usize,
    col: usize,
    d: f64,
    columns: core::ops::Range<usize>,
) {
    let columns = columns.start.min(n)..columns.end.min(n);
    for m in [a, inv] {
        if let Some(row) = row_mut(m, n, col).and_then(|r| r.get_mut(columns.clone())) {
            for x in row {
                *x /= d;
            }
        }
    }
}

/// [`GaussJordan::eliminate`] on the flat `n`×`n` matrices `a` and `inv`. O(n).
#[inline(never)]
fn eliminate_row(a: &mut [f64], inv: &mut [f64], n: usize, col: usize, r: usize) -> bool {
    if col >= n || r >= n || r == col {
        return false;
    }
    let f = a.get(r * n + col).copied().unwrap_or(0.0);
    if f == 0.0 {
        return false;
    }
    for m in [a, inv] {
        if let Some((row, pivot)) = two_rows_mut(m, n, r, col) {
            for (x, p) in row.iter_mut().zip(pivot.iter()) {
                *x -= f * *p;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    #[test]
    fn ln_is_accurate_over_the_decades_the_fits_use() {
        for x in [
            0.01f32, 0.1, 0.5, 0.7, 0.974, 0.99999, 1.0, 1.5, 3.0, 8.0, 100.0,
        ] {
            let want = f64::from(x).ln();
            let got = f64::from(super::ln(x));
            assert!(
                (got - want).abs() <= 1e-6 * want.abs().max(1e-3),
                "{x}: {got} vs {want}"
            );
        }
        assert!(super::ln(0.0).is_nan() && super::ln(-1.0).is_nan());
    }

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

    /// `exp64` as it was first written (its k through an i64): the same bits everywhere, so
    /// the trend tables stored before the change stand.
    #[test]
    fn exp64_keeps_the_bits_of_its_i64_form() {
        let reference = |x: f64| {
            const LN2_HI: f64 = f64::from_bits(0x3FE6_2E42_FEE0_0000);
            const LN2_LO: f64 = f64::from_bits(0x3DEA_39EF_3579_3C76);
            let x = x.clamp(-700.0, 700.0);
            let half = if x < 0.0 { -0.5 } else { 0.5 };
            let k = (x * core::f64::consts::LOG2_E + half) as i64;
            let r = (x - k as f64 * LN2_HI) - k as f64 * LN2_LO;
            let mut p = 1.0;
            let mut n = 13.0;
            while n > 0.5 {
                p = 1.0 + p * r / n;
                n -= 1.0;
            }
            p * f64::from_bits(((k + 1023) as u64) << 52)
        };
        let mut x = -720.0f64;
        while x <= 720.0 {
            // Each point, and the points where the rounding of k turns.
            for y in [
                x,
                (x / core::f64::consts::LN_2).round() * core::f64::consts::LN_2
                    + 0.5 * core::f64::consts::LN_2,
            ] {
                assert_eq!(exp64(y).to_bits(), reference(y).to_bits(), "exp64({y})");
            }
            x += 0.0731;
        }
        for y in [0.0, -0.0, 1e-300, -1e-300] {
            assert_eq!(exp64(y).to_bits(), reference(y).to_bits(), "exp64({y})");
        }
    }

    #[test]
    fn f64_exp_and_sqrt_match_std() {
        for i in -400..400 {
            let x = i as f64 * 0.37 + 0.013;
            let rel = (exp64(x) - x.exp()).abs() / x.exp();
            assert!(rel < 2e-15, "exp64({x}): rel error {rel}");
            let y = (x * 1e3).abs() + 1e-9;
            let rel = (sqrt64(y) - y.sqrt()).abs() / y.sqrt();
            assert!(rel < 1e-15, "sqrt64({y}): rel error {rel}");
        }
        assert_eq!(exp64(0.0), 1.0);
        assert!(exp64(1e6).is_finite());
        assert_eq!(sqrt64(4.0), 2.0);
        assert_eq!(sqrt64(-1.0), 0.0);
        assert_eq!(sqrt64(f64::INFINITY), f64::INFINITY);
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

#[cfg(test)]
mod sin_turns_check {
    /// The same parabolic approximation as micromath's sine, within rounding of the two
    /// reductions: within 1e-5 of the unit amplitude over 7.5 turns.
    #[test]
    fn sin_turns_is_micromaths_sine_on_turns() {
        let mut worst = 0.0f32;
        for k in 0..100_000 {
            let u = k as f32 * 7.5e-5;
            let a = super::sin_turns(u);
            let b = super::sin(super::TAU * super::frac(u));
            worst = worst.max((a - b).abs());
        }
        assert!(worst < 1e-5, "{worst}");
    }
}
