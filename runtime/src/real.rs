//! The scalar abstraction shared by generated code and the runtime: `f32` on the Cortex-M4F
//! firmware (single-precision FPU), `f64` on the host.
//!
//! Transcendental functions come from `libm`, so the same code builds with and without `std`.

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A floating-point scalar usable by generated rig code and the control laws.
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
    + AddAssign
    + SubAssign
    + MulAssign
{
    /// Additive identity.
    const ZERO: Self;
    /// Multiplicative identity.
    const ONE: Self;
    /// Converts from `f64` (rounding to nearest for `f32`).
    fn from_f64(value: f64) -> Self;
    /// Widens to `f64`.
    fn to_f64(self) -> f64;
    /// Converts an integer (rounding to nearest for `f32`), without a detour through `f64`
    /// (which is software floating point on the Cortex-M4F).
    fn from_i64(value: i64) -> Self;
    /// `e^self`.
    fn exp(self) -> Self;
    /// Sine.
    fn sin(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// Sine and cosine of the same angle, sharing the argument reduction where the
    /// implementation can (generated code calls this once per joint angle).
    #[inline]
    fn sin_cos(self) -> (Self, Self) {
        (self.sin(), self.cos())
    }
    /// Square root (NaN for negative input).
    fn sqrt(self) -> Self;
    /// `self·a + b` rounded once (a fused multiply-add), the same bits on every target: the
    /// FPU's `vfma.f32` with the `fpu-fma` feature on ARM (`f32`), the FMA3 instruction on x86
    /// when compiled with `target_feature = "fma"`, else libm's exact software `fma`/`fmaf`.
    /// Code generated with fused multiply-adds calls this and its sign variants.
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// `self·a − b` rounded once (negating `b` is exact, so this is [`Real::mul_add`]`(self, a, −b)`).
    #[inline]
    fn mul_sub(self, a: Self, b: Self) -> Self {
        self.mul_add(a, -b)
    }
    /// `b − self·a` rounded once.
    #[inline]
    fn neg_mul_add(self, a: Self, b: Self) -> Self {
        (-self).mul_add(a, b)
    }
    /// `−self·a − b` rounded once.
    #[inline]
    fn neg_mul_sub(self, a: Self, b: Self) -> Self {
        (-self).mul_add(a, -b)
    }
    /// Absolute value.
    fn abs(self) -> Self;
    /// `atan2(self, x)`.
    fn atan2(self, x: Self) -> Self;
    /// `true` unless NaN or infinite.
    fn is_finite(self) -> bool;
    /// Rounds half away from zero.
    fn round(self) -> Self;
    /// Floor.
    fn floor(self) -> Self;
    /// The larger of two values; NaN-propagation is not relied upon by callers.
    #[inline]
    fn max(self, other: Self) -> Self {
        if self > other {
            self
        } else {
            other
        }
    }
    /// The smaller of two values.
    #[inline]
    fn min(self, other: Self) -> Self {
        if self < other {
            self
        } else {
            other
        }
    }
    /// Clamps to `[lower, upper]`; callers guarantee `lower <= upper`.
    #[inline]
    fn clamp_to(self, lower: Self, upper: Self) -> Self {
        self.max(lower).min(upper)
    }
}

/// Sine and cosine in single precision for the Cortex-M4F, whose FPU has no double precision.
///
/// `libm::sinf`/`cosf` reduce the argument and evaluate in `f64`, which on the M4F is
/// software floating point (about 1,300 instructions a call). Joint angles are small, so
/// here the argument is reduced in `f32` by the nearest multiple `j` of π/2 with a
/// three-part (Cody–Waite) split of π/2 whose first two parts times `j` are exact for
/// `|j| < 2¹⁶`, then sine and cosine come from the minimax polynomials of Cephes' `sinf`/`cosf`
/// on [−π/4, π/4]. The error is below 2 × 10⁻⁷ (a few ulp near 1) for `|x| ≤ 8192`.
///
/// **Range.** Beyond `|x| = 8192` rad the single-precision result is NaN, as for non-finite
/// input. An angle that large is not a pose of any rig (it is more than 1,300 turns) but a
/// sensor or state fault, and NaN makes the control path's checks latch it; handling it
/// "correctly" would need `libm`'s 4 KB Payne–Hanek reduction and software `f64` on the
/// Cortex-M4F. The `f64` implementation (host) is exact everywhere.
mod single {
    const HALF_PI_1: f32 = 1.570_312_5;
    const HALF_PI_2: f32 = 4.837_513e-4;
    const HALF_PI_3: f32 = 7.549_79e-8;
    const REDUCTION_LIMIT: f32 = 8192.0;

    /// Reduces `x` to `y ∈ [−π/4, π/4]` and evaluates sin y and cos y; returns the quadrant.
    #[inline]
    fn reduced(x: f32) -> (f32, f32, i32) {
        let j = (x * core::f32::consts::FRAC_2_PI + if x >= 0.0 { 0.5 } else { -0.5 }) as i32;
        let jf = j as f32;
        let y = ((x - jf * HALF_PI_1) - jf * HALF_PI_2) - jf * HALF_PI_3;
        polynomials(y, j)
    }

    #[inline]
    fn polynomials(y: f32, j: i32) -> (f32, f32, i32) {
        let z = y * y;
        let sin = y + y * z * (-1.666_665_5e-1 + z * (8.332_161e-3 + z * -1.951_529_6e-4));
        let cos = 1.0 - 0.5 * z + z * z * (4.166_664_6e-2 + z * (-1.388_731_6e-3 + z * 2.443_315_7e-5));
        (sin, cos, j & 3)
    }

    /// `(sin x, cos x)`.
    #[inline]
    pub fn sin_cos(x: f32) -> (f32, f32) {
        // NaN fails the comparison too.
        let (s, c, quadrant) = if libm::fabsf(x) <= REDUCTION_LIMIT {
            reduced(x)
        } else {
            return (f32::NAN, f32::NAN);
        };
        match quadrant {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }

    /// `sin x`.
    #[inline]
    pub fn sin(x: f32) -> f32 {
        sin_cos(x).0
    }

    /// `cos x`.
    #[inline]
    pub fn cos(x: f32) -> f32 {
        sin_cos(x).1
    }
}

/// `√x` in single precision: the FPU's `vsqrt.f32` with the `fpu-sqrt` feature on ARM (14
/// cycles on the Cortex-M4F, with four `vmov`s), else libm's `sqrtf` (software on targets
/// whose libm has no hardware path, as on ARM: about 50 instructions a call). Both are
/// correctly rounded (IEEE 754), so an `f32` run on the host and on the target agree bit
/// for bit; negative input gives NaN in both.
#[inline]
fn single_sqrt(x: f32) -> f32 {
    #[cfg(all(feature = "fpu-sqrt", target_arch = "arm"))]
    {
        // Rust's `sreg` operand class needs the `vfp2` feature (double precision), which a
        // single-precision FPU (the M4F's FPv4-SP) lacks, so the operands travel in core
        // registers and `s0` is saved and restored around the instruction.
        let bits: u32;
        // SAFETY: only registers are touched: `s0` is restored before the block ends, the
        // operands are core registers; no memory, no stack, no APSR flags (`vsqrt` sets only
        // the FPSCR's cumulative exception bits, which nothing here reads).
        unsafe {
            core::arch::asm!(
                "vmov {saved}, s0",
                "vmov s0, {x}",
                "vsqrt.f32 s0, s0",
                "vmov {root}, s0",
                "vmov s0, {saved}",
                x = in(reg) x.to_bits(),
                root = lateout(reg) bits,
                saved = out(reg) _,
                options(pure, nomem, nostack, preserves_flags)
            );
        }
        f32::from_bits(bits)
    }
    #[cfg(not(all(feature = "fpu-sqrt", target_arch = "arm")))]
    {
        libm::sqrtf(x)
    }
}

/// `x·y + z` in single precision, rounded once: the FPU's `vfma.f32` with the `fpu-fma`
/// feature on ARM, the FMA3 instruction on x86 compiled with `target_feature = "fma"`, else
/// libm's `fmaf` (exact, in software). All three are correctly rounded, so an `f32` run on the
/// host and on the target agree bit for bit.
///
/// On the Cortex-M4F the inline assembly costs more than the instruction: Rust's `sreg`
/// operand class needs the `vfp2` feature (double precision), which the M4F's FPv4-SP lacks,
/// so the operands travel through core registers (`vmov`, one cycle each; about nine
/// instructions in all against two for an unfused `vmul` and `vadd`). What the fusion buys there
/// is one rounding instead of two, and libm's software `fmaf` (about a hundred instructions of
/// software `f64`) is not used.
#[inline]
fn single_mul_add(x: f32, y: f32, z: f32) -> f32 {
    #[cfg(all(feature = "fpu-fma", target_arch = "arm"))]
    {
        let bits: u32;
        // SAFETY: only registers are touched: `s0`–`s2` are declared clobbered, the operands
        // are core registers; no memory, no stack, no APSR flags (`vfma` sets only the FPSCR's
        // cumulative exception bits, which nothing here reads).
        unsafe {
            core::arch::asm!(
                "vmov s0, {z}",
                "vmov s1, {x}",
                "vmov s2, {y}",
                "vfma.f32 s0, s1, s2",
                "vmov {r}, s0",
                x = in(reg) x.to_bits(),
                y = in(reg) y.to_bits(),
                z = in(reg) z.to_bits(),
                r = lateout(reg) bits,
                out("s0") _,
                out("s1") _,
                out("s2") _,
                options(pure, nomem, nostack, preserves_flags)
            );
        }
        f32::from_bits(bits)
    }
    #[cfg(all(
        not(all(feature = "fpu-fma", target_arch = "arm")),
        target_arch = "x86_64",
        target_feature = "fma"
    ))]
    {
        use core::arch::x86_64::{_mm_cvtss_f32, _mm_fmadd_ss, _mm_set_ss};
        // SAFETY: the `fma` target feature is enabled at compile time (the `cfg` above).
        unsafe { _mm_cvtss_f32(_mm_fmadd_ss(_mm_set_ss(x), _mm_set_ss(y), _mm_set_ss(z))) }
    }
    #[cfg(all(
        not(all(feature = "fpu-fma", target_arch = "arm")),
        not(all(target_arch = "x86_64", target_feature = "fma"))
    ))]
    {
        libm::fmaf(x, y, z)
    }
}

/// `x·y + z` in double precision, rounded once: the FMA3 instruction on x86 compiled with
/// `target_feature = "fma"`, else libm's exact `fma`.
#[inline]
fn double_mul_add(x: f64, y: f64, z: f64) -> f64 {
    #[cfg(all(target_arch = "x86_64", target_feature = "fma"))]
    {
        use core::arch::x86_64::{_mm_cvtsd_f64, _mm_fmadd_sd, _mm_set_sd};
        // SAFETY: the `fma` target feature is enabled at compile time (the `cfg` above).
        unsafe { _mm_cvtsd_f64(_mm_fmadd_sd(_mm_set_sd(x), _mm_set_sd(y), _mm_set_sd(z))) }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "fma")))]
    {
        libm::fma(x, y, z)
    }
}

/// `(sin x, cos x)` in double precision (libm).
#[inline]
fn double_sin_cos(x: f64) -> (f64, f64) {
    (libm::sin(x), libm::cos(x))
}

macro_rules! impl_real {
    ($t:ty, $exp:path, $sin:path, $cos:path, $sin_cos:path, $sqrt:path, $mul_add:path, $fabs:path, $atan2:path, $round:path, $floor:path) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            #[inline]
            fn from_f64(value: f64) -> Self {
                value as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn from_i64(value: i64) -> Self {
                value as $t
            }
            #[inline]
            fn exp(self) -> Self {
                $exp(self)
            }
            #[inline]
            fn sin(self) -> Self {
                $sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                $cos(self)
            }
            #[inline]
            fn sin_cos(self) -> (Self, Self) {
                $sin_cos(self)
            }
            #[inline]
            fn sqrt(self) -> Self {
                $sqrt(self)
            }
            #[inline]
            fn mul_add(self, a: Self, b: Self) -> Self {
                $mul_add(self, a, b)
            }
            #[inline]
            fn abs(self) -> Self {
                $fabs(self)
            }
            #[inline]
            fn atan2(self, x: Self) -> Self {
                $atan2(self, x)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline]
            fn round(self) -> Self {
                $round(self)
            }
            #[inline]
            fn floor(self) -> Self {
                $floor(self)
            }
        }
    };
}

impl_real!(
    f32,
    libm::expf,
    single::sin,
    single::cos,
    single::sin_cos,
    single_sqrt,
    single_mul_add,
    libm::fabsf,
    libm::atan2f,
    libm::roundf,
    libm::floorf
);
impl_real!(
    f64,
    libm::exp,
    libm::sin,
    libm::cos,
    double_sin_cos,
    libm::sqrt,
    double_mul_add,
    libm::fabs,
    libm::atan2,
    libm::round,
    libm::floor
);

#[cfg(test)]
mod tests {
    use super::Real;

    /// The runtime's `mul_add` rounds once: it agrees bit for bit with std's `mul_add` (the
    /// platform's correctly rounded fma), including the halfway cases where a multiplication
    /// and an addition, or an `f64` detour for `f32`, would round twice.
    #[test]
    fn mul_add_is_a_correctly_rounded_fused_multiply_add() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(7);
        let mut differs_from_unfused = 0usize;
        for _ in 0..200_000 {
            let scale = |rng: &mut rand::rngs::SmallRng| 10f64.powi(rng.gen_range(-8..8));
            let (x, y, z): (f64, f64, f64) = (
                rng.gen_range(-1.0..1.0) * scale(&mut rng),
                rng.gen_range(-1.0..1.0) * scale(&mut rng),
                rng.gen_range(-1.0..1.0) * scale(&mut rng),
            );
            assert_eq!(Real::mul_add(x, y, z).to_bits(), f64::mul_add(x, y, z).to_bits(), "{x} {y} {z}");
            assert_eq!(Real::mul_sub(x, y, z).to_bits(), f64::mul_add(x, y, -z).to_bits());
            assert_eq!(Real::neg_mul_add(x, y, z).to_bits(), f64::mul_add(-x, y, z).to_bits());
            assert_eq!(Real::neg_mul_sub(x, y, z).to_bits(), f64::mul_add(-x, y, -z).to_bits());
            let (a, b, c) = (x as f32, y as f32, z as f32);
            assert_eq!(Real::mul_add(a, b, c).to_bits(), f32::mul_add(a, b, c).to_bits(), "{a} {b} {c}");
            differs_from_unfused += usize::from(Real::mul_add(a, b, c) != a * b + c);
        }
        // Single-precision halfway cases: x·y + z exactly halfway between two floats in f64,
        // where rounding the f64 sum to f32 would be a second rounding.
        let (x, y) = (1.0f32 + f32::EPSILON, 1.0f32 - f32::EPSILON);
        for z in [0.0f32, 1.0e-8, -1.0e-8, 3.0, -0.75] {
            assert_eq!(Real::mul_add(x, y, z).to_bits(), f32::mul_add(x, y, z).to_bits(), "{z}");
        }
        assert!(differs_from_unfused > 0, "the test never exercised a rounding difference");
        assert!(
            Real::mul_add(f32::NAN, 1.0, 1.0).is_nan() && Real::mul_add(f64::INFINITY, 0.0, 1.0).is_nan()
        );
    }

    #[test]
    fn single_precision_square_root_is_correctly_rounded() {
        // Against std's `f32::sqrt` (IEEE 754, correctly rounded), bit for bit.
        for i in 0..5000u32 {
            let x = i as f32 * 0.37 + 1e-3;
            assert_eq!(Real::sqrt(x).to_bits(), x.sqrt().to_bits(), "{x}");
        }
        assert_eq!(Real::sqrt(4.0f32), 2.0);
        assert!(Real::sqrt(-1.0f32).is_nan());
    }

    #[test]
    fn double_precision_sine_and_cosine_match_the_platform() {
        // `f64::sin_cos` of the runtime (libm) against std's (the platform's libm): both
        // within an ulp or two of the exact values.
        for i in -2000..=2000 {
            let x = f64::from(i) * 3.7e-3;
            let (s, c) = Real::sin_cos(x);
            assert!((s - x.sin()).abs() <= 4.0 * f64::EPSILON, "sin {x}");
            assert!((c - x.cos()).abs() <= 4.0 * f64::EPSILON, "cos {x}");
            assert_eq!((s, c), (Real::sin(x), Real::cos(x)));
        }
        // sin²+cos² = 1 at an angle where neither is near 0 or ±1.
        let (s, c) = Real::sin_cos(0.9f64);
        assert!((s * s + c * c - 1.0).abs() < 1e-15 && s > 0.78 && c > 0.62);
    }

    #[test]
    fn single_precision_sine_and_cosine_are_accurate() {
        let mut worst = 0.0f64;
        let mut check = |x: f32| {
            let (s, c) = Real::sin_cos(x);
            let exact = (f64::from(x).sin(), f64::from(x).cos());
            worst = worst.max((f64::from(s) - exact.0).abs()).max((f64::from(c) - exact.1).abs());
            assert_eq!(s, Real::sin(x));
            assert_eq!(c, Real::cos(x));
        };
        for i in -200_000..=200_000 {
            check(i as f32 * 1e-4);
        }
        for i in -1000..=1000 {
            check(i as f32 * 8.19);
        }
        assert!(worst < 2e-7, "worst error {worst:e}");
        assert!(Real::sin(f32::NAN).is_nan() && Real::cos(f32::INFINITY).is_nan());
        // Beyond the documented range: NaN, which the control path latches as a fault.
        for x in [8192.5f32, -1.0e5, f32::MAX] {
            let (s, c) = Real::sin_cos(x);
            assert!(s.is_nan() && c.is_nan(), "{x}");
        }
        let (s, c) = Real::sin_cos(8191.9f32);
        assert!((f64::from(s) - 8191.9f32.sin() as f64).abs() < 1e-3 && c.is_finite());
    }

    /// A scalar outside the runtime's two (`f32`, `f64`), implementing only the required items
    /// of [`Real`] by delegating to std's `f64`: the provided methods are what it gets.
    #[derive(Clone, Copy, Debug, Default, PartialEq, PartialOrd)]
    struct Plain(f64);

    macro_rules! plain_operators {
        ($($op:ident $method:ident $sym:tt, $assign:ident $assign_method:ident;)*) => {$(
            impl core::ops::$op for Plain {
                type Output = Plain;
                fn $method(self, other: Plain) -> Plain {
                    Plain(self.0 $sym other.0)
                }
            }
            impl core::ops::$assign for Plain {
                fn $assign_method(&mut self, other: Plain) {
                    self.0 = self.0 $sym other.0;
                }
            }
        )*};
    }
    plain_operators! {
        Add add +, AddAssign add_assign;
        Sub sub -, SubAssign sub_assign;
        Mul mul *, MulAssign mul_assign;
        Div div /, DivAssign div_assign;
    }
    impl core::ops::Neg for Plain {
        type Output = Plain;
        fn neg(self) -> Plain {
            Plain(-self.0)
        }
    }
    impl Real for Plain {
        const ZERO: Self = Plain(0.0);
        const ONE: Self = Plain(1.0);
        fn from_f64(value: f64) -> Self {
            Plain(value)
        }
        fn to_f64(self) -> f64 {
            self.0
        }
        fn from_i64(value: i64) -> Self {
            Plain(value as f64)
        }
        fn exp(self) -> Self {
            Plain(self.0.exp())
        }
        fn sin(self) -> Self {
            Plain(self.0.sin())
        }
        fn cos(self) -> Self {
            Plain(self.0.cos())
        }
        fn sqrt(self) -> Self {
            Plain(self.0.sqrt())
        }
        fn mul_add(self, a: Self, b: Self) -> Self {
            Plain(self.0.mul_add(a.0, b.0))
        }
        fn abs(self) -> Self {
            Plain(self.0.abs())
        }
        fn atan2(self, x: Self) -> Self {
            Plain(self.0.atan2(x.0))
        }
        fn is_finite(self) -> bool {
            self.0.is_finite()
        }
        fn round(self) -> Self {
            Plain(self.0.round())
        }
        fn floor(self) -> Self {
            Plain(self.0.floor())
        }
    }

    /// The provided methods of [`Real`], which `f32` and `f64` partly override (`sin_cos`),
    /// on a scalar that overrides none, against std's `f64`: `sin_cos` is `(sin, cos)`, the
    /// sign variants of `mul_add` are the exact products and sums of these small integers,
    /// `max`, `min` and `clamp_to` the larger, smaller, clamped value. (Written for the
    /// held-out cargo-mutants survivor that replaced the default `sin_cos` by `(0, 0)`, which
    /// no test reached: both of the runtime's scalars override it.)
    #[test]
    fn provided_methods_on_a_scalar_that_overrides_none() {
        for x in [0.9, -2.5, 0.0, 3.0] {
            let (s, c) = Plain(x).sin_cos();
            assert_eq!((s.0, c.0), (x.sin(), x.cos()), "sin_cos({x})");
        }
        let (x, a, b) = (Plain(3.0), Plain(5.0), Plain(7.0));
        assert_eq!(x.mul_add(a, b), Plain(22.0));
        assert_eq!(x.mul_sub(a, b), Plain(8.0));
        assert_eq!(x.neg_mul_add(a, b), Plain(-8.0));
        assert_eq!(x.neg_mul_sub(a, b), Plain(-22.0));
        assert_eq!((x.max(a), a.max(x)), (a, a));
        assert_eq!((x.min(a), a.min(x)), (x, x));
        assert_eq!(Plain(9.0).clamp_to(x, a), a);
        assert_eq!(Plain(-9.0).clamp_to(x, a), x);
        assert_eq!(Plain(4.0).clamp_to(x, a), Plain(4.0));
    }
}
