//! Objects that move on their own (a scene file's `motion`): each turns at a constant angular
//! velocity `ω` about a pivot `c` while the pivot moves at a constant velocity `v`, so that a
//! point `x` of the object (where it is at time 0) is at time `t` at
//!
//! `P(t) x = R(ω t) (x − c) + c + v t`,
//!
//! and between two updates, at `t₀` and `t₁`, the object moves by the rigid motion
//!
//! `P(t₁) P(t₀)⁻¹ y = R(ω (t₁ − t₀)) (y − c − v t₀) + c + v t₁`
//!
//! (the turn about the pivot where it was, then the pivot's travel). [`MovingObjects`] moves a
//! god object's objects so before each of its updates, carrying a proxy in contact along
//! ([`GodObject::move_object`]): a device that moves its objects itself, from a motion given
//! once, needs neither a link fast enough to stream them nor the host's clock.

use crate::control::ImpedanceParameters;
use crate::control::TaskReference;
use crate::proxy::GodObject;
use crate::shape::RigidMotion;
use crate::tick::ReferenceSource;
use crate::Real;

/// Writes the `K × K` turn `turn` into the top left of `rotation` (called with `K = M`).
fn place<S: Copy, const M: usize, const K: usize>(rotation: &mut [[S; M]; M], turn: &[[S; K]; K]) {
    for (row, turn_row) in rotation.iter_mut().zip(turn.iter()) {
        for (entry, value) in row.iter_mut().zip(turn_row.iter()) {
            *entry = *value;
        }
    }
}

/// How an object moves (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectMotion<S, const M: usize> {
    /// `v`, m/s.
    pub velocity: [S; M],
    /// `ω`, rad/s: in a 2-D task its first entry (counter-clockwise), in 3-D the vector (about
    /// that axis, right-handed, by its length); the identity turn in any other dimension.
    pub angular_velocity: [S; 3],
    /// `c`, the point it turns about, where it is at time 0, m.
    pub pivot: [S; M],
}

impl<S: Real, const M: usize> ObjectMotion<S, M> {
    /// The rotation `R(ω t)` by rows: a planar turn in 2-D, Rodrigues' formula in 3-D
    /// (`R = I + sin θ [u]× + (1 − cos θ) [u]×²`, `θ = |ω| t`, `u = ω/|ω|`), the identity
    /// without a turn.
    pub fn rotation_at(&self, time: S) -> [[S; M]; M] {
        let mut rotation = RigidMotion::<S, M>::identity().rotation;
        let [wx, wy, wz] = self.angular_velocity;
        if M == 2 {
            let (sin, cos) = (wx * time).sin_cos();
            place(&mut rotation, &[[cos, -sin], [sin, cos]]);
        } else if M == 3 {
            let rate = (wx * wx + wy * wy + wz * wz).sqrt();
            if rate > S::ZERO {
                let (x, y, z) = (wx / rate, wy / rate, wz / rate);
                let (sin, cos) = (rate * time).sin_cos();
                let one_minus_cos = S::ONE - cos;
                let turn = [
                    [
                        cos + x * x * one_minus_cos,
                        x * y * one_minus_cos - z * sin,
                        x * z * one_minus_cos + y * sin,
                    ],
                    [
                        y * x * one_minus_cos + z * sin,
                        cos + y * y * one_minus_cos,
                        y * z * one_minus_cos - x * sin,
                    ],
                    [
                        z * x * one_minus_cos - y * sin,
                        z * y * one_minus_cos + x * sin,
                        cos + z * z * one_minus_cos,
                    ],
                ];
                place(&mut rotation, &turn);
            }
        }
        rotation
    }

    /// Where the pivot is at `time`: `c + v t`.
    pub fn pivot_at(&self, time: S) -> [S; M] {
        let mut pivot = self.pivot;
        for (c, v) in pivot.iter_mut().zip(self.velocity.iter()) {
            *c += *v * time;
        }
        pivot
    }

    /// The rigid motion from where the object is at `from` to where it is at `to`:
    /// `y ↦ R(ω (to − from)) (y − c(from)) + c(to)`.
    pub fn between(&self, from: S, to: S) -> RigidMotion<S, M> {
        let turn = RigidMotion { rotation: self.rotation_at(to - from), translation: [S::ZERO; M] };
        let (before, after) = (self.pivot_at(from), self.pivot_at(to));
        let turned = turn.rotate(&before);
        let mut translation = after;
        for (t, r) in translation.iter_mut().zip(turned.iter()) {
            *t -= *r;
        }
        RigidMotion { rotation: turn.rotation, translation }
    }
}

/// A god object whose objects move on their own: before each update (one per impedance tick,
/// `period` apart, the first at time 0) every object with a motion is moved from where it was
/// at the last update to where its motion has taken it.
#[derive(Clone, Copy, Debug)]
pub struct MovingObjects<'a, S, const K: usize, const M: usize> {
    /// The renderer.
    pub god_object: GodObject<'a, S, K, M>,
    /// Each object slot's motion; `None` for an object that stays.
    motions: [Option<ObjectMotion<S, M>>; K],
    period: S,
    updates: u32,
    /// Whether any object has a motion (else an update moves nothing and costs nothing).
    moving: bool,
    /// Moves the god object refused (a motion that is not rigid: [`GodObject::move_object`]);
    /// the object then stays where it was.
    pub refused: u32,
}

impl<'a, S: Real, const K: usize, const M: usize> MovingObjects<'a, S, K, M> {
    /// `god_object` with the objects' `motions`, updated every `period` seconds.
    pub fn new(
        god_object: GodObject<'a, S, K, M>,
        motions: [Option<ObjectMotion<S, M>>; K],
        period: S,
    ) -> Self {
        let moving = motions.iter().any(Option::is_some);
        Self { god_object, motions, period, updates: 0, moving, refused: 0 }
    }

    /// Each object slot's motion; `None` for an object that stays.
    pub fn motions(&self) -> &[Option<ObjectMotion<S, M>>; K] {
        &self.motions
    }

    /// Sets the motion of object slot `index` (`None`: it stays where it is now); `false` for
    /// an index beyond the slots.
    pub fn set_motion(&mut self, index: usize, motion: Option<ObjectMotion<S, M>>) -> bool {
        let set = match self.motions.get_mut(index) {
            Some(slot) => {
                *slot = motion;
                true
            }
            None => false,
        };
        self.moving = self.motions.iter().any(Option::is_some);
        set
    }

    /// The time of the next update, s.
    pub fn time(&self) -> S {
        S::from_f64(f64::from(self.updates)) * self.period
    }

    /// Moves every moving object to where it is at the next update's time.
    fn pose(&mut self) {
        if !self.moving || self.updates == 0 {
            return;
        }
        let to = self.time();
        let from = S::from_f64(f64::from(self.updates - 1)) * self.period;
        for (index, motion) in self.motions.iter().enumerate() {
            if let Some(motion) = motion {
                if !self.god_object.move_object(index, &motion.between(from, to)) {
                    self.refused = self.refused.saturating_add(1);
                }
            }
        }
    }
}

impl<'a, S: Real, const K: usize, const M: usize> ReferenceSource<S, M> for MovingObjects<'a, S, K, M> {
    fn update_reference(
        &mut self,
        task_position: &[S; M],
        parameters: &mut ImpedanceParameters<S, M>,
    ) -> TaskReference<S, M> {
        self.pose();
        self.updates = self.updates.saturating_add(1);
        self.god_object.update_reference(task_position, parameters)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::ObjectKind;
    use crate::shape::{Material, Object, Shape};

    fn apply(motion: &RigidMotion<f64, 3>, x: &[f64; 3]) -> [f64; 3] {
        let turned = motion.rotate(x);
        [
            turned[0] + motion.translation[0],
            turned[1] + motion.translation[1],
            turned[2] + motion.translation[2],
        ]
    }

    /// The turn against its defining properties (orthonormal, the axis kept, the angle from
    /// the trace, the sense right-handed), and the motion between two times against the
    /// object's pose `P(t) x = R(ω t)(x − c) + c + v t` written out here.
    #[test]
    fn an_object_turns_about_its_moving_pivot() {
        let motion = ObjectMotion {
            velocity: [0.01, -0.02, 0.03],
            angular_velocity: [0.3, -0.4, 1.2],
            pivot: [0.1, 0.2, -0.1],
        };
        let t = 0.7;
        let r = motion.rotation_at(t);
        for i in 0..3 {
            for k in 0..3 {
                let product: f64 = (0..3).map(|j| r[i][j] * r[k][j]).sum();
                assert!((product - f64::from(u8::from(i == k))).abs() < 1e-12, "{r:?}");
            }
        }
        let axis = [0.3, -0.4, 1.2];
        let rate = (0.09f64 + 0.16 + 1.44).sqrt();
        let kept = RigidMotion { rotation: r, translation: [0.0; 3] }.rotate(&axis);
        for k in 0..3 {
            assert!((kept[k] - axis[k]).abs() < 1e-12);
        }
        assert!((r[0][0] + r[1][1] + r[2][2] - (1.0 + 2.0 * (rate * t).cos())).abs() < 1e-12);
        // About z alone, a quarter turn takes x to y.
        let about_z = ObjectMotion { velocity: [0.0; 3], angular_velocity: [0.0, 0.0, 1.0], pivot: [0.0; 3] };
        let quarter = about_z.rotation_at(core::f64::consts::FRAC_PI_2);
        assert!((quarter[1][0] - 1.0).abs() < 1e-12 && quarter[0][0].abs() < 1e-12);
        // In the plane, counter-clockwise.
        let planar = ObjectMotion { velocity: [0.0; 2], angular_velocity: [1.0, 0.0, 0.0], pivot: [0.0; 2] };
        let planar_quarter = planar.rotation_at(core::f64::consts::FRAC_PI_2);
        assert!((planar_quarter[1][0] - 1.0).abs() < 1e-12 && planar_quarter[0][1] + 1.0 < 1e-12);
        // From 0.2 s to 0.9 s, a point of the object goes from P(0.2) x to P(0.9) x.
        let pose = |time: f64, x: &[f64; 3]| {
            let offset = [x[0] - 0.1, x[1] - 0.2, x[2] + 0.1];
            let turned =
                RigidMotion { rotation: motion.rotation_at(time), translation: [0.0; 3] }.rotate(&offset);
            [turned[0] + 0.1 + 0.01 * time, turned[1] + 0.2 - 0.02 * time, turned[2] - 0.1 + 0.03 * time]
        };
        let x = [0.05, -0.3, 0.2];
        let moved = apply(&motion.between(0.2, 0.9), &pose(0.2, &x));
        let expected = pose(0.9, &x);
        for k in 0..3 {
            assert!((moved[k] - expected[k]).abs() < 1e-12, "{moved:?} vs {expected:?}");
        }
        // No motion without velocity or turn.
        let still = ObjectMotion { velocity: [0.0; 3], angular_velocity: [0.0; 3], pivot: [1.0, 2.0, 3.0] };
        assert_eq!(still.between(0.0, 5.0), RigidMotion::identity());
    }

    /// A floor rising at 1 cm/s under a HIP held 5 mm below where it started: each update
    /// moves the floor by one period's rise, and the proxy resting on it rises with it.
    #[test]
    fn a_rising_floor_lifts_the_proxy_resting_on_it() {
        let mut god_object: GodObject<f64, 2, 3> = GodObject::new(0.0, 0.0, 0.0, 1e-9);
        let floor = Shape::HalfSpace { point: [0.0, 0.0, -0.01], normal: [0.0, 0.0, 1.0] };
        god_object
            .add(Object {
                shape: floor,
                kind: ObjectKind::Solid,
                material: Material::frictionless(1000.0, 1.0),
            })
            .unwrap();
        god_object.reset([0.0; 3]); // Above the floor.
        let rise = ObjectMotion { velocity: [0.0, 0.0, 0.01], angular_velocity: [0.0; 3], pivot: [0.0; 3] };
        // Made to move after the scene was built.
        let mut scene = MovingObjects::new(god_object, [None, None], 0.001);
        assert!(scene.set_motion(0, Some(rise)));
        let mut parameters = ImpedanceParameters { stiffness: [0.0; 3], damping: [0.0; 3], mass: [1.0; 3] };
        let hip = [0.0, 0.0, -0.015];
        for update in 0..500 {
            let reference = scene.update_reference(&hip, &mut parameters);
            // At update k the floor is at −0.01 + 0.01 · k · 1 ms (it reaches the HIP's height
            // after 500 ms, where the loop ends).
            let floor_height = -0.01 + 0.01 * f64::from(update) * 0.001;
            assert!((reference.position[2] - floor_height).abs() < 1e-9, "update {update}: {reference:?}");
            assert_eq!(parameters.stiffness, [1000.0; 3]);
        }
        assert!((scene.time() - 0.5).abs() < 1e-12);
        assert_eq!(scene.refused, 0);
        // Stopped, the floor stays where it is; a slot beyond the god object's is refused.
        assert!(scene.set_motion(0, None));
        assert!(!scene.set_motion(2, Some(rise)));
        let resting = scene.update_reference(&hip, &mut parameters).position;
        for _ in 0..10 {
            assert_eq!(scene.update_reference(&hip, &mut parameters).position, resting);
        }
        assert!((resting[2] - (-0.01 + 0.01 * 0.499)).abs() < 1e-9, "{resting:?}");
    }
}
