//! Who commands a front (`control`, docs/fronts.md "One commanding client per front"): the
//! ownership state machine of one front, pure (time is passed in), driven by the front task.
//!
//! `exclusive`: the first writer whose command is accepted owns the front; it keeps it while
//! its commands keep being accepted and until it has been silent for the front's hold time
//! (a writer that goes away counts as silent from its last accepted command: no instant
//! hand-over). Samples of other writers are refused whole until then, except a writer that
//! asks to take over (`handgate send --force`). `shared`: every writer is taken.

use std::collections::HashSet;
use std::time::{Duration, Instant};

use handgate_adapters::dds::WriterHandle;
use handgate_adapters::front::config::Control;

/// Writers named in the log per owner at most (a flood of writers is not named forever).
const MAX_NAMED: usize = 256;

/// Whether a sample of a writer may go on to the front's decode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Admit {
    /// Yes: it may take or keep the front if it is accepted.
    Yes,
    /// No: another writer owns the front. `first`: the first refusal of this writer under
    /// this owner (to name it in the log once).
    Foreign { first: bool },
}

/// How the front changed hands after an accepted sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Change {
    /// The front was free (first owner).
    First,
    /// The previous owner had been silent for the hold time.
    AfterSilence { silent: Duration },
    /// Taken over from an owner that was not silent (`--force`).
    Forced,
}

#[derive(Debug, Clone, Copy)]
struct Owner {
    writer: WriterHandle,
    /// Its last accepted sample.
    last: Instant,
}

/// One front's ownership.
#[derive(Debug)]
pub(super) struct Ownership {
    control: Control,
    hold: Duration,
    owner: Option<Owner>,
    /// Writers refused (and named) under the current owner.
    named: HashSet<WriterHandle>,
}

impl Ownership {
    pub(super) fn new(control: Control, hold: Duration) -> Self {
        Self {
            control,
            hold,
            owner: None,
            named: HashSet::new(),
        }
    }

    /// The owner at `now`, if it has not been silent for the hold time.
    fn live_owner(&self, now: Instant) -> Option<Owner> {
        self.owner.filter(|o| now.saturating_duration_since(o.last) < self.hold)
    }

    /// Whether a sample of `writer` (`force`: it asks to take over) arriving at `now` may
    /// go on to decode. Changes nothing but the record of who was named.
    pub(super) fn admit(&mut self, writer: WriterHandle, force: bool, now: Instant) -> Admit {
        if self.control == Control::Shared || force {
            return Admit::Yes;
        }
        match self.live_owner(now) {
            Some(o) if o.writer != writer => {
                let first = self.named.len() < MAX_NAMED && self.named.insert(writer);
                Admit::Foreign { first }
            }
            _ => Admit::Yes,
        }
    }

    /// A sample of `writer` was accepted (at least one device took it) at `now`: it owns
    /// the front from now. Returns how the front changed hands, if it did.
    pub(super) fn accepted(&mut self, writer: WriterHandle, now: Instant) -> Option<Change> {
        if self.control == Control::Shared {
            return None;
        }
        let live = self.live_owner(now);
        let previous = self.owner.replace(Owner { writer, last: now });
        match previous {
            Some(p) if p.writer == writer => None,
            prev => {
                self.named.clear();
                Some(match (prev, live) {
                    (None, _) => Change::First,
                    (Some(_), Some(_)) => Change::Forced,
                    (Some(p), None) => Change::AfterSilence {
                        silent: now.saturating_duration_since(p.last),
                    },
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOLD: Duration = Duration::from_millis(200);
    const A: WriterHandle = 0xa;
    const B: WriterHandle = 0xb;
    const C: WriterHandle = 0xc;

    fn at(t0: Instant, ms: u64) -> Instant {
        t0 + Duration::from_millis(ms)
    }

    #[test]
    fn the_first_accepted_writer_owns_the_front_and_others_are_refused_while_it_streams() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        assert_eq!(o.admit(A, false, t0), Admit::Yes);
        assert_eq!(o.accepted(A, t0), Some(Change::First));
        for k in 1..20u64 {
            let t = at(t0, 10 * k);
            assert_eq!(o.admit(A, false, t), Admit::Yes);
            assert_eq!(o.accepted(A, t), None, "the owner keeps the front");
            let first = k == 1;
            assert_eq!(o.admit(B, false, t), Admit::Foreign { first }, "at {k}");
        }
        assert_eq!(
            o.admit(C, false, at(t0, 195)),
            Admit::Foreign { first: true },
            "each refused writer is named once"
        );
    }

    #[test]
    fn a_writer_admitted_but_not_accepted_takes_nothing() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        // A's sample is admitted but rejected by decode: no owner yet.
        assert_eq!(o.admit(A, false, t0), Admit::Yes);
        assert_eq!(o.admit(B, false, at(t0, 1)), Admit::Yes);
        assert_eq!(o.accepted(B, at(t0, 1)), Some(Change::First));
        assert_eq!(o.admit(A, false, at(t0, 2)), Admit::Foreign { first: true });
    }

    #[test]
    fn the_front_is_free_once_the_owner_is_silent_for_the_hold_time_not_before() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        o.accepted(A, t0);
        assert!(matches!(o.admit(B, false, at(t0, 199)), Admit::Foreign { .. }));
        assert_eq!(o.admit(B, false, at(t0, 200)), Admit::Yes);
        assert_eq!(
            o.accepted(B, at(t0, 250)),
            Some(Change::AfterSilence {
                silent: Duration::from_millis(250)
            })
        );
        // A is now the foreign one, and named again (new owner).
        assert_eq!(o.admit(A, false, at(t0, 260)), Admit::Foreign { first: true });
        assert_eq!(o.admit(A, false, at(t0, 270)), Admit::Foreign { first: false });
    }

    #[test]
    fn the_owner_coming_back_after_its_silence_is_not_a_change() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        o.accepted(A, t0);
        assert_eq!(o.admit(A, false, at(t0, 5000)), Admit::Yes);
        assert_eq!(o.accepted(A, at(t0, 5000)), None);
    }

    #[test]
    fn a_forcing_writer_takes_over_a_streaming_owner() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        o.accepted(A, t0);
        assert_eq!(o.admit(C, true, at(t0, 10)), Admit::Yes);
        assert_eq!(o.accepted(C, at(t0, 10)), Some(Change::Forced));
        assert_eq!(o.admit(A, false, at(t0, 20)), Admit::Foreign { first: true });
        assert_eq!(o.accepted(C, at(t0, 20)), None);
    }

    #[test]
    fn shared_takes_every_writer_and_tracks_no_owner() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Shared, HOLD);
        for (k, w) in [A, B, A, C, B].into_iter().enumerate() {
            let t = at(t0, k as u64);
            assert_eq!(o.admit(w, false, t), Admit::Yes);
            assert_eq!(o.accepted(w, t), None);
        }
    }

    #[test]
    fn a_flood_of_writers_is_named_at_most_max_named_times() {
        let t0 = Instant::now();
        let mut o = Ownership::new(Control::Exclusive, HOLD);
        o.accepted(A, t0);
        let named = (1..=(MAX_NAMED as u64 + 50))
            .filter(|w| {
                matches!(
                    o.admit(0x1000 + w, false, at(t0, 1)),
                    Admit::Foreign { first: true, .. }
                )
            })
            .count();
        assert_eq!(named, MAX_NAMED);
    }
}
