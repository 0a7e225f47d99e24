//! `hapticgen zwidth` in short form: the simulated stable region of the parallel link's
//! virtual wall grows with the wall damping, stays under the analytic stability bound
//! `2 (b + B)/T`, and contains the paper's Fig. 7 wall (1500 N/m, 5 N·s/m).

use std::path::Path;

use hapticgen_host::simulation::Simulation;
use hapticgen_host::zwidth::{is_stable, sweep, write, Sweep};

#[test]
fn the_stable_region_grows_with_damping_and_lies_under_the_bound() {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/parallel_link_2dof.yaml");
    let sim = Simulation::load(&model, Some("horizontal")).expect("shipped model");
    let z = sweep(&sim, &Sweep::quick()).expect("the sweep runs");
    assert_eq!(z.boundary.len(), 3);
    for pair in z.boundary.windows(2) {
        assert!(pair[1].stable_stiffness > pair[0].stable_stiffness, "{:?}", z.boundary);
    }
    for p in &z.boundary {
        assert!(p.stable_stiffness <= 1.05 * p.stable_bound, "{p:?}");
    }
    assert!(is_stable(&sim, 1500.0, 5.0, 1.0).unwrap(), "the paper's wall must be stable");
    assert!(!is_stable(&sim, 30_000.0, 5.0, 1.0).unwrap(), "a wall far beyond the bound must not be");
    let out = std::env::temp_dir().join(format!("hapticgen-zwidth-{}", std::process::id()));
    write(&z, "parallel link", &out).expect("written");
    for file in ["zwidth.csv", "zwidth.svg", "zwidth.png", "zwidth.md"] {
        assert!(out.join(file).exists(), "{file}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A spatial task's wall (a half-space rendered by the god object), pressed at the
/// PHANToM Premium-like arm's home pose: a wall well under the analytic bound holds the arm
/// still, one far above it does not.
#[test]
fn a_spatial_wall_is_stable_under_the_bound_and_not_far_above_it() {
    use hapticgen_host::zwidth::{is_stable_at, Press};
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/phantom_premium.yaml");
    let sim = Simulation::load(&model, None).expect("shipped model");
    let press = Press::home(&sim);
    assert!(is_stable_at(&sim, &press, 100.0, 0.0, 1.0).unwrap(), "a soft wall must be stable");
    assert!(
        !is_stable_at(&sim, &press, 20_000.0, 0.0, 1.0).unwrap(),
        "a wall 20 times the bound must not be"
    );
}
