//! Runs `TICKS` full 1 kHz ticks of a shipped rig for `valgrind --tool=callgrind`, which counts
//! instructions exactly (repeatable on a noisy machine). `bench/callgrind.sh` runs it with 0
//! and with 10,000 ticks and divides the difference, so start-up cost cancels.
//!
//! `tick_instructions RIG MODE TICKS` with RIG `joystick` | `parallel_link` | `planar_arm` |
//! `phantom` | `puma560` | `pantograph`, MODE `fused` (the runtime with the generated, fused
//! law) | `generic` (the runtime's generic law on the generated terms). The joystick holds a
//! position (Controller 2), the parallel link renders a virtual circle (Controller 3); the other
//! rigs hold a task-space reference 1 cm from their firmware image's start pose (Controller 3;
//! the runtime's renderer is 2-D), which is enough to run the whole tick: estimation, the law,
//! safety and the current loop.

use std::hint::black_box;

use hapticgen_runtime::control::{
    ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference,
};
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs, ReferenceSource};
use hapticgen_runtime::RigModel;
use hapticgen_tests::{
    joystick_1dof_f64::Joystick1dof, pantograph_5bar_horizontal_f64::Pantograph5bar,
    parallel_link_2dof_vertical_f64::ParallelLink2dof, phantom_3dof_f64::Phantom3dof,
    planar_arm_2dof_vertical_f64::PlanarArm2dof, puma560_f64::Puma560,
};

fn settings<const N: usize, const M: usize>(
    law: ImpedanceLaw,
    gains: [hapticgen_runtime::current_loop::CurrentLoopGains<f64>; N],
) -> HapticLoopSettings<f64, N, M> {
    HapticLoopSettings {
        controller: ImpedanceController {
            law,
            parameters: ImpedanceParameters { stiffness: [1.0; M], damping: [0.01; M], mass: [0.01; M] },
            options: ControlOptions { min_abs_jacobian_determinant: 1e-4, ..ControlOptions::paper() },
        },
        estimator: EstimatorSettings {
            sample_period: 1e-3,
            velocity_cutoff_hz: 50.0,
            acceleration_cutoff_hz: 20.0,
        },
        zero_offset: [0.1; N],
        initial_counts: [0; N],
        force_calibration: ForceSensorCalibration { scale: [1.0; M], offset: [0.0; M] },
        current_gains: gains,
        max_tick_gap: 1,
    }
}

/// Controller 3 holding a point 1 cm from the task position at `start` (joint angles, degrees).
fn hold<R, const N: usize, const M: usize>(
    rig: R,
    gains: [hapticgen_runtime::current_loop::CurrentLoopGains<f64>; N],
    start_degrees: [f64; N],
    fused: bool,
    ticks: u32,
) where
    R: FusedImpedance<N, M, Scalar = f64> + RigModel<N, M, Scalar = f64>,
{
    let start = start_degrees.map(f64::to_radians);
    let position = RigModel::position(&rig, &start);
    let reference = TaskReference::at_rest(std::array::from_fn(|i| position[i] + 0.01));
    let mut s = settings::<N, M>(ImpedanceLaw::JacobianTranspose, gains);
    s.zero_offset = start;
    let haptic = HapticLoop::new(rig, reference, &s).expect("settings");
    run(haptic, fused, ticks);
}

fn run<R, Src, const N: usize, const M: usize>(mut haptic: HapticLoop<R, Src, N, M>, fused: bool, ticks: u32)
where
    R: FusedImpedance<N, M, Scalar = f64>,
    Src: ReferenceSource<f64, M>,
{
    let measured = [0.1; N];
    for tick in 1..=ticks {
        let t = f64::from(tick) * 1e-3;
        let counts: [i32; N] = std::array::from_fn(|i| (600.0 * ((2.0 + i as f64) * t).sin()) as i32);
        let inputs = ImpedanceInputs { encoder_counts: counts, force_readings: [0.0; M], tick };
        let report = if fused {
            haptic.impedance_tick_fused(black_box(&inputs))
        } else {
            haptic.impedance_tick(black_box(&inputs))
        };
        // A latched fault would skip the law and make the count meaningless.
        if let Some(fault) = black_box(report).command.fault {
            eprintln!("tick {tick}: fault {fault:?}");
            std::process::exit(1);
        }
        black_box(haptic.current_tick(black_box(&measured)));
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(rig), Some(mode), Some(ticks)) =
        (args.get(1), args.get(2), args.get(3).and_then(|t| t.parse().ok()))
    else {
        eprintln!("usage: tick_instructions joystick|parallel_link|planar_arm|phantom|puma560|pantograph fused|generic TICKS");
        std::process::exit(2);
    };
    let fused = mode == "fused";
    match rig.as_str() {
        "joystick" => {
            let s = settings::<1, 1>(ImpedanceLaw::NaturalInertia, Joystick1dof::CURRENT_LOOP_GAINS);
            let haptic =
                HapticLoop::new(Joystick1dof::NOMINAL, TaskReference::at_rest([0.0]), &s).expect("settings");
            run(haptic, fused, ticks);
        }
        "parallel_link" => {
            let mut scene: Scene<f64, 2, 8> = Scene::new(0.0, 5.0, 0.3e-3);
            scene.add(VirtualObject {
                shape: Shape::Circle { center: [0.0, 0.13], radius: 0.02 },
                kind: ObjectKind::Cavity,
                stiffness: 1500.0,
                damping: 5.0,
            });
            let s = settings::<2, 2>(ImpedanceLaw::JacobianTranspose, ParallelLink2dof::CURRENT_LOOP_GAINS);
            let haptic = HapticLoop::new(ParallelLink2dof::NOMINAL, scene, &s).expect("settings");
            run(haptic, fused, ticks);
        }
        // The firmware images' start poses (targets/firmware/variants.txt).
        "planar_arm" => {
            hold(PlanarArm2dof::NOMINAL, PlanarArm2dof::CURRENT_LOOP_GAINS, [70.0, 30.0], fused, ticks);
        }
        "phantom" => {
            hold(Phantom3dof::NOMINAL, Phantom3dof::CURRENT_LOOP_GAINS, [0.0, 20.0, 30.0], fused, ticks)
        }
        "puma560" => {
            let start = [0.0, 45.0, -180.0, 0.0, 45.0, 0.0];
            hold(Puma560::NOMINAL, Puma560::CURRENT_LOOP_GAINS, start, fused, ticks);
        }
        "pantograph" => {
            hold(Pantograph5bar::NOMINAL, Pantograph5bar::CURRENT_LOOP_GAINS, [117.5, 62.5], fused, ticks);
        }
        other => {
            eprintln!("unknown rig `{other}`");
            std::process::exit(2);
        }
    }
}
