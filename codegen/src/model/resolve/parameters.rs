//! The `parameters` section: each becomes a constant or, if `tunable`, an atom of the
//! generated code's parameter vector; the `gravity` vector.

use super::{is_identifier, key, Resolver};
use crate::model::schema::ModelFile;
use crate::model::types::ResolvedParameter;
use crate::sym::poly::{Atom, Poly};

/// Resolves the parameters; returns the tunable ones in the order of their atoms.
pub(super) fn parameters(r: &mut Resolver<'_, '_>, file: &ModelFile) -> Vec<ResolvedParameter> {
    // Parameters.
    let mut tunable = Vec::new();
    for (name, p) in &file.parameters {
        let path = [key("parameters"), key(name)];
        if !is_identifier(name) {
            r.error_hint(
                &path,
                format!("`{name}` is not a valid parameter name"),
                "use snake_case letters, digits and underscores, starting with a letter",
            );
        }
        r.nominal.insert(name.clone(), p.value);
        let poly = if p.tunable {
            tunable.push(ResolvedParameter {
                name: name.clone(),
                value: p.value,
                description: p.description.clone(),
                unit: p.unit.clone(),
            });
            Poly::atom(Atom::Param((tunable.len() - 1) as u16))
        } else {
            Poly::constant(p.value)
        };
        r.parameters.insert(name.clone(), poly);
    }

    tunable
}
