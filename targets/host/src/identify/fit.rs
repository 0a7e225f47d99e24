//! From logs to base parameters: filtering, differentiation, weighted least squares.
//!
//! **Signals.** The encoder angles go through a zero-phase low-pass filter: a 2nd-order
//! Butterworth section run forward and backward (4th order in magnitude, no phase lag), cutoff
//! [`FitSettings::cutoff_hz`]; `q̇` and `q̈` are five-point central differences of the filtered
//! angles (fourth order). A device's ticks land on its current-loop periods, so the log is
//! first interpolated onto evenly spaced times.
//!
//! **Parallel filtering** (Gautier 1997). `Y` is evaluated at every sample, then each of its
//! entries and the torque ([`TorqueSource`]: commanded by default) go through the same
//! zero-phase filter before the fit: `τ = Y β` is linear in β, so `τ_f = Y_f β` holds exactly,
//! the Coulomb columns' sign included (filtering `τ` alone smears every velocity reversal into
//! the friction columns: 12 % on the joystick's viscous friction), and what the filter removes —
//! the torque held between ticks, sampled on uneven times, the feedback's reaction to encoder
//! steps — is removed from both sides. Then every [`FitSettings::decimate`]-th sample is kept,
//! and [`FitSettings::edge`] seconds at each end of a log (the filter's transients) are
//! dropped.
//!
//! **Rows.** Each sample gives one row per joint. A joint's row is left out where that joint
//! moves slower than [`FitSettings::min_speed`]: there a real joint sticks (static friction),
//! which the smoothed Coulomb column does not describe; and within [`FitSettings::slow_guard`]
//! (1.5 periods of the cutoff) of such a stretch, where the filter has spread the sticking
//! joint's torque into the neighbouring rows.
//!
//! **Estimate.** Ordinary least squares `β₀ = W⁺ t` (SVD), then each joint's residual variance
//! `σ_j² = ‖t_j − W_j β₀‖² / (r_j − P / N)` weights its rows by `1/σ_j` and the weighted problem
//! is solved again (Gautier & Poignet 2001). The parameters' covariance is
//! `(Wᵀ Σ⁻¹ W)⁻¹`, from the weighted problem's singular values; each parameter's standard
//! deviation and relative deviation `100 σ / |β|` are reported. The condition number is that of
//! `W` with unit-length columns (as [`super::excite`] optimises it). All of it is computed on
//! each joint's rows reduced by a QR factorisation, `[W_j | t_j] = Q_j R_j` (`P + 1` rows per
//! joint instead of thousands; the same norms, singular values and solutions), and `Y` is
//! evaluated on the samples in parallel.

// Matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

use nalgebra::{DMatrix, DVector};

use super::log::IdentificationLog;
use super::regressor::RegressorTape;

/// Settings of the fit.
#[derive(Clone, Debug, PartialEq)]
pub struct FitSettings {
    /// Cutoff of the zero-phase low-pass filter, Hz.
    pub cutoff_hz: f64,
    /// Keep every this-many filtered samples.
    pub decimate: usize,
    /// Seconds dropped at each end of a log.
    pub edge: f64,
    /// A joint's rows are used where it moves faster than this, rad/s (m/s).
    pub min_speed: f64,
    /// And only this long, s, before or after it last moved slower than
    /// [`FitSettings::min_speed`]: the zero-phase filter spreads what a sticking joint's
    /// friction does (which the smoothed Coulomb column does not describe) over its impulse
    /// response, into the rows either side of a reversal. [`FitSettings::with_cutoff`] sets it
    /// to [`SLOW_GUARD_PERIODS`] periods of the cutoff.
    pub slow_guard: f64,
    /// Which torque the fit explains.
    pub torque: TorqueSource,
    /// Per joint, how much later the logged torque (of [`FitSettings::torque`]) acts on the
    /// device, s; empty: it acts when logged. A commanded torque takes effect from the next
    /// current-loop period and reaches the motor through the current loop's mean delay; a
    /// measured one trails the motor by the current sensor's filter lag (a negative lead).
    /// Left uncorrected, a delay `d` makes the fit read the inertial torque's derivative as
    /// viscous friction, off by about `D ω² d` (`torque_leads` gives the values).
    pub torque_lead: Vec<f64>,
}

/// Which of a log's torques the fit explains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TorqueSource {
    /// `tau_cmd_*`, the commanded torque: what the motors make as far as the current loop
    /// follows its setpoint (kHz bandwidth, far above an excitation's few Hz). The default.
    Commanded,
    /// `tau_*`, from the measured currents: seen through the current sensor's anti-aliasing
    /// filter, whose lag, differentiated by the fit, biases it (on the simulated joystick:
    /// the inertia 2.4 % low and the viscous friction 30 % high).
    Measured,
}

/// How many periods of the filter's cutoff a row keeps from a slow stretch of its joint
/// ([`FitSettings::slow_guard`]): 0.1 s at 15 Hz, about where the filter's impulse response has
/// died out.
pub const SLOW_GUARD_PERIODS: f64 = 1.5;

impl FitSettings {
    /// The default settings with the filter's cutoff at `cutoff_hz` and the guard around slow
    /// stretches scaled with it.
    pub fn with_cutoff(cutoff_hz: f64) -> FitSettings {
        FitSettings {
            cutoff_hz,
            decimate: 5,
            edge: 0.2,
            min_speed: 0.05,
            slow_guard: SLOW_GUARD_PERIODS / cutoff_hz,
            torque: TorqueSource::Commanded,
            torque_lead: Vec::new(),
        }
    }
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings::with_cutoff(15.0)
    }
}

/// One filtered sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// Time, s.
    pub time: f64,
    /// `q`.
    pub q: Vec<f64>,
    /// `q̇`.
    pub qd: Vec<f64>,
    /// `q̈`.
    pub qdd: Vec<f64>,
    /// The joint torque ([`FitSettings::torque`]).
    pub tau: Vec<f64>,
}

/// One log, prepared: its samples at the full (resampled) rate.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// The samples, evenly spaced.
    pub samples: Vec<Sample>,
    /// Their rate, Hz.
    pub sample_hz: f64,
}

/// The identified base parameters and their figures.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// `β̂`, in the regressor's column order.
    pub beta: Vec<f64>,
    /// The standard deviation of each.
    pub sigma: Vec<f64>,
    /// `cond(W)` with unit-length columns.
    pub condition_number: f64,
    /// Per joint: RMS of the residual `τ − Y β̂` over its rows.
    pub residual_rms: Vec<f64>,
    /// Per joint: RMS of the torque over its rows.
    pub torque_rms: Vec<f64>,
    /// Per joint: rows used.
    pub rows: Vec<usize>,
}

/// Second-order Butterworth low-pass section (bilinear transform, prewarped).
fn butterworth(cutoff_hz: f64, sample_hz: f64) -> ([f64; 3], [f64; 2]) {
    let k = (std::f64::consts::PI * cutoff_hz / sample_hz).tan();
    let norm = 1.0 / (1.0 + std::f64::consts::SQRT_2 * k + k * k);
    let b0 = k * k * norm;
    ([b0, 2.0 * b0, b0], [2.0 * (k * k - 1.0) * norm, (1.0 - std::f64::consts::SQRT_2 * k + k * k) * norm])
}

fn filter_once(x: &[f64], b: [f64; 3], a: [f64; 2]) -> Vec<f64> {
    // Started at rest at the first value, so a constant signal passes unchanged.
    let first = x.first().copied().unwrap_or(0.0);
    let (mut x1, mut x2, mut y1, mut y2) = (first, first, first, first);
    x.iter()
        .map(|&x0| {
            let y0 = b[0] * x0 + b[1] * x1 + b[2] * x2 - a[0] * y1 - a[1] * y2;
            (x2, x1, y2, y1) = (x1, x0, y1, y0);
            y0
        })
        .collect()
}

/// The zero-phase filter of the module documentation.
pub fn zero_phase(x: &[f64], cutoff_hz: f64, sample_hz: f64) -> Vec<f64> {
    let (b, a) = butterworth(cutoff_hz, sample_hz);
    let forward = filter_once(x, b, a);
    let reversed: Vec<f64> = forward.into_iter().rev().collect();
    let mut out = filter_once(&reversed, b, a);
    out.reverse();
    out
}

/// [`zero_phase`] of every channel of `rows` in place: `rows` holds `channels` interleaved
/// signals, sample by sample (row-major), as `Y` is evaluated; each is filtered exactly as
/// [`zero_phase`] filters one, sweeping the rows forward then backward (no transposition).
fn zero_phase_rows(rows: &mut [f64], channels: usize, cutoff_hz: f64, sample_hz: f64) {
    let (b, a) = butterworth(cutoff_hz, sample_hz);
    if channels == 0 || rows.len() < channels {
        return;
    }
    // Per channel: x1, x2, y1, y2, started at rest at the sweep's first value.
    let mut state = vec![[0.0_f64; 4]; channels];
    let sweep = |row: &mut [f64], state: &mut [[f64; 4]]| {
        for (x0, [x1, x2, y1, y2]) in row.iter_mut().zip(state.iter_mut()) {
            let y0 = b[0] * *x0 + b[1] * *x1 + b[2] * *x2 - a[0] * *y1 - a[1] * *y2;
            (*x2, *x1, *y2, *y1) = (*x1, *x0, *y1, y0);
            *x0 = y0;
        }
    };
    let rest = |row: &[f64], state: &mut [[f64; 4]]| {
        for (value, s) in row.iter().zip(state.iter_mut()) {
            *s = [*value; 4];
        }
    };
    rest(&rows[..channels], &mut state);
    for row in rows.chunks_exact_mut(channels) {
        sweep(row, &mut state);
    }
    rest(&rows[rows.len() - channels..], &mut state);
    for row in rows.chunks_exact_mut(channels).rev() {
        sweep(row, &mut state);
    }
}

/// `log` onto the evenly spaced times `t_0 + k · period`: a device's ticks land on its
/// current-loop periods (7.5 kHz), so a 1 kHz log's samples are 0.93 or 1.07 ms apart. Angles
/// are interpolated linearly. A torque holds from its tick to the next, so each evenly spaced
/// sample takes the held torque's average over the `period` centred on it: sampling it at the
/// instant instead moves it by up to half a tick, which a fit reads as viscous friction
/// (the tracking loop's 8 Hz correction times the joint's inertia: 5 times the joystick's
/// true value).
fn resampled(log: &IdentificationLog, period: f64, torque: TorqueSource, lead: &[f64]) -> IdentificationLog {
    let mut out = IdentificationLog::new(log.joints.clone());
    let count = log.len();
    let start = log.time[0];
    let n = log.joints.len();
    // The held torque's integral from `a` to `b` (held before the first tick at its value,
    // after the last at the last's).
    let held_average = |rows: &[Vec<f64>], a: f64, b: f64, from: usize| -> Vec<f64> {
        let mut sum = vec![0.0; n];
        let mut k = from;
        let mut t = a;
        while t < b {
            let until = if k + 1 < count { log.time[k + 1].min(b) } else { b };
            let until = until.max(t);
            for j in 0..n {
                sum[j] += rows[k][j] * (until - t);
            }
            t = until;
            if k + 1 < count && log.time[k + 1] <= t {
                k += 1;
            } else if until >= b {
                break;
            }
        }
        sum.iter().map(|v| v / (b - a)).collect()
    };
    let mut i = 0;
    for step in 0..count {
        let t = start + step as f64 * period;
        while i + 2 < count && log.time[i + 1] <= t {
            i += 1;
        }
        let (t0, t1) = (log.time[i], log.time[i + 1]);
        let w = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        let q: Vec<f64> = log.q[i].iter().zip(&log.q[i + 1]).map(|(a, b)| a + w * (b - a)).collect();
        // Each joint's torque acting over the window: the logged one over the window moved
        // back by its lead (from the tick in force at the moved window's start).
        let acting = |rows: &[Vec<f64>], source: TorqueSource| -> Vec<f64> {
            (0..n)
                .map(|j| {
                    let shift = if source == torque { lead.get(j).copied().unwrap_or(0.0) } else { 0.0 };
                    let (a, b) = (t - 0.5 * period - shift, t + 0.5 * period - shift);
                    let mut first = i;
                    while first > 0 && log.time[first] > a {
                        first -= 1;
                    }
                    while first + 1 < count && log.time[first + 1] <= a {
                        first += 1;
                    }
                    held_average(rows, a, b, first)[j]
                })
                .collect()
        };
        out.push(
            t,
            &q,
            &acting(&log.tau, TorqueSource::Measured),
            &acting(&log.tau_command, TorqueSource::Commanded),
        );
    }
    out
}

/// Resamples one log, filters its angles and differentiates them (`what` names it in errors).
pub fn prepare(log: &IdentificationLog, settings: &FitSettings, what: &str) -> Result<Segment, String> {
    let count = log.len();
    if count < 50 {
        return Err(format!(
            "error: {what}: {count} samples; a fit needs at least 50 (and far more to be useful)"
        ));
    }
    let duration = log.time[count - 1] - log.time[0];
    let period = duration / (count - 1) as f64;
    if let Some(i) = (1..count).find(|&i| log.time[i] - log.time[i - 1] > 2.0 * period) {
        return Err(format!(
            "error: {what}:{}: a gap of {:.6} s in a log sampled every {period:.6} s on average",
            i + 2,
            log.time[i] - log.time[i - 1]
        ));
    }
    let sample_hz = 1.0 / period;
    if !(settings.cutoff_hz > 0.0 && settings.cutoff_hz < 0.45 * sample_hz) {
        return Err(format!(
            "error: the filter's cutoff {} Hz must lie between 0 and 0.45 × the log's rate ({sample_hz:.0} Hz)",
            settings.cutoff_hz
        ));
    }
    if let Some(bad) = settings.torque_lead.iter().find(|d| !(d.is_finite() && d.abs() < 0.1)) {
        return Err(format!("error: a torque lead of {bad} s: it must be finite and under 0.1 s"));
    }
    let log = &resampled(log, period, settings.torque, &settings.torque_lead);
    let n = log.joints.len();
    let column = |rows: &[Vec<f64>], j: usize| -> Vec<f64> { rows.iter().map(|r| r[j]).collect() };
    let q: Vec<Vec<f64>> =
        (0..n).map(|j| zero_phase(&column(&log.q, j), settings.cutoff_hz, sample_hz)).collect();
    let torque = match settings.torque {
        TorqueSource::Commanded => &log.tau_command,
        TorqueSource::Measured => &log.tau,
    };
    let tau: Vec<Vec<f64>> = (0..n).map(|j| column(torque, j)).collect();
    let mut samples = Vec::with_capacity(count);
    for i in 2..count.saturating_sub(2) {
        samples.push(Sample {
            time: log.time[i],
            q: (0..n).map(|j| q[j][i]).collect(),
            qd: (0..n)
                .map(|j| (8.0 * (q[j][i + 1] - q[j][i - 1]) - (q[j][i + 2] - q[j][i - 2])) / (12.0 * period))
                .collect(),
            qdd: (0..n)
                .map(|j| {
                    (16.0 * (q[j][i + 1] + q[j][i - 1]) - (q[j][i + 2] + q[j][i - 2]) - 30.0 * q[j][i])
                        / (12.0 * period * period)
                })
                .collect(),
            tau: (0..n).map(|j| tau[j][i]).collect(),
        });
    }
    Ok(Segment { samples, sample_hz })
}

/// A segment's `Y` entries and torques, each filtered, row-major: sample `i`'s values start at
/// `i * (N * P + N)`, entry (r, c) of `Y` at offset `r * P + c`, joint j's torque at `N * P + j`;
/// and the samples at each end the filter's transients spoil.
fn filtered_series(
    regressor: &RegressorTape,
    segment: &Segment,
    settings: &FitSettings,
) -> (Vec<f64>, usize) {
    use rayon::prelude::*;
    let (n, p) = (regressor.joints(), regressor.columns());
    let width = n * p + n;
    // Y at every sample, in parallel chunks (each with its own register file): the costliest
    // step of a fit, a Delta's regressor being thousands of operations.
    const CHUNK: usize = 256;
    let mut rows = vec![0.0; segment.samples.len() * width];
    rows.par_chunks_mut(CHUNK * width).zip(segment.samples.par_chunks(CHUNK)).for_each(|(out, samples)| {
        let mut scratch = regressor.scratch();
        for (row, s) in out.chunks_mut(width).zip(samples) {
            regressor.eval(&mut scratch, &s.q, &s.qd, &s.qdd, &mut row[..n * p]);
            row[n * p..].copy_from_slice(&s.tau);
        }
    });
    zero_phase_rows(&mut rows, width, settings.cutoff_hz, segment.sample_hz);
    (rows, (settings.edge * segment.sample_hz).ceil() as usize)
}

/// Per joint and sample: whether the joint moves slower than [`FitSettings::min_speed`] there
/// or within [`FitSettings::slow_guard`] of it.
fn slow_stretches(segment: &Segment, settings: &FitSettings) -> Vec<Vec<bool>> {
    let count = segment.samples.len();
    // Clamped to the segment: a guard longer than the log only has to cover all of it.
    let guard = (settings.slow_guard.max(0.0) * segment.sample_hz).round().min(count as f64) as usize;
    let joints = segment.samples.first().map_or(0, |s| s.qd.len());
    (0..joints)
        .map(|j| {
            let mut slow = vec![false; count];
            for (i, sample) in segment.samples.iter().enumerate() {
                if sample.qd[j].abs() < settings.min_speed {
                    slow[i.saturating_sub(guard)..(i + guard + 1).min(count)].fill(true);
                }
            }
            slow
        })
        .collect()
}

/// Stacks the rows of `segments`: `Y` and `τ` filtered alike, trimmed, decimated, the rows
/// [`FitSettings::min_speed`] lets through; returns `W`, `t` and each row's joint.
fn stack(
    regressor: &RegressorTape,
    segments: &[Segment],
    settings: &FitSettings,
) -> (DMatrix<f64>, DVector<f64>, Vec<usize>) {
    let (n, p) = (regressor.joints(), regressor.columns());
    let mut rows = Vec::new();
    let mut torques = Vec::new();
    let mut joint_of = Vec::new();
    for segment in segments {
        let (filtered, edge) = filtered_series(regressor, segment, settings);
        let slow = slow_stretches(segment, settings);
        let width = n * p + n;
        let mut i = edge;
        while i + edge < segment.samples.len() {
            let row = &filtered[i * width..(i + 1) * width];
            for j in 0..n {
                if slow[j][i] {
                    continue;
                }
                rows.extend_from_slice(&row[j * p..(j + 1) * p]);
                torques.push(row[n * p + j]);
                joint_of.push(j);
            }
            i += settings.decimate.max(1);
        }
    }
    (DMatrix::from_row_slice(torques.len(), p, &rows), DVector::from_vec(torques), joint_of)
}

/// A log's torques over time beside their predictions, for the report's figures.
#[derive(Clone, Debug, PartialEq)]
pub struct PredictionTrace {
    /// Time of each kept sample, s.
    pub time: Vec<f64>,
    /// `[j][i]`: joint j's torque (filtered as the fit sees it).
    pub measured: Vec<Vec<f64>>,
    /// `[b][j][i]`: the torque `Y β_b` predicts with the `b`-th parameter vector.
    pub predicted: Vec<Vec<Vec<f64>>>,
}

/// The torques of `segment` and their predictions by each of `betas`, every
/// [`FitSettings::decimate`]-th sample between the filter's edges (every row, the slow ones
/// too: the figure shows where the model misses).
pub fn prediction_trace(
    regressor: &RegressorTape,
    betas: &[&[f64]],
    segment: &Segment,
    settings: &FitSettings,
) -> PredictionTrace {
    let (n, p) = (regressor.joints(), regressor.columns());
    let (filtered, edge) = filtered_series(regressor, segment, settings);
    let width = n * p + n;
    let mut trace = PredictionTrace {
        time: Vec::new(),
        measured: vec![Vec::new(); n],
        predicted: vec![vec![Vec::new(); n]; betas.len()],
    };
    let mut i = edge;
    while i + edge < segment.samples.len() {
        trace.time.push(segment.samples[i].time);
        let row = &filtered[i * width..(i + 1) * width];
        for j in 0..n {
            trace.measured[j].push(row[n * p + j]);
            for (b, beta) in betas.iter().enumerate() {
                trace.predicted[b][j]
                    .push(row[j * p..(j + 1) * p].iter().zip(beta.iter()).map(|(y, b)| y * b).sum());
            }
        }
        i += settings.decimate.max(1);
    }
    trace
}

/// Identifies the base parameters from prepared logs.
pub fn fit(regressor: &RegressorTape, segments: &[Segment], settings: &FitSettings) -> Result<Fit, String> {
    let (n, p) = (regressor.joints(), regressor.columns());
    let names = &regressor.regressor.base;
    let (w, t, joint_of) = stack(regressor, segments, settings);
    let mut rows = vec![0; n];
    for &j in &joint_of {
        rows[j] += 1;
    }
    if w.nrows() < 2 * p {
        return Err(format!(
            "error: {} usable rows (joints moving faster than {} rad/s, and for {} s either side) for {p} base parameters; a fit needs \
             at least {} (a longer log, or a trajectory that moves every joint)",
            w.nrows(),
            settings.min_speed,
            settings.slow_guard,
            2 * p
        ));
    }
    // Each joint's rows reduced to a triangle, `[W_j | t_j] = Q_j R_j`: as `‖[W_j | t_j] x‖ =
    // ‖R_j x‖` for every x, the column norms, the singular values, the least-squares
    // solutions (weighted per joint) and each joint's residual follow from the stacked `R_j`,
    // (P + 1) rows per joint instead of thousands.
    let triangles: Vec<DMatrix<f64>> = (0..n)
        .map(|j| {
            let mine: Vec<usize> = (0..joint_of.len()).filter(|&r| joint_of[r] == j).collect();
            let block =
                DMatrix::from_fn(mine.len(), p + 1, |i, c| if c < p { w[(mine[i], c)] } else { t[mine[i]] });
            block.qr().r()
        })
        .collect();
    let stacked = |weights: &[f64]| -> (DMatrix<f64>, DVector<f64>) {
        let height: usize = triangles.iter().map(|r| r.nrows()).sum();
        let mut a = DMatrix::zeros(height, p);
        let mut b = DVector::zeros(height);
        let mut at = 0;
        for (r, weight) in triangles.iter().zip(weights) {
            for i in 0..r.nrows() {
                for c in 0..p {
                    a[(at + i, c)] = weight * r[(i, c)];
                }
                b[at + i] = weight * r[(i, p)];
            }
            at += r.nrows();
        }
        (a, b)
    };
    // `‖t_j − W_j β‖²`.
    let residual_squares = |beta: &DVector<f64>| -> Vec<f64> {
        triangles
            .iter()
            .map(|r| {
                (0..r.nrows())
                    .map(|i| (r[(i, p)] - (0..p).map(|c| r[(i, c)] * beta[c]).sum::<f64>()).powi(2))
                    .sum()
            })
            .collect()
    };
    let (reduced, reduced_torque) = stacked(&vec![1.0; n]);
    // Which parameters no row excites, and how well the rest are conditioned.
    let mut scaled = reduced.clone();
    let mut unexcited = Vec::new();
    for c in 0..p {
        let norm = scaled.column(c).norm();
        if norm > 1e-12 * (w.nrows() as f64).sqrt() {
            scaled.column_mut(c).scale_mut(1.0 / norm);
        } else {
            unexcited.push(names[c].name.clone());
        }
    }
    if !unexcited.is_empty() {
        return Err(format!("error: the logs do not excite the base parameters {}", unexcited.join(", ")));
    }
    let svd = scaled.svd(false, true);
    let (largest, smallest) =
        svd.singular_values.iter().fold((0.0_f64, f64::INFINITY), |(a, b), &s| (a.max(s), b.min(s)));
    let condition_number = largest / smallest;
    if condition_number.is_nan() || condition_number >= 1e8 {
        // The direction of the smallest singular value names the parameters it mixes.
        let index = svd.singular_values.iamin();
        let mut involved = Vec::new();
        if let Some(v_t) = &svd.v_t {
            let direction = v_t.row(index);
            for c in 0..p {
                if direction[c].abs() > 0.3 {
                    involved.push(names[c].name.clone());
                }
            }
        }
        return Err(format!(
            "error: the logs hardly excite a combination of the base parameters {} (condition number {:.3e}): \
             a joint that barely moves, or a trajectory that is not exciting",
            involved.join(", "),
            condition_number
        ));
    }
    // Ordinary, then weighted least squares.
    let solve = |a: &DMatrix<f64>, b: &DVector<f64>| -> Result<DVector<f64>, String> {
        a.clone().svd(true, true).solve(b, 1e-14).map_err(|e| format!("error: least squares: {e}"))
    };
    let beta0 = solve(&reduced, &reduced_torque)?;
    let mut variance = residual_squares(&beta0);
    for j in 0..n {
        let dof = (rows[j] as f64 - p as f64 / n as f64).max(1.0);
        variance[j] = (variance[j] / dof).max(1e-300);
    }
    let weights: Vec<f64> = variance.iter().map(|v| 1.0 / v.sqrt()).collect();
    let (weighted_matrix, weighted_torque) = stacked(&weights);
    let beta = solve(&weighted_matrix, &weighted_torque)?;
    // Covariance (Wᵀ Σ⁻¹ W)⁻¹ = V S⁻² Vᵀ of the weighted problem.
    let weighted = weighted_matrix.svd(false, true);
    let v_t = weighted.v_t.ok_or("error: least squares: no singular vectors")?;
    let sigma: Vec<f64> = (0..p)
        .map(|c| {
            let variance: f64 = (0..p).map(|k| (v_t[(k, c)] / weighted.singular_values[k]).powi(2)).sum();
            variance.sqrt()
        })
        .collect();
    let residual = residual_squares(&beta);
    let mut residual_rms = vec![0.0; n];
    let mut torque_rms = vec![0.0; n];
    for j in 0..n {
        let count = rows[j].max(1) as f64;
        residual_rms[j] = (residual[j] / count).sqrt();
        torque_rms[j] = (triangles[j].column(p).norm_squared() / count).sqrt();
    }
    Ok(Fit { beta: beta.iter().copied().collect(), sigma, condition_number, residual_rms, torque_rms, rows })
}

/// Per joint, the RMS of the torque predicted by `beta` minus the measured one, and the RMS
/// of the measured torque, over the rows [`FitSettings::min_speed`] lets through.
pub fn prediction_error(
    regressor: &RegressorTape,
    beta: &[f64],
    segments: &[Segment],
    settings: &FitSettings,
) -> (Vec<f64>, Vec<f64>) {
    let n = regressor.joints();
    let (w, t, joint_of) = stack(regressor, segments, settings);
    let predicted = &w * DVector::from_column_slice(beta);
    let (mut error, mut torque, mut count) = (vec![0.0; n], vec![0.0; n], vec![0usize; n]);
    for (r, &j) in joint_of.iter().enumerate() {
        error[j] += (predicted[r] - t[r]).powi(2);
        torque[j] += t[r] * t[r];
        count[j] += 1;
    }
    for j in 0..n {
        let c = count[j].max(1) as f64;
        error[j] = (error[j] / c).sqrt();
        torque[j] = (torque[j] / c).sqrt();
    }
    (error, torque)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A segment at 1 kHz whose joint 0 reverses twice (speed `cos(π t)`) and whose joint 1
    /// moves at a steady 1 rad/s.
    fn reversing_segment() -> Segment {
        let samples = (0..2000)
            .map(|i| {
                let time = i as f64 * 1e-3;
                Sample {
                    time,
                    q: vec![0.0; 2],
                    qd: vec![(std::f64::consts::PI * time).cos(), 1.0],
                    qdd: vec![0.0; 2],
                    tau: vec![0.0; 2],
                }
            })
            .collect();
        Segment { samples, sample_hz: 1000.0 }
    }

    #[test]
    fn rows_near_a_slow_stretch_are_left_out_as_far_as_the_guard_reaches() {
        let segment = reversing_segment();
        for guard in [0.0, 0.1, 0.25] {
            let settings = FitSettings { slow_guard: guard, ..FitSettings::default() };
            let slow = slow_stretches(&segment, &settings);
            // Sample by sample against the definition: slow where some sample within the guard
            // (in time) is slower than the threshold.
            for (i, s) in segment.samples.iter().enumerate() {
                let near_slow = segment
                    .samples
                    .iter()
                    .any(|o| (o.time - s.time).abs() <= guard + 1e-9 && o.qd[0].abs() < settings.min_speed);
                assert_eq!(slow[0][i], near_slow, "guard {guard} s, t = {} s", s.time);
                assert!(!slow[1][i], "joint 1 never slows down");
            }
        }
        // 0.1 s after the reversal at 0.5 s (0.084 s after the slow stretch), joint 0 moves at 0.31 rad/s, far above the
        // threshold: left out with the default guard (0.1 s at 15 Hz), kept without one.
        let default = slow_stretches(&segment, &FitSettings::default());
        let unguarded = slow_stretches(&segment, &FitSettings { slow_guard: 0.0, ..FitSettings::default() });
        assert!(default[0][600] && !unguarded[0][600]);
        // A guard longer than the log covers all of it, without overflowing.
        let everything = FitSettings { slow_guard: f64::INFINITY, ..FitSettings::default() };
        assert!(slow_stretches(&segment, &everything)[0].iter().all(|&s| s));
    }

    #[test]
    fn the_interleaved_filter_filters_each_channel_as_the_single_one_does() {
        let rate = 1000.0;
        let channels: Vec<Vec<f64>> = (0..3)
            .map(|c| (0..500).map(|i| (i as f64 * 0.01 * (c + 1) as f64).sin() + 0.3 * c as f64).collect())
            .collect();
        let mut rows: Vec<f64> = (0..500).flat_map(|i| channels.iter().map(move |x| x[i])).collect();
        zero_phase_rows(&mut rows, 3, 15.0, rate);
        for (c, x) in channels.iter().enumerate() {
            let single = zero_phase(x, 15.0, rate);
            for i in 0..500 {
                assert_eq!(rows[i * 3 + c], single[i], "channel {c}, sample {i}");
            }
        }
    }

    #[test]
    fn the_zero_phase_filter_passes_slow_signals_without_lag_and_stops_fast_ones() {
        let rate = 1000.0;
        let slow: Vec<f64> =
            (0..4000).map(|i| (std::f64::consts::TAU * 1.0 * i as f64 / rate).sin()).collect();
        let fast: Vec<f64> =
            (0..4000).map(|i| (std::f64::consts::TAU * 200.0 * i as f64 / rate).sin()).collect();
        let (slow_out, fast_out) = (zero_phase(&slow, 15.0, rate), zero_phase(&fast, 15.0, rate));
        // Away from the ends: 1 Hz through unchanged (no lag, gain 1 to 1e-4), 200 Hz gone.
        for i in 500..3500 {
            assert!((slow_out[i] - slow[i]).abs() < 1e-4, "{i}: {} vs {}", slow_out[i], slow[i]);
            assert!(fast_out[i].abs() < 1e-3, "{i}: {}", fast_out[i]);
        }
    }
}
