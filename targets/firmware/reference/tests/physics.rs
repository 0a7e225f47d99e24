//! The reference runs against what each scenario's physics predicts in closed form (the
//! numbers come from the scenario's own constants, not from earlier runs). Every image whose
//! line names the scenario is checked.

use hapticgen_codegen::scene::SceneEffect;
use hapticgen_fw_reference::{find, host_run, int, list, variants};
use hapticgen_fw_sim::scenarios::{
    hold_pose, joint_spring, scene_contact, sphere_cavity, wall_contact, PAPER_RENDERING,
};

/// `(k, q, x)` of every trace line of the f64 reference run (µrad, µm or µrad).
fn trace(name: &str) -> Vec<(i64, Vec<i64>, Vec<i64>)> {
    let text = host_run(name, "f64").unwrap();
    let summary = find(&text, "SUMMARY").unwrap();
    assert_eq!(int(summary, "fault").unwrap(), 0, "{name}: {summary}");
    text.lines()
        .filter(|l| l.starts_with("S "))
        .map(|l| (int(l, "k").unwrap(), list(l, "q").unwrap(), list(l, "x").unwrap()))
        .collect()
}

fn images(scenario: &str) -> Vec<&'static str> {
    variants::SCENARIOS.iter().filter(|(_, s)| *s == scenario).map(|(n, _)| *n).collect()
}

/// The sample at period `k` (the push ends at `CURRENT_LOOP_HZ` = 7500 periods, 1 s).
fn at(trace: &[(i64, Vec<i64>, Vec<i64>)], k: i64) -> &[i64] {
    &trace.iter().find(|(kk, _, _)| *kk == k).unwrap().2
}

fn offset(a: &[i64], b: &[i64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| (x - y) as f64 * 1e-6).collect()
}

fn offset_m(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[test]
fn hold_pose_gives_way_by_force_over_stiffness_and_returns() {
    let names = images("hold_pose");
    assert!(!names.is_empty());
    for name in names {
        let t = trace(name);
        let start = &t[0].2;
        // End of the push: the spring alone holds F, along −x_M only.
        let d = offset(at(&t, 7500), start);
        let expected = -hold_pose::FORCE / hold_pose::STIFFNESS;
        let last = d.len() - 1;
        assert!((d[last] - expected).abs() < 0.1 * expected.abs(), "{name}: {d:?} vs {expected}");
        for (axis, v) in d[..last].iter().enumerate() {
            assert!(v.abs() < 0.1 * expected.abs(), "{name}: axis {axis} moved {v} m");
        }
        // 0.5 s after letting go: back within a tenth of the deflection.
        let end = offset(&t.last().unwrap().2, start);
        assert!(norm(&end) < 0.1 * expected.abs(), "{name}: ends {end:?} from the start");
    }
}

#[test]
fn sphere_cavity_holds_the_point_on_its_wall_along_the_push() {
    let names = images("sphere_cavity");
    assert!(!names.is_empty());
    let (grid, stiffness) = (PAPER_RENDERING[0], PAPER_RENDERING[1]);
    for name in names {
        let t = trace(name);
        let start = &t[0].2;
        let d = offset(at(&t, 7500), start);
        // Concave wall: at rest beyond the wall by F/K, along the push (2, 1, 2)/3.
        let expected = sphere_cavity::RADIUS + sphere_cavity::FORCE / stiffness;
        assert!((norm(&d) - expected).abs() < 2.0 * grid, "{name}: |{d:?}| vs {expected}");
        let cosine = (2.0 * d[0] + d[1] + 2.0 * d[2]) / 3.0 / norm(&d);
        assert!(cosine > 0.995, "{name}: direction {d:?}, cosine {cosine}");
        // After letting go the wall pushes it back inside, where the grid holds it.
        let end = offset(&t.last().unwrap().2, start);
        assert!(norm(&end) < sphere_cavity::RADIUS, "{name}: ends {end:?} outside the cavity");
    }
}

#[test]
fn wall_contact_stops_the_point_at_the_wall() {
    let names = images("wall_contact");
    assert!(!names.is_empty());
    for name in names {
        let force = variants::wall_push(name).unwrap();
        let [_, stiffness, _] = variants::rendering(name).unwrap_or(PAPER_RENDERING);
        let t = trace(name);
        let start = &t[0].2;
        let wall = wall_contact::WALL;
        let pushed: Vec<(i64, f64)> = t
            .iter()
            .filter(|(k, _, _)| (750..=7500).contains(k))
            .map(|(k, _, x)| (*k, offset(x, start)[0]))
            .collect();
        // Over the last 0.3 s of the push the point rests (on average over the ring) in
        // the wall by F/K.
        let late: Vec<f64> = pushed.iter().filter(|(k, _)| *k >= 5250).map(|(_, x)| x - wall).collect();
        let mean = late.iter().sum::<f64>() / late.len() as f64;
        let penetration = force / stiffness;
        assert!(
            (mean - penetration).abs() < 0.1 * penetration,
            "{name}: in the wall by {mean} m, F/K = {penetration}"
        );
        // Passivity: the deepest penetration p cannot exceed what the operator's work
        // F (d + p) can store in the wall spring, K p² / 2 = F (d + p).
        let deepest = pushed.iter().map(|(_, x)| x - wall).fold(f64::MIN, f64::max);
        let bound = (force + (force * force + 2.0 * stiffness * force * wall).sqrt()) / stiffness;
        assert!(deepest < bound, "{name}: {deepest} m into the wall, energy bound {bound} m");
    }
}

#[test]
fn fig4_step_settles_at_force_over_stiffness() {
    let names = images("fig4_step");
    assert!(!names.is_empty());
    for name in names {
        let t = trace(name);
        // K_d = 1 N·m/rad, 1 N·m: 1 rad; after 1.9 s of a ζ ≈ 0.09 ring, within 10 %.
        let (_, q, _) = t.last().unwrap();
        let end = (q[0] - t[0].1[0]) as f64 * 1e-6;
        assert!((end - 1.0).abs() < 0.1, "{name}: ends at {end} rad");
    }
}

#[test]
fn scene_contact_rests_force_over_stiffness_inside_the_scene() {
    let firmware = hapticgen_fw_build::firmware_dir(std::path::Path::new(env!("CARGO_MANIFEST_DIR")));
    let table = hapticgen_fw_build::read_table(&firmware).unwrap();
    let names = images("scene_contact");
    assert!(!names.is_empty());
    for name in names {
        let line = table.iter().find(|v| v.name == name).unwrap();
        let scene =
            hapticgen_codegen::scene::load(&firmware.join("../..").join(line.scene.as_deref().unwrap()))
                .unwrap();
        let [_, stiffness, _] = variants::rendering(name).unwrap_or(PAPER_RENDERING);
        let model = firmware.join("../..").join(&line.model);
        let current_loop_hz = hapticgen_codegen::load_file(&model, &line.model, line.variant.as_deref())
            .unwrap()
            .rates
            .current_loop_hz;
        let t = trace(name);
        // The push lasts to the end: over the last 0.3 s the point rests F/K deep in the
        // object it was pushed onto (where that object is then, for a moving one: a desk rising
        // at 5 mm/s carries the point up), and nowhere deeper; or, with a spring effect holding
        // it in free space, F/k below the spring's anchor, outside every object.
        let late: Vec<(f64, Vec<f64>)> = t
            .iter()
            .filter(|(k, _, _)| *k >= 9000)
            .map(|(k, _, x)| {
                (*k as f64 / f64::from(current_loop_hz), x.iter().map(|v| *v as f64 * 1e-6).collect())
            })
            .collect();
        assert!(!late.is_empty());
        let deepest = |(time, x): &(f64, Vec<f64>)| {
            scene
                .objects
                .iter()
                .filter_map(|object| match &object.motion {
                    Some(motion) => object.depth(&motion.carried_back(*time, x)),
                    None => object.depth(x),
                })
                .fold(f64::NEG_INFINITY, f64::max)
        };
        match &scene.effect {
            None => {
                let expected = scene_contact::FORCE / stiffness;
                for sample in late {
                    let depth = deepest(&sample);
                    assert!(
                        (depth - expected).abs() < 0.1 * expected,
                        "{name}: {depth} m deep at {sample:?}, F/K = {expected}"
                    );
                }
            }
            Some(SceneEffect::Spring { anchor, stiffness }) => {
                let sag = scene_contact::FORCE / stiffness;
                let mut expected = anchor.clone();
                *expected.last_mut().unwrap() -= sag;
                for sample in late {
                    let x = &sample.1;
                    assert!(
                        norm(&offset_m(x, &expected)) < 0.1 * sag,
                        "{name}: at {x:?}, F/k below the anchor {expected:?}"
                    );
                    assert!(deepest(&sample) < 0.0, "{name}: at {x:?}, inside an object");
                }
            }
            Some(other) => panic!("{name}: no closed form here for the effect {other:?}"),
        }
    }
}

#[test]
fn joint_spring_twists_the_last_axis_by_torque_over_stiffness() {
    let names = images("joint_spring");
    assert!(!names.is_empty());
    for name in names {
        let t = trace(name);
        let start = &t[0].2;
        // Over the last 0.3 s of the twist (torque SHARE·K on the last axis) the last axis rests
        // SHARE rad from the start and the others where they started: on the differential
        // wrist, both drives turn against each other and the pitch stands still.
        let late: Vec<Vec<f64>> = t
            .iter()
            .filter(|(k, _, _)| (5250..=7500).contains(k))
            .map(|(_, _, x)| offset(x, start))
            .collect();
        assert!(!late.is_empty());
        let last = start.len() - 1;
        for x in &late {
            assert!(
                (x[last] - joint_spring::SHARE).abs() < 0.05 * joint_spring::SHARE,
                "{name}: twisted {x:?}"
            );
            for other in &x[..last] {
                assert!(other.abs() < 0.02 * joint_spring::SHARE, "{name}: the other axes moved: {x:?}");
            }
        }
        // Let go at 1 s: back at the start by the end.
        let end = offset(&t.last().unwrap().2, start);
        assert!(norm(&end) < 0.05 * joint_spring::SHARE, "{name}: ends at {end:?}");
    }
}
