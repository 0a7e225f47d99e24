//! Emission of the `hapticgen_runtime::fused::FusedImpedance` implementation: each control
//! law [`super::laws::build`] constructs (eq. (3)–(12)) lowered to one straight-line function,
//! its external inputs (reference, impedance parameters, sensed force or acceleration) read
//! from the arguments.

use proc_macro2::{Ident, Span, TokenStream};
use quote::{format_ident, quote};

use crate::dynamics::mechanics::Mechanics;
use crate::model::Model;
use crate::sym::dag::OpCounts;

use super::literal::{unsuffixed, Scalar};
use super::lower::{BodyEmitter, EmitOptions};
use super::naming::{rig_type_name, SharedNames};

/// Emits the `FusedImpedance` implementation: one straight-line function per law; returns it
/// with the operation counts of each law that has a closed form, in emission order.
pub(crate) fn fused_impl(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    names: &SharedNames,
) -> (TokenStream, Vec<(String, OpCounts)>) {
    use super::laws::{build, External, Law};
    let s = scalar.tokens();
    let (n_usize, m_usize) = (mech.joints, mech.task_dim);
    let n = unsuffixed(n_usize);
    let m = unsuffixed(m_usize);
    let type_name = Ident::new(&rig_type_name(model), Span::call_site());
    let reference_ty = quote!(::hapticgen_runtime::control::TaskReference<#s, #m>);
    let parameters_ty = quote!(::hapticgen_runtime::control::ImpedanceParameters<#s, #m>);
    let fused_ty = quote!(::hapticgen_runtime::fused::FusedTorque<#s, #n>);
    let laws = [
        (Law::JacobianTranspose, "jacobian_transpose_torque", None),
        (Law::ForceFeedback, "force_feedback_torque", Some("operator_force")),
        (Law::AccelerationFeedback, "acceleration_feedback_torque", Some("task_acceleration")),
        (Law::NaturalInertia, "natural_inertia_torque", None),
    ];
    let mut methods = TokenStream::new();
    let mut counts_by_law = Vec::new();
    for (law, name, sensed) in laws {
        let mut body = BodyEmitter::new(model, mech, scalar, options);
        body.share_names(names);
        for kind in External::ALL {
            for k in 0..m_usize {
                let kk = unsuffixed(k);
                let (binding, access) = match kind {
                    External::ReferencePosition => {
                        (format!("reference_position_{k}"), quote!(reference.position[#kk]))
                    }
                    External::ReferenceVelocity => {
                        (format!("reference_velocity_{k}"), quote!(reference.velocity[#kk]))
                    }
                    External::ReferenceAcceleration => {
                        (format!("reference_acceleration_{k}"), quote!(reference.acceleration[#kk]))
                    }
                    External::Stiffness => (format!("stiffness_{k}"), quote!(parameters.stiffness[#kk])),
                    External::Damping => (format!("desired_damping_{k}"), quote!(parameters.damping[#kk])),
                    External::Mass => (format!("desired_mass_{k}"), quote!(parameters.mass[#kk])),
                    External::Sensed => {
                        let field = format_ident!("{}", sensed.unwrap_or("sensed"));
                        (format!("{}_{k}", sensed.unwrap_or("sensed")), quote!(#field[#kk]))
                    }
                };
                body.naming.externals.push((binding, access));
            }
        }
        let nodes = build(&mut body.dag, model, mech, law);
        if let Some(nodes) = &nodes {
            body.hints.extend(nodes.names.iter().cloned());
        }
        let fn_name = format_ident!("{}", name);
        let sensed_arg = sensed.map(|field| {
            let ident = format_ident!("{}{}", if nodes.is_some() { "" } else { "_" }, field);
            quote!(, #ident: &[#s; #m])
        });
        let prefix = |arg: &str| format_ident!("{}{}", if nodes.is_some() { "" } else { "_" }, arg);
        let (q, qd, reference, parameters) =
            (prefix("q"), prefix("qd"), prefix("reference"), prefix("parameters"));
        let args = quote!(&self, #q: &[#s; #n], #qd: &[#s; #n], #reference: &#reference_ty, #parameters: &#parameters_ty #sensed_arg);
        let tokens = match (law, nodes) {
            (Law::JacobianTranspose, Some(nodes)) => {
                let (statements, outputs, counts) = body.emit(&nodes.torque, name);
                counts_by_law.push((name.to_string(), counts));
                quote! {
                    #[inline]
                    fn #fn_name(#args) -> [#s; #n] {
                        #statements
                        [#(#outputs),*]
                    }
                }
            }
            (_, Some(nodes)) => {
                let mut roots = nodes.torque.clone();
                roots.extend(nodes.jacobian_determinant);
                let (statements, outputs, counts) = body.emit(&roots, name);
                counts_by_law.push((name.to_string(), counts));
                let (torque, det) = outputs.split_at(n_usize);
                let det = det.first().cloned().unwrap_or_else(|| scalar.literal(1.0));
                let det_field = if det.to_string() == "jacobian_determinant" {
                    quote!(jacobian_determinant)
                } else {
                    quote!(jacobian_determinant: #det)
                };
                quote! {
                    #[inline]
                    fn #fn_name(#args) -> Option<#fused_ty> {
                        #statements
                        Some(::hapticgen_runtime::fused::FusedTorque {
                            torque: [#(#torque),*],
                            #det_field,
                        })
                    }
                }
            }
            // No closed form for this task (`J` not square, or larger than 3 × 3): the trait's
            // default returns `None`.
            (_, None) => TokenStream::new(),
        };
        methods.extend(tokens);
    }
    let tokens = quote! {
        impl ::hapticgen_runtime::fused::FusedImpedance<#n, #m> for #type_name {
            #methods
        }
    };
    (tokens, counts_by_law)
}
