//! The `drives` section: gear ratios, efficiencies, limits and motor data in range.

use super::{key, Resolver};
use crate::model::schema::ModelFile;

/// Checks every drive's numbers.
pub(super) fn drives(r: &mut Resolver<'_, '_>, file: &ModelFile) {
    // Drives.
    for (name, d) in &file.drives {
        let base = vec![key("drives"), key(name)];
        let at = |k: &[&str]| {
            let mut p = base.clone();
            p.extend(k.iter().map(|s| key(s)));
            p
        };
        r.positive(d.gear_ratio, &at(&["gear_ratio"]));
        if !(d.efficiency > 0.0 && d.efficiency <= 1.0) {
            r.error(&at(&["efficiency"]), format!("must be in (0, 1], got {}", d.efficiency));
        }
        r.positive(d.torque_limit, &at(&["torque_limit"]));
        r.positive(d.current_limit, &at(&["current_limit"]));
        r.positive(d.supply_voltage, &at(&["supply_voltage"]));
        r.non_negative(d.motor.rotor_inertia, &at(&["motor", "rotor_inertia"]));
        r.positive(d.motor.resistance, &at(&["motor", "resistance"]));
        r.positive(d.motor.inductance, &at(&["motor", "inductance"]));
        r.positive(d.motor.torque_constant, &at(&["motor", "torque_constant"]));
        if d.encoder.counts_per_turn == 0 {
            r.error(&at(&["encoder", "counts_per_turn"]), "must be positive, got 0");
        }
        r.non_negative(d.backlash, &at(&["backlash"]));
        r.non_negative(d.coulomb_friction, &at(&["coulomb_friction"]));
        r.non_negative(d.static_friction, &at(&["static_friction"]));
    }
}
