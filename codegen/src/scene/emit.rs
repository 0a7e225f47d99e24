//! Writing a scene as Rust source for the firmware images: the runtime's objects, their
//! motions and the free-space effect, meshes as `static` arrays.

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

use super::objects::{Scene, SceneEffect, SceneShape};
use crate::Scalar;

/// Rust source (formatted) of a scene for a `task_dim`-dimensional rig in `scalar`: a module
/// body with `pub const OBJECTS: usize`, the meshes as `static` arrays (`MESH_0`, …, in flash
/// on a target; [`crate::mesh::emit`]), `pub fn objects() -> [Object<'static, S, M>; OBJECTS]`,
/// the runtime's objects, `pub fn motions() -> [Option<ObjectMotion<S, M>>; OBJECTS]`, how each
/// moves, and `pub fn effect(impedance_period: S) -> Effect<S, M>`, the free-space effect
/// (`Effect::None` when the file names none).
pub fn emit(scene: &Scene, task_dim: usize, scalar: Scalar) -> Result<String, String> {
    scene.check_task_dim(task_dim)?;
    let ty = match scalar {
        Scalar::F32 => quote!(f32),
        Scalar::F64 => quote!(f64),
    };
    let number = |x: f64| match scalar {
        Scalar::F32 => Literal::f32_unsuffixed(x as f32),
        Scalar::F64 => Literal::f64_unsuffixed(x),
    };
    let vector = |values: &[f64]| {
        let values = values.iter().map(|&x| number(x));
        quote!([#(#values),*])
    };
    let shape = quote!(::hapticgen_runtime::shape::Shape);
    let mut meshes = String::new();
    let mut mesh_count = 0;
    let mut polytopes: Vec<TokenStream> = Vec::new();
    let mut objects: Vec<TokenStream> = Vec::new();
    let mut motions: Vec<TokenStream> = Vec::new();
    // A motion's vectors padded with zeros: `velocity` and `pivot` to the task's dimension,
    // `angular_velocity` to three (the runtime's `ObjectMotion`; a 2-D turn is its first).
    let padded = |values: &[f64], length: usize| {
        let values: Vec<f64> = (0..length).map(|k| values.get(k).copied().unwrap_or(0.0)).collect();
        vector(&values)
    };
    for object in &scene.objects {
        motions.push(match &object.motion {
            None => quote!(None),
            Some(motion) => {
                let velocity = padded(&motion.velocity, task_dim);
                let angular_velocity = padded(&motion.angular_velocity, 3);
                let pivot = padded(&motion.pivot, task_dim);
                quote!(Some(::hapticgen_runtime::motion::ObjectMotion {
                    velocity: #velocity,
                    angular_velocity: #angular_velocity,
                    pivot: #pivot,
                }))
            }
        });
        let geometry = match &object.shape {
            SceneShape::HalfSpace { point, normal } => {
                // The normal was normalised when the file was read.
                let (point, normal) = (vector(point), vector(normal));
                quote!(#shape::HalfSpace { point: #point, normal: #normal })
            }
            SceneShape::Sphere { center, radius } => {
                let (center, radius) = (vector(center), number(*radius));
                quote!(#shape::Sphere { center: #center, radius: #radius })
            }
            SceneShape::Box { center, axes, half_extents } => {
                let (center, half_extents) = (vector(center), vector(half_extents));
                let axes: Vec<TokenStream> = axes.iter().map(|axis| vector(axis)).collect();
                quote!(#shape::Box { center: #center, axes: [#(#axes),*], half_extents: #half_extents })
            }
            SceneShape::Capsule { a, b, radius } => {
                let (a, b, radius) = (vector(a), vector(b), number(*radius));
                quote!(#shape::Capsule { a: #a, b: #b, radius: #radius })
            }
            SceneShape::Cylinder { a, b, radius } => {
                let (a, b, radius) = (vector(a), vector(b), number(*radius));
                quote!(#shape::Cylinder { a: #a, b: #b, radius: #radius })
            }
            SceneShape::Polytope { planes } => {
                let name = Ident::new(&format!("POLYTOPE_{}", polytopes.len()), Span::call_site());
                let count = Literal::usize_unsuffixed(planes.len());
                let m = Literal::usize_unsuffixed(task_dim);
                let entries = planes.iter().map(|plane| {
                    let (normal, offset) = (vector(&plane.normal), number(plane.offset));
                    quote!(::hapticgen_runtime::shape::Plane { normal: #normal, offset: #offset })
                });
                polytopes.push(quote! {
                    static #name: [::hapticgen_runtime::shape::Plane<#ty, #m>; #count] = [#(#entries),*];
                });
                quote!(#shape::Polytope { planes: &#name })
            }
            SceneShape::Mesh { mesh, offset } => {
                let name = format!("MESH_{mesh_count}");
                mesh_count += 1;
                meshes.push_str(&crate::mesh::emit(mesh, &name, scalar));
                let ident = Ident::new(&name, Span::call_site());
                let offset = vector(offset);
                quote!(#shape::MeshAt {
                    mesh: &#ident,
                    placement: ::hapticgen_runtime::shape::RigidMotion::translation(#offset),
                })
            }
        };
        let kind = if object.cavity { quote!(Cavity) } else { quote!(Solid) };
        let [stiffness, damping, static_friction, dynamic_friction] =
            [object.stiffness, object.damping, object.static_friction, object.dynamic_friction].map(number);
        objects.push(quote! {
            ::hapticgen_runtime::shape::Object {
                shape: #geometry,
                kind: ::hapticgen_runtime::render::ObjectKind::#kind,
                material: ::hapticgen_runtime::shape::Material {
                    stiffness: #stiffness,
                    damping: #damping,
                    static_friction: #static_friction,
                    dynamic_friction: #dynamic_friction,
                },
            }
        });
    }
    let count = Literal::usize_unsuffixed(objects.len());
    let m = Literal::usize_unsuffixed(task_dim);
    let effect_type = quote!(::hapticgen_runtime::effects::Effect);
    // Only a vibration advances with the tick; the other effects take the period to keep one
    // signature for every scene.
    let (period, effect) = match &scene.effect {
        None => (quote!(_impedance_period), quote!(#effect_type::None)),
        Some(SceneEffect::Spring { anchor, stiffness }) => {
            let (anchor, stiffness) = (vector(anchor), number(*stiffness));
            (
                quote!(_impedance_period),
                quote!(#effect_type::Spring { anchor: #anchor, stiffness: #stiffness }),
            )
        }
        Some(SceneEffect::Viscous { damping }) => {
            let damping = number(*damping);
            (quote!(_impedance_period), quote!(#effect_type::Viscous { damping: #damping }))
        }
        Some(SceneEffect::Force { force }) => {
            let force = vector(force);
            (quote!(_impedance_period), quote!(#effect_type::Force { force: #force }))
        }
        Some(SceneEffect::Vibration { direction, amplitude, frequency }) => {
            let (direction, amplitude, frequency) =
                (vector(direction), number(*amplitude), number(*frequency));
            (
                quote!(impedance_period),
                quote!(#effect_type::Vibration {
                    direction: #direction,
                    amplitude: #amplitude,
                    frequency: #frequency,
                    period: impedance_period,
                }),
            )
        }
    };
    let tokens = quote! {
        #(#polytopes)*
        /// Objects in the scene.
        pub const OBJECTS: usize = #count;
        /// The scene's objects, as the runtime renders them.
        pub fn objects() -> [::hapticgen_runtime::shape::Object<'static, #ty, #m>; OBJECTS] {
            [#(#objects),*]
        }
        /// Each object's motion (`None`: it stays), as the runtime moves it before each update.
        pub fn motions() -> [Option<::hapticgen_runtime::motion::ObjectMotion<#ty, #m>>; OBJECTS] {
            [#(#motions),*]
        }
        /// The scene's free-space effect, for an impedance loop ticking every
        /// `impedance_period` seconds.
        pub fn effect(#period: #ty) -> #effect_type<#ty, #m> {
            #effect
        }
    };
    Ok(format!(
        "// @generated by hapticgen {} from a scene file. Do not edit.\n{}{}",
        crate::version::VERSION,
        meshes,
        crate::format_tokens(&tokens)
    ))
}
