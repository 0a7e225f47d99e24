//! Design of the inner current loop (paper, section 2): discrete pole placement for a PI
//! controller with integral action on the motor's electrical model `V(s) = I(s)(sL + R)`.
//!
//! The result feeds `hapticgen_runtime::current_loop::CurrentLoopGains`; the controller form
//! assumed here is exactly the runtime's:
//!
//! ```text
//! v_k = kp·(β·r_k − y_k) + z_k,    z_{k+1} = z_k + ki·T·(r_k − y_k)
//! ```
//!
//! with `β = 0` (proportional action on the measurement, "I-P"): a textbook PI (`β = 1`) puts a
//! zero at `1 − ki·T/kp` that makes even an overdamped pole pair overshoot by 10 % or more; with
//! `β = 0` the reference-to-current transfer has no controller zero, so an overdamped placement
//! gives a (practically) monotone step.
//!
//! **Plant model.** The armature `1/(sL + R)` is driven by a zero-order hold (the PWM voltage
//! computed at sample `k` is held until `k + 1`) and discretised exactly (matrix exponential).
//! The current is measured through the anti-aliasing Bessel filter. A Bessel filter has an
//! almost linear phase, i.e. it acts mostly as a delay equal to its DC group delay; that delay
//! is modelled as a **first-order lag `1/(τs + 1)` with `τ` = the Bessel filter's DC group
//! delay** (`τ = d_n / ω_c`, with `d_n` = 1, 1.3617, 1.7557, 2.1139 for orders 1–4 of a
//! Bessel filter normalised to −3 dB at `ω_c`). The lag has the same low-frequency phase
//! (`−ωτ`) as the filter, which is what matters up to the loop's bandwidth. Plant and lag are
//! discretised together, exactly.
//!
//! **Placement.** The gains place the closed-loop poles of the loop on the armature model
//! `b/(z − a)` (`a = e^{−RT/L}`, `b = (1 − a)/R`) exactly at the ZOH image `e^{sT}` of the
//! continuous pair with natural frequency `ω_n` and damping `ζ`:
//! `(z − 1)(z − a) + b·(kp·(z − 1) + ki·T) = z² + d₁z + d₀`, i.e.
//! `kp = (d₁ + 1 + a)/b`, `ki = (d₀ − a + b·kp)/(b·T)`.
//! The filter lag is then taken into account in the choice of `ω_n`: it is found by bisection
//! so that the −3 dB bandwidth from the reference to the true (unfiltered) current, computed on
//! the unit circle for the loop *with* the lag in the feedback path, equals the requested one.
//!
//! Why not place all poles of the loop with the lag: with the lag the loop has three poles and
//! the PI only two gains. Requiring the overdamped pair of a 700 Hz loop (`ω_n` ≈ 1.17 kHz for
//! `ζ = 1.05`) to be exact roots forces the third pole outside the unit circle for any
//! realistic anti-aliasing cutoff at 7.5 kHz. The lag therefore turns the placed pair into
//! a real dominant pole plus a faster, less damped pair; [`CurrentLoopDesign`] reports these
//! poles of the full loop (`achieved_damping_ratio` is that of the dominant, slowest mode,
//! `least_damping_ratio` the smallest of all modes), and the reference step stays free of
//! overshoot because, with `β = 0`, the controller adds no zero.

use std::f64::consts::PI;

/// What the current-loop designer needs to know.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoopDesignInput {
    /// Armature resistance R, Ω.
    pub resistance: f64,
    /// Armature inductance L, H.
    pub inductance: f64,
    /// Current-loop sample rate, Hz (7500 in the paper).
    pub sample_rate_hz: f64,
    /// Requested closed-loop −3 dB bandwidth, Hz (700 in the paper).
    pub bandwidth_hz: f64,
    /// Requested damping ratio of the dominant pole pair (slightly overdamped: 1.05).
    pub damping_ratio: f64,
    /// −3 dB cutoff of the anti-aliasing Bessel filter on the current sense, Hz.
    pub filter_cutoff_hz: f64,
    /// Order of the Bessel filter, 1 to 4.
    pub filter_order: u32,
}

/// The designed gains and what they achieve on the design model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoopDesign {
    /// Proportional gain, V/A.
    pub kp: f64,
    /// Integral gain, V/(A·s).
    pub ki: f64,
    /// Setpoint weight β of the proportional term (0: proportional on the measurement).
    pub proportional_setpoint_weight: f64,
    /// Sample period T, s.
    pub sample_period: f64,
    /// Time constant of the first-order lag standing for the Bessel filter, s.
    pub filter_time_constant: f64,
    /// Natural frequency `ω_n/2π` of the pair placed on the armature model, Hz (the requested
    /// damping ratio is placed exactly on that model).
    pub natural_frequency_hz: f64,
    /// −3 dB bandwidth of the loop with the filter lag (reference → true current), Hz.
    pub achieved_bandwidth_hz: f64,
    /// Damping ratio of the dominant (slowest) mode of the loop with the filter lag
    /// (1 for a real pole).
    pub achieved_damping_ratio: f64,
    /// Natural frequency of that dominant mode, Hz.
    pub dominant_mode_hz: f64,
    /// Smallest damping ratio among all modes of the loop with the filter lag.
    pub least_damping_ratio: f64,
    /// Closed-loop poles of the loop with the filter lag, z-plane `(re, im)`.
    pub closed_loop_poles: [(f64, f64); 3],
    /// Mean delay of the closed loop from setpoint to armature current, s: `Σ (1 − y_k) T`
    /// over its unit-step response (the group delay at DC). The impedance law's
    /// `spring_lead_time` can compensate it.
    pub mean_delay: f64,
}

/// Normalised DC group delay of Bessel filters of order 1–4 with −3 dB at 1 rad/s.
const BESSEL_GROUP_DELAY: [f64; 4] = [1.0, 1.3617, 1.7557, 2.1139];

/// Designs the PI current controller; see the module docs for the method.
pub fn design_current_loop(input: &CurrentLoopDesignInput) -> Result<CurrentLoopDesign, String> {
    let positive = |name: &str, value: f64| {
        if value.is_finite() && value > 0.0 {
            Ok(())
        } else {
            Err(format!("current loop: {name} must be positive and finite, got {value}"))
        }
    };
    positive("resistance", input.resistance)?;
    positive("inductance", input.inductance)?;
    positive("sample rate", input.sample_rate_hz)?;
    positive("bandwidth", input.bandwidth_hz)?;
    positive("damping ratio", input.damping_ratio)?;
    positive("filter cutoff", input.filter_cutoff_hz)?;
    let nyquist = input.sample_rate_hz / 2.0;
    if input.bandwidth_hz >= 0.5 * nyquist {
        return Err(format!(
            "current loop: bandwidth {} Hz must be below a quarter of the sample rate ({} Hz, half the \
             Nyquist frequency {nyquist} Hz)",
            input.bandwidth_hz,
            0.5 * nyquist
        ));
    }
    let group_delay = match input.filter_order {
        1..=4 => BESSEL_GROUP_DELAY[input.filter_order as usize - 1],
        other => return Err(format!("current loop: Bessel filter order must be 1 to 4, got {other}")),
    };
    let sample_period = 1.0 / input.sample_rate_hz;
    let filter_time_constant = group_delay / (2.0 * PI * input.filter_cutoff_hz);
    let plant = DiscretePlant::new(input.resistance, input.inductance, filter_time_constant, sample_period);

    let target = input.bandwidth_hz;
    let zeta = input.damping_ratio;
    let evaluate = |natural_hz: f64| -> Option<(Placement, f64)> {
        let placement = plant.place(natural_hz, zeta);
        let poles = cubic_roots(&characteristic_polynomial(&plant.closed_loop(&placement).0));
        if !poles.iter().all(|&(re, im)| re.hypot(im) < 1.0) {
            return None;
        }
        let bandwidth = plant.bandwidth_hz(&placement, nyquist)?;
        Some((placement, bandwidth))
    };
    // The bandwidth grows with ω_n; bisect on ω_n. An unstable loop counts as "too fast".
    let (mut low, mut high) = (0.1 * target, 0.45 * input.sample_rate_hz);
    let mut best = None;
    for _ in 0..52 {
        let middle = 0.5 * (low + high);
        match evaluate(middle) {
            Some((placement, bandwidth)) => {
                if bandwidth < target {
                    low = middle;
                } else {
                    high = middle;
                }
                best = Some((placement, bandwidth, middle));
            }
            None => high = middle,
        }
    }
    let (placement, achieved_bandwidth_hz, natural_frequency_hz) =
        best.ok_or_else(|| "current loop: no stable design found".to_string())?;
    if (achieved_bandwidth_hz - target).abs() > 0.01 * target {
        return Err(format!(
            "current loop: cannot reach {target} Hz with this sample rate and filter \
             (best {achieved_bandwidth_hz:.1} Hz)"
        ));
    }
    let poles = cubic_roots(&characteristic_polynomial(&plant.closed_loop(&placement).0));
    let modes = poles.map(|z| continuous_mode(z, sample_period));
    let dominant =
        modes.iter().copied().fold(
            (f64::INFINITY, 1.0),
            |slowest, mode| {
                if mode.0 < slowest.0 {
                    mode
                } else {
                    slowest
                }
            },
        );
    let least_damping_ratio = modes.iter().map(|mode| mode.1).fold(f64::INFINITY, f64::min);
    Ok(CurrentLoopDesign {
        kp: placement.kp,
        ki: placement.ki,
        proportional_setpoint_weight: 0.0,
        sample_period,
        filter_time_constant,
        natural_frequency_hz,
        achieved_bandwidth_hz,
        achieved_damping_ratio: dominant.1,
        dominant_mode_hz: dominant.0 / (2.0 * PI),
        least_damping_ratio,
        closed_loop_poles: poles,
        mean_delay: plant.mean_delay(&placement),
    })
}

#[derive(Clone, Copy, Debug)]
struct Placement {
    kp: f64,
    ki: f64,
}

/// Armature current and filtered current, `ẋ = A x + B v`, discretised with a ZOH.
struct DiscretePlant {
    transition: [[f64; 2]; 2],
    input: [f64; 2],
    sample_period: f64,
    /// `a = e^{−RT/L}` of the armature alone.
    armature_pole: f64,
    /// `b = (1 − a)/R` of the armature alone.
    armature_gain: f64,
}

impl DiscretePlant {
    fn new(resistance: f64, inductance: f64, filter_time_constant: f64, period: f64) -> Self {
        let a = [[-resistance / inductance, 0.0], [1.0 / filter_time_constant, -1.0 / filter_time_constant]];
        let b = [1.0 / inductance, 0.0];
        let (transition, input) = zoh_discretise(&a, &b, period);
        let armature_pole = (-resistance * period / inductance).exp();
        Self {
            transition,
            input,
            sample_period: period,
            armature_pole,
            armature_gain: (1.0 - armature_pole) / resistance,
        }
    }

    /// Closed-loop matrix on `[i, i_f, z]` (z = integral state in volts) and the reference
    /// input vector, for the runtime's PI with β = 0.
    fn closed_loop(&self, gains: &Placement) -> ([[f64; 3]; 3], [f64; 3]) {
        let (phi, gamma, t) = (&self.transition, &self.input, self.sample_period);
        // v = −kp·i_f + z;  z⁺ = z + ki·T·(r − i_f).
        let matrix = [
            [phi[0][0], phi[0][1] - gains.kp * gamma[0], gamma[0]],
            [phi[1][0], phi[1][1] - gains.kp * gamma[1], gamma[1]],
            [0.0, -gains.ki * t, 1.0],
        ];
        (matrix, [0.0, 0.0, gains.ki * t])
    }

    /// Places the pair `(ω_n, ζ)` exactly on the armature-only model (see the module docs).
    fn place(&self, natural_hz: f64, zeta: f64) -> Placement {
        let t = self.sample_period;
        let wn = 2.0 * PI * natural_hz;
        let (d1, d0) = if zeta >= 1.0 {
            let root = (zeta * zeta - 1.0).sqrt();
            let z1 = ((-zeta + root) * wn * t).exp();
            let z2 = ((-zeta - root) * wn * t).exp();
            (-(z1 + z2), z1 * z2)
        } else {
            let radius = (-zeta * wn * t).exp();
            let angle = wn * (1.0 - zeta * zeta).sqrt() * t;
            (-2.0 * radius * angle.cos(), radius * radius)
        };
        let (a, b) = (self.armature_pole, self.armature_gain);
        let kp = (d1 + 1.0 + a) / b;
        let ki = (d0 - a + b * kp) / (b * t);
        Placement { kp, ki }
    }

    /// Mean delay of the unit-step response of reference → armature current, s.
    fn mean_delay(&self, gains: &Placement) -> f64 {
        let (matrix, input) = self.closed_loop(gains);
        let mut x = [0.0f64; 3];
        let mut delay = 0.0;
        // Long enough for the slowest mode (a few hundred Hz) to decay completely.
        for _ in 0..20_000 {
            delay += (1.0 - x[0]) * self.sample_period;
            x = std::array::from_fn(|i| (0..3).map(|j| matrix[i][j] * x[j]).sum::<f64>() + input[i]);
        }
        delay
    }

    /// −3 dB bandwidth of reference → armature current, Hz; `None` if it never drops 3 dB
    /// below Nyquist.
    fn bandwidth_hz(&self, gains: &Placement, nyquist: f64) -> Option<f64> {
        let (matrix, input) = self.closed_loop(gains);
        let gain_at = |hz: f64| {
            let angle = 2.0 * PI * hz * self.sample_period;
            frequency_response_magnitude(&matrix, &input, angle)
        };
        let dc = gain_at(0.0);
        let threshold = dc / 2f64.sqrt();
        // A coarse scan finds the first crossing (the response is smooth on this scale: the
        // loop's slowest mode is far above nyquist / 400); bisection then refines it.
        let step = nyquist / 400.0;
        let mut previous = 0.0;
        let mut hz = step;
        while hz < nyquist {
            if gain_at(hz) < threshold {
                let (mut low, mut high) = (previous, hz);
                for _ in 0..60 {
                    let middle = 0.5 * (low + high);
                    if gain_at(middle) < threshold {
                        high = middle;
                    } else {
                        low = middle;
                    }
                }
                return Some(0.5 * (low + high));
            }
            previous = hz;
            hz += step;
        }
        None
    }
}

/// `|H(e^{jθ})|` for `H(z) = e₀ᵀ (zI − A)⁻¹ b` (output: the armature current, state 0).
fn frequency_response_magnitude(matrix: &[[f64; 3]; 3], input: &[f64; 3], angle: f64) -> f64 {
    let (c, s) = (angle.cos(), angle.sin());
    // Complex 3x3 system (zI − A) x = b by Gaussian elimination with partial pivoting.
    let mut re = [[0.0; 3]; 3];
    let mut im = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            re[i][j] = -matrix[i][j];
        }
        re[i][i] += c;
        im[i][i] += s;
    }
    let mut b_re = *input;
    let mut b_im = [0.0; 3];
    for col in 0..3 {
        let mut pivot = col;
        for row in col + 1..3 {
            if re[row][col].hypot(im[row][col]) > re[pivot][col].hypot(im[pivot][col]) {
                pivot = row;
            }
        }
        re.swap(col, pivot);
        im.swap(col, pivot);
        b_re.swap(col, pivot);
        b_im.swap(col, pivot);
        let (pr, pi) = (re[col][col], im[col][col]);
        let norm = pr * pr + pi * pi;
        for row in col + 1..3 {
            // factor = a[row][col] / pivot
            let (ar, ai) = (re[row][col], im[row][col]);
            let fr = (ar * pr + ai * pi) / norm;
            let fi = (ai * pr - ar * pi) / norm;
            for k in col..3 {
                let (xr, xi) = (re[col][k], im[col][k]);
                re[row][k] -= fr * xr - fi * xi;
                im[row][k] -= fr * xi + fi * xr;
            }
            let (xr, xi) = (b_re[col], b_im[col]);
            b_re[row] -= fr * xr - fi * xi;
            b_im[row] -= fr * xi + fi * xr;
        }
    }
    let mut x_re = [0.0; 3];
    let mut x_im = [0.0; 3];
    for i in (0..3).rev() {
        let (mut sr, mut si) = (b_re[i], b_im[i]);
        for k in i + 1..3 {
            sr -= re[i][k] * x_re[k] - im[i][k] * x_im[k];
            si -= re[i][k] * x_im[k] + im[i][k] * x_re[k];
        }
        let (pr, pi) = (re[i][i], im[i][i]);
        let norm = pr * pr + pi * pi;
        x_re[i] = (sr * pr + si * pi) / norm;
        x_im[i] = (si * pr - sr * pi) / norm;
    }
    x_re[0].hypot(x_im[0])
}

/// `(a2, a1, a0)` of `det(zI − A) = z³ + a2 z² + a1 z + a0`.
fn characteristic_polynomial(a: &[[f64; 3]; 3]) -> [f64; 3] {
    let trace = a[0][0] + a[1][1] + a[2][2];
    let minors = a[0][0] * a[1][1] - a[0][1] * a[1][0] + a[0][0] * a[2][2] - a[0][2] * a[2][0]
        + a[1][1] * a[2][2]
        - a[1][2] * a[2][1];
    [-trace, minors, -det3(a)]
}

fn det3(a: &[[f64; 3]; 3]) -> f64 {
    a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
}

/// Roots of `z³ + a2 z² + a1 z + a0` as `(re, im)`, by Durand–Kerner iteration.
fn cubic_roots(coefficients: &[f64; 3]) -> [(f64, f64); 3] {
    let [a2, a1, a0] = *coefficients;
    let mul = |p: (f64, f64), q: (f64, f64)| (p.0 * q.0 - p.1 * q.1, p.0 * q.1 + p.1 * q.0);
    let mut roots = [(0.4, 0.9), (-0.65, 0.72), (0.9, -0.4)];
    for _ in 0..500 {
        for i in 0..3 {
            let z = roots[i];
            let z2 = mul(z, z);
            let z3 = mul(z2, z);
            let value = (z3.0 + a2 * z2.0 + a1 * z.0 + a0, z3.1 + a2 * z2.1 + a1 * z.1);
            let mut denominator = (1.0, 0.0);
            for (j, other) in roots.iter().enumerate() {
                if j != i {
                    denominator = mul(denominator, (z.0 - other.0, z.1 - other.1));
                }
            }
            let norm = denominator.0 * denominator.0 + denominator.1 * denominator.1;
            if norm > 0.0 {
                let quotient = (
                    (value.0 * denominator.0 + value.1 * denominator.1) / norm,
                    (value.1 * denominator.0 - value.0 * denominator.1) / norm,
                );
                roots[i] = (z.0 - quotient.0, z.1 - quotient.1);
            }
        }
    }
    roots
}

/// `(ω, ζ)` of the continuous mode `s = ln(z)/T` equivalent to a z-plane pole.
fn continuous_mode(pole: (f64, f64), period: f64) -> (f64, f64) {
    let sigma = pole.0.hypot(pole.1).ln() / period;
    let omega = pole.1.atan2(pole.0) / period;
    let natural = sigma.hypot(omega);
    (natural, if natural > 0.0 { -sigma / natural } else { 1.0 })
}

/// Exact ZOH discretisation of `ẋ = A x + b v`: `Φ = e^{AT}`, `Γ = ∫₀ᵀ e^{Aσ} dσ b`, from the
/// exponential of the augmented matrix `[[A, b], [0, 0]]·T`.
fn zoh_discretise(a: &[[f64; 2]; 2], b: &[f64; 2], period: f64) -> ([[f64; 2]; 2], [f64; 2]) {
    let mut augmented = [[0.0; 3]; 3];
    for i in 0..2 {
        for j in 0..2 {
            augmented[i][j] = a[i][j] * period;
        }
        augmented[i][2] = b[i] * period;
    }
    let e = expm(&augmented);
    ([[e[0][0], e[0][1]], [e[1][0], e[1][1]]], [e[0][2], e[1][2]])
}

/// Matrix exponential by scaling and squaring with a Taylor series (ample for 3 × 3 with
/// real, well-separated eigenvalues).
#[allow(clippy::needless_range_loop)] // textbook i, j, m matrix products
pub(crate) fn expm<const N: usize>(a: &[[f64; N]; N]) -> [[f64; N]; N] {
    let norm = a.iter().map(|row| row.iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max);
    let mut squarings = 0;
    let mut scale = 1.0;
    while norm * scale > 0.25 {
        scale *= 0.5;
        squarings += 1;
    }
    let mut result = [[0.0; N]; N];
    let mut term = [[0.0; N]; N];
    for i in 0..N {
        result[i][i] = 1.0;
        term[i][i] = 1.0;
    }
    for k in 1..=20 {
        let mut next = [[0.0; N]; N];
        for i in 0..N {
            for j in 0..N {
                for m in 0..N {
                    next[i][j] += term[i][m] * a[m][j] * scale;
                }
                next[i][j] /= k as f64;
            }
        }
        term = next;
        for i in 0..N {
            for j in 0..N {
                result[i][j] += term[i][j];
            }
        }
    }
    for _ in 0..squarings {
        let mut squared = [[0.0; N]; N];
        for i in 0..N {
            for j in 0..N {
                for m in 0..N {
                    squared[i][j] += result[i][m] * result[m][j];
                }
            }
        }
        result = squared;
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RE40: R = 0.299 Ω, L = 0.082 mH, k_t = 30.2 mN·m/A, 24 V supply; 7.5 kHz, 700 Hz, ζ = 1.05.
    const RESISTANCE: f64 = 0.299;
    const INDUCTANCE: f64 = 0.082e-3;
    const TORQUE_CONSTANT: f64 = 30.2e-3;
    const SUPPLY: f64 = 24.0;

    fn re40_input(filter_cutoff_hz: f64, filter_order: u32) -> CurrentLoopDesignInput {
        CurrentLoopDesignInput {
            resistance: RESISTANCE,
            inductance: INDUCTANCE,
            sample_rate_hz: 7500.0,
            bandwidth_hz: 700.0,
            damping_ratio: 1.05,
            filter_cutoff_hz,
            filter_order,
        }
    }

    /// The sampled-data loop, simulated independently of the design model: the armature
    /// (with back-EMF `k_t·ω` of a locked rotor, ω = 0) and the *true* Bessel filter of the
    /// given order as a state-space system, discretised exactly with a ZOH on the voltage;
    /// the PI exactly in the runtime's form, saturation at ± supply included.
    struct Simulation {
        transition: Vec<Vec<f64>>,
        input: Vec<f64>,
        state: Vec<f64>,
        integral: f64,
        design: CurrentLoopDesign,
    }

    impl Simulation {
        fn new(design: CurrentLoopDesign, filter_cutoff_hz: f64, filter_order: u32) -> Self {
            // Bessel polynomials (delay-normalised) scaled so that −3 dB is at the cutoff.
            let (coefficients, three_db): (Vec<f64>, f64) = match filter_order {
                1 => (vec![1.0], 1.0),
                2 => (vec![3.0, 3.0], 1.3617),
                _ => panic!("test supports orders 1 and 2"),
            };
            let wc = 2.0 * PI * filter_cutoff_hz / three_db; // delay-normalised frequency unit
            let n = filter_order as usize;
            // States: [i, f_1..f_n], filter in controllable canonical form driven by i,
            // output = the filtered current with unity DC gain.
            let size = n + 2; // + 1 augmented input column
            let mut a = vec![vec![0.0; size]; size];
            a[0][0] = -RESISTANCE / INDUCTANCE;
            a[0][size - 1] = 1.0 / INDUCTANCE;
            // Filter: y^(n) + c_{n-1} y^(n-1) + … + c_0 y = c_0 i   (time scaled by wc)
            // coefficients above are [c_0, c_1, …] for s^0, s^1, … .
            for k in 0..n - 1 {
                a[1 + k][2 + k] = 1.0;
            }
            for (k, c) in coefficients.iter().enumerate() {
                a[n][1 + k] = -c * wc.powi((n - k) as i32);
            }
            a[n][0] = coefficients[0] * wc.powi(n as i32);
            let period = design.sample_period;
            for row in a.iter_mut() {
                for v in row.iter_mut() {
                    *v *= period;
                }
            }
            let e = expm_dynamic(&a);
            let transition = (0..size - 1).map(|i| (0..size - 1).map(|j| e[i][j]).collect()).collect();
            let input = (0..size - 1).map(|i| e[i][size - 1]).collect();
            Self { transition, input, state: vec![0.0; size - 1], integral: 0.0, design }
        }

        fn current(&self) -> f64 {
            self.state[0]
        }

        /// The filter output `y` (state 1; the later states are its derivatives).
        fn measured(&self) -> f64 {
            self.state[1]
        }

        /// One sample of the runtime's PI formula, then the plant over one period.
        fn step(&mut self, reference: f64) -> f64 {
            let d = &self.design;
            let measured = self.measured();
            let error = reference - measured;
            let proportional = d.kp * (d.proportional_setpoint_weight * reference - measured);
            let raw = proportional + self.integral;
            let voltage = raw.clamp(-SUPPLY, SUPPLY);
            let may_integrate = (raw < SUPPLY || error < 0.0) && (raw > -SUPPLY || error > 0.0);
            if may_integrate {
                self.integral = (self.integral + d.ki * d.sample_period * error)
                    .clamp(-SUPPLY - proportional, SUPPLY - proportional);
            }
            let next: Vec<f64> = (0..self.state.len())
                .map(|i| {
                    self.transition[i].iter().zip(&self.state).map(|(a, x)| a * x).sum::<f64>()
                        + self.input[i] * voltage
                })
                .collect();
            self.state = next;
            voltage
        }
    }

    fn expm_dynamic(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
        match a.len() {
            3 => to_vec(&expm::<3>(&to_array(a))),
            4 => to_vec(&expm::<4>(&to_array(a))),
            n => panic!("unsupported size {n}"),
        }
    }

    fn to_array<const N: usize>(a: &[Vec<f64>]) -> [[f64; N]; N] {
        let mut out = [[0.0; N]; N];
        for i in 0..N {
            for j in 0..N {
                out[i][j] = a[i][j];
            }
        }
        out
    }

    fn to_vec<const N: usize>(a: &[[f64; N]; N]) -> Vec<Vec<f64>> {
        a.iter().map(|row| row.to_vec()).collect()
    }

    /// Step overshoot (fraction of the final value) of the true current, and the peak voltage.
    fn step_overshoot(sim: &mut Simulation, amplitude: f64) -> (f64, f64) {
        let mut peak = 0.0f64;
        let mut peak_voltage = 0.0f64;
        for _ in 0..3000 {
            peak_voltage = peak_voltage.max(sim.step(amplitude).abs());
            peak = peak.max(sim.current());
        }
        let final_value = sim.current();
        assert!((final_value - amplitude).abs() < 1e-6 * amplitude, "no steady state");
        ((peak - final_value) / final_value, peak_voltage)
    }

    /// Steady-state gain of the true current for a sinusoidal reference, by least squares.
    fn simulated_gain(design: CurrentLoopDesign, cutoff: f64, order: u32, hz: f64) -> f64 {
        let mut sim = Simulation::new(design, cutoff, order);
        let amplitude = 1.0;
        let w = 2.0 * PI * hz * design.sample_period;
        let (mut ss, mut sc, mut cc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for k in 0..6000 {
            sim.step(amplitude * (w * k as f64).sin());
            // The current after the step belongs to sample k + 1.
            if k >= 3000 {
                let (s, c) = ((w * (k + 1) as f64).sin(), (w * (k + 1) as f64).cos());
                let y = sim.current();
                ss += s * s;
                sc += s * c;
                cc += c * c;
                ys += y * s;
                yc += y * c;
            }
        }
        let det = ss * cc - sc * sc;
        let a = (ys * cc - yc * sc) / det;
        let b = (yc * ss - ys * sc) / det;
        a.hypot(b) / amplitude
    }

    fn simulated_bandwidth(design: CurrentLoopDesign, cutoff: f64, order: u32) -> f64 {
        let threshold = 1.0 / 2f64.sqrt();
        let (mut low, mut high) = (10.0, 3700.0);
        // First crossing: scan, then bisect.
        let mut hz = 10.0;
        while hz < 3700.0 {
            if simulated_gain(design, cutoff, order, hz) < threshold {
                high = hz;
                break;
            }
            low = hz;
            hz += 25.0;
        }
        for _ in 0..20 {
            let middle = 0.5 * (low + high);
            if simulated_gain(design, cutoff, order, middle) < threshold {
                high = middle;
            } else {
                low = middle;
            }
        }
        0.5 * (low + high)
    }

    fn check(cutoff: f64, order: u32) {
        let design = design_current_loop(&re40_input(cutoff, order)).expect("design");
        let bandwidth = simulated_bandwidth(design, cutoff, order);
        let mut sim = Simulation::new(design, cutoff, order);
        let (overshoot, peak_voltage) = step_overshoot(&mut sim, 1.0);
        println!(
            "RE40 @ 7.5 kHz, Bessel order {order} at {cutoff} Hz: kp = {:.4} V/A, ki = {:.1} V/(A·s), \
             placed ω_n = {:.1} Hz (ζ = 1.05 on the armature model); with the lag: dominant mode \
             {:.1} Hz ζ = {:.3}, least ζ = {:.3}; simulated −3 dB bandwidth {:.1} Hz \
             (design model {:.1} Hz), step overshoot {:.3} %, peak voltage per A {:.3} V \
             (k_t = {TORQUE_CONSTANT} N·m/A, supply {SUPPLY} V)",
            design.kp,
            design.ki,
            design.natural_frequency_hz,
            design.dominant_mode_hz,
            design.achieved_damping_ratio,
            design.least_damping_ratio,
            bandwidth,
            design.achieved_bandwidth_hz,
            overshoot * 100.0,
            peak_voltage,
        );
        assert!((design.achieved_bandwidth_hz - 700.0).abs() < 7.0);
        assert!(design.achieved_damping_ratio >= 1.0 - 1e-9, "dominant mode should be real");
        assert!((bandwidth - 700.0).abs() < 70.0, "bandwidth {bandwidth} Hz not within 10 % of 700 Hz");
        assert!(overshoot < 0.01, "overshoot {} %", overshoot * 100.0);
    }

    #[test]
    fn re40_meets_bandwidth_and_overshoot_with_first_order_filter() {
        check(2500.0, 1);
    }

    #[test]
    fn re40_meets_bandwidth_and_overshoot_with_true_second_order_bessel() {
        check(2500.0, 2);
    }

    #[test]
    fn saturated_loop_recovers_without_windup() {
        let design = design_current_loop(&re40_input(2500.0, 2)).expect("design");
        let mut sim = Simulation::new(design, 2500.0, 2);
        // 100 A is out of reach (24 V / 0.299 Ω = 80.3 A): the output saturates for 40 ms.
        let mut saturated_samples = 0;
        for _ in 0..300 {
            if sim.step(100.0).abs() >= 0.99 * SUPPLY {
                saturated_samples += 1;
            }
        }
        assert!(saturated_samples > 250);
        // Back to 20 A: with conditional integration the loop leaves saturation at once.
        let mut lowest = f64::INFINITY;
        for _ in 0..100 {
            sim.step(20.0);
            lowest = lowest.min(sim.current());
        }
        println!(
            "after 300 saturated samples at 100 A, step to 20 A: lowest {lowest:.3} A, \
             after 100 samples {:.4} A",
            sim.current()
        );
        assert!(lowest > 19.8, "undershoot to {lowest} A");
        assert!((sim.current() - 20.0).abs() < 0.01 * 20.0);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let mut input = re40_input(2500.0, 2);
        input.inductance = 0.0;
        assert!(design_current_loop(&input).unwrap_err().contains("inductance"));
        let mut input = re40_input(2500.0, 2);
        input.filter_order = 7;
        assert!(design_current_loop(&input).is_err());
        let mut input = re40_input(2500.0, 2);
        input.bandwidth_hz = 3000.0;
        assert!(design_current_loop(&input).is_err());
        let mut input = re40_input(2500.0, 2);
        input.damping_ratio = f64::NAN;
        assert!(design_current_loop(&input).is_err());
    }

    #[test]
    fn expm_matches_scalar_exponential_and_zoh_of_first_order_plant() {
        let e = expm(&[[-2.0]]);
        assert!((e[0][0] - (-2.0f64).exp()).abs() < 1e-14);
        // Armature alone: a = e^{−RT/L}, b = (1 − a)/R.
        let t = 1.0 / 7500.0;
        let e = expm(&[[-RESISTANCE / INDUCTANCE * t, t / INDUCTANCE], [0.0, 0.0]]);
        let a = (-RESISTANCE * t / INDUCTANCE).exp();
        assert!((e[0][0] - a).abs() < 1e-14);
        assert!((e[0][1] - (1.0 - a) / RESISTANCE).abs() < 1e-12);
    }
}
