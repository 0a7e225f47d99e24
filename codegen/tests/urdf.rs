//! URDF export and import: a spatial serial model exported to URDF and imported back gives the
//! same numbers; what the model cannot express is an error at the URDF element.

use std::path::Path;

use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::{evaluate, Evaluated, State};
use hapticgen_codegen::model::{Model, Source};
use hapticgen_codegen::urdf;
use hapticgen_codegen::{load, load_file};

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

fn without_rotors(model: &Model, e: &Evaluated) -> Vec<f64> {
    let mut d = e.inertia_matrix.clone();
    for (i, j) in model.joints.iter().enumerate() {
        d[i][i] -= j.drive.gear_ratio * j.drive.gear_ratio * j.drive.motor.rotor_inertia;
    }
    d.into_iter().flatten().collect()
}

fn numbers(model: &Model, mech: &Mechanics, q: &[f64], qd: &[f64]) -> Vec<f64> {
    let params = model.nominal_parameters();
    let state = State { q, qd, parameters: &params };
    let e = evaluate(mech, &state, None);
    let mut out = without_rotors(model, &e);
    out.extend(e.coriolis_times_qdot.iter().zip(&e.g).map(|(c, g)| c + g));
    out.extend(&e.g);
    for f in &mech.frames {
        let e = hapticgen_codegen::eval::evaluate_frame(mech, &state, f);
        out.extend(e.rotation.iter().flatten());
        out.extend(e.angular_jacobian.iter().flatten());
    }
    for p in &mech.points {
        let pe = evaluate(mech, &state, Some(p));
        out.extend(&pe.p);
        out.extend(pe.jacobian.iter().flatten());
    }
    out
}

#[test]
fn spatial_models_round_trip_through_urdf() {
    for file in
        ["models/puma560.yaml", "models/phantom_3dof.yaml", "codegen/tests/good-models/spatial_arm_3dof.yaml"]
    {
        let original = load_file(&root().join(file), file, None).unwrap_or_else(|d| panic!("{d}"));
        let text = urdf::export(&original).unwrap_or_else(|e| panic!("{file}: {e}"));
        let yaml = urdf::import(&text, "exported.urdf", urdf::DEFAULT_DRIVE)
            .unwrap_or_else(|d| panic!("{file}: {d}"));
        let imported = load(&Source { name: "imported.yaml", text: &yaml }, None)
            .unwrap_or_else(|d| panic!("{file}: the imported model does not load:\n{d}\n{yaml}"));
        assert_eq!(imported.joints.len(), original.joints.len());
        assert_eq!(imported.points.len(), original.points.len(), "{file}: points become links and back");
        assert_eq!(imported.frames.len(), original.frames.len(), "{file}: frames become links and back");
        let (a, b) = (hapticgen_codegen::derive(&original), hapticgen_codegen::derive(&imported));
        for k in 0..20 {
            let t = f64::from(k);
            let q: Vec<f64> = original
                .joints
                .iter()
                .enumerate()
                .map(|(i, j)| j.lower + (j.upper - j.lower) * (0.5 + 0.45 * (t * (1.0 + i as f64)).sin()))
                .collect();
            let qd: Vec<f64> = (0..q.len()).map(|i| (t + i as f64).cos() * 2.0).collect();
            let (x, y) = (numbers(&original, &a, &q, &qd), numbers(&imported, &b, &q, &qd));
            assert_eq!(x.len(), y.len());
            for (i, (u, v)) in x.iter().zip(&y).enumerate() {
                assert!(
                    (u - v).abs() <= 1e-12 * u.abs().max(1.0),
                    "{file}: value {i}: {u} vs {v} at q = {q:?}"
                );
            }
        }
    }
}

fn reject(urdf_text: &str) -> hapticgen_codegen::Diagnostic {
    match urdf::import(urdf_text, "robot.urdf", urdf::DEFAULT_DRIVE) {
        Ok(yaml) => panic!("accepted:\n{yaml}"),
        Err(d) => d.0[0].clone(),
    }
}

const LINK: &str = r#"<inertial><mass value="1.0"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>"#;

fn robot(joints: &str) -> String {
    format!(
        "<robot name=\"r\">\n<link name=\"base\"/>\n<link name=\"a\">{LINK}</link>\n<link name=\"b\">{LINK}</link>\n{joints}\n</robot>\n"
    )
}

const REVOLUTE_A: &str = r#"<joint name="j1" type="revolute"><parent link="base"/><child link="a"/><limit lower="-1" upper="1" effort="2" velocity="1"/></joint>"#;

#[test]
fn what_the_model_cannot_express_is_an_error_at_the_element() {
    let floating = robot(&format!(
        "{REVOLUTE_A}\n<joint name=\"free\" type=\"floating\"><parent link=\"a\"/><child link=\"b\"/></joint>"
    ));
    let d = reject(&floating);
    assert_eq!((d.line, d.column), (6, 1), "{d}");
    assert_eq!(d.path, "robot/joint[name=free]");
    assert!(d.message.contains("`floating`"), "{d}");

    let mimic = robot(&format!(
        "{REVOLUTE_A}\n<joint name=\"j2\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><mimic joint=\"j1\"/><limit lower=\"-1\" upper=\"1\"/></joint>"
    ));
    let d = reject(&mimic);
    assert_eq!(d.line, 6, "{d}");
    assert_eq!(d.path, "robot/joint[name=j2]/mimic");
    assert!(d.message.contains("mimics"), "{d}");

    let two_roots = robot(REVOLUTE_A);
    let d = reject(&two_roots);
    assert!(d.message.contains("several root links: base, b"), "{d}");
    assert_eq!(d.path, "robot/link[name=b]");

    let lp = robot(&format!(
        "{REVOLUTE_A}\n<joint name=\"j2\" type=\"revolute\"><parent link=\"base\"/><child link=\"b\"/><limit lower=\"-1\" upper=\"1\"/></joint>\n<joint name=\"j3\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><limit lower=\"-1\" upper=\"1\"/></joint>"
    ));
    let d = reject(&lp);
    assert!(d.message.contains("closed kinematic loop"), "{d}");
    assert_eq!(d.path, "robot/joint[name=j3]");

    let bad_number = robot(&format!(
        "{}\n<joint name=\"weld\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>",
        REVOLUTE_A.replace("<limit", "<origin xyz=\"0 zero 0\"/><limit")
    ));
    let d = reject(&bad_number);
    assert!(d.message.contains("expected 3 numbers"), "{d}");
    assert_eq!(d.path, "robot/joint[name=j1]/origin");
}

#[test]
fn a_small_urdf_imports_and_loads() {
    let text = robot(&format!(
        "{REVOLUTE_A}\n<joint name=\"j2\" type=\"continuous\"><parent link=\"a\"/><child link=\"b\"/><origin xyz=\"0.2 0 0\" rpy=\"1.5707963267948966 0 0\"/><axis xyz=\"0 1 0\"/><dynamics damping=\"0.01\"/></joint>"
    ));
    let yaml = urdf::import(&text, "robot.urdf", urdf::DEFAULT_DRIVE).unwrap_or_else(|d| panic!("{d}"));
    let m =
        load(&Source { name: "imported.yaml", text: &yaml }, None).unwrap_or_else(|d| panic!("{d}\n{yaml}"));
    assert_eq!(m.joints.len(), 2);
    assert_eq!(m.joints[1].upper, std::f64::consts::PI, "continuous joints get ±π");
    assert_eq!(m.joints[0].drive.torque_limit, 2.0, "the effort becomes the torque limit");
    assert_eq!(m.joints[1].drive.torque_limit, 3.0, "no effort: the template's");
    assert!(yaml.starts_with("# Imported by hapticgen"));
}
