//! When the device loop exchanges: the 1 kHz grid, and how it may follow the commands
//! ([`Align`]). A pure schedule over [`Instant`]s: the loop asks it when the next exchange is
//! due and tells it when exchanges start and end; it never reads the clock itself, so every
//! rule here is tested over made-up times (docs/dex3-usb.md, "Aligning the exchange to
//! commands").
//!
//! - [`Align::Off`]: absolute deadlines `t0 + k·period`; a late cycle skips the deadlines it
//!   missed (no catch-up burst). A command waits for the next deadline.
//! - [`Align::Early`]: as `Off`, but a command not yet sent makes the next exchange due at
//!   `max(its arrival, previous exchange + min_gap)` when that is before the next deadline;
//!   an exchange that starts early re-anchors the grid on itself (the next deadline is one
//!   period after it). No exchange, early or on the grid, is due within `min_gap` of the
//!   previous one (`Off` and `Phase` can follow a late wake-up closely: that is the old loop's
//!   behaviour), and none is due later than a period after it; the early exchange replaces
//!   the scheduled one, and exchanges outnumber periods only by the commands that came in
//!   between.
//! - [`Align::Phase`]: one exchange per period on the grid, but the grid moves by at most
//!   `max_shift` per cycle towards the phase at which commands arrive, so that a client at a
//!   steady rate finds the exchange `lead` after its command.

use std::time::{Duration, Instant};

/// How the device loop's exchanges follow the commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Align {
    /// Fixed grid: a command waits for the next deadline.
    #[default]
    Off,
    /// Exchange as soon as a new command arrives, but never within `min_gap` of the previous
    /// exchange; the grid restarts from every early exchange.
    Early { min_gap: Duration },
    /// Fixed period; the grid's phase moves by at most `max_shift` per cycle so that
    /// commands arrive `lead` before a deadline.
    Phase { max_shift: Duration, lead: Duration },
}

impl Align {
    /// Whether a new command should wake the loop before its deadline.
    pub fn wakes_on_command(&self) -> bool {
        matches!(self, Align::Early { .. })
    }
}

/// The loop's schedule (one per connection).
#[derive(Debug, Clone)]
pub struct Schedule {
    period: Duration,
    align: Align,
    /// Grid origin: deadline `k` is `t0 + k·period`.
    t0: Instant,
    /// Index of the next deadline.
    k: u64,
    /// Start of the previous exchange.
    last_start: Option<Instant>,
    /// Phase correction still to apply, ns; positive moves the grid earlier.
    shift_left: i64,
}

/// `t0 + k·period` without accumulating rounding.
fn grid(t0: Instant, period: Duration, k: u64) -> Instant {
    t0 + Duration::from_nanos((period.as_nanos() * k as u128).min(u64::MAX as u128) as u64)
}

/// `a - b` in ns, signed.
fn signed_ns(a: Instant, b: Instant) -> i64 {
    if a >= b {
        (a - b).as_nanos().min(i64::MAX as u128) as i64
    } else {
        -((b - a).as_nanos().min(i64::MAX as u128) as i64)
    }
}

impl Schedule {
    /// A schedule whose first exchange is due at `now`.
    pub fn new(period: Duration, align: Align, now: Instant) -> Self {
        Self {
            period,
            align,
            t0: now,
            k: 0,
            last_start: None,
            shift_left: 0,
        }
    }

    /// The next deadline on the grid.
    pub fn deadline(&self) -> Instant {
        grid(self.t0, self.period, self.k)
    }

    /// When the next exchange is due, given the arrival of the newest command not sent yet
    /// (`None`: no such command).
    pub fn due(&self, pending: Option<Instant>) -> Instant {
        let d = self.deadline();
        match (self.align, self.last_start) {
            (Align::Early { min_gap }, Some(last)) => {
                let soonest = last + min_gap;
                // A grid deadline too is never within min_gap of the previous exchange (after a
                // late wake-up the next deadline can be close behind).
                match pending {
                    Some(arrived) => d.min(arrived.max(soonest)).max(soonest),
                    None => d.max(soonest),
                }
            }
            _ => d,
        }
    }

    /// An exchange starts at `start`, sending a new command that arrived at `sent` (`None`:
    /// it repeats the previous command or holds).
    pub fn begin(&mut self, start: Instant, sent: Option<Instant>) {
        let d = self.deadline();
        match self.align {
            Align::Off => {}
            Align::Early { .. } => {
                if start < d {
                    // The early exchange replaces the scheduled one: the grid restarts here.
                    self.t0 = start;
                    self.k = 0;
                }
            }
            Align::Phase { lead, .. } => {
                if let Some(arrived) = sent {
                    // Positive: the command waited longer than `lead` for this deadline (move the
                    // grid earlier); negative: it came later than `lead` before it (move it later).
                    // Wrapped to the shorter way round the period.
                    let p = self.period.as_nanos() as i64;
                    let mut err = signed_ns(d, arrived) - lead.as_nanos() as i64;
                    err = err.rem_euclid(p);
                    if err > p / 2 {
                        err -= p;
                    }
                    self.shift_left = err;
                }
            }
        }
        self.last_start = Some(start);
    }

    /// The exchange ended at `now`: moves to the next deadline (after at most one phase step)
    /// and returns how many deadlines were missed (skipped, never caught up).
    pub fn end(&mut self, now: Instant) -> u64 {
        self.k += 1;
        if let Align::Phase { max_shift, .. } = self.align {
            let m = max_shift.as_nanos().min(i64::MAX as u128) as i64;
            let step = self.shift_left.clamp(-m, m);
            self.shift_left -= step;
            if step >= 0 {
                self.t0 -= Duration::from_nanos(step as u64);
            } else {
                self.t0 += Duration::from_nanos(step.unsigned_abs());
            }
        }
        let next = self.deadline();
        if now > next {
            let behind = ((now - next).as_nanos() / self.period.as_nanos()) as u64 + 1;
            self.k += behind;
            behind
        } else {
            0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: Duration = Duration::from_millis(1);

    fn us(n: u64) -> Duration {
        Duration::from_micros(n)
    }

    /// What the loop does, over made-up times: commands arrive at `arrivals` (sorted, after
    /// `t`), the loop wakes on each (when its mode does) and at every due time, an exchange
    /// takes `took`. Returns (start, arrival of the new command it sent) per exchange, until
    /// `until`.
    fn run(
        align: Align,
        start: Instant,
        arrivals: &[Instant],
        took: Duration,
        until: Instant,
    ) -> Vec<(Instant, Option<Instant>)> {
        let mut s = Schedule::new(P, align, start);
        let mut t = start;
        let mut sent_upto = 0; // arrivals[..sent_upto] are sent or superseded
        let mut out = Vec::new();
        while t < until {
            // The newest command arrived by `t` and not sent yet.
            let arrived = arrivals.partition_point(|a| *a <= t);
            let pending = (arrived > sent_upto).then(|| arrivals[arrived - 1]);
            let due = s.due(if align.wakes_on_command() { pending } else { None });
            if let Some(next) = arrivals.get(arrived).filter(|a| **a < due && align.wakes_on_command()) {
                t = *next; // woken by the command: look again
                continue;
            }
            t = t.max(due);
            if t >= until {
                break;
            }
            let arrived = arrivals.partition_point(|a| *a <= t);
            let sent = (arrived > sent_upto).then(|| arrivals[arrived - 1]);
            sent_upto = arrived;
            s.begin(t, sent);
            out.push((t, sent));
            t += took;
            s.end(t);
        }
        out
    }

    /// The old loop's schedule: `t0 + k·P`, late deadlines skipped.
    fn old_schedule(start: Instant, took: Duration, until: Instant) -> Vec<Instant> {
        let (mut k, mut t, mut out) = (0u64, start, Vec::new());
        while t < until {
            out.push(t);
            let now = t + took;
            k += 1;
            let mut next = grid(start, P, k);
            if now > next {
                k += ((now - next).as_nanos() / P.as_nanos()) as u64 + 1;
                next = grid(start, P, k);
            }
            t = next;
        }
        out
    }

    /// Commands at `every`, each `jitter(i)` into its period.
    fn stream(t0: Instant, every: Duration, n: u32, jitter: impl Fn(u32) -> Duration) -> Vec<Instant> {
        (0..n).map(|i| t0 + every * i + jitter(i)).collect()
    }

    /// A fixed pseudo-random phase in 0..d.
    fn scatter(d: Duration) -> impl Fn(u32) -> Duration {
        move |i| {
            Duration::from_nanos(
                (u64::from(i).wrapping_mul(2_654_435_761) % 1_000_003) * d.as_nanos() as u64 / 1_000_003,
            )
        }
    }

    #[test]
    fn off_is_the_old_schedule() {
        let t0 = Instant::now();
        let cmds = stream(t0 + us(130), us(1000), 50, scatter(us(1000)));
        for took in [us(7), us(400), us(2500)] {
            let got: Vec<Instant> = run(Align::Off, t0, &cmds, took, t0 + us(60_000))
                .into_iter()
                .map(|(s, _)| s)
                .collect();
            assert_eq!(got, old_schedule(t0, took, t0 + us(60_000)), "took {took:?}");
        }
    }

    #[test]
    fn off_ignores_commands_and_counts_misses() {
        let t0 = Instant::now();
        let mut s = Schedule::new(P, Align::Off, t0);
        assert_eq!(s.due(Some(t0)), t0);
        s.begin(t0, Some(t0));
        assert_eq!(s.end(t0 + us(10)), 0);
        assert_eq!(
            s.due(Some(t0 + us(20))),
            t0 + P,
            "a command does not move an off schedule"
        );
        s.begin(t0 + P, None);
        // Ends 2.5 periods later: deadlines 2 and 3 are missed, the next is 4.
        assert_eq!(s.end(t0 + us(3500)), 2);
        assert_eq!(s.deadline(), t0 + us(4000));
    }

    #[test]
    fn early_exchanges_on_a_command_after_min_gap() {
        let t0 = Instant::now();
        let min_gap = us(300);
        let align = Align::Early { min_gap };
        // One exchange at t0, a command at 450 µs (after min_gap): exchanged at once.
        let got = run(align, t0, &[t0 + us(450)], us(5), t0 + us(2000));
        assert_eq!(got[0], (t0, None));
        assert_eq!(got[1], (t0 + us(450), Some(t0 + us(450))));
        // The grid restarted there: the next exchange is one period later.
        assert_eq!(got[2].0, t0 + us(1450));
        // A command within min_gap of the previous exchange waits for min_gap, not the deadline.
        let got = run(align, t0, &[t0 + us(100)], us(5), t0 + us(2000));
        assert_eq!(got[1], (t0 + min_gap, Some(t0 + us(100))));
        assert_eq!(got[2].0, t0 + min_gap + P);
    }

    #[test]
    fn early_never_closer_than_min_gap_nor_further_than_a_period() {
        let t0 = Instant::now();
        for min_gap in [us(100), us(300), us(500), us(900)] {
            for (every, n) in [(us(1000), 400u32), (us(5000), 80), (us(250), 1600), (us(1300), 300)] {
                let cmds = stream(t0 + us(17), every, n, scatter(every));
                let got = run(Align::Early { min_gap }, t0, &cmds, us(8), t0 + us(400_000));
                for w in got.windows(2) {
                    let gap = w[1].0 - w[0].0;
                    assert!(
                        gap >= min_gap,
                        "gap {gap:?} < min_gap {min_gap:?} (commands every {every:?})"
                    );
                    assert!(gap <= P, "gap {gap:?} > period (commands every {every:?})");
                }
                // Every command is sent (or superseded) by the first exchange at or after
                // max(its arrival, previous exchange + min_gap): never later than that.
                let last = got.last().expect("exchanges").0;
                for (i, a) in cmds.iter().enumerate().filter(|(_, a)| **a + P < last) {
                    let superseded = cmds
                        .get(i + 1)
                        .is_some_and(|b| got.iter().find(|(s, _)| *s >= *a).is_some_and(|(s, _)| b <= s));
                    if superseded {
                        continue;
                    }
                    let (s, sent) = *got.iter().find(|(s, _)| *s >= *a).expect("sent");
                    assert_eq!(sent, Some(*a));
                    let prev = got.iter().rev().find(|(p, _)| *p < *a).map(|(p, _)| *p).unwrap_or(t0);
                    assert!(
                        s <= (*a).max(prev + min_gap),
                        "command at {:?} sent at {:?}",
                        *a - t0,
                        s - t0
                    );
                }
            }
        }
    }

    #[test]
    fn early_keeps_min_gap_after_a_late_wake_up() {
        // The exchange due at 1 ms starts 980 µs late: the next grid deadline (2 ms) would be
        // 20 µs after it; early waits for min_gap, with or without a command.
        let t0 = Instant::now();
        let min_gap = us(500);
        let mut s = Schedule::new(P, Align::Early { min_gap }, t0);
        s.begin(t0, None);
        assert_eq!(s.end(t0 + us(5)), 0);
        let late = t0 + us(1980);
        s.begin(late, None);
        assert_eq!(s.end(late + us(5)), 0);
        assert_eq!(s.deadline(), t0 + us(2000));
        assert_eq!(s.due(None), late + min_gap);
        assert_eq!(s.due(Some(late + us(10))), late + min_gap);
        // The postponed grid exchange comes before a command arriving after it.
        assert_eq!(s.due(Some(late + us(700))), late + min_gap);
        // Off keeps the old schedule: 20 µs later.
        let mut o = Schedule::new(P, Align::Off, t0);
        o.begin(t0, None);
        o.end(t0 + us(5));
        o.begin(late, None);
        o.end(late + us(5));
        assert_eq!(o.due(Some(late + us(10))), t0 + us(2000));
    }

    #[test]
    fn early_keeps_the_exchange_rate_bounded() {
        // Commands at 1 kHz, each at a random point of its period: every exchange is at least
        // min_gap after the previous, and at most one exchange per command is added to the
        // 1 kHz grid.
        let t0 = Instant::now();
        let min_gap = us(500);
        let n = 1000;
        let cmds = stream(t0 + us(3), P, n, scatter(P));
        let until = t0 + P * n;
        let got = run(Align::Early { min_gap }, t0, &cmds, us(8), until);
        let periods = (until - t0).as_nanos() / P.as_nanos();
        assert!(got.len() as u128 <= (until - t0).as_nanos() / min_gap.as_nanos() + 1);
        assert!(got.len() as u128 <= periods + n as u128, "{} exchanges", got.len());
        assert!(
            got.len() as u128 >= periods,
            "{} exchanges in {periods} periods",
            got.len()
        );
    }

    #[test]
    fn phase_shift_is_bounded_per_cycle() {
        let t0 = Instant::now();
        let max_shift = us(20);
        let align = Align::Phase {
            max_shift,
            lead: us(50),
        };
        for (every, jitter) in [
            (us(1000), us(0)),
            (us(5000), us(0)),
            (us(1000), us(1000)),
            (us(2000), us(700)),
        ] {
            let cmds = stream(t0 + us(610), every, 200, scatter(jitter));
            let got = run(align, t0, &cmds, us(8), t0 + every * 200);
            for w in got.windows(2) {
                let gap = w[1].0 - w[0].0;
                assert!(
                    gap >= P - max_shift && gap <= P + max_shift,
                    "period {gap:?} beyond ±{max_shift:?} (commands every {every:?})"
                );
            }
        }
    }

    #[test]
    fn phase_converges_to_lead_before_a_steady_client() {
        // A client at exactly 1 kHz, its commands 610 µs after the loop's deadlines (each
        // waits 390 µs): the grid moves earlier by 20 µs a cycle until each command arrives
        // `lead` before a deadline.
        let t0 = Instant::now();
        let lead = us(50);
        let align = Align::Phase {
            max_shift: us(20),
            lead,
        };
        let cmds = stream(t0 + us(610), P, 200, |_| Duration::ZERO);
        let got = run(align, t0, &cmds, us(8), t0 + us(200_000));
        let waits: Vec<Duration> = got.iter().filter_map(|(s, sent)| sent.map(|a| *s - a)).collect();
        assert!(waits[0] > us(300), "starts far: {:?}", waits[0]);
        let tail = &waits[waits.len() - 50..];
        assert!(tail.iter().all(|w| *w == lead), "settles at lead: {tail:?}");
        // The same client against `off` waits the same 390 µs forever.
        let off = run(Align::Off, t0, &cmds, us(8), t0 + us(200_000));
        assert!(off
            .iter()
            .filter_map(|(s, sent)| sent.map(|a| *s - a))
            .all(|w| w == us(390)));
    }

    #[test]
    fn phase_without_commands_keeps_the_grid() {
        let t0 = Instant::now();
        let align = Align::Phase {
            max_shift: us(20),
            lead: us(50),
        };
        let got: Vec<Instant> = run(align, t0, &[], us(8), t0 + us(30_000))
            .into_iter()
            .map(|(s, _)| s)
            .collect();
        assert_eq!(got, old_schedule(t0, us(8), t0 + us(30_000)));
    }
}
