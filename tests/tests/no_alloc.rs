//! The generated parallel link in the full control stack allocates nothing: a counting global
//! allocator over 10,000 impedance ticks (estimation, fused generated law and the generic law,
//! rendering of a virtual circle, safety) and their 75,000 current-loop ticks.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use hapticgen_runtime::control::{ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
use hapticgen_tests::parallel_link_2dof_vertical_f64::ParallelLink2dof;

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

#[test]
fn ten_thousand_generated_ticks_allocate_nothing() {
    let mut scene: Scene<f64, 2, 8> = Scene::new(0.0, 5.0, 0.3e-3);
    scene.add(VirtualObject {
        shape: Shape::Circle { center: [0.0, 0.13], radius: 0.02 },
        kind: ObjectKind::Cavity,
        stiffness: 1500.0,
        damping: 5.0,
    });
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law: ImpedanceLaw::Controller3,
            parameters: ImpedanceParameters { stiffness: [0.0; 2], damping: [5.0; 2], mass: [0.2; 2] },
            options: ControlOptions { min_abs_jacobian_determinant: 1e-4, ..ControlOptions::paper() },
        },
        estimator: EstimatorSettings { sample_period: 1e-3, velocity_cutoff_hz: 50.0, acceleration_cutoff_hz: 20.0 },
        zero_offset: [1.4, 0.1],
        initial_counts: [0; 2],
        force_calibration: ForceSensorCalibration { scale: [5.0; 2], offset: [2.5; 2] },
        current_gains: ParallelLink2dof::CURRENT_LOOP_GAINS[0],
        max_tick_gap: 1,
    };
    let mut haptic = HapticLoop::new(ParallelLink2dof::NOMINAL, scene, &settings).expect("settings");
    let laws = [
        ImpedanceLaw::Controller3,
        ImpedanceLaw::Controller2Mobility,
        ImpedanceLaw::Controller2Accel,
        ImpedanceLaw::Controller1ForceSensing,
    ];
    let measured = [0.2, -0.1];
    let (mut impedance_ticks, mut current_ticks, mut tick) = (0, 0, 0u32);
    COUNTING.with(|c| c.set(true));
    while impedance_ticks < 10_000 {
        current_ticks += 1;
        let (_, due) = haptic.current_tick(&measured);
        if due {
            tick += 1;
            haptic.controller.law = laws[(tick as usize / 2500) % laws.len()];
            let t = f64::from(tick) * 1e-3;
            let inputs = ImpedanceInputs {
                encoder_counts: [(600.0 * (2.0 * t).sin()) as i32, (900.0 * (1.3 * t).sin()) as i32],
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
    COUNTING.with(|c| c.set(false));
    let allocations = ALLOCATIONS.with(Cell::get);
    assert!(current_ticks >= 74_990, "{current_ticks} current ticks");
    assert_eq!(allocations, 0, "{allocations} allocations in {impedance_ticks} ticks");
    assert!(haptic.safety().fault().is_none(), "{:?}", haptic.safety().fault());
}
