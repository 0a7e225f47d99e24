//! Assembly of a rig's items: the struct (tunable parameters as fields), its constants
//! (nominal values, drive trains, current-loop gains), its methods, the
//! `::hapticgen_runtime::RigModel` implementation and the fused control laws' implementation,
//! with the operation counts of every emitted function. The `RigModel` glue is the runtime's
//! `impl_rig_model!`, which calls the inherent methods.

use proc_macro2::{Ident, Span, TokenStream};
use quote::{format_ident, quote};

use crate::check::CheckedModel;
use crate::dynamics::mechanics::Mechanics;
use crate::model::JointKind;
use crate::sym::dag::{NodeId, OpCounts};

use super::catalogue::function_specs;
use super::fused_impl::fused_impl;
use super::literal::{unsuffixed, Scalar};
use super::loops::loop_constraints_impl;
use super::lower::{BodyEmitter, EmitOptions};
use super::methods::{closure_margin_function, function_sharing, regressor_function, terms_function};
use super::naming::{rig_type_name, SharedNames};

/// Operation counts of each emitted function and of the fused tick.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Stats {
    /// Per function, in emission order.
    pub functions: Vec<(String, OpCounts)>,
}

/// Emits every item of a rig: the struct, its methods and the `RigModel` implementation.
pub fn items(
    model: &CheckedModel,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
) -> (TokenStream, Stats) {
    let s = scalar.tokens();
    let n = unsuffixed(mech.joints);
    let m = unsuffixed(mech.task_dim);
    let type_name = Ident::new(&rig_type_name(model), Span::call_site());
    let rig_name = &model.name;
    let mut stats = Stats::default();

    // One name per value across every function of the rig.
    let names = SharedNames::default();
    let mut methods = TokenStream::new();
    for spec in function_specs(model, mech) {
        let (tokens, counts) = function_sharing(model, mech, scalar, options, &spec, &names);
        methods.extend(tokens);
        stats.functions.push((spec.name.clone(), counts));
    }
    let (terms, tick) = terms_function(model, mech, scalar, options, &names);
    stats.functions.push(("terms".into(), tick));
    methods.extend(terms);
    // A closed chain's `RigModel::loop_margin` is the least of its `closure_margin`.
    let mut loop_margin = TokenStream::new();
    if let Some((margin, counts)) = closure_margin_function(model, mech, scalar, options, &names) {
        stats.functions.push(("closure_margin".into(), counts));
        methods.extend(margin);
        loop_margin = quote!(, closure_margin);
    }
    // The identification regressor, on request only.
    if options.regressor {
        let (regressor, counts) = regressor_function(model, mech, scalar, options, &names);
        stats.functions.push(("regressor".into(), counts));
        methods.extend(regressor);
    }
    let (fused, fused_counts) = fused_impl(model, mech, scalar, options, &names);
    stats.functions.extend(fused_counts);
    let loop_constraints = match loop_constraints_impl(model, mech, scalar, options, &names) {
        Some((tokens, counts)) => {
            stats.functions.extend(counts);
            tokens
        }
        None => TokenStream::new(),
    };

    // Damping depends on tunable parameters at most.
    let mut damping_body = BodyEmitter::new(model, mech, scalar, options);
    damping_body.share_names(&names);
    let damping_roots: Vec<NodeId> = mech.damping.iter().map(|p| damping_body.dag.polynomial(p)).collect();
    let (damping_statements, damping_values, _) = damping_body.emit(&damping_roots, "damping");

    // Tunable parameters become fields.
    let fields = model.tunable.iter().map(|p| {
        let ident = format_ident!("{}", p.name);
        let doc = format!(
            " {}{}",
            p.description.clone().unwrap_or_else(|| format!("Tunable parameter `{}`", p.name)),
            p.unit.as_ref().map(|u| format!(" ({u})")).unwrap_or_default()
        );
        quote!(#[doc = #doc] pub #ident: #s,)
    });
    let nominal_fields = model.tunable.iter().map(|p| {
        let ident = format_ident!("{}", p.name);
        let v = scalar.literal(p.value);
        quote!(#ident: #v,)
    });
    // A spatial closed chain keeps the loops it closed last (reused within a tick, the next
    // tick's warm start): a cache, so the rig is `Clone` but not `Copy`.
    let spatial_loops = mech.closures.as_ref().and_then(|c| c.solved_at_run_time());
    let (cache_field, cache_nominal, derives) = match spatial_loops {
        Some(spatial) => {
            let p = unsuffixed(spatial.passive);
            (
                quote! {
                    /// The loops closed last (`::hapticgen_runtime::loops::close_loops`).
                    loop_cache: ::hapticgen_runtime::loops::LoopCache<#s, #n, #p>,
                },
                quote!(loop_cache: ::hapticgen_runtime::loops::LoopCache::new(),),
                quote!(#[derive(Clone, Debug, PartialEq)]),
            )
        }
        None => (TokenStream::new(), TokenStream::new(), quote!(#[derive(Clone, Copy, Debug, PartialEq)])),
    };
    // Each use of the constant is a fresh rig with an empty cache, which is what a user
    // writing `FalconDelta::NOMINAL` means.
    let nominal_allow = match spatial_loops {
        Some(_) => quote!(#[allow(clippy::declare_interior_mutable_const)]),
        None => TokenStream::new(),
    };
    let struct_def = if model.tunable.is_empty() && spatial_loops.is_none() {
        quote!(pub struct #type_name;)
    } else {
        quote!(pub struct #type_name { #(#fields)* #cache_field })
    };
    let nominal = if model.tunable.is_empty() && spatial_loops.is_none() {
        quote!(#type_name)
    } else {
        quote!(#type_name { #(#nominal_fields)* #cache_nominal })
    };

    let drives = model.joints.iter().map(|j| {
        let d = &j.drive;
        let lit = |v: f64| scalar.literal(v);
        let (gr, eff, kt, r, l, jm, tl, cl, sv) = (
            lit(d.gear_ratio),
            lit(d.efficiency),
            lit(d.motor.torque_constant),
            lit(d.motor.resistance),
            lit(d.motor.inductance),
            lit(d.motor.rotor_inertia),
            lit(d.torque_limit),
            lit(d.current_limit),
            lit(d.supply_voltage),
        );
        let counts = proc_macro2::Literal::u32_unsuffixed(d.encoder.counts_per_turn);
        let (lo, hi) = (lit(j.lower), lit(j.upper));
        quote! {
            ::hapticgen_runtime::DriveTrain {
                gear_ratio: #gr,
                efficiency: #eff,
                torque_constant: #kt,
                resistance: #r,
                inductance: #l,
                rotor_inertia: #jm,
                torque_limit: #tl,
                current_limit: #cl,
                supply_voltage: #sv,
                encoder_counts_per_turn: #counts,
                position_lower: #lo,
                position_upper: #hi,
            }
        }
    });
    // A transmission's coupling, as the constant `RigModel::coupling` returns.
    let (coupling_const, coupling_macro) = match &model.coupling {
        Some(coupling) => {
            let matrix = |rows: &[Vec<f64>]| {
                let rows = rows.iter().map(|row| {
                    let entries = row.iter().map(|&x| scalar.literal(x));
                    quote!([#(#entries),*])
                });
                quote!([#(#rows),*])
            };
            let (c, c_inverse) = (matrix(&coupling.drive_from_joint), matrix(&coupling.joint_from_drive));
            (
                quote! {
                    /// The transmission's coupling: drive `k` (in joint `k`'s slot) turns its output
                    /// by `a = C q`.
                    pub const COUPLING: ::hapticgen_runtime::Coupling<#s, #n> =
                        ::hapticgen_runtime::Coupling { drive_from_joint: #c, joint_from_drive: #c_inverse };
                },
                quote!(; coupling COUPLING),
            )
        }
        None => (TokenStream::new(), TokenStream::new()),
    };
    // The drives' Coulomb friction, as the constant `RigModel::coulomb_friction` returns; only
    // for a rig that has some (without it the trait's default, zero, holds).
    let (friction_const, friction_macro) = if model.joints.iter().any(|j| j.drive.coulomb_friction != 0.0) {
        let values = model.joints.iter().map(|j| scalar.literal(j.drive.coulomb_friction));
        (
            quote! {
                /// Each drive's Coulomb friction `F_c` at its output, N·m (N), in the order of `q`:
                /// what the runtime's friction compensation feeds forward when it is on
                /// (`ControlOptions::friction_compensation_band`).
                pub const COULOMB_FRICTION: [#s; #n] = [#(#values),*];
            },
            quote!(; friction COULOMB_FRICTION),
        )
    } else {
        (TokenStream::new(), TokenStream::new())
    };
    // Measured joints (a gimbal): their names and encoders, for `hapticgen_runtime::measured`.
    let measured_consts = if model.measured.is_empty() {
        TokenStream::new()
    } else {
        let k = unsuffixed(model.measured.len());
        let names = model.measured.iter().map(|j| j.name.as_str());
        let joints = model.measured.iter().map(|j| {
            let (counts, lower, upper) =
                (j.counts_per_turn, scalar.literal(j.lower), scalar.literal(j.upper));
            let revolute = j.kind == JointKind::Revolute;
            quote! {
                ::hapticgen_runtime::measured::MeasuredJoint {
                    counts_per_turn: #counts,
                    revolute: #revolute,
                    lower: #lower,
                    upper: #upper,
                }
            }
        });
        quote! {
            /// The measured joints' names, in the order of the frame functions' `measured`.
            pub const MEASURED_JOINT_NAMES: [&'static str; #k] = [#(#names),*];
            /// The measured joints' encoders and ranges (`hapticgen_runtime::measured::measured_angles`
            /// turns their counts into `measured`).
            pub const MEASURED_JOINTS: [::hapticgen_runtime::measured::MeasuredJoint<#s>; #k] = [#(#joints),*];
        }
    };
    let gains = model.analyses.current_loop_designs.iter().map(|d| {
        let (kp, ki, t, beta) = (
            scalar.literal(d.kp),
            scalar.literal(d.ki),
            scalar.literal(d.sample_period),
            scalar.literal(d.proportional_setpoint_weight),
        );
        quote! {
            ::hapticgen_runtime::current_loop::CurrentLoopGains {
                kp: #kp,
                ki: #ki,
                sample_period: #t,
                proportional_setpoint_weight: #beta,
            }
        }
    });
    let gains_doc: Vec<String> = {
        let cl = &model.current_loop;
        let mut lines = vec![
            " Gains of each joint's PI current loop (section 2), designed by discrete pole placement"
                .to_string(),
            format!(
                " on `V = I (sL + R)` at {} Hz for a {} Hz bandwidth and damping ratio {}, taking the lag",
                model.rates.current_loop_hz, cl.bandwidth_hz, cl.damping_ratio
            ),
            format!(
                " of an order-{} Bessel anti-aliasing filter at {} Hz into account.",
                cl.anti_alias_filter_order, cl.anti_alias_cutoff_hz
            ),
        ];
        for (j, d) in model.joints.iter().zip(&model.analyses.current_loop_designs) {
            lines.push(String::new());
            lines.push(format!(
                " Joint `{}`: R = {} Ω, L = {:e} H; achieved bandwidth {:.1} Hz, dominant damping ratio {:.3}.",
                j.name, j.drive.motor.resistance, j.drive.motor.inductance, d.achieved_bandwidth_hz,
                d.achieved_damping_ratio
            ));
        }
        lines
    };
    let joint_names = model.joints.iter().map(|j| j.name.as_str());
    let joint_kinds = model.joints.iter().map(|j| match j.kind {
        JointKind::Revolute => "revolute",
        JointKind::Prismatic => "prismatic",
    });
    let current_hz = model.rates.current_loop_hz;
    let impedance_hz = model.rates.impedance_loop_hz;
    let description = format!(
        " The `{}` rig{}.",
        rig_name,
        model
            .description
            .as_ref()
            .map(|d| format!(": {}", d.trim().trim_end_matches('.')))
            .unwrap_or_default()
    );
    let closure_doc: Vec<String> = match &mech.closures {
        None => Vec::new(),
        Some(c) if c.spatial.is_some() => {
            let spatial = c.spatial.as_ref().map(|s| (s.actuated, s.passive)).unwrap_or_default();
            let passive: Vec<String> =
                (spatial.0..spatial.0 + spatial.1).map(|j| format!("`{}`", c.names[j])).collect();
            let mut lines = vec![
                String::new(),
                format!(
                    " A spatial closed chain reduced to its actuated joints; its passive joints {} are solved",
                    passive.join(", ")
                ),
            ];
            if c.solved_at_run_time().is_some() {
                lines.extend([
                    " at the top of each function by Newton's method on the loops' constraints".into(),
                    " (`hapticgen_runtime::loops::close_loops`, with the `LoopConstraints` implementation below).".into(),
                    " Where the loops cannot be solved (out of reach, singular, non-finite input) the functions".into(),
                ]);
            } else {
                lines.extend([
                    " in closed form at the top of each function: the platform where three spheres about the"
                        .into(),
                    " knees meet, the knees' and the platform joint's sines and cosines from the shins'"
                        .into(),
                    " directions, their rates and `Ȧ q̇_a` by differentiating that. Where the loops cannot"
                        .into(),
                    " close (out of reach, singular, non-finite input) the functions".into(),
                ]);
            }
            lines.extend([
                " return NaN (they never panic), which the runtime's safety monitor latches as a fault with"
                    .into(),
                " zero torque.".into(),
            ]);
            lines
        }
        Some(c) => {
            let loops: Vec<String> = c
                .loops
                .iter()
                .map(|l| {
                    format!(
                        "`{}` (passive `{}` and `{}`, branch {})",
                        l.name,
                        c.names[l.joints[0]],
                        c.names[l.joints[1]],
                        if l.branch_sign > 0.0 { "left" } else { "right" }
                    )
                })
                .collect();
            vec![
                String::new(),
                format!(
                    " A closed chain reduced to its actuated joints by the closures {}.",
                    loops.join(", ")
                ),
                " Where the loop cannot close, or at the aligned-links boundary, the functions return".into(),
                " non-finite values (they never panic), which the runtime's safety monitor latches as a"
                    .into(),
                " fault with zero torque.".into(),
            ]
        }
    };
    let variant_doc = format!(
        " Generated from `{}`{}; `{}` joints, `{}` task coordinates.",
        model.file,
        model.variant.as_ref().map(|v| format!(", variant `{v}`")).unwrap_or_default(),
        n,
        m
    );

    let tokens = quote! {
        #[doc = #description]
        ///
        #[doc = #variant_doc]
        #(#[doc = #closure_doc])*
        #derives
        #struct_def

        impl Default for #type_name {
            fn default() -> Self {
                Self::NOMINAL
            }
        }

        impl #type_name {
            /// The rig with every tunable parameter at its nominal value.
            #nominal_allow
            pub const NOMINAL: Self = #nominal;
            /// Number of joints.
            pub const JOINTS: usize = #n;
            /// Number of task coordinates.
            pub const TASK_DIM: usize = #m;
            /// Joint names, in the order of `q`.
            pub const JOINT_NAMES: [&'static str; #n] = [#(#joint_names),*];
            /// Joint kinds, in the order of `q`.
            pub const JOINT_KINDS: [&'static str; #n] = [#(#joint_kinds),*];
            /// The drive train of each joint, in the order of `q`.
            pub const DRIVES: [::hapticgen_runtime::DriveTrain<#s>; #n] = [#(#drives),*];
            #coupling_const
            #friction_const
            #measured_consts
            #(#[doc = #gains_doc])*
            pub const CURRENT_LOOP_GAINS: [::hapticgen_runtime::current_loop::CurrentLoopGains<#s>; #n] =
                [#(#gains),*];

            /// Diagonal of the viscous damping matrix `B` of eq. (1).
            #[inline]
            #[must_use]
            pub fn damping(&self) -> [#s; #n] {
                #damping_statements
                [#(#damping_values),*]
            }

            #methods
        }

        // `RigModel` by the inherent methods above.
        ::hapticgen_runtime::impl_rig_model!(#type_name, #s, #n, #m, #rig_name, #current_hz, #impedance_hz #loop_margin #coupling_macro #friction_macro);

        #fused

        #loop_constraints
    };
    (tokens, stats)
}
