//! The remaining sections: sensors, loop rates, current-loop targets, rendering and the
//! default variant.

use std::collections::HashSet;

use super::{key, Resolver};
use crate::model::positions::Segment;
use crate::model::schema::ModelFile;

/// Checks sensors, rates, current-loop targets, rendering and the default variant.
pub(super) fn settings(r: &mut Resolver<'_, '_>, file: &ModelFile, variant: &Option<String>) {
    // Sensors, rates, current loop, rendering.
    let mut sensor_names = HashSet::new();
    for (i, s) in file.sensors.iter().enumerate() {
        let at = |k: &str| vec![key("sensors"), Segment::Index(i), key(k)];
        if !sensor_names.insert(s.name.clone()) {
            r.error(&at("name"), format!("sensor `{}` is defined twice", s.name));
        }
        if s.scale == 0.0 {
            r.error(&at("scale"), "must not be zero");
        }
        r.positive(s.full_scale, &at("full_scale"));
        r.non_negative(s.noise, &at("noise"));
        r.non_negative(s.resolution, &at("resolution"));
    }
    let rates_path = |k: &str| vec![key("rates"), key(k)];
    if file.rates.current_loop_hz == 0 {
        r.error(&rates_path("current_loop_hz"), "must be positive, got 0");
    }
    if file.rates.impedance_loop_hz == 0 {
        r.error(&rates_path("impedance_loop_hz"), "must be positive, got 0");
    } else if file.rates.impedance_loop_hz > file.rates.current_loop_hz {
        r.error(
            &rates_path("impedance_loop_hz"),
            format!(
                "the impedance loop ({} Hz) cannot run faster than the current loop ({} Hz)",
                file.rates.impedance_loop_hz, file.rates.current_loop_hz
            ),
        );
    }
    let cl = |k: &str| vec![key("current_loop"), key(k)];
    r.positive(file.current_loop.bandwidth_hz, &cl("bandwidth_hz"));
    r.positive(file.current_loop.damping_ratio, &cl("damping_ratio"));
    r.positive(file.current_loop.anti_alias_cutoff_hz, &cl("anti_alias_cutoff_hz"));
    // The PI design (`check::current_loop`) needs the bandwidth below half the Nyquist frequency.
    let limit = f64::from(file.rates.current_loop_hz) / 4.0;
    if file.current_loop.bandwidth_hz >= limit && limit > 0.0 {
        r.error(
            &cl("bandwidth_hz"),
            format!(
                "must be below a quarter of `rates.current_loop_hz` ({limit} Hz, half the current loop's \
                 Nyquist frequency), got {} Hz",
                file.current_loop.bandwidth_hz
            ),
        );
    }
    if let Some(rend) = &file.rendering {
        let at = |k: &str| vec![key("rendering"), key(k)];
        r.positive(rend.grid_spacing, &at("grid_spacing"));
        r.non_negative(rend.wall_stiffness, &at("wall_stiffness"));
        r.non_negative(rend.wall_damping, &at("wall_damping"));
    }
    if let Some(d) = &file.default_variant {
        if !file.variants.contains_key(d) && variant.is_none() {
            r.error(&[key("default_variant")], format!("unknown variant `{d}`"));
        }
    }
}

/// The anti-alias filter's order is one the current-loop design supports.
pub(super) fn current_loop_filter(r: &mut Resolver<'_, '_>, file: &ModelFile) {
    let cl = |k: &str| vec![key("current_loop"), key(k)];
    if !(1..=4).contains(&file.current_loop.anti_alias_filter_order) {
        r.error(
            &cl("anti_alias_filter_order"),
            format!("must be 1, 2, 3 or 4, got {}", file.current_loop.anti_alias_filter_order),
        );
    }
}
