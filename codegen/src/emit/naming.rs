//! Names in the emitted code: the binding of each input (`q1`, `sin_q1`, `q1_dot`, a tunable
//! parameter, a fused law's external input), the rig-wide names of intermediate values
//! ([`RigNames`]) and the rig struct's type name.

use std::cell::RefCell;
use std::rc::Rc;

use proc_macro2::TokenStream;
use rustc_hash::FxHashMap as HashMap;

use crate::model::Model;
use crate::sym::poly::Atom;

/// Names of inputs and how the generated code reads them.
#[derive(Clone)]
pub(crate) struct Naming<'m> {
    /// The model whose joints and tunable parameters are named.
    pub(crate) model: &'m Model,
    /// Inputs of fused control laws: binding name and how to read the value.
    pub(crate) externals: Vec<(String, TokenStream)>,
    /// The rig's names across its functions (none for a function emitted on its own).
    pub(crate) shared: Option<SharedNames>,
    /// A spatial closed chain's passive coordinates and sensitivities, solved at run time.
    pub(crate) loops: Option<LoopInputs>,
}

/// Where a spatial closed chain's run-time loop values come from
/// (`hapticgen_runtime::loops`): the passive coordinates `N … N+P−1` of the open tree, their
/// rates, and the sensitivity atoms `A`, `Ȧ` (`Atom::Closure`, numbered as
/// `crate::dynamics::spatial_loops::SpatialLoops::sensitivity` does).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LoopInputs {
    /// Number of actuated coordinates `N`.
    pub(crate) actuated: usize,
    /// Number of passive coordinates `P`.
    pub(crate) passive: usize,
    /// Whether the values are the fields of a `ClosedLoops` named `loops`, solved at the top of
    /// the function (`true`), or the arguments `passive` and `passive_rate` of the functions
    /// describing the constraints (`false`).
    pub(crate) solved: bool,
}

/// What an atom is to a spatial closed chain's loops.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LoopRead {
    /// Passive coordinate `r` (its angle, sine or cosine).
    Passive(usize),
    /// The rate of passive coordinate `r`.
    PassiveRate(usize),
    /// `A[r][j]` (`rate`: `Ȧ[r][j]`).
    Sensitivity { r: usize, j: usize, rate: bool },
    /// `(Ȧ q̇_a)[r]`, passive coordinate `r`'s acceleration at `q̈_a = 0`.
    Convective(usize),
}

impl LoopInputs {
    /// What `atom` reads, if it is a loop value.
    pub(crate) fn read(&self, atom: Atom) -> Option<LoopRead> {
        let (n, p) = (self.actuated, self.passive);
        let passive = |j: u16| usize::from(j).checked_sub(n).filter(|&r| r < p);
        match atom {
            Atom::Q(j) | Atom::Sin(j) | Atom::Cos(j) => passive(j).map(LoopRead::Passive),
            Atom::Qd(j) => passive(j).map(LoopRead::PassiveRate),
            Atom::Closure(k) => {
                let k = usize::from(k);
                if k < 2 * p * n {
                    Some(LoopRead::Sensitivity { r: (k / n) % p, j: k % n, rate: k >= p * n })
                } else {
                    (k < 2 * p * n + p).then(|| LoopRead::Convective(k - 2 * p * n))
                }
            }
            _ => None,
        }
    }

    /// The sine and cosine of passive coordinate `r`, a pair computed with the solution: a
    /// field of the solution `loops`, or the argument `passive_sin_cos`.
    pub(crate) fn sin_cos_tokens(&self, r: usize) -> TokenStream {
        let r = super::literal::unsuffixed(r);
        if self.solved {
            quote::quote!(loops.passive_sin_cos[#r])
        } else {
            quote::quote!(passive_sin_cos[#r])
        }
    }

    /// The expression reading a loop value: a field of the solution `loops`, or an argument.
    pub(crate) fn tokens(&self, read: LoopRead) -> TokenStream {
        use quote::{format_ident, quote};
        let index = super::literal::unsuffixed;
        let (array, r, column) = match read {
            LoopRead::Passive(r) => ("passive", r, None),
            LoopRead::PassiveRate(r) => ("passive_rate", r, None),
            LoopRead::Sensitivity { r, j, rate: false } => ("sensitivity", r, Some(j)),
            LoopRead::Sensitivity { r, j, rate: true } => ("sensitivity_rate", r, Some(j)),
            LoopRead::Convective(r) => ("passive_convective_acceleration", r, None),
        };
        let array = format_ident!("{}", array);
        // The constraint functions take the passive values as arguments; `A`, `Ȧ` and `Ȧ q̇_a`
        // are only ever read from a solution.
        let from_solution = self.solved || !matches!(read, LoopRead::Passive(_) | LoopRead::PassiveRate(_));
        let array = if from_solution { quote!(loops.#array) } else { quote!(#array) };
        let r = index(r);
        match column.map(index) {
            Some(j) => quote!(#array[#r][#j]),
            None => quote!(#array[#r]),
        }
    }
}

impl Naming<'_> {
    /// Whether reading `atom` needs the joint velocities `qd`: a velocity, or a loop value
    /// computed from them.
    pub(crate) fn reads_velocity(&self, atom: Atom) -> bool {
        match self.loops.and_then(|l| l.read(atom)) {
            Some(
                LoopRead::PassiveRate(_) | LoopRead::Sensitivity { rate: true, .. } | LoopRead::Convective(_),
            ) => true,
            _ => matches!(atom, Atom::Qd(_)),
        }
    }

    /// The binding name of an input.
    pub(crate) fn atom_name(&self, atom: Atom) -> String {
        let joint = |j: u16| self.model.coordinate_name(usize::from(j)).to_string();
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
            Atom::Closure(k) => match self.loops.and_then(|l| l.read(atom)) {
                Some(LoopRead::Sensitivity { r, j, rate }) => format!(
                    "{}_per_{}{}",
                    joint((self.model.joints.len() + r) as u16),
                    joint(j as u16),
                    if rate { "_rate" } else { "" }
                ),
                Some(LoopRead::Convective(r)) => {
                    format!("{}_convective_acceleration", joint((self.model.joints.len() + r) as u16))
                }
                _ => format!("closure_{k}"),
            },
            Atom::External(k) => self
                .externals
                .get(usize::from(k))
                .map(|e| e.0.clone())
                .unwrap_or_else(|| format!("input_{k}")),
        }
    }
}

/// `snake_case` → `CamelCase`.
pub(crate) fn camel_case(name: &str) -> String {
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

/// The names of a rig's values across all its emitted functions, so that one value has one
/// name everywhere (`inertia_01` in `inertia_matrix`, `inverse_dynamics` and the fused laws).
/// A value is identified by the text of its expression over its operands' names: the same
/// text is the same computation, in whichever function it stands.
#[derive(Default)]
pub(crate) struct RigNames {
    /// The name of each value named so far, by the text of its expression.
    names: HashMap<String, String>,
    /// The value (expression text) each name was given to first.
    owners: HashMap<String, String>,
}

impl RigNames {
    /// The name a value got in an earlier function.
    pub(crate) fn name(&self, value: &str) -> Option<&String> {
        self.names.get(value)
    }

    /// Whether `name` belongs to a value other than `value`.
    pub(crate) fn taken_by_other(&self, name: &str, value: &str) -> bool {
        self.owners.get(name).is_some_and(|v| v != value)
    }

    /// Records the name of a value; a later, better name (`better`) replaces an earlier one.
    pub(crate) fn record(&mut self, value: &str, name: &str, better: bool) {
        if better || !self.names.contains_key(value) {
            self.names.insert(value.to_string(), name.to_string());
        }
        self.owners.entry(name.to_string()).or_insert_with(|| value.to_string());
    }
}

/// The rig-wide names, shared by every function emitted for one rig.
pub(crate) type SharedNames = Rc<RefCell<RigNames>>;
