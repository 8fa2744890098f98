//! Periodic publishing on absolute deadlines: the k-th tick is due at `start + k·period`, so
//! a late wake-up (a loaded machine, tokio's 1 ms timer) delays one sample but never the
//! ones after it and the average rate holds. A stall of more than a few periods re-anchors the
//! grid at the present instead of bursting out every missed sample. The rule is the front
//! core's [`StateGrid`] (the one home of it, unit-tested there); this is its timer for the
//! async tasks.

use std::time::Duration;

use handgate_adapters::front::core::StateGrid;
use tokio::time::Instant;

/// Absolute-deadline ticker (cancel-safe: state only changes after the wait completed): a
/// [`StateGrid`] that no device drives, slept on.
#[derive(Debug)]
pub struct Ticker {
    grid: StateGrid,
}

impl Ticker {
    /// First tick at once (a state-only front's first state, the status's first snapshot, go
    /// out as soon as the task runs, not a period later), then every period.
    pub fn new(period: Duration) -> Self {
        Self {
            grid: StateGrid::new(period, false, std::time::Instant::now()),
        }
    }

    /// From a rate in Hz (clamped to at least 0.1 Hz).
    pub fn hz(rate: f64) -> Self {
        Self::new(Duration::from_secs_f64(1.0 / rate.max(0.1)))
    }

    /// When the next tick is due.
    pub fn deadline(&self) -> Instant {
        Instant::from_std(self.grid.deadline())
    }

    /// Ticks dropped by re-anchoring after stalls.
    pub fn dropped(&self) -> u64 {
        self.grid.dropped
    }

    /// Waits for the next deadline (at once when it has passed) and advances the grid.
    pub async fn tick(&mut self) {
        tokio::time::sleep_until(self.deadline()).await;
        self.advance(Instant::now());
    }

    fn advance(&mut self, now: Instant) {
        self.grid.due(now.into_std());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn late_ticks_keep_the_grid_and_stalls_reanchor() {
        let p = Duration::from_millis(2);
        let mut t = Ticker::new(p);
        let d0 = t.deadline();
        // 1.5 periods late: the next deadline is still on the grid (one period after d0).
        t.advance(d0 + p + p / 2);
        assert_eq!(t.deadline(), d0 + p);
        t.advance(d0 + p + p / 2);
        assert_eq!(t.deadline(), d0 + 2 * p);
        // A stall of 20 periods: re-anchored one period after now, not 20 catch-up ticks.
        let now = d0 + 22 * p;
        t.advance(now);
        assert_eq!(t.deadline(), now + p);
        assert!(t.dropped() >= 19, "{}", t.dropped());
    }
}
