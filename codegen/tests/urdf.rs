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

/// A URDF with `<mimic>` joints (tests/urdf/mimic_arm.urdf, written by hand): imported, its
/// two mimic joints follow their leaders; exported again, it writes both `<mimic>` elements and
/// imports back to the same numbers. (Pinocchio's own mimic joints check the numbers
/// themselves: scripts/pinocchio-check.sh.)
#[test]
fn mimic_joints_import_and_export() {
    let text = std::fs::read_to_string(root().join("tests/urdf/mimic_arm.urdf")).unwrap();
    let yaml = urdf::import(&text, "mimic_arm.urdf", urdf::DEFAULT_DRIVE).unwrap_or_else(|d| panic!("{d}"));
    let model =
        load(&Source { name: "imported.yaml", text: &yaml }, None).unwrap_or_else(|d| panic!("{d}\n{yaml}"));
    assert_eq!(model.joints.len(), 3, "yaw, shoulder, elbow are the coordinates");
    let followed: Vec<(&str, &str, f64, f64)> = model
        .mimic
        .iter()
        .map(|m| (m.name.as_str(), model.coordinate_name(m.leader), m.multiplier, m.offset))
        .collect();
    assert_eq!(followed, [("finger_joint", "shoulder", 1.0, -0.4), ("plate", "elbow", -1.0, 0.2)]);
    let exported = urdf::export(&model).unwrap_or_else(|e| panic!("{e}"));
    assert!(exported.contains(r#"<mimic joint="elbow" multiplier="-1.0" offset="0.2"/>"#), "{exported}");
    assert!(exported.contains(r#"<mimic joint="shoulder" multiplier="1.0" offset="-0.4"/>"#), "{exported}");
    let again =
        urdf::import(&exported, "exported.urdf", urdf::DEFAULT_DRIVE).unwrap_or_else(|d| panic!("{d}"));
    let reloaded =
        load(&Source { name: "again.yaml", text: &again }, None).unwrap_or_else(|d| panic!("{d}\n{again}"));
    let (a, b) = (hapticgen_codegen::derive(&model), hapticgen_codegen::derive(&reloaded));
    let q = [0.3, -0.4, 0.8];
    let qd = [0.5, 1.1, -0.7];
    let (x, y) = (numbers(&model, &a, &q, &qd), numbers(&reloaded, &b, &q, &qd));
    assert_eq!(x.len(), y.len());
    for (i, (u, v)) in x.iter().zip(&y).enumerate() {
        assert!((u - v).abs() <= 1e-12 * u.abs().max(1.0), "value {i}: {u} vs {v}");
    }
}

/// A measured joint (a gimbal's: an encoder, no motor) exports as a URDF joint with no effort,
/// its encoder in a comment: the mimic arm with a measured roll under its tool plate.
#[test]
fn measured_joints_export_as_joints_without_effort() {
    let text = std::fs::read_to_string(root().join("codegen/tests/good-models/mimic_arm.yaml")).unwrap();
    let with_gimbal = text
        .replacen(
            "joints:\n",
            "joints:\n  - name: tool_roll\n    type: revolute\n    axis: [1.0, 0.0, 0.0]\n    limits: {lower: -2.0, upper: 2.0}\n    measured: {counts_per_turn: 4096, dynamics: lumped}\n",
            1,
        )
        .replacen(
            "bodies:\n",
            "bodies:\n  - name: tool_ring\n    mass: 0.0\n    com: [0.0, 0.0, 0.0]\n    inertia: {ixx: 0.0, iyy: 0.0, izz: 0.0}\n    parent: tool_plate\n    joint: tool_roll\n",
            1,
        );
    let model =
        load(&Source { name: "gimbal.yaml", text: &with_gimbal }, None).unwrap_or_else(|d| panic!("{d}"));
    assert_eq!(model.measured.len(), 1);
    let exported = urdf::export(&model).unwrap_or_else(|e| panic!("{e}"));
    let joint = exported.split("<joint name=\"tool_roll\"").nth(1).expect("the measured joint is written");
    let joint = &joint[..joint.find("</joint>").expect("closed")];
    assert!(joint.contains("<!-- measured: 4096 counts per turn, no motor -->"), "{joint}");
    assert!(joint.contains("lower=\"-2.0\" upper=\"2.0\" effort=\"0.0\""), "{joint}");
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

    // A revolute mimic joint turning twice as fast as its leader: the model's mimic joints
    // turn by ±q + offset only (their kinematics stay in the leader's sine and cosine).
    let mimic = robot(&format!(
        "{REVOLUTE_A}\n<joint name=\"j2\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><mimic joint=\"j1\" multiplier=\"2\"/><limit lower=\"-1\" upper=\"1\"/></joint>"
    ));
    let d = reject(&mimic);
    assert_eq!(d.line, 6, "{d}");
    assert_eq!(d.path, "robot/joint[name=j2]/mimic");
    assert!(d.message.contains("multiplier must be 1 or -1"), "{d}");
    let unknown_leader = robot(&format!(
        "{REVOLUTE_A}\n<joint name=\"j2\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><mimic joint=\"j9\"/><limit lower=\"-1\" upper=\"1\"/></joint>"
    ));
    let d = reject(&unknown_leader);
    assert_eq!(d.path, "robot/joint[name=j2]/mimic");
    assert!(d.message.contains("mimics unknown joint `j9`"), "{d}");

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

/// A rigid transform: rotation and translation.
type Pose = ([[f64; 3]; 3], [f64; 3]);

fn compose((ra, pa): &Pose, (rb, pb): &Pose) -> Pose {
    let r = std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| ra[i][k] * rb[k][j]).sum()));
    let p = std::array::from_fn(|i| pa[i] + (0..3).map(|k| ra[i][k] * pb[k]).sum::<f64>());
    (r, p)
}

/// URDF's `rpy`: `Rz(yaw) · Ry(pitch) · Rx(roll)`.
fn rpy_rotation([roll, pitch, yaw]: [f64; 3]) -> [[f64; 3]; 3] {
    let (sr, cr, sp, cp, sy, cy) = (roll.sin(), roll.cos(), pitch.sin(), pitch.cos(), yaw.sin(), yaw.cos());
    [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
}

/// Rotation by `angle` about the unit `axis` (Rodrigues).
fn axis_rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = (angle.sin(), angle.cos());
    let [x, y, z] = axis;
    [
        [c + x * x * (1.0 - c), x * y * (1.0 - c) - z * s, x * z * (1.0 - c) + y * s],
        [y * x * (1.0 - c) + z * s, c + y * y * (1.0 - c), y * z * (1.0 - c) - x * s],
        [z * x * (1.0 - c) - y * s, z * y * (1.0 - c) + x * s, c + z * z * (1.0 - c)],
    ]
}

/// Every link's world pose in a URDF at joint angles given by name (the URDF's own reading,
/// independent of the exporter's transforms).
fn urdf_link_poses(text: &str, angle: impl Fn(&str) -> f64) -> std::collections::HashMap<String, Pose> {
    let triple = |s: Option<&str>| -> [f64; 3] {
        let v: Vec<f64> = s.unwrap_or("0 0 0").split_whitespace().map(|x| x.parse().unwrap()).collect();
        [v[0], v[1], v[2]]
    };
    let document = roxmltree::Document::parse(text).unwrap();
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut poses = std::collections::HashMap::from([("base".to_string(), (identity, [0.0; 3]))]);
    // The exporter writes each joint after its parent link's joint.
    for joint in document.root_element().children().filter(|n| n.has_tag_name("joint")) {
        let child_named = |tag: &str| joint.children().find(|n| n.has_tag_name(tag));
        let parent = child_named("parent").and_then(|n| n.attribute("link")).unwrap();
        let child = child_named("child").and_then(|n| n.attribute("link")).unwrap();
        let origin = child_named("origin");
        let at = (
            rpy_rotation(triple(origin.and_then(|o| o.attribute("rpy")))),
            triple(origin.and_then(|o| o.attribute("xyz"))),
        );
        let mut pose = compose(&poses[parent], &at);
        if joint.attribute("type") == Some("revolute") {
            let axis = triple(child_named("axis").and_then(|a| a.attribute("xyz")));
            let name = joint.attribute("name").unwrap();
            pose = compose(&pose, &(axis_rotation(axis, angle(name)), [0.0; 3]));
        }
        poses.insert(child.to_string(), pose);
    }
    poses
}

#[test]
fn a_closed_chains_open_tree_exports_with_the_closures_it_cut() {
    use hapticgen_codegen::dynamics::kinematics::point_positions;
    use hapticgen_codegen::sym::poly::State;

    let file = "models/falcon_delta.yaml";
    let checked = load_file(&root().join(file), file, None).unwrap_or_else(|d| panic!("{d}"));
    let model = &checked.model;
    // Users asking for the rig's URDF are refused: a URDF cannot state the loops.
    let refused = urdf::export(model).expect_err("a closed chain has no URDF");
    assert!(refused.contains("passive"), "{refused}");
    let tree = urdf::export_open_tree(model).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(tree.actuated, model.joints.len());
    assert_eq!(tree.coordinates.len(), model.tree_coordinates());
    assert_eq!(tree.closures.len(), model.spatial_closures.len());
    let parameters = model.nominal_parameters();
    let points = point_positions(model);
    let poses_at = |q: &[f64]| {
        urdf_link_poses(&tree.urdf, |name| {
            let j = tree.coordinates.iter().position(|c| c == name).unwrap_or_else(|| panic!("joint {name}"));
            q[j]
        })
    };
    // The open tree moves as the model's tree, at any tree coordinates.
    for k in 0..10 {
        let q: Vec<f64> =
            (0..tree.coordinates.len()).map(|j| (1.3 * k as f64 + 0.7 * j as f64).sin()).collect();
        let poses = poses_at(&q);
        for (point, world) in model.points.iter().zip(&points) {
            let state = State { q: &q, qd: &[], parameters: &parameters };
            let (_, urdf_world) = poses[&urdf::point_link_name(&point.name)];
            for (axis, (u, v)) in world.iter().map(|p| p.eval(&state)).zip(urdf_world).enumerate() {
                assert!((u - v).abs() < 1e-12, "point {} axis {axis}: {u} vs {v} at {q:?}", point.name);
            }
        }
    }
    // Where the loops close, the cut closures' points meet and their axes are square.
    let spatial = checked.analyses.closures.as_ref().and_then(|c| c.spatial.as_ref()).expect("spatial loops");
    for actuated in [[0.35, 0.35, 0.35], [0.1, 0.6, 0.3], [0.7, 0.0, 0.5]] {
        let passive = spatial.passive_coordinates(&actuated, &parameters).expect("the loops close");
        let q: Vec<f64> = actuated.iter().chain(&passive).copied().collect();
        let poses = poses_at(&q);
        for closure in &tree.closures {
            let [(_, a), (_, b)] = closure.point_links.clone().map(|link| poses[&link]);
            let gap = (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
            assert!(gap < 1e-12, "closure {}: the points are {gap} m apart at {q:?}", closure.name);
            let [(x, u), (y, v)] =
                closure.perpendicular_axes.clone().expect("the Falcon's closures keep axes square");
            let world = |link: &String, axis: [f64; 3]| -> [f64; 3] {
                let r = poses[link].0;
                std::array::from_fn(|i| (0..3).map(|k| r[i][k] * axis[k]).sum())
            };
            let (u, v) = (world(&x, u), world(&y, v));
            let cosine: f64 = (0..3).map(|i| u[i] * v[i]).sum();
            assert!(cosine.abs() < 1e-12, "closure {}: the axes' cosine is {cosine}", closure.name);
        }
    }
}
