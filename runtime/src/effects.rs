//! Free-space force effects for the god-object renderer ([`crate::proxy::GodObject`]): what the
//! operator feels away from every object.
//!
//! The impedance law's interface is a reference `x_d` with gains `K_d`, `B_d`, so that the force
//! on the operator is `K_d (x_d − x) − B_d ẋ`. Each effect is written in those terms, so the
//! control tick is unchanged:
//!
//! * **spring to a point** `a` with stiffness `k`: `x_d = a`, `K_d = k` (force `k (a − x)`);
//! * **viscous field** `b`: `B_d = b` (force `−b ẋ`);
//! * **constant force** `F`: `x_d = x + F / K_d` with the free-space `K_d` (force `F`);
//! * **vibration** along the unit `e` of amplitude `A` and frequency `f`:
//!   `F(t) = A sin(2π f t) e`, by the same offset; `|F| ≤ A` always, the phase kept in
//!   `[0, 1)` so it never loses precision however long the device runs.
//!
//! The forces that need an offset (constant, vibration) need a positive, finite free-space
//! `K_d`; without one they do nothing.

use crate::shape::{add_scaled, finite};
use crate::Real;

/// One free-space effect.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Effect<S, const M: usize> {
    /// No effect: the proxy at the HIP, the free-space gains.
    None,
    /// A spring pulling the device towards `anchor`.
    Spring {
        /// The point the spring pulls towards.
        anchor: [S; M],
        /// Its stiffness, N/m.
        stiffness: S,
    },
    /// A viscous field.
    Viscous {
        /// Damping, N·s/m.
        damping: S,
    },
    /// A constant force.
    Force {
        /// The force, N.
        force: [S; M],
    },
    /// A sinusoidal force along a direction.
    Vibration {
        /// Unit direction.
        direction: [S; M],
        /// Amplitude, N (the force never exceeds it).
        amplitude: S,
        /// Frequency, Hz.
        frequency: S,
        /// The update period, s (the impedance tick's).
        period: S,
    },
}

/// The reference and gains an effect asks for, and its phase state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EffectState<S> {
    phase: S,
}

impl<S: Real> Default for EffectState<S> {
    fn default() -> Self {
        Self { phase: S::ZERO }
    }
}

impl<S: Real> EffectState<S> {
    /// The phase of a vibration, in cycles, in `[0, 1)`.
    pub fn phase(&self) -> S {
        self.phase
    }

    /// The reference `x_d` and gains `(K_d, B_d)` of `effect` for the HIP `hip` with the
    /// free-space gains `stiffness`, `damping`; advances a vibration by one period.
    pub fn apply<const M: usize>(
        &mut self,
        effect: &Effect<S, M>,
        hip: &[S; M],
        stiffness: S,
        damping: S,
    ) -> ([S; M], S, S) {
        let offset = |force: &[S; M]| {
            if stiffness > S::ZERO && stiffness.is_finite() && finite(force) {
                add_scaled(hip, S::ONE / stiffness, force)
            } else {
                *hip
            }
        };
        match *effect {
            Effect::None => (*hip, stiffness, damping),
            Effect::Spring { anchor, stiffness } => (anchor, stiffness, damping),
            Effect::Viscous { damping } => (*hip, stiffness, damping),
            Effect::Force { force } => (offset(&force), stiffness, damping),
            Effect::Vibration { direction, amplitude, frequency, period } => {
                let angle = S::from_f64(2.0 * core::f64::consts::PI) * self.phase;
                let value = amplitude * angle.sin().clamp_to(-S::ONE, S::ONE);
                let step = frequency * period;
                if step.is_finite() {
                    let next = self.phase + step;
                    self.phase = next - next.floor();
                }
                (offset(&add_scaled(&[S::ZERO; M], value, &direction)), stiffness, damping)
            }
        }
    }
}
