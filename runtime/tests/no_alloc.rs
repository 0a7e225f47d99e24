//! A counting global allocator shows that full ticks (estimation, rig terms, rendering,
//! impedance law, safety, current loop) allocate nothing: 10,000 impedance ticks with their
//! 75,000 current-loop ticks on the 2-DOF rig.

// Index loops mirror the equations component by component.
#![allow(clippy::needless_range_loop)]

mod common;

use common::Parallelogram;
use hapticgen_runtime::control::{ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct CountingAllocator;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

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

fn contour(x: f64) -> f64 {
    0.02 * (20.0 * x).sin() - 0.02
}

fn contour_slope(x: f64) -> f64 {
    0.4 * (20.0 * x).cos()
}

#[test]
fn ten_thousand_full_ticks_allocate_nothing() {
    let mut scene: Scene<f64, 4, 8> = Scene::new(200.0, 2.0, 0.3e-3);
    let objects = [
        Shape::Circle { center: [0.1, 0.1], radius: 0.05 },
        Shape::Rectangle { center: [0.05, 0.12], half_extents: [0.01, 0.02], angle: 0.3 },
        Shape::ContourFunction { function: contour, slope: contour_slope, x1_range: [-0.1, 0.3] },
    ];
    for (shape, kind) in objects.into_iter().zip([ObjectKind::Cavity, ObjectKind::Solid, ObjectKind::Solid]) {
        scene.add(VirtualObject { shape, kind, stiffness: 1500.0, damping: 5.0 });
    }
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law: ImpedanceLaw::Controller3,
            parameters: ImpedanceParameters { stiffness: [0.0; 2], damping: [0.0; 2], mass: [0.1; 2] },
            options: ControlOptions {
                omit_damping_compensation: true,
                min_abs_jacobian_determinant: 1e-4,
                spring_lead_time: 0.0,
            },
        },
        estimator: EstimatorSettings {
            sample_period: 1e-3,
            velocity_cutoff_hz: 50.0,
            acceleration_cutoff_hz: 20.0,
        },
        zero_offset: [1.4, -0.3],
        initial_counts: [0; 2],
        force_calibration: ForceSensorCalibration { scale: [1.0; 2], offset: [0.0; 2] },
        current_gains: CurrentLoopGains {
            kp: 0.43,
            ki: 1219.6,
            sample_period: 1.0 / 7500.0,
            proportional_setpoint_weight: 0.0,
        },
        max_tick_gap: 1,
    };
    let mut haptic = HapticLoop::new(Parallelogram, scene, &settings).expect("loop");
    let laws = [
        ImpedanceLaw::Controller3,
        ImpedanceLaw::Controller2Mobility,
        ImpedanceLaw::Controller2Accel,
        ImpedanceLaw::Controller1ForceSensing,
    ];
    COUNTING.with(|c| c.set(true));
    let mut impedance_ticks = 0u32;
    let mut current_ticks = 0u32;
    let mut fallbacks = 0;
    while impedance_ticks < 10_000 {
        let measured = *haptic.current_setpoints();
        let (_voltages, due) = haptic.current_tick(&measured);
        current_ticks += 1;
        if due {
            haptic.controller.law = laws[(impedance_ticks / 2500) as usize % laws.len()];
            let phase = impedance_ticks as f64 * 1e-3;
            let counts =
                [(3000.0 * (2.0 * phase).sin()) as i32, (2000.0 * (3.0 * phase).cos()) as i32 - 2000];
            let report = haptic.impedance_tick(&ImpedanceInputs {
                encoder_counts: counts,
                force_readings: [0.5, -0.25],
                tick: impedance_ticks,
            });
            if report.control_status == hapticgen_runtime::control::ControlStatus::SingularFallback {
                fallbacks += 1;
            }
            impedance_ticks += 1;
        }
    }
    COUNTING.with(|c| c.set(false));
    let allocations = ALLOCATIONS.with(|n| n.get());
    println!(
        "{impedance_ticks} impedance ticks, {current_ticks} current ticks, {fallbacks} \
         singular fallbacks, fault {:?}: {allocations} allocations",
        haptic.safety().fault()
    );
    assert_eq!(haptic.safety().fault(), None);
    assert_eq!(allocations, 0);
}
