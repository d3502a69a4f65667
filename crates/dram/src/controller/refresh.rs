//! Refresh scheduling: all-bank REFs per rank, one every tREFI or in batches.
//!
//! Rank `r` of `n` is first due at `P · (r + 1) / n` when staggered (else at `P`), then every
//! `P` after its previous due time, where the period `P = batch × tREFI`; so the long-run rate
//! is exactly one REF per tREFI however late each one is issued. Once due, the rank is
//! *pending*: the controller stops serving its requests, precharges its open banks and issues
//! `batch` REFs back to back (each blocks the rank for tRFC). With `batch = 1` (the default)
//! that is the usual one REF per tREFI; `batch = 8` is USIMM's scheme (eight REFs every
//! 8 × tREFI, JESD79-3F §4.9.1 allows up to eight to be postponed). The refresh is not
//! postponed further.

use crate::spec::DramSpec;

#[derive(Clone, Debug)]
pub struct Refresh {
    pub enabled: bool,
    /// tREFI × batch.
    period: u64,
    batch: u32,
    /// Next due cycle per rank.
    pub due: Vec<u64>,
    /// Due and not all of its batch issued yet.
    pub pending: Vec<bool>,
    /// REFs of the current batch still to issue, per pending rank.
    left: Vec<u32>,
    /// Ranks pending.
    pending_count: usize,
    /// Earliest due time among ranks not pending (`u64::MAX`: none, or disabled).
    next_due: u64,
}

impl Refresh {
    pub fn new(spec: &DramSpec) -> Self {
        let n = u64::from(spec.org.ranks);
        let batch = spec.refresh().batch;
        let period = spec.t.refi * u64::from(batch);
        let stagger = spec.refresh().stagger_ranks;
        let mut r = Refresh {
            enabled: spec.refresh().enabled,
            period,
            batch,
            due: (0..n)
                .map(|r| {
                    if stagger {
                        period * (r + 1) / n
                    } else {
                        period
                    }
                })
                .collect(),
            pending: vec![false; n as usize],
            left: vec![0; n as usize],
            pending_count: 0,
            next_due: u64::MAX,
        };
        r.update_next_due();
        r
    }

    fn update_next_due(&mut self) {
        self.next_due = if self.enabled {
            self.due
                .iter()
                .zip(&self.pending)
                .filter(|(_, p)| !**p)
                .map(|(d, _)| *d)
                .min()
                .unwrap_or(u64::MAX)
        } else {
            u64::MAX
        };
    }

    /// Mark ranks whose refresh is due by cycle `t`; true if any became pending.
    #[inline]
    pub fn poll(&mut self, t: u64) -> bool {
        if t < self.next_due {
            return false;
        }
        for r in 0..self.due.len() {
            if !self.pending[r] && t >= self.due[r] {
                self.pending[r] = true;
                self.left[r] = self.batch;
                self.pending_count += 1;
            }
        }
        self.update_next_due();
        true
    }

    /// The period between due times (tREFI × batch).
    pub fn period(&self) -> u64 {
        self.period
    }

    /// REFs per due time.
    pub fn batch(&self) -> u32 {
        self.batch
    }

    /// Is any rank pending?
    #[inline]
    pub fn any_pending(&self) -> bool {
        self.pending_count > 0
    }

    /// A REF was issued for `rank`.
    pub fn issued(&mut self, rank: usize) {
        self.left[rank] -= 1;
        if self.left[rank] == 0 {
            self.pending[rank] = false;
            self.pending_count -= 1;
            self.due[rank] += self.period;
            self.update_next_due();
        }
    }

    /// Move `rank`'s (not pending) due time on by `n` periods, whose refreshes the caller
    /// counts without simulating them.
    pub fn skip(&mut self, rank: usize, n: u64) {
        debug_assert!(!self.pending[rank]);
        self.due[rank] += n * self.period;
        self.update_next_due();
    }

    /// Earliest due time among ranks not yet pending (an event for the scheduler).
    #[inline]
    pub fn next_due(&self) -> Option<u64> {
        (self.next_due != u64::MAX).then_some(self.next_due)
    }
}
