//! Literals of the emitted code: the scalar type ([`Scalar`]), float literals of that type
//! (named `core` constants where a value is exactly one, `NAN`/`INFINITY` where it is not
//! finite, the short decimal a folded product of the model's numbers stands for: see
//! [`short_decimal`]) and unsuffixed integer literals for array lengths and indices.

use proc_macro2::{Span, TokenStream};
use quote::quote;

/// The floating-point type of the generated code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scalar {
    /// Single precision (Cortex-M4F firmware).
    F32,
    /// Double precision (host).
    F64,
}

impl Scalar {
    /// `f32` or `f64`.
    pub fn name(self) -> &'static str {
        match self {
            Scalar::F32 => "f32",
            Scalar::F64 => "f64",
        }
    }

    pub(crate) fn tokens(self) -> TokenStream {
        match self {
            Scalar::F32 => quote!(f32),
            Scalar::F64 => quote!(f64),
        }
    }

    /// A literal of this type. A value that is exactly one of `core`'s mathematical constants
    /// (e.g. a joint limit of −45° = −π/4) is written as that constant, which is what clippy's
    /// `approx_constant` lint asks of the generated code.
    pub fn literal(self, value: f64) -> TokenStream {
        // A constant that is not finite in this type (a 0/0 folded in the DAG for a singular
        // model, or an f64 beyond f32's range) is spelled with the type's named constants:
        // the runtime's checks then see it, and no float literal is malformed.
        let rounded = match self {
            Scalar::F32 => f64::from(value as f32),
            Scalar::F64 => value,
        };
        if !rounded.is_finite() {
            let ty = self.tokens();
            return if rounded.is_nan() {
                quote!(#ty::NAN)
            } else if rounded > 0.0 {
                quote!(#ty::INFINITY)
            } else {
                quote!(#ty::NEG_INFINITY)
            };
        }
        let magnitude = short_decimal(value.abs());
        if let Some(name) = named_constant(magnitude) {
            let ident = syn::Ident::new(name, Span::call_site());
            let ty = self.tokens();
            let path = quote!(::core::#ty::consts::#ident);
            return if value < 0.0 { quote!(-#path) } else { path };
        }
        let text = match self {
            Scalar::F32 => format!("{:?}_f32", magnitude as f32),
            Scalar::F64 => format!("{magnitude:?}_f64"),
        };
        let lit = syn::LitFloat::new(&text, Span::call_site());
        if value < 0.0 {
            quote!(-#lit)
        } else {
            quote!(#lit)
        }
    }
}

/// Significant digits of the decimals [`short_decimal`] restores.
pub(crate) const SHORT_DECIMAL_DIGITS: usize = 8;

/// How many units in the last place a folded value may lie from the decimal
/// [`short_decimal`] restores.
pub(crate) const SHORT_DECIMAL_ULPS: u64 = 4;

/// `x`, or the decimal of at most [`SHORT_DECIMAL_DIGITS`] significant digits within
/// [`SHORT_DECIMAL_ULPS`] units in the last place of it.
///
/// Why: the model file's numbers are short decimals, and the generator folds products and sums
/// of them in binary floating point, which leaves rounding noise in the last bits
/// (`0.0024 × 1.2` folds to `0.0028799999999999997`). The exact value of such a product is a
/// short decimal, and the literal of that decimal is its correctly rounded value: the code shows
/// the number a reviewer can check against the file, and is no less accurate. A value that is
/// not such a product lands this close to a short decimal by chance with a probability of about
/// 1e-7 (8-digit decimals are 1e-8 apart relative to the value, 4 ulps are 9e-16), so nothing
/// computed from angles, square roots or quotients is moved.
pub(crate) fn short_decimal(x: f64) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    let rounded: f64 = match format!("{x:.*e}", SHORT_DECIMAL_DIGITS - 1).parse() {
        Ok(parsed) => parsed,
        Err(_) => return x,
    };
    if rounded != x && ulps_apart(x, rounded) <= SHORT_DECIMAL_ULPS {
        rounded
    } else {
        x
    }
}

/// How many representable `f64`s lie between `a` and `b` (both finite, of the same sign).
fn ulps_apart(a: f64, b: f64) -> u64 {
    if a.is_sign_negative() != b.is_sign_negative() {
        return u64::MAX;
    }
    a.to_bits().abs_diff(b.to_bits())
}

/// The name of the `core::f64::consts` constant equal to `x`, if any.
fn named_constant(x: f64) -> Option<&'static str> {
    use std::f64::consts as c;
    const NAMES: [(f64, &str); 17] = [
        (c::PI, "PI"),
        (c::TAU, "TAU"),
        (c::FRAC_PI_2, "FRAC_PI_2"),
        (c::FRAC_PI_3, "FRAC_PI_3"),
        (c::FRAC_PI_4, "FRAC_PI_4"),
        (c::FRAC_PI_6, "FRAC_PI_6"),
        (c::FRAC_PI_8, "FRAC_PI_8"),
        (c::FRAC_1_PI, "FRAC_1_PI"),
        (c::FRAC_2_PI, "FRAC_2_PI"),
        (c::FRAC_2_SQRT_PI, "FRAC_2_SQRT_PI"),
        (c::SQRT_2, "SQRT_2"),
        (c::FRAC_1_SQRT_2, "FRAC_1_SQRT_2"),
        (c::E, "E"),
        (c::LN_2, "LN_2"),
        (c::LN_10, "LN_10"),
        (c::LOG2_E, "LOG2_E"),
        (c::LOG10_E, "LOG10_E"),
    ];
    NAMES.iter().find(|(v, _)| *v == x).map(|(_, name)| *name)
}

/// An integer literal without a type suffix (`2`, not `2usize`).
pub(crate) fn unsuffixed(n: usize) -> proc_macro2::Literal {
    proc_macro2::Literal::usize_unsuffixed(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folded_product_of_short_decimals_is_written_as_its_exact_decimal() {
        // Products and sums of model numbers whose binary folding leaves noise.
        assert_eq!(0.0024_f64 * 1.2, 0.0028799999999999997);
        assert_eq!(short_decimal(0.0024 * 1.2), 0.00288);
        assert_eq!(short_decimal(0.1025 * 0.1025), 0.01050625);
        assert_eq!(short_decimal(0.1 + 0.2), 0.3);
        assert_eq!(short_decimal(2.5 * 9.81), 24.525);
        // Exact values, and values far from any short decimal, are kept bit for bit.
        for kept in [0.00288, 1.0 / 3.0, std::f64::consts::SQRT_2 / 2.0, 1.0 / 0.1025, 1e-300, 0.0] {
            assert_eq!(short_decimal(kept).to_bits(), kept.to_bits(), "{kept:e}");
        }
        // The bound is four units in the last place: five away is not noise of a fold.
        let five_away = f64::from_bits(0.00288_f64.to_bits() + 5);
        assert_eq!(short_decimal(five_away), five_away);
        let four_away = f64::from_bits(0.00288_f64.to_bits() - 4);
        assert_eq!(short_decimal(four_away), 0.00288);
        assert!(short_decimal(f64::NAN).is_nan());
        assert_eq!(short_decimal(f64::INFINITY), f64::INFINITY);
    }
}
