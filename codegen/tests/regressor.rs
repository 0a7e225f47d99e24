//! The identification regressor's base parameters against the textbook grouping (Khalil and
//! Kleinfinger 1987; Gautier 1990) of the planar two-link arm, `l1 = 1 m`: with gravity in the
//! plane, seven inertial base parameters `mx1 + l1·m2`, `my1`, `zz1 + l1²·m2 + ia1`, `mx2`,
//! `my2`, `zz2`, `ia2` (the elbow's rotor alone, its column `q̈2` differing from `zz2`'s
//! `q̈1 + q̈2`); without gravity the first moments of the first link drop out of τ. The
//! regressor of every shipped model is checked against the compiled inverse dynamics in
//! `tests/tests/regressor.rs` (workspace tests); this file checks only the grouping.

use std::path::Path;

use hapticgen_codegen::dynamics::regressor::Regressor;

fn combinations(file: &str, variant: &str) -> Vec<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(file);
    let model = hapticgen_codegen::load_file(&path, file, Some(variant)).unwrap_or_else(|d| panic!("{d}"));
    let regressor = Regressor::new(&model, model.analyses.closures.as_ref());
    regressor.base.iter().map(|b| format!("{} = {}", b.name, b.describe(&regressor.standard))).collect()
}

#[test]
fn planar_arm_base_parameters_are_khalils_grouping() {
    let vertical = combinations("models/planar_arm_2dof.yaml", "vertical");
    let inertial = [
        "mx_link1_r = mx_link1 + m_link2",
        "my_link1 = my_link1",
        "zz_link1_r = zz_link1 + m_link2 + ia_shoulder",
        "mx_link2 = mx_link2",
        "my_link2 = my_link2",
        "zz_link2 = zz_link2",
    ];
    assert_eq!(vertical[..6], inertial, "{vertical:#?}");
    let drives =
        ["fv_shoulder", "fc_shoulder", "off_shoulder", "ia_elbow", "fv_elbow", "fc_elbow", "off_elbow"];
    let names: Vec<&str> = vertical[6..].iter().map(|c| c.split(" = ").next().unwrap()).collect();
    assert_eq!(names, drives);

    let horizontal = combinations("models/planar_arm_2dof.yaml", "horizontal");
    assert_eq!(horizontal.len(), vertical.len() - 2, "{horizontal:#?}");
    assert_eq!(horizontal[0], "zz_link1_r = zz_link1 + m_link2 + ia_shoulder");
    assert!(!horizontal.iter().any(|c| c.starts_with("mx_link1") || c.starts_with("my_link1")));
}

/// The Delta's universal joints each put a massless cross between thigh and shin (and shin and
/// platform): the model makes them massless, so none of their parameters is a base parameter
/// or part of one, and what a cross's column would have absorbed stays with the shins.
#[test]
fn a_massless_cross_has_no_base_parameter() {
    let file = "models/falcon_delta.yaml";
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(file);
    let model = hapticgen_codegen::load_file(&path, file, None).unwrap_or_else(|d| panic!("{d}"));
    let crosses: Vec<&str> =
        model.model.bodies.iter().map(|b| b.name.as_str()).filter(|name| name.ends_with("_cross")).collect();
    assert_eq!(crosses.len(), 4, "{crosses:?}");
    let regressor = Regressor::new(&model, model.analyses.closures.as_ref());
    for base in &regressor.base {
        for &(s, _) in &base.combination {
            let name = &regressor.standard[s].name;
            assert!(
                !crosses.iter().any(|cross| name.ends_with(&format!("_{cross}"))),
                "{} = {} involves a cross",
                base.name,
                base.describe(&regressor.standard)
            );
        }
    }
    // Three legs' shins keep their own rotational inertia about the knee's second axis.
    for leg in 1..=3 {
        assert!(
            regressor.base.iter().any(|b| b.name.starts_with(&format!("yy_shin{leg}"))),
            "{:#?}",
            regressor.base.iter().map(|b| &b.name).collect::<Vec<_>>()
        );
    }
}
