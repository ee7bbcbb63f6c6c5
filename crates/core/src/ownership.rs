//! Who drives a vessel: the ownership protocol between daemons configured for the same vessel,
//! as a pure state machine (no clock, no network: time and the liveliness events come in).
//!
//! ## Model
//!
//! Every daemon configured for a vessel is a *candidate*: it holds the liveliness token
//! `vessels/<v>/fdi/candidate/<id>` as long as it runs. The daemon that drives the vessel (the
//! *holder*) also holds `vessels/<v>/fdi/holder/<id>` and the contract's `fdi/alive`. Ids are
//! compared as strings (byte order); every daemon sees the same tokens, so every daemon
//! computes the same answer. The rules, evaluated on every event and timeout:
//!
//! 1. **Claim.** For `claim_s` after its start a daemon only listens (its liveliness
//!    subscriber's history brings the tokens already there). Then, if another daemon holds the
//!    vessel, it stands by; if none does, the lowest id among the live candidates (itself
//!    included) holds. Two daemons started together thus settle on the lowest id, one
//!    `claim_s` after the later one started.
//! 2. **Incumbent.** A holder keeps the vessel while its tokens live: a candidate that comes
//!    later (even with a lower id) stands by.
//! 3. **Takeover.** When no holder token is left, a standby waits `takeover_s` (longer than the
//!    contract's excitation `hold_s`: whatever the old holder last sent has expired, so its
//!    test is never continued), then the lowest live candidate holds.
//! 4. **Two holders** (a healed partition): the holder with the lowest id keeps the vessel,
//!    every other holder yields at once, on the event that shows it the other holder.
//!
//! Invariants (unit tests below): a holder never sees a live holder with a lower id after an
//! event has been handled; a daemon holds only after `claim_s` and, after a holder it saw went
//! away, only `takeover_s` later; the decision depends only on the set of live tokens and on
//! time, not on the order events arrive in.

use std::collections::BTreeSet;

/// A daemon's part in one vessel's ownership.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Role {
    /// Listening for the tokens already there (the first `claim_s`).
    Claiming,
    /// Driving the vessel.
    Holder,
    /// Standing by: another daemon holds the vessel (`holder`), or none does yet (`None`: a
    /// takeover is pending).
    Standby {
        /// The holder's id, when one is alive.
        holder: Option<String>,
    },
}

impl Role {
    /// Whether this role drives the vessel.
    pub fn drives(&self) -> bool {
        matches!(self, Role::Holder)
    }
}

/// A liveliness event about another daemon's tokens for this vessel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// `fdi/candidate/<id>` appeared.
    CandidateUp(String),
    /// `fdi/candidate/<id>` went away.
    CandidateDown(String),
    /// `fdi/holder/<id>` appeared.
    HolderUp(String),
    /// `fdi/holder/<id>` went away.
    HolderDown(String),
}

/// One vessel's ownership as seen by the daemon `me`. Drive it with [`Ownership::handle`] and
/// [`Ownership::handle_timeout`] (at [`Ownership::poll_timeout`]); read [`Ownership::role`].
#[derive(Debug, Clone)]
pub struct Ownership {
    me: String,
    claim_s: f64,
    takeover_s: f64,
    /// When the claim window ends [s].
    claim_end: f64,
    /// Other live candidates.
    candidates: BTreeSet<String>,
    /// Other live holders.
    holders: BTreeSet<String>,
    /// Since when no holder is known (after one went away) [s]: the takeover clock.
    vacant_since: Option<f64>,
    role: Role,
}

impl Ownership {
    /// Daemon `me`, started at `now` [s], with the claim window and the takeover delay.
    pub fn new(me: &str, now: f64, claim_s: f64, takeover_s: f64) -> Self {
        Self {
            me: me.to_string(),
            claim_s,
            takeover_s,
            claim_end: now + claim_s,
            candidates: BTreeSet::new(),
            holders: BTreeSet::new(),
            vacant_since: None,
            role: Role::Claiming,
        }
    }

    /// This daemon's id.
    pub fn id(&self) -> &str {
        &self.me
    }

    /// The role now.
    pub fn role(&self) -> &Role {
        &self.role
    }

    /// The other live holders (more than none while this daemon holds: a healed partition).
    pub fn other_holders(&self) -> &BTreeSet<String> {
        &self.holders
    }

    /// The other live candidates.
    pub fn other_candidates(&self) -> &BTreeSet<String> {
        &self.candidates
    }

    /// The claim window [s].
    pub fn claim_s(&self) -> f64 {
        self.claim_s
    }

    /// Takes an event at `now` [s]; returns the new role when it changed.
    pub fn handle(&mut self, now: f64, ev: Event) -> Option<Role> {
        match ev {
            Event::CandidateUp(id) if id != self.me => {
                self.candidates.insert(id);
            }
            Event::CandidateDown(id) => {
                self.candidates.remove(&id);
            }
            Event::HolderUp(id) if id != self.me => {
                self.holders.insert(id);
                self.vacant_since = None;
            }
            Event::HolderDown(id) => {
                if self.holders.remove(&id) && self.holders.is_empty() {
                    self.vacant_since = Some(now);
                }
            }
            // Our own tokens, echoed back.
            Event::CandidateUp(_) | Event::HolderUp(_) => {}
        }
        self.decide(now)
    }

    /// Takes the passing of time; returns the new role when it changed.
    pub fn handle_timeout(&mut self, now: f64) -> Option<Role> {
        self.decide(now)
    }

    /// When [`Ownership::handle_timeout`] must be called next [s] (`None`: only on events).
    pub fn poll_timeout(&self) -> Option<f64> {
        match &self.role {
            Role::Claiming => Some(self.claim_end),
            Role::Holder => None,
            Role::Standby { .. } => match self.vacant_since {
                Some(t) if self.holders.is_empty() && self.lowest_candidate() => {
                    Some(t + self.takeover_s)
                }
                _ => None,
            },
        }
    }

    /// Whether this daemon has the lowest id among the live candidates.
    fn lowest_candidate(&self) -> bool {
        self.candidates.first().is_none_or(|c| self.me < *c)
    }

    fn decide(&mut self, now: f64) -> Option<Role> {
        let lowest = self.lowest_candidate();
        let first_holder = self.holders.first().cloned();
        let next = match (&self.role, first_holder) {
            (Role::Claiming, _) if now < self.claim_end => Role::Claiming,
            (Role::Holder, Some(h)) if h < self.me => Role::Standby { holder: Some(h) },
            (Role::Holder, _) => Role::Holder,
            (Role::Claiming | Role::Standby { .. }, Some(h)) => Role::Standby { holder: Some(h) },
            (Role::Claiming, None) if lowest => Role::Holder,
            (Role::Claiming | Role::Standby { .. }, None) => {
                // No holder: the takeover clock runs from when the last one went (or from
                // now, when none was ever seen: the lowest candidate was still claiming).
                let since = *self.vacant_since.get_or_insert(now);
                if lowest && now >= since + self.takeover_s {
                    Role::Holder
                } else {
                    Role::Standby { holder: None }
                }
            }
        };
        if next == Role::Holder {
            self.vacant_since = None;
        }
        (next != self.role).then(|| {
            self.role = next.clone();
            next
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CLAIM: f64 = 0.5;
    const TAKEOVER: f64 = 3.0;

    fn up(id: &str) -> Event {
        Event::CandidateUp(id.into())
    }

    fn standby(h: &str) -> Role {
        Role::Standby {
            holder: Some(h.into()),
        }
    }

    #[test]
    fn alone_it_holds_after_the_claim_window_not_before() {
        let mut o = Ownership::new("a", 10.0, CLAIM, TAKEOVER);
        assert_eq!(o.poll_timeout(), Some(10.5));
        assert_eq!(o.handle_timeout(10.49), None);
        assert_eq!(o.role(), &Role::Claiming);
        assert_eq!(o.handle_timeout(10.5), Some(Role::Holder));
        assert_eq!(o.poll_timeout(), None);
    }

    #[test]
    fn two_started_together_settle_on_the_lowest_id_whatever_the_order_of_events() {
        // Each sees the other's candidate token within the window, in either order.
        let mut a = Ownership::new("a", 0.0, CLAIM, TAKEOVER);
        let mut b = Ownership::new("b", 0.1, CLAIM, TAKEOVER);
        b.handle(0.1, up("a"));
        a.handle(0.2, up("b"));
        assert_eq!(a.handle_timeout(0.5), Some(Role::Holder));
        assert_eq!(
            b.handle_timeout(0.6),
            Some(Role::Standby { holder: None }),
            "b waits for a's holder token"
        );
        assert_eq!(
            b.handle(0.61, Event::HolderUp("a".into())),
            Some(standby("a"))
        );
        // b started first and sees a's token late: still a.
        let mut b = Ownership::new("b", 0.0, CLAIM, TAKEOVER);
        let mut a = Ownership::new("a", 0.3, CLAIM, TAKEOVER);
        a.handle(0.3, up("b"));
        b.handle(0.35, up("a"));
        assert_eq!(b.handle_timeout(0.5), Some(Role::Standby { holder: None }));
        assert_eq!(a.handle_timeout(0.8), Some(Role::Holder));
    }

    #[test]
    fn a_newcomer_stands_by_even_with_a_lower_id() {
        let mut a = Ownership::new("a", 100.0, CLAIM, TAKEOVER);
        a.handle(100.0, up("z"));
        a.handle(100.0, Event::HolderUp("z".into()));
        assert_eq!(a.handle_timeout(100.5), Some(standby("z")));
        assert_eq!(a.poll_timeout(), None);
    }

    #[test]
    fn takeover_comes_takeover_s_after_the_holder_went_and_only_to_the_lowest() {
        let mut b = Ownership::new("b", 0.0, CLAIM, TAKEOVER);
        let mut c = Ownership::new("c", 0.0, CLAIM, TAKEOVER);
        for (o, other) in [(&mut b, "c"), (&mut c, "b")] {
            o.handle(0.0, up("a"));
            o.handle(0.0, up(other));
            o.handle(0.0, Event::HolderUp("a".into()));
            o.handle_timeout(0.5);
            assert_eq!(o.role(), &standby("a"));
        }
        // a is killed at 50 s: its tokens go.
        for o in [&mut b, &mut c] {
            assert_eq!(
                o.handle(50.0, Event::HolderDown("a".into())),
                Some(Role::Standby { holder: None })
            );
            o.handle(50.0, Event::CandidateDown("a".into()));
        }
        assert_eq!(b.poll_timeout(), Some(53.0));
        assert_eq!(c.poll_timeout(), None, "c is not the lowest");
        assert_eq!(b.handle_timeout(52.99), None);
        assert_eq!(b.handle_timeout(53.0), Some(Role::Holder));
        assert_eq!(c.handle_timeout(60.0), None);
        assert_eq!(
            c.handle(53.01, Event::HolderUp("b".into())),
            Some(standby("b"))
        );
        // A holder that comes back within the delay cancels the takeover.
        let mut d = Ownership::new("d", 0.0, CLAIM, TAKEOVER);
        d.handle(0.0, Event::HolderUp("e".into()));
        d.handle_timeout(1.0);
        d.handle(10.0, Event::HolderDown("e".into()));
        d.handle(11.0, Event::HolderUp("f".into()));
        assert_eq!(d.handle_timeout(20.0), None);
        assert_eq!(d.role(), &standby("f"));
    }

    #[test]
    fn of_two_holders_the_higher_id_yields_on_the_event_and_the_lower_keeps() {
        let mut a = Ownership::new("a", 0.0, CLAIM, TAKEOVER);
        let mut b = Ownership::new("b", 0.0, CLAIM, TAKEOVER);
        a.handle_timeout(1.0);
        b.handle_timeout(1.0);
        assert!(
            a.role().drives() && b.role().drives(),
            "partitioned: both hold"
        );
        // The partition heals.
        assert_eq!(
            b.handle(7.0, Event::HolderUp("a".into())),
            Some(standby("a"))
        );
        assert_eq!(a.handle(7.0, Event::HolderUp("b".into())), None);
        assert!(a.role().drives());
        assert!(a.other_holders().contains("b"));
        assert_eq!(a.handle(7.1, Event::HolderDown("b".into())), None);
        assert!(a.other_holders().is_empty());
    }

    #[test]
    fn its_own_tokens_echoed_back_change_nothing() {
        let mut a = Ownership::new("a", 0.0, CLAIM, TAKEOVER);
        a.handle_timeout(0.5);
        assert_eq!(a.handle(1.0, Event::HolderUp("a".into())), None);
        assert_eq!(a.handle(1.0, up("a")), None);
        assert!(a.other_holders().is_empty() && a.other_candidates().is_empty());
        assert!(a.role().drives());
    }
}
