//! The reference engine: every TP, every cycle.
//!
//! Each cycle: the memory system advances to the cycle and returned misses are applied; every
//! TP whose next instruction can issue (in order, its operands readable, no access pending)
//! asks for its unit and fetch bank; requests are granted in order of priority key (ties by
//! TP index) while the TM's units of the class and the bank's fetch ports have room; then the
//! cycle's data-cache and atomic accesses are offered: first those booked before the cycle, TM
//! by TM and oldest first, then those of TPs that resumed in the cycle, in TP order. Slow (its
//! cost is cycles × TPs), plain, and the definition the fast engine is tested against.

use crate::chip::{Chip, ChipError, Offered, Wait};
use crate::fast::Progress;
use crate::source::Source;
use crate::stats::Stall;

/// Run the frame cycle by cycle (to its end, or to `limit` cycles); returns the last cycle
/// simulated.
pub fn run<S: Source>(
    chip: &mut Chip<'_, S>,
    limit: Option<u64>,
    progress: Progress<'_>,
) -> Result<u64, ChipError> {
    let n = chip.tps();
    let tms = chip.cfg.tms as usize;
    let width = chip.row_width;
    let mut used = vec![0u8; tms * width];
    let mut want: Vec<(u64, u32, u32)> = Vec::with_capacity(n);
    let mut accesses: Vec<u32> = Vec::with_capacity(n);
    let mut done = std::mem::take(&mut chip.completions);
    let mut t = 0u64;
    while chip.live > 0 {
        chip.sample_until(t);
        if limit.is_some_and(|l| t >= l) {
            break;
        }
        chip.hier.advance_to(t)?;
        chip.hier.drain_completions(&mut done);
        for c in done.drain(..) {
            chip.complete(&c);
        }
        used.fill(0);
        want.clear();
        accesses.clear();
        for tp in 0..n {
            match chip.cores[tp].wait {
                Wait::Halted => continue,
                // Refused accesses were charged in full when refused.
                Wait::Access => {
                    if chip.cores[tp].access_at == t {
                        accesses.push(tp as u32);
                    }
                    continue;
                }
                Wait::Ready | Wait::Blocked => {}
            }
            let Some(i) = chip.current(tp) else {
                continue;
            };
            let core = &chip.cores[tp];
            if t < core.next_issue {
                // The previous instruction issued this cycle, or a branch is resolving
                // (charged at the branch).
                continue;
            }
            let d = chip.dec[i];
            let late = d.regs & core.pending
                | d.regs & {
                    let mut m = 0u32;
                    let mut r = d.regs;
                    while r != 0 {
                        let k = r.trailing_zeros();
                        r &= r - 1;
                        if core.ready_at(k as usize) > t {
                            m |= 1 << k;
                        }
                    }
                    m
                };
            if late != 0 {
                let cause = if late & core.from_mem != 0 {
                    Stall::Memory
                } else {
                    Stall::Operand
                };
                chip.issue.stall[cause as usize] += 1;
                continue;
            }
            want.push((chip.key_of(tp, i), tp as u32, i as u32));
        }
        want.sort_unstable();
        for &(key, tp, i) in &want {
            let (tp, i) = (tp as usize, i as usize);
            let d = chip.dec[i];
            let core = &chip.cores[tp];
            let row = &mut used[core.tm as usize * width..(core.tm as usize + 1) * width];
            let cls = d.class as usize;
            let bank = core.icache_col as usize + d.bank as usize;
            if d.class.is_unit() && row[cls] >= chip.caps[core.tm as usize][cls] {
                chip.issue.stall[Stall::Unit as usize] += 1;
                chip.issue.unit_busy[cls] += 1;
                continue;
            }
            if row[bank] >= chip.fetch_cap {
                chip.issue.stall[Stall::Fetch as usize] += 1;
                continue;
            }
            if d.class.is_unit() {
                row[cls] += 1;
            }
            row[bank] += 1;
            let core = &mut chip.cores[tp];
            core.key = key;
            if d.class.is_sync() {
                core.wait = Wait::Access;
                core.access_at = t;
                accesses.push(tp as u32);
            } else {
                chip.retire_issue(tp, i, t);
                chip.sampler.issue(t);
            }
        }
        // Two rounds: the accesses booked before this cycle, TM by TM, oldest first (by key,
        // ties by TP index); then those of TPs that resumed this cycle (key `t`), in TP order.
        let cores = &chip.cores;
        accesses.sort_unstable_by_key(|&tp| {
            let c = &cores[tp as usize];
            (c.key == t, c.tm, c.key, tp)
        });
        for &tp in &accesses {
            let tp = tp as usize;
            let i = (chip.cores[tp].run.seg.start + chip.cores[tp].ip) as usize;
            if let Offered::Busy { retry_at } = chip.access(tp, i, t)? {
                chip.cores[tp].access_at = retry_at;
            }
        }
        if t & 0xFFF == 0 {
            progress(t, chip.pixels_done, chip.rays_done);
        }
        t += 1;
    }
    chip.completions = done;
    Ok(t.saturating_sub(1))
}
