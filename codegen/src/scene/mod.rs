//! Scene files: the virtual objects a rig touches, in its task frame (metres), read once for
//! every tool that renders them (docs/scenes.md): `hapticgen simulate --scene` and `hapticgen
//! connect --scene` on the host, and the firmware images whose `variants.txt` line names a
//! scene, for which [`emit`] writes the objects as Rust source (meshes as `static` arrays).
//!
//! ```yaml
//! objects:
//!   - half_space: {point: [0, 0, -0.05], normal: [0, 0, 1], stiffness: 800, damping: 2,
//!                  friction: {static: 0.4, dynamic: 0.3}}
//!   - sphere: {centre: [0.03, 0, -0.02], radius: 0.015, stiffness: 600, damping: 1}
//!   - box: {centre: [-0.03, 0, -0.04], half_extents: [0.01, 0.02, 0.01], stiffness: 700, damping: 2}
//!   - mesh: {file: meshes/knob.obj, offset: [0, 0.03, -0.04], stiffness: 500, damping: 1}
//! ```
//!
//! Each object is a map of one key, its kind: `sphere` (`cavity: true` keeps the point inside
//! instead), `box` (axis-aligned, or turned by `rotation`: `[angle]` in 2-D, `[roll, pitch,
//! yaw]` in 3-D), `half_space` (behind the plane; the normal points to free
//! space and is normalised here), `polytope` (`planes`: a list of `{point, normal}`, the solid
//! behind every one), `capsule` and `cylinder` (`a`, `b`: the axis's ends, the
//! cylinder's cap centres; `radius`) or `mesh` (a closed triangle mesh from an OBJ or STL file,
//! named relative to the scene file, placed at `offset`; 3-D tasks only). Every object has a
//! surface `stiffness` (N/m) and `damping` (N·s/m), and optionally `friction` with `static`
//! and `dynamic` coefficients (0 ≤ dynamic ≤ static), and optionally `motion` (`velocity`,
//! `angular_velocity` and the `pivot` it turns about: [`SceneMotion`]; the simulator moves it,
//! firmware images refuse it). A file may name one free-space `effect` (`spring: {anchor,
//! stiffness}`, `viscous: {damping}`, `force: {force}` or `vibration: {direction, amplitude,
//! frequency}`: `hapticgen_runtime::effects`), which the simulator and the firmware images render.
//! Vectors hold one coordinate per task axis ([`Scene::check_task_dim`]). Every error names the
//! file, line and column of the value.
//!
//! The scene's types and their geometry are `objects`' (re-exported here); reading and
//! validating a file is `file`'s job ([`load`], [`parse`]), writing a scene as Rust source
//! `emit`'s ([`emit()`]).

mod emit;
mod file;
mod objects;

pub use emit::emit;
pub use file::{load, parse};
pub use objects::{Scene, SceneEffect, SceneMotion, SceneObject, ScenePlane, SceneShape};

#[cfg(test)]
mod tests {
    use super::SceneShape;

    fn depth(shape: SceneShape, p: [f64; 3]) -> f64 {
        shape.depth(&p).unwrap()
    }

    /// A syntax or shape error says where it is once, at the front, as the model's do.
    #[test]
    fn a_scene_error_names_its_location_once() {
        let text = "objects:\n  - sphere: {center: [0, 0, 0], radius: 0.01}\n    colour: red\n";
        let error = super::parse("bad.yaml", text, std::path::Path::new(".")).err().unwrap();
        assert!(error.starts_with("error: bad.yaml:"), "{error}");
        assert!(!error.contains(" at line "), "{error}");
    }

    #[test]
    fn depths_are_the_shapes_closed_forms() {
        let floor = || SceneShape::HalfSpace { point: vec![0.0, 0.0, 1.0], normal: vec![0.0, 0.0, 2.0] };
        assert_eq!(depth(floor(), [5.0, 5.0, 0.25]), 0.75);
        assert_eq!(depth(floor(), [0.0, 0.0, 3.0]), -2.0);
        let ball = || SceneShape::Sphere { center: vec![1.0, 0.0, 0.0], radius: 0.5 };
        assert_eq!(depth(ball(), [1.0, 0.25, 0.0]), 0.25);
        assert_eq!(depth(ball(), [1.0, 0.0, -2.0]), -1.5);
        let cube = || SceneShape::axis_aligned_box(vec![0.0; 3], vec![1.0, 2.0, 3.0]);
        assert_eq!(depth(cube(), [0.5, 0.0, 0.0]), 0.5);
        assert_eq!(depth(cube(), [0.0, 1.75, 0.0]), 0.25);
        // Outside beyond an edge: √(1² + 1²); beyond a corner: √3.
        assert!((depth(cube(), [2.0, 3.0, 0.0]) + 2f64.sqrt()).abs() < 1e-15);
        assert!((depth(cube(), [-2.0, -3.0, 4.0]) + 3f64.sqrt()).abs() < 1e-15);
        // The same box turned by 90° about z: its x half extent (1) now lies along y, its y
        // (2) along x; and a 2-D square turned by 45°, whose corner reaches √2 along x.
        let turned = SceneShape::Box {
            center: vec![0.0; 3],
            axes: super::file::box_axes(3, Some(&[0.0, 0.0, std::f64::consts::FRAC_PI_2])).unwrap(),
            half_extents: vec![1.0, 2.0, 3.0],
        };
        assert!((depth(turned.clone(), [1.75, 0.0, 0.0]) - 0.25).abs() < 1e-15);
        assert!((depth(turned, [0.0, 1.5, 0.0]) + 0.5).abs() < 1e-15);
        let diamond = SceneShape::Box {
            center: vec![1.0, 0.0],
            axes: super::file::box_axes(2, Some(&[std::f64::consts::FRAC_PI_4])).unwrap(),
            half_extents: vec![1.0, 1.0],
        };
        assert!((diamond.depth(&[1.0 + 2f64.sqrt() - 0.1, 0.0]).unwrap() - 0.1 / 2f64.sqrt()).abs() < 1e-15);
        assert!(
            super::file::box_axes(3, Some(&[0.1])).is_err()
                && super::file::box_axes(1, Some(&[0.1])).is_err()
        );
        // The unit cube as six planes: inside, the nearest face (as the box); outside, the
        // farthest plane's distance (beyond an edge, 1, a lower bound of √2).
        let planes = (0..3)
            .flat_map(|i| {
                [1.0, -1.0].map(|side| super::ScenePlane {
                    normal: (0..3).map(|k| if k == i { side } else { 0.0 }).collect(),
                    offset: 1.0,
                })
            })
            .collect();
        let polytope = SceneShape::Polytope { planes };
        assert_eq!(depth(polytope.clone(), [0.5, 0.25, 0.0]), 0.5);
        assert_eq!(depth(polytope.clone(), [2.0, 0.0, 0.0]), -1.0);
        assert_eq!(depth(polytope, [2.0, 2.0, 0.0]), -1.0);
    }

    /// Each effect kind is emitted as the runtime's, with the file's numbers; only a vibration
    /// uses the tick's period.
    #[test]
    fn a_scene_s_effect_is_emitted_as_the_runtime_s() {
        let emitted = |effect: &str| {
            let text = format!("objects: []\neffect: {effect}\n");
            let scene = super::parse("s.yaml", &text, std::path::Path::new(".")).unwrap();
            let code = super::emit(&scene, 3, crate::Scalar::F64).unwrap();
            let start = code.find("pub fn effect(").unwrap();
            // Whitespace and the formatter's trailing commas aside.
            code[start..].split_whitespace().collect::<Vec<_>>().join(" ").replace(", }", " }")
        };
        let effect = "::hapticgen_runtime::effects::Effect";
        assert_eq!(
            emitted("{viscous: {damping: 2}}"),
            format!("pub fn effect(_impedance_period: f64) -> {effect}<f64, 3> {{ {effect}::Viscous {{ damping: 2.0 }} }}")
        );
        assert!(emitted("{spring: {anchor: [0, 0, -0.1], stiffness: 500}}")
            .contains(&format!("{effect}::Spring {{ anchor: [0.0, 0.0, -0.1], stiffness: 500.0 }}")));
        assert!(emitted("{force: {force: [0, 1, 0]}}")
            .contains(&format!("{effect}::Force {{ force: [0.0, 1.0, 0.0] }}")));
        let vibration = emitted("{vibration: {direction: [0, 0, 2], amplitude: 0.5, frequency: 100}}");
        assert!(vibration.starts_with("pub fn effect(impedance_period: f64)"), "{vibration}");
        assert!(
            vibration.contains(&format!(
                "{effect}::Vibration {{ direction: [0.0, 0.0, 1.0], amplitude: 0.5, frequency: 100.0, period: impedance_period }}"
            )),
            "{vibration}"
        );
        let none =
            super::emit(&super::Scene { objects: vec![], effect: None }, 2, crate::Scalar::F32).unwrap();
        let none = none.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(none.contains(&format!("-> {effect}<f32, 2> {{ {effect}::None }}")), "{none}");
    }

    #[test]
    fn capsule_and_cylinder_depths_are_closed_forms() {
        // A capsule and a cylinder along z from 0 to 2, radius 0.5.
        let capsule = || SceneShape::Capsule { a: vec![0.0; 3], b: vec![0.0, 0.0, 2.0], radius: 0.5 };
        assert!((depth(capsule(), [0.25, 0.0, 1.0]) - 0.25).abs() < 1e-15);
        assert!((depth(capsule(), [0.0, 0.0, 3.0]) + 0.5).abs() < 1e-15);
        assert!((depth(capsule(), [1.5, 0.0, -1.0]) - (0.5 - 3.25f64.sqrt())).abs() < 1e-15);
        let cylinder = || SceneShape::Cylinder { a: vec![0.0; 3], b: vec![0.0, 0.0, 2.0], radius: 0.5 };
        assert!((depth(cylinder(), [0.1, 0.0, 0.05]) - 0.05).abs() < 1e-15);
        assert!((depth(cylinder(), [0.0, 0.3, 1.0]) - 0.2).abs() < 1e-15);
        assert!((depth(cylinder(), [0.0, 0.0, -1.0]) + 1.0).abs() < 1e-15);
        assert!((depth(cylinder(), [1.5, 0.0, 3.0]) + 2f64.sqrt()).abs() < 1e-15);
        assert!((depth(cylinder(), [0.0, 1.5, 1.0]) + 1.0).abs() < 1e-15);
    }
}
