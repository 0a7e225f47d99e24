//! Generated rigs in the full control stack allocate nothing, counted by a counting global
//! allocator (per thread, only while a loop runs):
//!
//! - the generated parallel link rendering a scene of a circular cavity, a rotated rectangle and
//!   a contour function, over 10,000 impedance ticks (estimation, the fused generated law and the
//!   runtime's generic law in turn, all four impedance laws, rendering, safety) and their 75,000
//!   current-loop ticks;
//! - every generated rig of the registry (each shipped model, variant and scalar, unfused and
//!   fused) holding a fixed task reference, 400 impedance ticks each with both tick functions,
//!   every law the rig's shape allows (Controllers 1 and 2 need as many joints as task axes),
//!   and their current-loop ticks.
//!
//! The runtime is `no_std` without `alloc`, so what this guards is the code generated into a
//! `std` crate and anything that brings `alloc` into the tick path.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use hapticgen_runtime::control::{
    ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference,
};
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
use hapticgen_runtime::Real;
use hapticgen_tests::parallel_link_2dof_vertical_f64::ParallelLink2dof;
use hapticgen_tests::stack::{encoder_counts, parallel_link_settings};
use hapticgen_tests::{visit_all, RigInfo, RigVisitor};

struct CountingAllocator;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = COUNTING.try_with(|counting| {
            if counting.get() {
                let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
            }
        });
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Runs `f` with this thread's allocations counted; returns its result and the count.
fn count_allocations<T>(f: impl FnOnce() -> T) -> (T, usize) {
    ALLOCATIONS.with(|n| n.set(0));
    COUNTING.with(|c| c.set(true));
    let result = f();
    COUNTING.with(|c| c.set(false));
    (result, ALLOCATIONS.with(Cell::get))
}

fn contour(x: f64) -> f64 {
    0.02 * (20.0 * x).sin() + 0.1
}

fn contour_slope(x: f64) -> f64 {
    0.4 * (20.0 * x).cos()
}

/// The circular cavity of Fig. 7 and, beside it, a rotated rectangle and a contour function.
fn scene() -> Scene<f64, 4, 8> {
    let mut scene = Scene::new(0.0, 5.0, 0.3e-3);
    let objects = [
        (Shape::Circle { center: [0.0, 0.13], radius: 0.02 }, ObjectKind::Cavity),
        (
            Shape::Rectangle { center: [0.03, 0.16], half_extents: [0.01, 0.02], angle: 0.3 },
            ObjectKind::Solid,
        ),
        (
            Shape::ContourFunction { function: contour, slope: contour_slope, x1_range: [-0.1, 0.1] },
            ObjectKind::Solid,
        ),
    ];
    for (shape, kind) in objects {
        scene.add(VirtualObject { shape, kind, stiffness: 1500.0, damping: 5.0 });
    }
    scene
}

#[test]
fn ten_thousand_generated_ticks_rendering_a_scene_allocate_nothing() {
    let settings = parallel_link_settings(ImpedanceLaw::JacobianTranspose);
    let mut haptic = HapticLoop::new(ParallelLink2dof::NOMINAL, scene(), &settings).expect("settings");
    let laws = [
        ImpedanceLaw::JacobianTranspose,
        ImpedanceLaw::NaturalInertia,
        ImpedanceLaw::AccelerationFeedback,
        ImpedanceLaw::ForceFeedback,
    ];
    let measured = [0.2, -0.1];
    let ((impedance_ticks, current_ticks), allocations) = count_allocations(|| {
        let (mut impedance_ticks, mut current_ticks, mut tick) = (0, 0, 0u32);
        while impedance_ticks < 10_000 {
            current_ticks += 1;
            let (_, due) = haptic.current_tick(&measured);
            if due {
                tick += 1;
                haptic.controller.law = laws[(tick as usize / 2500) % laws.len()];
                let t = f64::from(tick) * 1e-3;
                let inputs = ImpedanceInputs {
                    encoder_counts: encoder_counts(tick),
                    force_readings: [2.5 + 0.1 * t.sin(), 2.5],
                    tick,
                };
                if tick % 2 == 0 {
                    haptic.impedance_tick_fused(&inputs);
                } else {
                    haptic.impedance_tick(&inputs);
                }
                impedance_ticks += 1;
            }
        }
        (impedance_ticks, current_ticks)
    });
    assert!(current_ticks >= 74_990, "{current_ticks} current ticks");
    assert_eq!(allocations, 0, "{allocations} allocations in {impedance_ticks} ticks");
    assert!(haptic.safety().fault().is_none(), "{:?}", haptic.safety().fault());
}

/// Impedance ticks per rig in [`every_generated_rig_ticks_without_allocating`].
const TICKS_PER_RIG: u32 = 400;

/// Runs one rig's loop against a fixed reference and asserts that it allocates nothing.
fn ticks_allocate_nothing<R, const N: usize, const M: usize>(info: &RigInfo, rig: &R) -> u32
where
    R: FusedImpedance<N, M> + Clone,
{
    let s = |x: f64| R::Scalar::from_f64(x);
    let drives = rig.drives();
    // Mid-range of each joint's travel, where the rig starts and moves about.
    let zero_offset: [R::Scalar; N] =
        std::array::from_fn(|i| (drives[i].position_lower + drives[i].position_upper) * s(0.5));
    let start = rig.position(&zero_offset);
    let reference = TaskReference {
        position: std::array::from_fn(|k| start[k] + s(0.005)),
        velocity: [s(0.0); M],
        acceleration: [s(0.0); M],
    };
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law: ImpedanceLaw::JacobianTranspose,
            parameters: ImpedanceParameters {
                stiffness: [s(200.0); M],
                damping: [s(2.0); M],
                mass: [s(0.2); M],
            },
            options: ControlOptions { min_abs_jacobian_determinant: s(1e-6), ..ControlOptions::paper() },
        },
        estimator: EstimatorSettings {
            sample_period: s(1.0) / s(f64::from(R::IMPEDANCE_LOOP_HZ)),
            velocity_cutoff_hz: s(50.0),
            acceleration_cutoff_hz: s(20.0),
        },
        zero_offset,
        initial_counts: [0; N],
        force_calibration: ForceSensorCalibration { scale: [s(1.0); M], offset: [s(0.0); M] },
        current_gains: [CurrentLoopGains {
            kp: s(0.43),
            ki: s(1219.6),
            sample_period: s(1.0) / s(f64::from(R::CURRENT_LOOP_HZ)),
            proportional_setpoint_weight: s(0.0),
        }; N],
        max_tick_gap: 1,
    };
    let mut haptic = HapticLoop::new(rig.clone(), reference, &settings)
        .unwrap_or_else(|| panic!("{}: unusable loop rates", info.module));
    let laws: &[ImpedanceLaw] = if N == M {
        &[
            ImpedanceLaw::JacobianTranspose,
            ImpedanceLaw::NaturalInertia,
            ImpedanceLaw::AccelerationFeedback,
            ImpedanceLaw::ForceFeedback,
        ]
    } else {
        &[ImpedanceLaw::JacobianTranspose]
    };
    let measured = [s(0.1); N];
    let (ticks, allocations) = count_allocations(|| {
        let mut tick = 0u32;
        while tick < TICKS_PER_RIG {
            let (_, due) = haptic.current_tick(&measured);
            if due {
                tick += 1;
                haptic.controller.law = laws[(tick / 50) as usize % laws.len()];
                // Each joint swings by a few hundred counts about its mid-range.
                let encoder_counts: [i32; N] = std::array::from_fn(|i| {
                    (300.0 * (f64::from(tick) * 0.01 * (1.0 + i as f64 * 0.3)).sin()) as i32
                });
                let inputs = ImpedanceInputs { encoder_counts, force_readings: [s(0.2); M], tick };
                if tick.is_multiple_of(2) {
                    haptic.impedance_tick_fused(&inputs);
                } else {
                    haptic.impedance_tick(&inputs);
                }
            }
        }
        tick
    });
    assert_eq!(allocations, 0, "{}: {allocations} allocations in {ticks} impedance ticks", info.module);
    ticks
}

/// Visits every generated rig and runs its loop.
#[derive(Default)]
struct EveryRig {
    rigs: usize,
    ticks: u32,
}

impl RigVisitor for EveryRig {
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64> + Clone, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    ) {
        self.ticks += ticks_allocate_nothing(info, rig);
        self.rigs += 1;
    }
    fn visit_f32<R: FusedImpedance<N, M, Scalar = f32> + Clone, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    ) {
        self.ticks += ticks_allocate_nothing(info, rig);
        self.rigs += 1;
    }
}

#[test]
fn every_generated_rig_ticks_without_allocating() {
    let mut every = EveryRig::default();
    visit_all(&mut every);
    assert!(every.rigs > 0, "no generated rigs were visited");
    assert_eq!(every.ticks, TICKS_PER_RIG * every.rigs as u32);
}
