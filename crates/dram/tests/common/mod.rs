//! Helpers shared by the integration tests: presets with checking mode on, addresses of given
//! banks and rows, and running requests to completion.
#![allow(dead_code)]

use rtsim_core::{MemCompletion, MemOp, MemRequest, MemoryPort};
use rtsim_dram::config::preset_config;
use rtsim_dram::mapping::Location;
use rtsim_dram::trace::{Pattern, Synthetic};
use rtsim_dram::{Dram, DramConfig, DriveOptions, Report, Requester, drive};
use std::convert::Infallible;

/// A preset with checking mode on (every issued command re-validated).
pub fn config(preset: &str) -> DramConfig {
    let mut c = preset_config(preset).unwrap();
    c.check = true;
    c
}

/// A DRAM serving a 1 GHz requester (TRaX's core).
pub fn dram(c: &DramConfig) -> Dram {
    dram_at(c, 1000.0)
}

/// A DRAM serving a requester clocked at `mhz`.
pub fn dram_at(c: &DramConfig, mhz: f64) -> Dram {
    Dram::new(c, Requester::mhz(mhz)).unwrap()
}

/// Byte address of a location.
pub fn addr(d: &Dram, channel: u32, rank: u32, bank: u32, row: u32, column: u32) -> u64 {
    let bpg = d.spec().org.banks_per_group;
    d.spec().mapper.encode(&Location {
        channel,
        rank,
        bank_group: bank / bpg,
        bank,
        row,
        column,
    })
}

pub fn req(id: u64, addr: u64, op: MemOp, arrival: u64) -> MemRequest {
    MemRequest {
        id,
        addr,
        op,
        arrival,
        tag: 0,
    }
}

/// Advance event by event until nothing is outstanding; returns the completions.
pub fn run_to_idle(d: &mut Dram) -> Vec<MemCompletion> {
    let mut out = Vec::new();
    while let Some(e) = d.next_event() {
        d.advance_to(e);
        d.drain_completions(&mut out);
    }
    out
}

/// Offer `r` at its arrival cycle (advancing to just before it) and run to idle.
pub fn single(d: &mut Dram, r: MemRequest) -> MemCompletion {
    if r.arrival > 0 {
        d.advance_to(r.arrival - 1);
    }
    d.try_enqueue(r).expect("queue has room");
    let out = run_to_idle(d);
    assert_eq!(out.len(), 1);
    out[0]
}

pub fn assert_legal(d: &Dram) {
    let v = d.violations();
    assert!(v.is_empty(), "checker found violations:\n{}", v.join("\n"));
}

/// Drive `n` synthetic 64-byte requests (`pattern`, read probability `read_ratio`, `interval`
/// requester cycles apart, addresses below `capacity`, seeded) through `d` to completion, and
/// report up to the last completion.
pub fn run_synthetic(
    d: &mut Dram,
    pattern: Pattern,
    n: u64,
    read_ratio: f64,
    interval: u64,
    capacity: u64,
    seed: u64,
) -> Report {
    let t = Synthetic::new(pattern, n, read_ratio, interval, 64, capacity, seed);
    let s = drive(
        d,
        t.map(Ok::<_, Infallible>),
        DriveOptions::default(),
        |_| {},
    )
    .unwrap();
    d.report(s.end_cycle)
}
