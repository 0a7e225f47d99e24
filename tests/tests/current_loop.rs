//! The inner current loop of section 2, end to end: the gains codegen emitted for each rig
//! (`CURRENT_LOOP_GAINS`), run by the runtime's PI controller at 7.5 kHz against the motor's
//! electrical model `V = I (sL + R)` (locked rotor, simulated finely between samples) with a
//! second-order Bessel anti-aliasing filter at 2.5 kHz on the current sense.
//! Requirements: −3 dB bandwidth within 10 % of 700 Hz, step overshoot under 1 %.

use hapticgen_runtime::current_loop::{CurrentController, CurrentLoopGains};
use hapticgen_tests::{joystick_1dof_f64::Joystick1dof, parallel_link_2dof_vertical_f64::ParallelLink2dof};

const RESISTANCE: f64 = 0.299;
const INDUCTANCE: f64 = 0.082e-3;
const SUPPLY: f64 = 24.0;
const SAMPLE_RATE: f64 = 7500.0;
const FILTER_CUTOFF: f64 = 2500.0;
const SUBSTEPS: usize = 64;

/// Motor current and the Bessel filter's state, integrated with RK4 between samples under a
/// constant (zero-order-held) voltage.
struct Plant {
    current: f64,
    filter: [f64; 2],
}

impl Plant {
    fn derivative(&self, state: [f64; 3], voltage: f64) -> [f64; 3] {
        // Bessel, order 2, −3 dB at FILTER_CUTOFF: H(s) = 3 / ((s/w)² + 3 (s/w) + 3).
        let w = 2.0 * std::f64::consts::PI * FILTER_CUTOFF / 1.3617;
        let [i, y, ydot] = state;
        [(voltage - RESISTANCE * i) / INDUCTANCE, ydot, w * w * (3.0 * i - 3.0 * y) - 3.0 * w * ydot]
    }

    fn advance(&mut self, voltage: f64, period: f64) {
        let h = period / SUBSTEPS as f64;
        let mut x = [self.current, self.filter[0], self.filter[1]];
        for _ in 0..SUBSTEPS {
            let add = |a: [f64; 3], b: [f64; 3], k: f64| [a[0] + k * b[0], a[1] + k * b[1], a[2] + k * b[2]];
            let k1 = self.derivative(x, voltage);
            let k2 = self.derivative(add(x, k1, h / 2.0), voltage);
            let k3 = self.derivative(add(x, k2, h / 2.0), voltage);
            let k4 = self.derivative(add(x, k3, h), voltage);
            x = std::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        }
        self.current = x[0];
        self.filter = [x[1], x[2]];
    }
}

/// Runs the loop for `samples` with a reference `reference(k)`; returns the true current.
fn run(gains: CurrentLoopGains<f64>, samples: usize, reference: impl Fn(usize) -> f64) -> Vec<f64> {
    let mut controller = CurrentController::new(gains, SUPPLY);
    let mut plant = Plant { current: 0.0, filter: [0.0; 2] };
    let period = 1.0 / SAMPLE_RATE;
    (0..samples)
        .map(|k| {
            let output = controller.step(reference(k), plant.filter[0]);
            plant.advance(output.voltage, period);
            plant.current
        })
        .collect()
}

fn overshoot(gains: CurrentLoopGains<f64>) -> f64 {
    let step = 1.0;
    let response = run(gains, 1500, |_| step);
    let peak = response.iter().fold(0.0f64, |m, &x| m.max(x));
    let settled = response[response.len() - 1];
    assert!((settled - step).abs() < 1e-6, "no integral action: settles at {settled}");
    (peak - step) / step
}

fn gain_at(gains: CurrentLoopGains<f64>, frequency: f64) -> f64 {
    let omega = 2.0 * std::f64::consts::PI * frequency / SAMPLE_RATE;
    let amplitude = 0.5;
    let samples = 3000;
    let response = run(gains, samples, |k| amplitude * (omega * k as f64).sin());
    // Amplitude by projection on sine and cosine over the last whole periods.
    let start = samples / 2;
    let (mut s, mut c) = (0.0, 0.0);
    let periods = ((samples - start) as f64 * omega / (2.0 * std::f64::consts::PI)).floor();
    let end = start + (periods * 2.0 * std::f64::consts::PI / omega) as usize;
    for (k, &y) in response.iter().enumerate().take(end).skip(start) {
        s += y * (omega * k as f64).sin();
        c += y * (omega * k as f64).cos();
    }
    let n = (end - start) as f64;
    2.0 * (s * s + c * c).sqrt() / n / amplitude
}

fn bandwidth(gains: CurrentLoopGains<f64>) -> f64 {
    let target = 1.0 / 2.0f64.sqrt();
    let (mut low, mut high) = (50.0, 3000.0);
    assert!(gain_at(gains, low) > target && gain_at(gains, high) < target);
    for _ in 0..40 {
        let mid = 0.5 * (low + high);
        if gain_at(gains, mid) > target {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

#[test]
fn emitted_current_loop_gains_meet_the_paper_specification() {
    let mut rigs = Vec::new();
    rigs.extend(Joystick1dof::CURRENT_LOOP_GAINS.iter().map(|g| ("joystick_1dof", *g)));
    rigs.extend(ParallelLink2dof::CURRENT_LOOP_GAINS.iter().map(|g| ("parallel_link_2dof", *g)));
    for (name, gains) in rigs {
        let bw = bandwidth(gains);
        let os = overshoot(gains);
        println!(
            "{name}: −3 dB bandwidth {bw:.1} Hz (target 700 Hz ± 10 %), step overshoot {:.3} %",
            os * 100.0
        );
        assert!((bw - 700.0).abs() <= 70.0, "{name}: bandwidth {bw} Hz");
        assert!(os < 0.01, "{name}: overshoot {:.3} %", os * 100.0);
    }
}

/// `HapticLoopSettings::for_rig` gives each motor the gains designed for it: on the PUMA 560,
/// whose wrist motors differ from its arm motors, the settings hold the rig's per-joint
/// design in joint order, not one motor's gains for all.
#[test]
fn settings_built_from_the_rig_carry_each_motors_own_gains() {
    use hapticgen_runtime::control::{ImpedanceController, ImpedanceLaw};
    use hapticgen_runtime::tick::HapticLoopSettings;
    use hapticgen_tests::puma560_f64::Puma560;

    let controller =
        ImpedanceController::new(ImpedanceLaw::JacobianTranspose, [100.0; 3], [5.0; 3], [0.2; 3]);
    let settings = HapticLoopSettings::for_rig(&Puma560::NOMINAL, controller);
    assert_eq!(settings.current_gains, Puma560::CURRENT_LOOP_GAINS);
    let first = settings.current_gains[0];
    assert!(
        settings.current_gains.iter().any(|gains| *gains != first),
        "the PUMA's motors differ, so must their gains: {:?}",
        settings.current_gains
    );
}
