//! Periodic publishing on absolute deadlines: the k-th tick is due at `start + k·period`, so
//! a late wake-up (a loaded machine, tokio's 1 ms timer) delays one sample but never the
//! ones after it and the average rate holds. A stall longer than [`STALL_PERIODS`] periods
//! re-anchors the grid at the present instead of bursting out every missed sample.

use std::time::Duration;

use tokio::time::Instant;

/// A tick later than this many periods re-anchors the grid (the missed ticks are dropped).
pub const STALL_PERIODS: u32 = 5;

/// Absolute-deadline ticker (cancel-safe: state only changes after the wait completed).
#[derive(Debug)]
pub struct Ticker {
    period: Duration,
    next: Instant,
    /// Ticks dropped by re-anchoring after stalls.
    pub dropped: u64,
}

impl Ticker {
    /// First tick at once (a state-only front's first state, the status's first snapshot, go
    /// out as soon as the task runs, not a period later), then every period.
    pub fn new(period: Duration) -> Self {
        let period = period.max(Duration::from_micros(100));
        Self {
            period,
            next: Instant::now(),
            dropped: 0,
        }
    }

    /// From a rate in Hz (clamped to at least 0.1 Hz).
    pub fn hz(rate: f64) -> Self {
        Self::new(Duration::from_secs_f64(1.0 / rate.max(0.1)))
    }

    /// When the next tick is due.
    pub fn deadline(&self) -> Instant {
        self.next
    }

    /// Restarts the grid one period from now (a sample published off the grid stands in for
    /// the tick that was due: the next one comes a full period after it).
    pub fn restart(&mut self) {
        self.next = Instant::now() + self.period;
    }

    /// Waits for the next deadline (at once when it has passed) and advances the grid.
    pub async fn tick(&mut self) {
        tokio::time::sleep_until(self.next).await;
        self.advance(Instant::now());
    }

    fn advance(&mut self, now: Instant) {
        let late = now.saturating_duration_since(self.next);
        if late > self.period * STALL_PERIODS {
            self.dropped += (late.as_nanos() / self.period.as_nanos().max(1)) as u64;
            self.next = now + self.period;
        } else {
            self.next += self.period;
        }
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
        assert!(t.dropped >= 19, "{}", t.dropped);
    }

    #[test]
    fn a_restart_moves_the_next_tick_a_full_period_after_it() {
        let p = Duration::from_secs(3600);
        let mut t = Ticker::new(p);
        let d0 = t.deadline();
        t.advance(d0); // on time: the grid moves one period
        assert_eq!(t.deadline(), d0 + p);
        let before = Instant::now();
        t.restart();
        let after = Instant::now();
        assert!(
            t.deadline() >= before + p && t.deadline() <= after + p,
            "one period after the restart, not on the old grid"
        );
    }
}
