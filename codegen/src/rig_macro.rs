//! The expansion of the `rig!` proc-macro, kept here so that the macro crate is a thin shell
//! and tests can compare the expansion with the build-script helper's output.
//!
//! Syntax: `rig!(pub mod NAME = "path/to/model.yaml", variant = "horizontal", scalar = f32, fma = true,
//! regressor = true);` (`variant`, `scalar`, `fma` and `regressor` are optional; `scalar` defaults
//! to `f64`, `fma` — fused multiply-adds, see [`crate::EmitOptions`] — and `regressor` — the
//! identification regressor, `crate::dynamics::regressor` — to `false`). The path is relative to
//! the invoking crate's `CARGO_MANIFEST_DIR`. A bad model becomes a `compile_error!` spanned
//! on the path literal, with an empty module of the requested name so that only one error is
//! reported.

use std::path::Path;

use proc_macro2::{Span, TokenStream};
use quote::{quote, quote_spanned};
use syn::parse::{Parse, ParseStream};
use syn::{Ident, LitStr, Token, Visibility};

use crate::{Diagnostics, EmitOptions, Scalar};

/// The parsed arguments of `rig!`.
pub struct RigInput {
    /// Visibility of the generated module.
    pub visibility: Visibility,
    /// Name of the generated module.
    pub module: Ident,
    /// The model file, as written.
    pub path: LitStr,
    /// The variant, if given.
    pub variant: Option<LitStr>,
    /// The scalar type.
    pub scalar: Scalar,
    /// The emission options (`fma = true`: fused multiply-adds; `regressor = true`: the
    /// identification regressor).
    pub options: EmitOptions,
}

impl Parse for RigInput {
    fn parse(input: ParseStream<'_>) -> syn::Result<Self> {
        let visibility: Visibility = input.parse()?;
        input.parse::<Token![mod]>().map_err(|e| {
            syn::Error::new(
                e.span(),
                "expected `mod NAME = \"model.yaml\"`, e.g. `rig!(pub mod arm = \"models/arm.yaml\")`",
            )
        })?;
        let module: Ident = input.parse()?;
        input.parse::<Token![=]>()?;
        let path: LitStr = input.parse().map_err(|e| {
            syn::Error::new(e.span(), "expected the model file as a string literal, e.g. \"models/arm.yaml\"")
        })?;
        let mut variant = None;
        let mut scalar = None;
        let mut fma = None;
        let mut regressor = None;
        while !input.is_empty() {
            input.parse::<Token![,]>()?;
            if input.is_empty() {
                break;
            }
            let key: Ident = input.parse()?;
            input.parse::<Token![=]>()?;
            match key.to_string().as_str() {
                "variant" if variant.is_none() => variant = Some(input.parse::<LitStr>()?),
                "scalar" if scalar.is_none() => {
                    let ty: Ident = input.parse()?;
                    scalar = Some(match ty.to_string().as_str() {
                        "f32" => Scalar::F32,
                        "f64" => Scalar::F64,
                        other => {
                            return Err(syn::Error::new(
                                ty.span(),
                                format!("unsupported scalar type `{other}`: expected `f32` or `f64`"),
                            ))
                        }
                    });
                }
                "fma" if fma.is_none() => fma = Some(input.parse::<syn::LitBool>()?.value),
                "regressor" if regressor.is_none() => regressor = Some(input.parse::<syn::LitBool>()?.value),
                "variant" | "scalar" | "fma" | "regressor" => {
                    return Err(syn::Error::new(key.span(), format!("`{key}` is given twice")));
                }
                other => {
                    return Err(syn::Error::new(
                        key.span(),
                        format!(
                            "unknown option `{other}`: expected `variant = \"...\"`, `scalar = f32 | f64`, `fma = true | false` or `regressor = true | false`"
                        ),
                    ))
                }
            }
        }
        Ok(RigInput {
            visibility,
            module,
            path,
            variant,
            scalar: scalar.unwrap_or(Scalar::F64),
            options: EmitOptions {
                fused_multiply_add: fma.unwrap_or(false),
                regressor: regressor.unwrap_or(false),
            },
        })
    }
}

/// Expands `rig!` given the invoking crate's manifest directory.
pub fn expand(input: TokenStream, manifest_dir: &Path) -> TokenStream {
    let parsed: RigInput = match syn::parse2(input) {
        Ok(p) => p,
        Err(e) => return e.to_compile_error(),
    };
    let RigInput { visibility, module, path, variant, scalar, options } = &parsed;
    let file = path.value();
    let full = manifest_dir.join(&file);
    let variant_name = variant.as_ref().map(LitStr::value);
    let span = path.span();
    let generated = crate::load_file(&full, &file, variant_name.as_deref())
        .map(|model| crate::generate_model_with(model, *scalar, *options));
    match generated {
        Ok(generated) => {
            let items = &generated.tokens;
            let tracked = full.to_string_lossy().into_owned();
            let doc = format!(
                " @generated by hapticgen {} from {}{}, scalar {}{}.",
                crate::VERSION,
                file,
                variant_name.map(|v| format!(" (variant {v})")).unwrap_or_default(),
                scalar.name(),
                if options.fused_multiply_add { ", fused multiply-adds" } else { "" }
            ) + if options.regressor { ", with the identification regressor" } else { "" };
            quote! {
                #[doc = #doc]
                #visibility mod #module {
                    // Makes cargo rebuild the invoking crate when the model file changes.
                    const _: &[u8] = include_bytes!(#tracked);
                    #items
                }
            }
        }
        Err(diagnostics) => {
            let stub = std::fs::read_to_string(&full).ok().and_then(|text| stub_type_name(&text));
            error_tokens(&diagnostics, span, visibility, module, stub)
        }
    }
}

/// The rig struct's name a model file would give (`name: my_arm` → `MyArm`), if its top-level
/// `name` can be read despite the errors: the stub module then holds a struct of that name, so
/// that the crate's `use module::MyArm;` resolves and the model's errors are the only ones.
fn stub_type_name(text: &str) -> Option<Ident> {
    let value: serde_yaml::Value = serde_yaml::from_str(text).ok()?;
    let name = value.get("name")?.as_str()?;
    if !name.bytes().all(|b| b == b'_' || b.is_ascii_lowercase() || b.is_ascii_digit()) {
        return None;
    }
    // The same type name the generator gives the rig (`emit::naming::rig_type_name`).
    syn::parse_str::<Ident>(&crate::emit::camel_case(name)).ok()
}

fn error_tokens(
    diagnostics: &Diagnostics,
    span: Span,
    visibility: &Visibility,
    module: &Ident,
    stub: Option<Ident>,
) -> TokenStream {
    let message = diagnostics.0.iter().map(|d| d.to_string()).collect::<Vec<_>>().join("\n");
    let stub = stub.map(|name| {
        quote_spanned! {span=>
            /// A stand-in: the model file has errors (see the compile error above).
            #[allow(dead_code)]
            pub struct #name;
        }
    });
    quote_spanned! {span=>
        ::core::compile_error!(#message);
        #visibility mod #module {
            #stub
        }
    }
}

/// Formats an expansion's items (the module's content) for comparison with the build helper.
pub fn expansion_items(input: TokenStream, manifest_dir: &Path) -> Option<String> {
    let file: syn::File = syn::parse2(expand(input, manifest_dir)).ok()?;
    let syn::Item::Mod(module) = file.items.into_iter().next()? else { return None };
    let (_, items) = module.content?;
    let items: Vec<syn::Item> =
        items.into_iter().filter(|i| !matches!(i, syn::Item::Const(c) if c.ident == "_")).collect();
    Some(prettyplease::unparse(&syn::File { shebang: None, attrs: vec![], items }))
}
