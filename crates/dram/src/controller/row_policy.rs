//! Row-buffer policies: when a column access should close its row (auto-precharge).

use super::queue::RequestQueues;
use crate::config::RowPolicyKind;

/// Should the column access of the request in `slot` (flat bank `b`, `row`) auto-precharge?
/// Open page: never (rows close on a conflict or a refresh). Closed page: unless another queued
/// request, read or write, wants the same row.
#[inline]
pub fn auto_precharge(
    policy: RowPolicyKind,
    q: &RequestQueues,
    b: usize,
    row: u32,
    slot: u32,
) -> bool {
    match policy {
        RowPolicyKind::Open => false,
        RowPolicyKind::Closed => !q.row_wanted(b, row, slot),
    }
}
