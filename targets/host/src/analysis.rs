//! Measuring the simulated responses: the natural frequency and damping ratio of a step
//! response are estimated from the samples (never restated from eq. (6) or (11)).
//!
//! [`fit_step_response`] fits the step response of a second-order system,
//! `x(t) = x₀ + A (1 − e^{−ζωτ}(cos ω_d τ + ζω/ω_d sin ω_d τ))`, `τ = t − t_s`,
//! `ω_d = ω√(1 − ζ²)`, by least squares (Levenberg–Marquardt on `A`, `ω`, `ζ`), started from
//! the logarithmic decrement of the response's peaks ([`log_decrement`]).

/// A fitted second-order step response.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepFit {
    /// Step amplitude `A` (final value − initial value).
    pub amplitude: f64,
    /// Natural frequency `ω`, rad/s.
    pub natural_frequency: f64,
    /// Damping ratio `ζ`.
    pub damping_ratio: f64,
    /// Root-mean-square residual of the fit, in the response's units.
    pub rms_residual: f64,
}

fn model(p: &[f64; 3], tau: f64) -> f64 {
    let [a, w, z] = *p;
    if tau <= 0.0 {
        return 0.0;
    }
    let z = z.clamp(1e-6, 0.999_999);
    let wd = w * (1.0 - z * z).sqrt();
    a * (1.0 - (-z * w * tau).exp() * ((wd * tau).cos() + z * w / wd * (wd * tau).sin()))
}

/// Peaks (alternating extrema) of `y` about zero: `(time, value)`.
fn extrema(t: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut start = 0;
    // Split the signal into half-cycles at sign changes; the extremum of each.
    for i in 1..=y.len() {
        let end_of_lobe = i == y.len() || (y[i] >= 0.0) != (y[start] >= 0.0);
        if end_of_lobe {
            if i > start + 2 {
                let (k, _) = y[start..i]
                    .iter()
                    .enumerate()
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                    .unwrap_or((0, &0.0));
                out.push((t[start + k], y[start + k]));
            }
            start = i;
        }
    }
    out
}

/// Damped frequency `ω_d` and damping ratio from the logarithmic decrement of the peaks of
/// `x − final_value` after `start`; `None` with fewer than three peaks.
pub fn log_decrement(t: &[f64], x: &[f64], start: f64, final_value: f64) -> Option<(f64, f64)> {
    let (ts, ys): (Vec<f64>, Vec<f64>) =
        t.iter().zip(x).filter(|(ti, _)| **ti > start).map(|(ti, xi)| (*ti, xi - final_value)).unzip();
    let peaks = extrema(&ts, &ys);
    // Drop the last lobe (possibly cut short) and insignificant ripples.
    let first = peaks.first()?.1.abs();
    let peaks: Vec<(f64, f64)> = peaks.into_iter().take_while(|p| p.1.abs() > 0.02 * first).collect();
    if peaks.len() < 3 {
        return None;
    }
    let half_periods = (peaks.len() - 1) as f64;
    let period = 2.0 * (peaks[peaks.len() - 1].0 - peaks[0].0) / half_periods;
    let delta = 2.0 * (peaks[0].1.abs() / peaks[peaks.len() - 1].1.abs()).ln() / half_periods;
    let zeta = delta / (4.0 * std::f64::consts::PI * std::f64::consts::PI + delta * delta).sqrt();
    Some((std::f64::consts::TAU / period, zeta))
}

fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d == 0.0 || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, slot) in x.iter_mut().enumerate() {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        *slot = det(m) / d;
    }
    Some(x)
}

/// Fits a second-order step response to the samples `(t, x)` for a step applied at `start`
/// from the value `initial`, over `t ∈ [start, end]`. `None` if the data cannot be fitted.
pub fn fit_step_response(t: &[f64], x: &[f64], start: f64, end: f64, initial: f64) -> Option<StepFit> {
    let data: Vec<(f64, f64)> = t
        .iter()
        .zip(x)
        .filter(|(ti, _)| **ti >= start && **ti <= end)
        .map(|(ti, xi)| (ti - start, xi - initial))
        .collect();
    if data.len() < 20 {
        return None;
    }
    let tail = &data[data.len() * 4 / 5..];
    let final_guess = tail.iter().map(|d| d.1).sum::<f64>() / tail.len() as f64;
    let times: Vec<f64> = data.iter().map(|d| d.0).collect();
    let values: Vec<f64> = data.iter().map(|d| d.1).collect();
    let (wd, zeta) = log_decrement(&times, &values, 0.0, final_guess).unwrap_or_else(|| {
        // Overdamped or too few peaks: start from the 63 % rise time.
        let rise = data.iter().find(|d| d.1.abs() >= 0.63 * final_guess.abs()).map_or(1.0, |d| d.0.max(1e-3));
        (1.0 / rise, 0.7)
    });
    let mut p = [final_guess, wd / (1.0 - zeta * zeta).max(1e-6).sqrt(), zeta.clamp(0.001, 0.99)];
    let cost = |p: &[f64; 3]| data.iter().map(|(tau, y)| (model(p, *tau) - y).powi(2)).sum::<f64>();
    let mut current = cost(&p);
    let mut lambda = 1e-3;
    for _ in 0..200 {
        let mut jtj = [[0.0; 3]; 3];
        let mut jtr = [0.0; 3];
        for (tau, y) in &data {
            let r = model(&p, *tau) - y;
            let mut grad = [0.0; 3];
            for (k, g) in grad.iter_mut().enumerate() {
                let h = 1e-7 * p[k].abs().max(1e-6);
                let mut q = p;
                q[k] += h;
                *g = (model(&q, *tau) - model(&p, *tau)) / h;
            }
            for i in 0..3 {
                jtr[i] += grad[i] * r;
                for j in 0..3 {
                    jtj[i][j] += grad[i] * grad[j];
                }
            }
        }
        let mut improved = false;
        for _ in 0..20 {
            let mut a = jtj;
            for (i, row) in a.iter_mut().enumerate() {
                row[i] += lambda * jtj[i][i].max(1e-30);
            }
            let Some(step) = solve3(a, [-jtr[0], -jtr[1], -jtr[2]]) else { break };
            let candidate =
                [p[0] + step[0], (p[1] + step[1]).max(1e-6), (p[2] + step[2]).clamp(1e-6, 0.999_999)];
            let c = cost(&candidate);
            if c < current {
                let relative = (current - c) / current.max(1e-300);
                p = candidate;
                current = c;
                lambda = (lambda * 0.3).max(1e-12);
                improved = relative > 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let rms_residual = (current / data.len() as f64).sqrt();
    let fit = StepFit { amplitude: p[0], natural_frequency: p[1], damping_ratio: p[2], rms_residual };
    (fit.amplitude.is_finite() && fit.natural_frequency.is_finite()).then_some(fit)
}

/// Mean of the samples with `t` in `[from, to]`.
pub fn mean_between(t: &[f64], x: &[f64], from: f64, to: f64) -> f64 {
    let values: Vec<f64> =
        t.iter().zip(x).filter(|(ti, _)| **ti >= from && **ti <= to).map(|(_, xi)| *xi).collect();
    if values.is_empty() {
        f64::NAN
    } else {
        values.iter().sum::<f64>() / values.len() as f64
    }
}

/// Root mean square of `x` minus its centred moving average over `window` samples: the
/// high-frequency content (e.g. torque noise from a quantised estimate).
pub fn high_frequency_rms(x: &[f64], window: usize) -> f64 {
    let half = window / 2;
    if x.len() <= window {
        return 0.0;
    }
    let mut sum = 0.0;
    let mut count = 0usize;
    for i in half..x.len() - half {
        let average = x[i - half..=i + half].iter().sum::<f64>() / (2 * half + 1) as f64;
        sum += (x[i] - average).powi(2);
        count += 1;
    }
    (sum / count as f64).sqrt()
}

/// Relative deviation `|measured − expected| / |expected|`.
pub fn relative_error(measured: f64, expected: f64) -> f64 {
    (measured - expected).abs() / expected.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_a_synthetic_response() {
        let truth = [0.8, 12.0, 0.15];
        let t: Vec<f64> = (0..4000).map(|k| k as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|&ti| 0.1 + model(&truth, ti - 0.5)).collect();
        let fit = fit_step_response(&t, &x, 0.5, 4.0, 0.1).expect("fit");
        assert!((fit.amplitude - 0.8).abs() < 1e-4, "{fit:?}");
        assert!((fit.natural_frequency - 12.0).abs() < 1e-3, "{fit:?}");
        assert!((fit.damping_ratio - 0.15).abs() < 1e-4, "{fit:?}");
        let (wd, zeta) = log_decrement(&t, &x, 0.5, 0.9).expect("peaks");
        assert!((wd - 12.0 * (1.0f64 - 0.0225).sqrt()).abs() < 0.1, "{wd}");
        assert!((zeta - 0.15).abs() < 0.01, "{zeta}");
    }
}
