//! Scene files on the host (docs/scenes.md): read by `hapticgen_codegen::scene`, the one
//! reader that the firmware's build scripts use too, into its types, which the host uses as
//! they are (the simulator's geometry on them is `crate::solids`, above this module: nothing
//! here uses it).

pub use hapticgen_codegen::scene::{
    load, parse, Scene, SceneEffect, SceneMotion, SceneObject, ScenePlane, SceneShape,
};

/// The scene's objects for a task of `task_dim` coordinates, after checking that every
/// vector has that many (the error names the object in the file).
pub fn objects_for_task(scene: &Scene, task_dim: usize) -> Result<Vec<SceneObject>, String> {
    scene.check_task_dim(task_dim)?;
    Ok(scene.objects.clone())
}

#[cfg(test)]
mod tests {
    use super::{load, objects_for_task, parse, SceneShape};
    use std::path::Path;

    fn parsed(text: &str) -> Result<super::Scene, String> {
        parse("s.yaml", text, Path::new("."))
    }

    #[test]
    fn every_kind_with_its_surface_and_friction() {
        let text = "objects:\n\
                    \x20 - half_space: {point: [0, 0, -0.05], normal: [0, 0, 2], stiffness: 800, damping: 2,\n\
                    \x20                friction: {static: 0.4, dynamic: 0.3}}\n\
                    \x20 - sphere: {centre: [0.03, 0, 0], radius: 0.015, cavity: true, stiffness: 600, damping: 1}\n\
                    \x20 - box: {centre: [0, 0, 0], half_extents: [0.01, 0.02, 0.03], stiffness: 700, damping: 2}\n\
                    \x20 - capsule: {a: [0, 0, 0], b: [0, 0.02, 0], radius: 0.005, stiffness: 700, damping: 2}\n\
                    \x20 - cylinder: {a: [0, 0, 0], b: [0, 0, 0.02], radius: 0.005, stiffness: 700, damping: 2}\n";
        let scene = parsed(text).unwrap();
        assert_eq!(scene.objects.len(), 5);
        assert!(matches!(&scene.objects[3].shape, SceneShape::Capsule { radius, .. } if *radius == 0.005));
        assert!(matches!(&scene.objects[4].shape, SceneShape::Cylinder { b, .. } if b[2] == 0.02));
        let floor = &scene.objects[0];
        assert!(matches!(&floor.shape, SceneShape::HalfSpace { normal, .. } if normal == &[0.0, 0.0, 1.0]));
        assert_eq!((floor.static_friction, floor.dynamic_friction), (0.4, 0.3));
        assert_eq!((floor.stiffness, floor.damping), (800.0, 2.0));
        let ball = &objects_for_task(&scene, 3).unwrap()[1];
        assert!(ball.cavity);
        // A cavity's wall is beyond its sphere: the centre is free, a point outside is inside the wall.
        assert!(ball.depth(&[0.03, 0.0, 0.0]).unwrap() < 0.0);
        assert!((ball.depth(&[0.03, 0.02, 0.0]).unwrap() - 0.005).abs() < 1e-12);
        assert!(scene.objects[1].location.starts_with("s.yaml:4:"), "{}", scene.objects[1].location);
        assert_eq!(objects_for_task(&scene, 3).unwrap().len(), 5);
        let error = objects_for_task(&scene, 2).unwrap_err();
        assert!(
            error.starts_with("error: s.yaml:2:") && error.contains("objects[0].half_space: point has 3"),
            "{error}"
        );
    }

    #[test]
    fn errors_name_the_value_where_it_is_written() {
        let cases = [
            ("objects:\n  - box: {centre: [0], half_extents: [-1], stiffness: 1, damping: 0}\n", "s.yaml:2:", "objects[0].box.half_extents: must be positive"),
            ("objects:\n  - sphere: {centre: [0], radius: 1, stiffness: 1, damping: 0,\n      friction: {static: 0.1, dynamic: 0.2}}\n", "s.yaml:3:", "objects[0].sphere.friction.dynamic: must not exceed the static coefficient 0.1"),
            ("objects:\n  - sphere: {centre: [0], radius: 1, stiffness: 1, damping: 0, colour: red}\n", "s.yaml:2:", "unknown field `colour`"),
            ("objects:\n  - half_space: {point: [0, 0], normal: [0, 0], stiffness: 1, damping: 0}\n", "s.yaml:2:", "objects[0].half_space.normal: must not be zero"),
            ("objects:\n  - mesh: {file: no-such.obj, stiffness: 1, damping: 0}\n", "s.yaml:2:", "objects[0].mesh.file:"),
            ("objects:\n  - capsule: {a: [0, 1], b: [0, 1], radius: 1, stiffness: 1, damping: 0}\n", "s.yaml:2:", "objects[0].capsule.b: must differ from `a`"),
            ("objects: []\neffect: {vibration: {direction: [0, 0], amplitude: 1, frequency: 100}}\n", "s.yaml:2:", "effect.vibration.direction: must not be zero"),
            ("objects: []\neffect: {spring: {anchor: [0], stiffness: -1}}\n", "s.yaml:2:", "effect.spring.stiffness: must be finite and not negative"),
            ("objects:\n  - polytope:\n      planes:\n        - {point: [0, 0], normal: [0, 1]}\n        - {point: [0, 0], normal: [0, 0]}\n      stiffness: 1\n      damping: 0\n", "s.yaml:5:", "objects[0].polytope.planes[1].normal: must not be zero"),
            ("objects:\n  - polytope: {planes: [], stiffness: 1, damping: 0}\n", "s.yaml:2:", "objects[0].polytope.planes: a polytope needs at least one plane"),
            ("objects:\n  - sphere: {centre: [0, 0], radius: 1, stiffness: 1, damping: 0,\n      motion: {angular_velocity: [1]}}\n", "s.yaml:3:", "objects[0].sphere.motion: a turning object needs `pivot`"),
            ("objects:\n  - sphere: {centre: [0, 0], radius: 1, stiffness: 1, damping: 0,\n      motion: {velocity: [0, .nan]}}\n", "s.yaml:3:", "objects[0].sphere.motion.velocity: must be 1 to 3 finite coordinates"),
            ("objects:\n  - sphere: {centre: [0, 0], radius: 1, stiffness: 1, damping: 0,\n      motion: {speed: 1}}\n", "s.yaml:3:", "unknown field `speed`"),
        ];
        for (text, at, message) in cases {
            let error = parsed(text).unwrap_err();
            assert!(error.starts_with(&format!("error: {at}")) && error.contains(message), "{error}");
        }
    }

    /// A motion's absent rates are zero in the object's dimension; its vectors are checked
    /// against the task's dimension like the shape's.
    #[test]
    fn a_motion_defaults_to_rest_and_is_checked_against_the_task() {
        let text = "objects:\n\
                    \x20 - box: {centre: [0, 0, 0], half_extents: [1, 1, 1], stiffness: 1, damping: 0,\n\
                    \x20        motion: {velocity: [0, 0, 0.01]}}\n\
                    \x20 - sphere: {centre: [0, 0, 0], radius: 1, stiffness: 1, damping: 0,\n\
                    \x20           motion: {angular_velocity: [0, 0, 2], pivot: [1, 0, 0]}}\n";
        let scene = parsed(text).unwrap();
        let lift = scene.objects[0].motion.as_ref().unwrap();
        assert_eq!((lift.angular_velocity.as_slice(), lift.pivot.as_slice()), (&[0.0; 3][..], &[0.0; 3][..]));
        let spin = scene.objects[1].motion.as_ref().unwrap();
        assert_eq!(spin.velocity, vec![0.0; 3]);
        // A quarter turn about z through (1, 0, 0) takes the origin to (1, −1, 0): carried back,
        // (1, −1, 0) is the origin.
        let back = spin.carried_back(std::f64::consts::FRAC_PI_4, &[1.0, -1.0, 0.0]);
        assert!(back.iter().all(|v| v.abs() < 1e-15), "{back:?}");
        // And carried, the origin is at (1, −1, 0); its x axis points along +y.
        let there = spin.carried(std::f64::consts::FRAC_PI_4, &[0.0; 3]);
        assert!(there.iter().zip([1.0, -1.0, 0.0]).all(|(a, b)| (a - b).abs() < 1e-15), "{there:?}");
        let axis = spin.turned(std::f64::consts::FRAC_PI_4, &[1.0, 0.0, 0.0]);
        assert!(axis.iter().zip([0.0, 1.0, 0.0]).all(|(a, b)| (a - b).abs() < 1e-15), "{axis:?}");
        assert!(spin.turns() && !lift.turns());
        // Carried along a lift of 1 cm/s for 2 s, a point rises 2 cm.
        let lifted = lift.carried(2.0, &[0.1, 0.2, 0.3]);
        assert!(lifted.iter().zip([0.1, 0.2, 0.32]).all(|(a, b)| (a - b).abs() < 1e-15), "{lifted:?}");
        assert!(objects_for_task(&scene, 3).is_ok());
        let planar = "objects:\n  - sphere: {centre: [0, 0], radius: 1, stiffness: 1, damping: 0,\n      motion: {angular_velocity: [1, 0, 0], pivot: [0, 0]}}\n";
        let error = objects_for_task(&parsed(planar).unwrap(), 2).unwrap_err();
        assert!(
            error.contains("objects[0].sphere: motion.angular_velocity has 3 values; a 2-D task needs 1"),
            "{error}"
        );
    }

    /// A mesh is read relative to the scene file: the repository's knob, from scenes/.
    #[test]
    fn a_mesh_is_read_relative_to_the_scene_file() {
        let directory = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        let text = "objects:\n  - mesh: {file: meshes/knob.obj, offset: [0, 0, -0.05], stiffness: 500, damping: 1}\n";
        let scene = parse("s.yaml", text, &directory).unwrap();
        assert!(
            matches!(&scene.objects[0].shape, SceneShape::Mesh { mesh, offset } if !mesh.faces.is_empty() && offset[2] == -0.05)
        );
        // The shipped example loads as a whole.
        let example = load(&directory.join("desk.yaml")).unwrap();
        assert!(example.objects.len() >= 3);
    }
}
