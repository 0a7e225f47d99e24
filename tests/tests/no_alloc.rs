//! The generated parallel link in the full control stack allocates nothing: a counting global
//! allocator over 10,000 impedance ticks (estimation, fused generated law and the generic law,
//! rendering of a virtual circle, safety) and their 75,000 current-loop ticks.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use hapticgen_runtime::control::ImpedanceLaw;
use hapticgen_runtime::tick::{HapticLoop, ImpedanceInputs};
use hapticgen_tests::parallel_link_2dof_vertical_f64::ParallelLink2dof;
use hapticgen_tests::stack::{circle_scene, encoder_counts, parallel_link_settings};

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
    let settings = parallel_link_settings(ImpedanceLaw::Controller3);
    let mut haptic = HapticLoop::new(ParallelLink2dof::NOMINAL, circle_scene(), &settings).expect("settings");
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
    COUNTING.with(|c| c.set(false));
    let allocations = ALLOCATIONS.with(Cell::get);
    assert!(current_ticks >= 74_990, "{current_ticks} current ticks");
    assert_eq!(allocations, 0, "{allocations} allocations in {impedance_ticks} ticks");
    assert!(haptic.safety().fault().is_none(), "{:?}", haptic.safety().fault());
}
