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
    /// Sine.
    fn sin(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// Square root (NaN for negative input).
    fn sqrt(self) -> Self;
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

macro_rules! impl_real {
    ($t:ty, $sin:path, $cos:path, $sqrt:path, $fabs:path, $atan2:path, $round:path, $floor:path) => {
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
            fn sin(self) -> Self {
                $sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                $cos(self)
            }
            #[inline]
            fn sqrt(self) -> Self {
                $sqrt(self)
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

impl_real!(f32, libm::sinf, libm::cosf, libm::sqrtf, libm::fabsf, libm::atan2f, libm::roundf, libm::floorf);
impl_real!(f64, libm::sin, libm::cos, libm::sqrt, libm::fabs, libm::atan2, libm::round, libm::floor);
