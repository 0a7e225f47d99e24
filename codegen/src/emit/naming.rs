//! Names in the emitted code: the binding of each input (`q1`, `sin_q1`, `q1_dot`, a tunable
//! parameter, a fused law's external input) and the rig struct's type name.

use proc_macro2::TokenStream;

use crate::model::Model;
use crate::sym::poly::Atom;

/// Names of inputs and how the generated code reads them.
#[derive(Clone)]
pub(crate) struct Naming<'m> {
    /// The model whose joints and tunable parameters are named.
    pub(crate) model: &'m Model,
    /// Inputs of fused control laws: binding name and how to read the value.
    pub(crate) externals: Vec<(String, TokenStream)>,
}

impl Naming<'_> {
    /// The binding name of an input.
    pub(crate) fn atom_name(&self, atom: Atom) -> String {
        let joint = |j: u16| self.model.joints[usize::from(j)].name.clone();
        match atom {
            Atom::Sin(j) => format!("sin_{}", joint(j)),
            Atom::Cos(j) => format!("cos_{}", joint(j)),
            // `q` and `qd` name the input arrays, so a joint called so gets a suffix.
            Atom::Q(j) => match joint(j).as_str() {
                "q" | "qd" => format!("{}_value", joint(j)),
                name => name.to_string(),
            },
            Atom::Qd(j) => format!("{}_dot", joint(j)),
            Atom::Qdd(j) => format!("{}_ddot", joint(j)),
            Atom::Param(k) => self.model.tunable[usize::from(k)].name.clone(),
            Atom::Closure(k) => format!("closure_{k}"),
            Atom::External(k) => self
                .externals
                .get(usize::from(k))
                .map(|e| e.0.clone())
                .unwrap_or_else(|| format!("input_{k}")),
        }
    }
}

/// `snake_case` → `CamelCase`.
fn camel_case(name: &str) -> String {
    name.split('_')
        .filter(|p| !p.is_empty())
        .map(|p| {
            let mut c = p.chars();
            match c.next() {
                Some(f) => f.to_ascii_uppercase().to_string() + c.as_str(),
                None => String::new(),
            }
        })
        .collect()
}

/// The Rust type name of a model's rig struct.
pub fn rig_type_name(model: &Model) -> String {
    camel_case(&model.name)
}
