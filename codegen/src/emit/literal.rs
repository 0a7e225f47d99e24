//! Literals of the emitted code: the scalar type ([`Scalar`]), float literals of that type
//! (named `core` constants where a value is exactly one, `NAN`/`INFINITY` where it is not
//! finite) and unsuffixed integer literals for array lengths and indices.

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
        let magnitude = value.abs();
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
