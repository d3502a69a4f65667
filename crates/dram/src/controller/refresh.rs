//! Refresh scheduling: an all-bank REF per rank every tREFI.
//!
//! Rank `r` of `n` is first due at `tREFI · (r + 1) / n` when staggered (else at tREFI), then
//! every tREFI after its previous due time, so the long-run rate is exactly one REF per tREFI
//! however late each one is issued. Once due, the rank is *pending*: the controller stops
//! serving its requests, precharges its open banks and issues REF (which blocks the rank for
//! tRFC). The refresh is not postponed.

use crate::spec::DramSpec;

#[derive(Clone, Debug)]
pub struct Refresh {
    pub enabled: bool,
    refi: u64,
    /// Next due cycle per rank.
    pub due: Vec<u64>,
    /// Due and not yet issued.
    pub pending: Vec<bool>,
}

impl Refresh {
    pub fn new(spec: &DramSpec) -> Self {
        let n = u64::from(spec.org.ranks);
        let refi = spec.t.refi;
        let stagger = spec.refresh().stagger_ranks;
        Refresh {
            enabled: spec.refresh().enabled,
            refi,
            due: (0..n)
                .map(|r| if stagger { refi * (r + 1) / n } else { refi })
                .collect(),
            pending: vec![false; n as usize],
        }
    }

    /// Mark ranks whose refresh is due by cycle `t`; true if any became pending.
    #[inline]
    pub fn poll(&mut self, t: u64) -> bool {
        if !self.enabled {
            return false;
        }
        let mut any = false;
        for (d, p) in self.due.iter().zip(self.pending.iter_mut()) {
            if !*p && t >= *d {
                *p = true;
                any = true;
            }
        }
        any
    }

    /// tREFI.
    pub fn interval(&self) -> u64 {
        self.refi
    }

    /// REF issued for `rank`.
    pub fn issued(&mut self, rank: usize) {
        self.pending[rank] = false;
        self.due[rank] += self.refi;
    }

    /// Earliest due time among ranks not yet pending (an event for the scheduler).
    pub fn next_due(&self) -> Option<u64> {
        if !self.enabled {
            return None;
        }
        self.due
            .iter()
            .zip(&self.pending)
            .filter(|(_, p)| !**p)
            .map(|(d, _)| *d)
            .min()
    }
}
