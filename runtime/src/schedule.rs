//! Multi-rate scheduling (paper, Fig. 1): the current-loop interrupt runs at `CURRENT_LOOP_HZ`
//! (7.5 kHz) and the impedance loop of eq. (3)–(13) at `IMPEDANCE_LOOP_HZ` (1 kHz).
//!
//! The ratio need not be an integer, so the [`Scheduler`] uses a Bresenham accumulator: each
//! fast tick adds `slow_hz`; when the sum reaches `fast_hz` the slow loop is due and `fast_hz`
//! is subtracted. Over any `fast_hz` fast ticks exactly `slow_hz` slow ticks are due, with no
//! long-term drift. **Jitter:** the slow loop runs on the fast tick at or just after its ideal
//! instant, so each activation is late by less than one fast period (< 133 µs at 7.5 kHz) and
//! successive intervals are `⌊r⌋` or `⌈r⌉` fast periods, `r = fast_hz / slow_hz` (7 or 8 fast
//! periods, 0.933 ms or 1.067 ms, alternating, for 7.5 kHz / 1 kHz). The impedance law uses the
//! nominal period `1/slow_hz`; the ±6.7 % interval error is part of the velocity estimate's
//! noise.
//!
//! Integer arithmetic only, constant time, no allocation: fit for interrupt context.

/// Decides, on every fast (current-loop) tick, whether the slow (impedance) loop is due.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Scheduler {
    fast_hz: u32,
    slow_hz: u32,
    accumulator: u32,
}

impl Scheduler {
    /// A scheduler for `fast_hz` ticks per second of which `slow_hz` trigger the slow loop.
    /// `None` unless `0 < slow_hz <= fast_hz`. The first slow tick is due on the first call.
    pub fn new(fast_hz: u32, slow_hz: u32) -> Option<Self> {
        if slow_hz == 0 || slow_hz > fast_hz {
            return None;
        }
        Some(Self { fast_hz, slow_hz, accumulator: fast_hz - slow_hz })
    }

    /// Call once per fast tick; `true` when the slow loop is due on this tick.
    #[inline]
    pub fn tick(&mut self) -> bool {
        // accumulator < fast_hz and slow_hz <= fast_hz, so no overflow below 2^31 Hz.
        self.accumulator += self.slow_hz;
        if self.accumulator >= self.fast_hz {
            self.accumulator -= self.fast_hz;
            true
        } else {
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_integer_ratio_has_exact_average_and_bounded_jitter() {
        let mut scheduler = Scheduler::new(7500, 1000).unwrap();
        let mut due = 0;
        let mut last = None;
        for tick in 0..75_000u32 {
            if scheduler.tick() {
                due += 1;
                if let Some(previous) = last {
                    let gap = tick - previous;
                    assert!(gap == 7 || gap == 8, "gap {gap}");
                }
                last = Some(tick);
            }
        }
        assert_eq!(due, 10_000);
    }

    #[test]
    fn integer_ratio_and_first_tick() {
        let mut scheduler = Scheduler::new(8000, 1000).unwrap();
        assert!(scheduler.tick());
        let pattern: [bool; 16] = core::array::from_fn(|_| scheduler.tick());
        assert_eq!(pattern.iter().filter(|&&d| d).count(), 2);
        assert!(pattern[7] && pattern[15]);
        assert!(Scheduler::new(1000, 0).is_none());
        assert!(Scheduler::new(1000, 2000).is_none());
    }
}
