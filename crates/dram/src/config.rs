//! The DRAM configuration tree: organisation, timing, currents, controller policies, refresh and
//! address mapping, as one serde struct with a documented default on every field.
//!
//! Defaults are the `gddr5-trax` preset (what the STRaTA paper's authors simulated); the other
//! standards are embedded TOML presets (`presets/*.toml`, see [`PRESETS`]). A run's tree is
//! assembled in layers — defaults → preset → user file → `--set` — by [`layers`], then
//! [`DramConfig::validate`] checks ranges and consistency (address bits that do not add up,
//! watermarks outside the queue, `tRC < tRAS + tRP` …) with errors that name the key and the
//! allowed range. Chip models embed this tree under `[dram]`.

use rtsim_config::{ConfigError, Layers, Validate, check_range};
use serde::{Deserialize, Serialize};
use std::path::Path;
use toml::{Table, Value};

/// Every setting of the DRAM model. Field docs state unit, default and effect.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DramConfig {
    /// Name of the preset this tree was built on (see `docs/DRAM.md`). `rtsim dram --preset` and
    /// chip configs use it to pick the base layer; in a resolved config it records the origin.
    /// Default `gddr5-trax`.
    pub preset: String,
    /// Address mapping, most significant field first: `row:rank:bank:channel:column:offset`
    /// (default, SimTRaX/USIMM mapping 1), `row:column:rank:bank:channel:offset` (USIMM mapping 0,
    /// channel-interleaved lines), or any order of the fields `row`, `rank`, `bankgroup`, `bank`,
    /// `channel`, `column`, `offset`, where a field may be split into slices with explicit widths,
    /// e.g. `row:column(3):bank:channel:column(4):offset`. `bank` without `bankgroup` is the bank
    /// index across groups. DRAMsim3 strings such as `rochrababgco` are accepted too. Address
    /// bits above the capacity are ignored.
    pub mapping: String,
    /// Permutation-based interleaving (Zhang, Zhu and Zhang, MICRO 2000): the bank index is XORed
    /// with the low bits of the row, spreading row conflicts over banks. Default false.
    pub bank_xor: bool,
    /// Re-validate every issued command against the constraint table with an independent,
    /// brute-force checker (slow: for tests and debugging). Violations are reported as errors.
    /// Default false.
    pub check: bool,
    pub organisation: Organisation,
    pub timing: Timing,
    pub current: Currents,
    pub controller: ControllerConfig,
    pub refresh: RefreshConfig,
    pub trace: TraceConfig,
}

/// Channels, ranks, banks, rows, columns and the data path.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Organisation {
    /// Independent channels, each with its own controller queues and data bus. Power of two,
    /// 1..=64. Default 16.
    pub channels: u32,
    /// Ranks per channel (share the channel's buses). Power of two, 1..=16. Default 1.
    pub ranks: u32,
    /// Bank groups per rank (DDR4, GDDR5); 1 = no bank groups. Power of two, 1..=16. Default 1.
    pub bank_groups: u32,
    /// Banks in each bank group. Power of two, 1..=64. Default 16.
    pub banks_per_group: u32,
    /// Rows per bank. Power of two, 2..=2^22. Default 8192.
    pub rows: u32,
    /// Device columns per row, in the datasheet sense (one column = `device_width` bits on each
    /// device): a row holds `columns × bus_width / 8` bytes per rank. Power of two. Default 1024
    /// (128 lines of 64 B: 8 KB rows).
    pub columns: u32,
    /// Data width of one device in bits (x4, x8, x16, x32, x64). Default 16.
    pub device_width: u32,
    /// Devices whose currents are summed for each rank's energy. Usually
    /// `bus_width / device_width`; free so that models such as SimTRaX's (16 chips per rank on a
    /// 64-bit bus) can be reproduced. 1..=256. Default 16.
    pub devices_per_rank: u32,
    /// Data bus width per channel in bits, multiple of 8, 8..=1024. Default 64.
    pub bus_width: u32,
    /// Burst length in beats (BL8 …). Default 8.
    pub burst_length: u32,
    /// Data beats per memory clock: 2 for DDR3/DDR4/LPDDR3, 4 for GDDR5 (data at twice WCK,
    /// WCK at twice CK). Must divide `burst_length`. Default 2.
    pub data_rate: u32,
    /// Bytes per request (the requester's line). A line larger than one burst is transferred as
    /// consecutive bursts of one column access. Power of two, 16..=4096. Default 64.
    pub line_bytes: u32,
}

/// Timing parameters in memory-clock cycles (tCK) unless stated otherwise. Keys use the JEDEC
/// names. `_L` variants apply between banks of the same bank group and default to the plain
/// value; with `bank_groups = 1` all banks share one group.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Timing {
    /// Memory (command) clock in MHz, rounded to whole hertz. Default 2000.
    pub clock_mhz: f64,
    /// CAS (read) latency: RD to first data beat. Default 28.
    #[serde(rename = "CL")]
    pub cl: u32,
    /// CAS write latency: WR to first data beat. Default 13.
    #[serde(rename = "CWL")]
    pub cwl: u32,
    /// ACT to RD, same bank. Default 28.
    #[serde(rename = "tRCD")]
    pub t_rcd: u32,
    /// ACT to WR, same bank (GDDR5's tRCDWR). Default: same as tRCD.
    #[serde(rename = "tRCDWR", skip_serializing_if = "Option::is_none")]
    pub t_rcdwr: Option<u32>,
    /// PRE to ACT, same bank. Default 28.
    #[serde(rename = "tRP")]
    pub t_rp: u32,
    /// ACT to PRE, same bank. Default 70.
    #[serde(rename = "tRAS")]
    pub t_ras: u32,
    /// ACT to ACT, same bank; must be at least tRAS + tRP. Default 98.
    #[serde(rename = "tRC")]
    pub t_rc: u32,
    /// ACT to ACT, same rank, different bank group (any bank when there are no groups).
    /// Default 13.
    #[serde(rename = "tRRD")]
    pub t_rrd: u32,
    /// ACT to ACT, same bank group (DDR4 tRRD_L). Default: same as tRRD.
    #[serde(rename = "tRRD_L", skip_serializing_if = "Option::is_none")]
    pub t_rrd_l: Option<u32>,
    /// Four-activate window per rank: at most 4 ACTs in any tFAW cycles. Default 80.
    #[serde(rename = "tFAW")]
    pub t_faw: u32,
    /// GDDR5 thirty-two-activate window per rank; 0 = none. Default 0.
    #[serde(rename = "t32AW")]
    pub t_32aw: u32,
    /// Write recovery: end of write data to PRE, same bank. Default 30.
    #[serde(rename = "tWR")]
    pub t_wr: u32,
    /// End of write data to RD, same rank, different bank group. Default 15.
    #[serde(rename = "tWTR")]
    pub t_wtr: u32,
    /// End of write data to RD, same bank group (DDR4 tWTR_L). Default: same as tWTR.
    #[serde(rename = "tWTR_L", skip_serializing_if = "Option::is_none")]
    pub t_wtr_l: Option<u32>,
    /// RD to PRE, same bank. Default 15.
    #[serde(rename = "tRTP")]
    pub t_rtp: u32,
    /// Column to column (RD-RD, WR-WR), same rank, different bank group. Default 4.
    #[serde(rename = "tCCD")]
    pub t_ccd: u32,
    /// Column to column, same bank group (DDR4/GDDR5 tCCD_L). Default: same as tCCD.
    #[serde(rename = "tCCD_L", skip_serializing_if = "Option::is_none")]
    pub t_ccd_l: Option<u32>,
    /// Rank-to-rank switch: extra data-bus idle time when consecutive bursts come from
    /// different ranks, and the read-to-write turnaround. Default 2.
    #[serde(rename = "tRTRS")]
    pub t_rtrs: u32,
    /// Rank switch between two writes: WR after WR to another rank waits burst + this.
    /// JESD79-3F, JESD79-4B, JESD209-3 and JESD212 define column-to-column spacing (tCCD) only
    /// within a rank and leave rank-to-rank spacing to the system; a write to another rank
    /// moves the termination (ODT) to other devices, so a memory controller leaves a bubble, as
    /// USIMM does with tRTRS. DRAMsim3 applies only the burst (set 0 to reproduce it).
    /// Default: same as tRTRS.
    #[serde(rename = "tRTRS_W2W", skip_serializing_if = "Option::is_none")]
    pub t_rtrs_w2w: Option<u32>,
    /// Precharge to precharge, same rank (GDDR5's tPPD); 0 = no such rule (DDR3, DDR4,
    /// LPDDR3 have none). Applies to refresh precharges as well. Default 0.
    #[serde(rename = "tPPD")]
    pub t_ppd: u32,
    /// REF to ACT or REF, same rank (refresh cycle time). Default 220.
    #[serde(rename = "tRFC")]
    pub t_rfc: u32,
    /// Average refresh interval per rank. Default 15600 (7.8 µs at 2 GHz).
    #[serde(rename = "tREFI")]
    pub t_refi: u32,
    /// Power-down exit to the first valid command (fast exit, precharge or active power-down).
    /// Used when `controller.power_down` is not `off`. Default 13.
    #[serde(rename = "tXP")]
    pub t_xp: u32,
    /// Minimum time in power-down before exit (CKE low pulse width). Default 10.
    #[serde(rename = "tCKE")]
    pub t_cke: u32,
}

/// IDD currents of one device (datasheet IDD table), in milliamperes, and its supply voltage.
/// Energy follows Micron TN-41-01 (see `docs/DRAM.md`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Currents {
    /// Supply voltage VDD in volts. Default 1.5.
    pub vdd: f64,
    /// One-bank ACT-PRE current (tRC cycling). Default 120.
    pub idd0: f64,
    /// Precharge power-down current, slow exit (DLL off). Recorded from the datasheet for
    /// completeness; the model has only fast-exit power-down, so it is not used. Default 12.
    pub idd2p0: f64,
    /// Precharge power-down current, fast exit (DLL on). Used for precharge power-down.
    /// Default 45.
    pub idd2p1: f64,
    /// Precharge standby current (all banks closed). Default 70.
    pub idd2n: f64,
    /// Active power-down current. Default 45.
    pub idd3p: f64,
    /// Active standby current (some bank open). Default 67.
    pub idd3n: f64,
    /// Burst read current. Default 250.
    pub idd4r: f64,
    /// Burst write current. Default 250.
    pub idd4w: f64,
    /// Burst refresh current (during tRFC). Default 260.
    pub idd5: f64,
}

/// Which request the scheduler serves first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SchedulerKind {
    /// First-ready FR-FCFS (Rixner et al., ISCA 2000): ready row hits first, oldest first; then
    /// the oldest ready ACT/PRE. A row with pending hits is not closed for a conflicting request
    /// unless `row_hit_cap` consecutive hits have been served.
    FrFcfs,
    /// Oldest first within each bank; across banks the oldest ready command.
    Fcfs,
    /// USIMM's FCFS (`scheduler-fcfs.c`): the first issuable command of any request, in
    /// arrival order. A younger request of a bank may go first when the older one's command
    /// cannot issue (its PRE may then close the older one's row).
    UsimmFcfs,
}

/// What the banks serve in write-drain mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WriteDrainKind {
    /// Only writes, as before (kept for comparison): a write's PRE may close a row that was
    /// opened for a queued read before the read used it.
    WritesOnly,
    /// Writes in drain mode, reads otherwise, but a bank never precharges a row that queued
    /// requests of the other kind want: it serves those hits first. So a drain does not close
    /// a row opened for a queued read before the read uses it (USIMM's rule as issue 12 states
    /// it), nor does the end of a drain close a row opened for a queued write.
    ProtectRows,
    /// Reads and writes together at every bank, FR-FCFS over both (DRAMsim3, whose per-bank
    /// command queues hold both kinds while writes drain).
    Mixed,
    /// DRAMsim3's write buffer (needs `command_queue_depth` > 0): the drain starts when the
    /// write queue (the writes not yet in command queues) holds `write_high_watermark` writes,
    /// or more than `write_low_watermark` while every command queue is empty, and moves as
    /// many writes into the command queues as the write queue held when it started; the drain
    /// only decides which kind moves into the command queues, and each bank serves its command
    /// queue, reads and writes together oldest first, in and out of drains.
    Dramsim3,
}

/// How the controller chooses among the banks' ready offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BankArbitration {
    /// By the scheduler's priority (FR-FCFS: row hits first, then the oldest; FCFS: the
    /// oldest), the lowest bank among equals.
    Priority,
    /// Round robin: the first bank with a ready offer after the bank of the last request
    /// command (DRAMsim3's `GetCommandToIssue`, which visits its per-bank command queues in
    /// turn); each bank's offer is still the scheduler's.
    RoundRobin,
}

/// When rows are closed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RowPolicyKind {
    /// Rows stay open until a conflicting request or a refresh needs the bank.
    Open,
    /// A column access auto-precharges (RDA/WRA) unless another queued request hits the row.
    Closed,
}

/// Rank power-down policy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PowerDownKind {
    /// Ranks never power down (USIMM's and DRAMsim3's default behaviour).
    Off,
    /// A rank with no queued requests for `power_down_idle` cycles enters fast-exit power-down
    /// (precharge power-down if all banks are closed, active power-down otherwise) and exits
    /// (tXP) when a request or a refresh needs it.
    Fast,
}

/// Memory controller: queues and policies (one controller per channel).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerConfig {
    /// Read queue capacity per channel; a full queue refuses requests (back-pressure).
    /// 1..=32768. Default 80.
    pub read_queue: u32,
    /// Write queue capacity per channel. 1..=32768. Default 96.
    pub write_queue: u32,
    /// `fr-fcfs`, `fcfs` or `usimm-fcfs`. Default `fr-fcfs`.
    pub scheduler: SchedulerKind,
    /// FR-FCFS starvation cap: after this many row hits since the row was opened, if the bank's
    /// oldest request wants another row, hits lose their priority. 0 = no cap (as in USIMM).
    /// DRAMsim3 has a fixed cap of 4 column commands, i.e. 3 here. Default 0.
    pub row_hit_cap: u32,
    /// FR-FCFS: never close a row while queued requests hit it (true, as DRAMsim3), or let a
    /// ready PRE for an older conflicting request close it when none of its hits can issue this
    /// cycle (false, USIMM 1.3's FR-FCFS). Default true.
    pub protect_row_hits: bool,
    /// `open` or `closed`. Default `open`.
    pub row_policy: RowPolicyKind,
    /// What banks serve in write-drain mode: `protect-rows` (writes, reads otherwise, but a row
    /// wanted by queued requests of the other kind serves them before it is closed),
    /// `writes-only` (the model before issue 12: a drain may close rows opened for reads, and
    /// its end rows opened for writes) or `mixed` (reads and writes together while draining,
    /// DRAMsim3). Default `protect-rows`.
    pub write_drain: WriteDrainKind,
    /// Memory cycles between a request's arrival at the controller and the first cycle in
    /// which the scheduler may issue a command for it (pipeline delay; latency still counts
    /// from arrival). DRAMsim3 issues two cycles after acceptance: 2 reproduces it; USIMM
    /// one: 1. Cost: none. 0..=1000. Default 0.
    pub admission_delay: u32,
    /// Per-bank command queues behind the read and write queues (DRAMsim3's structure): 0 =
    /// none (the scheduler sees every queued request); n > 0 = each bank holds at most n
    /// requests, reads and writes together, and the scheduler sees only those. Each cycle the
    /// oldest request of the queue being served (writes in drain mode, else reads) whose bank
    /// has room moves there, freeing its read/write-queue slot, so up to `n × banks` more
    /// requests wait in the controller. DRAMsim3 uses 8 (`queue_size`, per bank). 0..=64.
    /// Default 0.
    pub command_queue_depth: u32,
    /// Write-drain mode starts when the write queue holds at least this many writes; writes are
    /// also drained whenever no read waits (as in USIMM). Default 40.
    pub write_high_watermark: u32,
    /// Write-drain mode ends when the write queue holds at most this many writes. Must be below
    /// the high watermark. Default 20.
    pub write_low_watermark: u32,
    /// A read to a line with a queued write is answered from the write queue after
    /// `forward_latency` cycles without a DRAM access. Default true.
    pub forward_reads: bool,
    /// A read to a line already in the read queue waits for that read instead of accessing
    /// DRAM again (it still takes a read-queue slot). Default true.
    pub merge_reads: bool,
    /// A write to a line already in the write queue is merged into the queued write (it still
    /// takes a write-queue slot until that write is issued). Default true.
    pub merge_writes: bool,
    /// Memory cycles to answer a read from the write queue. Default 1.
    pub forward_latency: u32,
    /// `priority` (the scheduler's order across banks) or `round-robin` (DRAMsim3). Default
    /// `priority`.
    pub bank_arbitration: BankArbitration,
    /// `off` or `fast`. Default `off`.
    pub power_down: PowerDownKind,
    /// Idle memory cycles (no queued request for the rank) before a rank powers down.
    /// Default 100.
    pub power_down_idle: u32,
}

/// Refresh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RefreshConfig {
    /// Issue an all-bank REF to every rank every tREFI (banks are precharged first; the rank is
    /// busy for tRFC). Turning it off removes refresh's time and energy. Default true.
    pub enabled: bool,
    /// Spread the ranks' refreshes evenly over tREFI instead of refreshing all ranks at once.
    /// Default true.
    pub stagger_ranks: bool,
    /// REFs issued back to back per due time; due times are `batch × tREFI` apart, so the
    /// refresh rate is unchanged. 1 = one REF every tREFI (DRAMsim3); 8 = USIMM's eight every
    /// 8 × tREFI (JESD79-3F §4.9.1 and JESD79-4B §4.24 allow up to eight REFs to be postponed
    /// and issued together). A batch blocks the rank for `batch × tRFC`. 1..=8. Default 1.
    pub batch: u32,
}

/// Settings of standalone trace runs (`rtsim dram`); ignored by chip models.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TraceConfig {
    /// Clock of the trace's requester in MHz: `rtsim` and `usimm` trace cycles and synthetic
    /// traffic are in this clock, and latencies are also reported in it. Chip models pass their
    /// own clock instead (`rtsim_dram::Requester`). Any ratio to `timing.clock_mhz` within a
    /// factor of 1024; rounded to whole hertz. Default 1000 (TRaX's 1 GHz core).
    pub requester_clock_mhz: f64,
    /// USIMM traces: at most this many reads outstanding; the trace stalls until one returns
    /// (stands in for USIMM's reorder buffer; USIMM's 1channel.cfg uses ROBSIZE 64).
    /// 1..=1000000. Default 64.
    pub usimm_max_outstanding_reads: u32,
    /// Requests issued per requester cycle at most, whatever the trace's times (later ones move
    /// to the next cycle): 0 = no limit; 1 = DRAMsim3's trace front end, which offers one
    /// request per cycle. 0..=1000000. Default 0.
    pub max_per_cycle: u32,
}

impl Default for DramConfig {
    fn default() -> Self {
        DramConfig {
            preset: DEFAULT_PRESET.into(),
            mapping: "row:rank:bank:channel:column:offset".into(),
            bank_xor: false,
            check: false,
            organisation: Organisation::default(),
            timing: Timing::default(),
            current: Currents::default(),
            controller: ControllerConfig::default(),
            refresh: RefreshConfig::default(),
            trace: TraceConfig::default(),
        }
    }
}

impl Default for Organisation {
    fn default() -> Self {
        Organisation {
            channels: 16,
            ranks: 1,
            bank_groups: 1,
            banks_per_group: 16,
            rows: 8192,
            columns: 1024,
            device_width: 16,
            devices_per_rank: 16,
            bus_width: 64,
            burst_length: 8,
            data_rate: 2,
            line_bytes: 64,
        }
    }
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            clock_mhz: 2000.0,
            cl: 28,
            cwl: 13,
            t_rcd: 28,
            t_rcdwr: None,
            t_rp: 28,
            t_ras: 70,
            t_rc: 98,
            t_rrd: 13,
            t_rrd_l: None,
            t_faw: 80,
            t_32aw: 0,
            t_wr: 30,
            t_wtr: 15,
            t_wtr_l: None,
            t_rtp: 15,
            t_ccd: 4,
            t_ccd_l: None,
            t_rtrs: 2,
            t_rtrs_w2w: None,
            t_ppd: 0,
            t_rfc: 220,
            t_refi: 15600,
            t_xp: 13,
            t_cke: 10,
        }
    }
}

impl Default for Currents {
    fn default() -> Self {
        Currents {
            vdd: 1.5,
            idd0: 120.0,
            idd2p0: 12.0,
            idd2p1: 45.0,
            idd2n: 70.0,
            idd3p: 45.0,
            idd3n: 67.0,
            idd4r: 250.0,
            idd4w: 250.0,
            idd5: 260.0,
        }
    }
}

impl Default for ControllerConfig {
    fn default() -> Self {
        ControllerConfig {
            read_queue: 80,
            write_queue: 96,
            scheduler: SchedulerKind::FrFcfs,
            row_hit_cap: 0,
            protect_row_hits: true,
            row_policy: RowPolicyKind::Open,
            write_drain: WriteDrainKind::ProtectRows,
            bank_arbitration: BankArbitration::Priority,
            admission_delay: 0,
            command_queue_depth: 0,
            write_high_watermark: 40,
            write_low_watermark: 20,
            forward_reads: true,
            merge_reads: true,
            merge_writes: true,
            forward_latency: 1,
            power_down: PowerDownKind::Off,
            power_down_idle: 100,
        }
    }
}

impl Default for RefreshConfig {
    fn default() -> Self {
        RefreshConfig {
            enabled: true,
            stagger_ranks: true,
            batch: 1,
        }
    }
}

impl Default for TraceConfig {
    fn default() -> Self {
        TraceConfig {
            requester_clock_mhz: 1000.0,
            usimm_max_outstanding_reads: 64,
            max_per_cycle: 0,
        }
    }
}

impl Timing {
    /// tRCDWR, or tRCD when not given.
    pub fn rcdwr(&self) -> u32 {
        self.t_rcdwr.unwrap_or(self.t_rcd)
    }
    /// tRRD_L, or tRRD when not given.
    pub fn rrd_l(&self) -> u32 {
        self.t_rrd_l.unwrap_or(self.t_rrd)
    }
    /// tWTR_L, or tWTR when not given.
    pub fn wtr_l(&self) -> u32 {
        self.t_wtr_l.unwrap_or(self.t_wtr)
    }
    /// tCCD_L, or tCCD when not given.
    pub fn ccd_l(&self) -> u32 {
        self.t_ccd_l.unwrap_or(self.t_ccd)
    }
    /// tRTRS_W2W, or tRTRS when not given.
    pub fn rtrs_w2w(&self) -> u32 {
        self.t_rtrs_w2w.unwrap_or(self.t_rtrs)
    }
}

/// Largest value accepted for any timing parameter (cycles); keeps every sum far from overflow.
pub const MAX_TIMING_CYCLES: u32 = 10_000_000;

fn check_pow2(key: &str, v: u32, lo: u32, hi: u32) -> Result<(), ConfigError> {
    if v >= lo && v <= hi && v.is_power_of_two() {
        Ok(())
    } else {
        Err(ConfigError::range(
            key,
            v,
            format!("a power of two in {lo}..={hi}"),
        ))
    }
}

fn check_mhz(key: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && (0.001..=100_000.0).contains(&v) {
        Ok(())
    } else {
        Err(ConfigError::range(key, v, "0.001..=100000 (MHz)"))
    }
}

impl Validate for DramConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        if self.preset.trim().is_empty() {
            return Err(ConfigError::key("preset", "must not be empty"));
        }
        // The memory clock first: a bad one must not read as a bad requester clock.
        check_mhz("timing.clock_mhz", self.timing.clock_mhz)?;
        check_mhz("trace.requester_clock_mhz", self.trace.requester_clock_mhz)?;
        let ratio = self.trace.requester_clock_mhz / self.timing.clock_mhz;
        if !(1.0 / 1024.0..=1024.0).contains(&ratio) {
            return Err(ConfigError::range(
                "trace.requester_clock_mhz",
                self.trace.requester_clock_mhz,
                format!(
                    "within a factor of 1024 of timing.clock_mhz = {}",
                    self.timing.clock_mhz
                ),
            ));
        }
        self.organisation.validate()?;
        self.timing.validate_with(&self.organisation)?;
        self.current.validate()?;
        self.controller.validate()?;
        check_range("refresh.batch", self.refresh.batch, 1, 8)?;
        check_range(
            "trace.usimm_max_outstanding_reads",
            self.trace.usimm_max_outstanding_reads,
            1,
            1_000_000,
        )?;
        check_range(
            "trace.max_per_cycle",
            self.trace.max_per_cycle,
            0,
            1_000_000,
        )?;
        // The mapping needs the organisation's field widths: parsing it checks that the address
        // bits add up.
        crate::mapping::AddressMapper::new(&self.mapping, self.bank_xor, &self.organisation)?;
        Ok(())
    }
}

impl Validate for Organisation {
    fn validate(&self) -> Result<(), ConfigError> {
        let o = self;
        check_pow2("organisation.channels", o.channels, 1, 64)?;
        check_pow2("organisation.ranks", o.ranks, 1, 16)?;
        check_pow2("organisation.bank_groups", o.bank_groups, 1, 16)?;
        check_pow2("organisation.banks_per_group", o.banks_per_group, 1, 64)?;
        if o.bank_groups * o.banks_per_group > 256 {
            return Err(ConfigError::range(
                "organisation.banks_per_group",
                o.banks_per_group,
                format!(
                    "at most {} with {} bank groups (256 banks per rank)",
                    256 / o.bank_groups,
                    o.bank_groups
                ),
            ));
        }
        check_pow2("organisation.rows", o.rows, 2, 1 << 22)?;
        check_pow2("organisation.device_width", o.device_width, 4, 64)?;
        check_range("organisation.devices_per_rank", o.devices_per_rank, 1, 256)?;
        if !(8..=1024).contains(&o.bus_width) || o.bus_width % 8 != 0 {
            return Err(ConfigError::range(
                "organisation.bus_width",
                o.bus_width,
                "a multiple of 8 in 8..=1024 (bits)",
            ));
        }
        check_pow2("organisation.burst_length", o.burst_length, 1, 64)?;
        check_pow2("organisation.data_rate", o.data_rate, 1, 16)?;
        if o.burst_length % o.data_rate != 0 {
            return Err(ConfigError::range(
                "organisation.data_rate",
                o.data_rate,
                format!(
                    "a divisor of burst_length = {} (a burst must last whole clocks)",
                    o.burst_length
                ),
            ));
        }
        check_pow2("organisation.line_bytes", o.line_bytes, 16, 4096)?;
        let burst_bytes = u64::from(o.bus_width / 8) * u64::from(o.burst_length);
        if !burst_bytes.is_power_of_two() {
            return Err(ConfigError::key(
                "organisation.bus_width",
                format!(
                    "one burst moves bus_width/8 × burst_length = {burst_bytes} bytes; \
                     it must be a power of two so that lines map to whole bursts"
                ),
            ));
        }
        if u64::from(o.line_bytes) % burst_bytes != 0 {
            return Err(ConfigError::range(
                "organisation.line_bytes",
                o.line_bytes,
                format!("a multiple of one burst (bus_width/8 × burst_length = {burst_bytes} B)"),
            ));
        }
        if !o.columns.is_power_of_two() || o.columns > (1 << 20) {
            return Err(ConfigError::range(
                "organisation.columns",
                o.columns,
                "a power of two in 1..=1048576",
            ));
        }
        let row_bytes = u64::from(o.columns) * u64::from(o.bus_width / 8);
        if row_bytes < u64::from(o.line_bytes) {
            return Err(ConfigError::range(
                "organisation.columns",
                o.columns,
                format!(
                    "at least {} so that a row (columns × bus_width/8 bytes) holds one line of {} B",
                    u64::from(o.line_bytes) / u64::from(o.bus_width / 8),
                    o.line_bytes
                ),
            ));
        }
        let bits = [
            o.channels,
            o.ranks,
            o.bank_groups,
            o.banks_per_group,
            o.rows,
        ]
        .iter()
        .map(|v| v.trailing_zeros())
        .sum::<u32>()
            + row_bytes.trailing_zeros();
        if bits > 56 {
            return Err(ConfigError::key(
                "organisation",
                format!("capacity of 2^{bits} bytes exceeds the 2^56 supported"),
            ));
        }
        Ok(())
    }
}

impl Timing {
    fn validate_with(&self, o: &Organisation) -> Result<(), ConfigError> {
        check_mhz("timing.clock_mhz", self.clock_mhz)?;
        let m = MAX_TIMING_CYCLES;
        let positive: [(&str, u32); 12] = [
            ("timing.CL", self.cl),
            ("timing.CWL", self.cwl),
            ("timing.tRCD", self.t_rcd),
            ("timing.tRP", self.t_rp),
            ("timing.tRAS", self.t_ras),
            ("timing.tRC", self.t_rc),
            ("timing.tRRD", self.t_rrd),
            ("timing.tCCD", self.t_ccd),
            ("timing.tRFC", self.t_rfc),
            ("timing.tREFI", self.t_refi),
            ("timing.tRTP", self.t_rtp),
            ("timing.tXP", self.t_xp),
        ];
        for (k, v) in positive {
            check_range(k, v, 1, m)?;
        }
        let any: [(&str, u32); 7] = [
            ("timing.tFAW", self.t_faw),
            ("timing.t32AW", self.t_32aw),
            ("timing.tWR", self.t_wr),
            ("timing.tWTR", self.t_wtr),
            ("timing.tRTRS", self.t_rtrs),
            ("timing.tRTRS_W2W", self.rtrs_w2w()),
            ("timing.tPPD", self.t_ppd),
        ];
        for (k, v) in any {
            check_range(k, v, 0, m)?;
        }
        check_range("timing.tCKE", self.t_cke, 0, m)?;
        for (k, v) in [
            ("timing.tRCDWR", self.t_rcdwr),
            ("timing.tRRD_L", self.t_rrd_l),
            ("timing.tWTR_L", self.t_wtr_l),
            ("timing.tCCD_L", self.t_ccd_l),
        ] {
            if let Some(v) = v {
                check_range(k, v, 1, m)?;
            }
        }
        if self.t_rc < self.t_ras + self.t_rp {
            return Err(ConfigError::range(
                "timing.tRC",
                self.t_rc,
                format!(
                    ">= tRAS + tRP = {} (a bank cannot be re-activated before it is precharged)",
                    self.t_ras + self.t_rp
                ),
            ));
        }
        if self.t_refi <= self.t_rfc {
            return Err(ConfigError::range(
                "timing.tREFI",
                self.t_refi,
                format!("> tRFC = {} (refresh would never end)", self.t_rfc),
            ));
        }
        // A refresh closes every row; if a whole row access cannot fit between two refreshes,
        // a request could be re-opened forever and never served.
        let access = u64::from(self.t_rc)
            + u64::from(self.t_rcd.max(self.rcdwr()))
            + u64::from(self.cl.max(self.cwl))
            + u64::from(self.t_wr);
        let window = u64::from(self.t_refi - self.t_rfc);
        if access > window {
            return Err(ConfigError::key(
                "timing",
                format!(
                    "a row access (tRC + tRCD + CL + tWR = {access} cycles) does not fit between two refreshes (tREFI - tRFC = {window}); lower those or raise tREFI"
                ),
            ));
        }
        let _ = o;
        Ok(())
    }
}

impl Validate for Currents {
    fn validate(&self) -> Result<(), ConfigError> {
        let c = self;
        if !(c.vdd.is_finite() && c.vdd > 0.0 && c.vdd <= 5.0) {
            return Err(ConfigError::range("current.vdd", c.vdd, "(0, 5] volts"));
        }
        for (k, v) in [
            ("current.idd0", c.idd0),
            ("current.idd2p0", c.idd2p0),
            ("current.idd2p1", c.idd2p1),
            ("current.idd2n", c.idd2n),
            ("current.idd3p", c.idd3p),
            ("current.idd3n", c.idd3n),
            ("current.idd4r", c.idd4r),
            ("current.idd4w", c.idd4w),
            ("current.idd5", c.idd5),
        ] {
            if !(v.is_finite() && (0.0..=100_000.0).contains(&v)) {
                return Err(ConfigError::range(k, v, "0..=100000 (mA)"));
            }
        }
        // TN-41-01's incremental currents must not be negative.
        for (k, v, base, bk) in [
            ("current.idd4r", c.idd4r, c.idd3n, "idd3n"),
            ("current.idd4w", c.idd4w, c.idd3n, "idd3n"),
            ("current.idd5", c.idd5, c.idd3n, "idd3n"),
        ] {
            if v < base {
                return Err(ConfigError::range(k, v, format!(">= {bk} = {base} mA")));
            }
        }
        Ok(())
    }
}

impl Validate for ControllerConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        let c = self;
        check_range("controller.read_queue", c.read_queue, 1, 32768)?;
        check_range("controller.write_queue", c.write_queue, 1, 32768)?;
        check_range("controller.row_hit_cap", c.row_hit_cap, 0, 1_000_000)?;
        check_range("controller.admission_delay", c.admission_delay, 0, 1000)?;
        check_range(
            "controller.command_queue_depth",
            c.command_queue_depth,
            0,
            64,
        )?;
        if c.write_drain == WriteDrainKind::Dramsim3 && c.command_queue_depth == 0 {
            return Err(ConfigError::range(
                "controller.command_queue_depth",
                0,
                "1..=64 with controller.write_drain = dramsim3",
            ));
        }
        check_range(
            "controller.write_high_watermark",
            c.write_high_watermark,
            1,
            c.write_queue,
        )?;
        check_range(
            "controller.write_low_watermark",
            c.write_low_watermark,
            0,
            c.write_high_watermark - 1,
        )?;
        check_range(
            "controller.forward_latency",
            c.forward_latency,
            0,
            1_000_000,
        )?;
        check_range(
            "controller.power_down_idle",
            c.power_down_idle,
            1,
            100_000_000,
        )?;
        Ok(())
    }
}

/// A named preset: its name, a one-line description and its TOML text.
#[derive(Clone, Copy, Debug)]
pub struct Preset {
    pub name: &'static str,
    pub about: &'static str,
    pub toml: &'static str,
}

/// The presets shipped with rtsim; every value is cited in its file.
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "gddr5-trax",
        about: "SimTRaX's USIMM model of the STRaTA paper's GDDR5: 16 ch x 32 GB/s, DDR3-1600 \
                timings at 2 GHz, DDR3 currents x16 chips (default)",
        toml: include_str!("../presets/gddr5-trax.toml"),
    },
    Preset {
        name: "gddr5-strata",
        about: "the STRaTA paper's stated GDDR5: 8 x 64-bit channels at 8 Gb/s (512 GB/s), \
                2 x 8Gb x32 devices per channel, 8 KB rows",
        toml: include_str!("../presets/gddr5-strata.toml"),
    },
    Preset {
        name: "gddr5-8gb-x32",
        about: "one 8Gb x32 GDDR5 device at 8 Gb/s on a 32-bit channel (32 GB/s)",
        toml: include_str!("../presets/gddr5-8gb-x32.toml"),
    },
    Preset {
        name: "lpddr3-1600",
        about: "SGRT's memory: LPDDR3-1600, 2 x 32-bit channels, 12.8 GB/s",
        toml: include_str!("../presets/lpddr3-1600.toml"),
    },
    Preset {
        name: "ddr3-1600",
        about: "DDR3-1600 (11-11-11), 1Gb x16 parts, 1 channel x 64 bit, 2 ranks",
        toml: include_str!("../presets/ddr3-1600.toml"),
    },
    Preset {
        name: "ddr4-3200",
        about: "DDR4-3200 (22-22-22), 8Gb x8 parts, 1 channel x 64 bit, 4 bank groups",
        toml: include_str!("../presets/ddr4-3200.toml"),
    },
];

/// Names of the presets, for messages.
pub fn preset_names() -> Vec<&'static str> {
    PRESETS.iter().map(|p| p.name).collect()
}

/// Look up a preset by name.
pub fn preset(name: &str) -> Result<&'static Preset, ConfigError> {
    PRESETS
        .iter()
        .find(|p| p.name == name)
        .ok_or_else(|| ConfigError::unknown("DRAM preset", name, &preset_names()))
}

/// The preset's TOML as a table (its `preset` key set to its name).
pub fn preset_table(name: &str) -> Result<Table, ConfigError> {
    let p = preset(name)?;
    let mut t = rtsim_config::parse_toml(p.toml, &format!("preset {name}"))?;
    t.insert("preset".into(), Value::String(name.into()));
    Ok(t)
}

/// A preset as a validated config.
pub fn preset_config(name: &str) -> Result<DramConfig, ConfigError> {
    let mut l = Layers::new();
    l.merge_value(&DramConfig::default(), "built-in defaults")?;
    l.merge_table(preset_table(name)?, &format!("preset {name}"));
    l.build()
}

/// Strip an optional leading `dram.` from a key, so `rtsim dram` accepts both
/// `--set timing.tRCD=30` and `--set dram.timing.tRCD=30`.
pub fn relative_key(key: &str) -> &str {
    key.strip_prefix("dram.").unwrap_or(key)
}

/// The user's layers for a standalone DRAM run, relative to the DRAM root.
#[derive(Clone, Debug, Default)]
pub struct UserLayers<'a> {
    /// `--preset NAME` (overrides a `preset` key in the file; `--set preset=…` overrides both).
    pub preset: Option<&'a str>,
    /// `--config FILE`: either a DRAM tree at its root, or a file with a `[dram]` table (as chip
    /// configs have), whose `[dram]` table is used.
    pub file: Option<&'a Path>,
    /// `--set key=value` assignments; keys relative to the DRAM root, optionally prefixed
    /// with `dram.`.
    pub sets: &'a [String],
}

/// Assemble defaults → preset → user file → `--preset` → `--set`. The preset is taken from the
/// last layer that names one (default `gddr5-trax`) and merged beneath the user's layers.
pub fn layers(user: &UserLayers<'_>) -> Result<Layers, ConfigError> {
    // First the user's own layers, to find which preset they ask for.
    let mut mine = Layers::new();
    if let Some(path) = user.file {
        let text = rtsim_config::read_config_file(path)?;
        let origin = path.display().to_string();
        let mut table = rtsim_config::parse_toml(&text, &origin)?;
        if let Some(Value::Table(d)) = table.remove("dram") {
            if let Some(k) = table.keys().next() {
                return Err(ConfigError::key(
                    k,
                    format!(
                        "{origin} has a [dram] table; the DRAM model reads only that table here, \
                         so other top-level keys are not allowed"
                    ),
                ));
            }
            table = d;
        }
        mine.merge_table(table, &origin);
    }
    if let Some(p) = user.preset {
        mine.set_value("preset", Value::String(p.into()))?;
    }
    for s in user.sets {
        let (k, v) = match s.split_once('=') {
            Some((k, v)) => (relative_key(k.trim()), v),
            None => {
                return Err(ConfigError::BadSet {
                    arg: s.clone(),
                    message: "expected key=value".into(),
                });
            }
        };
        mine.set(&format!("{k}={v}")).map_err(|e| match e {
            ConfigError::BadSet { message, .. } => ConfigError::BadSet {
                arg: s.clone(),
                message,
            },
            other => other,
        })?;
    }
    if mine.get("requester_clock_mhz").is_some() {
        return Err(ConfigError::key(
            "requester_clock_mhz",
            "has moved to `trace.requester_clock_mhz` (used by `rtsim dram` only; chip models \
             pass their own clock to the DRAM model)",
        ));
    }
    let mut base = Layers::new();
    base.merge_value(&DramConfig::default(), "built-in defaults")?;
    rtsim_config::assemble(&base, &[preset_family("preset", "")], &mine)
}

/// The DRAM presets as a [`rtsim_config::PresetFamily`] named at `key` and merged at `at`
/// (`"preset"` at the root for a standalone run; `"dram.preset"` at `"dram"` in a chip's run
/// configuration).
pub fn preset_family<'a>(key: &'a str, at: &'a str) -> rtsim_config::PresetFamily<'a> {
    rtsim_config::PresetFamily {
        key,
        at,
        default: DEFAULT_PRESET,
        lookup: &preset_table,
    }
}

/// The preset a tree is built on when none is named.
pub const DEFAULT_PRESET: &str = "gddr5-trax";

/// Build and validate the DRAM config of a standalone run.
pub fn resolve(user: &UserLayers<'_>) -> Result<DramConfig, ConfigError> {
    layers(user)?.build()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_builds_and_validates() {
        for p in PRESETS {
            let c = preset_config(p.name).unwrap_or_else(|e| panic!("{}: {e}", p.name));
            assert_eq!(c.preset, p.name);
        }
    }

    #[test]
    fn default_equals_gddr5_trax_preset() {
        assert_eq!(preset_config("gddr5-trax").unwrap(), DramConfig::default());
    }

    /// A preset must set every organisation, timing and current key itself, so that nothing
    /// leaks in from the defaults (which are another standard's values).
    #[test]
    fn presets_set_every_required_key() {
        let defaults = Table::try_from(DramConfig::default()).unwrap();
        for p in PRESETS {
            let t = preset_table(p.name).unwrap();
            for section in ["organisation", "timing", "current"] {
                let want = defaults[section].as_table().unwrap();
                let got = t
                    .get(section)
                    .and_then(Value::as_table)
                    .unwrap_or_else(|| panic!("{}: no [{section}]", p.name));
                for k in want.keys() {
                    assert!(got.contains_key(k), "{}: [{section}] lacks {k}", p.name);
                }
            }
            assert!(t.contains_key("mapping"), "{}: no mapping", p.name);
        }
    }

    #[test]
    fn unknown_preset_lists_known_ones() {
        let e = resolve(&UserLayers {
            preset: Some("ddr9"),
            ..Default::default()
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("ddr9") && e.contains("gddr5-trax"), "{e}");
    }

    #[test]
    fn set_accepts_dram_prefix_and_overrides_preset() {
        let sets = vec![
            "timing.tRCD=30".to_string(),
            "dram.controller.scheduler=fcfs".to_string(),
            "mapping=row:column:rank:bank:channel:offset".to_string(),
        ];
        let c = resolve(&UserLayers {
            preset: Some("ddr3-1600"),
            file: None,
            sets: &sets,
        })
        .unwrap();
        assert_eq!(c.preset, "ddr3-1600");
        assert_eq!(c.timing.t_rcd, 30);
        assert_eq!(c.controller.scheduler, SchedulerKind::Fcfs);
        assert_eq!(c.mapping, "row:column:rank:bank:channel:offset");
        assert_eq!(c.organisation.ranks, 2);
    }

    #[test]
    fn bad_values_name_the_key_and_range() {
        let cases = [
            ("controller.scheduler=lifo", "controller.scheduler"),
            ("timing.tRCD=-1", "timing.tRCD"),
            ("timing.tRC=10", "timing.tRC"),
            ("organisation.channels=3", "organisation.channels"),
            (
                "controller.write_low_watermark=50",
                "controller.write_low_watermark",
            ),
            ("timing.tRCDX=3", "tRCDX"),
            ("organisation.line_bytes=16", "organisation.line_bytes"),
            ("mapping=rank:bank:channel:column:offset", "mapping"),
            ("timing.tRCD=9999999", "between two refreshes"),
            (
                "controller.command_queue_depth=65",
                "controller.command_queue_depth",
            ),
            (
                "controller.admission_delay=1001",
                "controller.admission_delay",
            ),
            ("controller.write_drain=sometimes", "controller.write_drain"),
            (
                "controller.write_drain=dramsim3",
                "controller.command_queue_depth",
            ),
            (
                "controller.bank_arbitration=lottery",
                "controller.bank_arbitration",
            ),
            ("trace.max_per_cycle=2000000", "trace.max_per_cycle"),
            ("refresh.batch=9", "refresh.batch"),
            ("refresh.batch=0", "refresh.batch"),
        ];
        for (set, key) in cases {
            let sets = vec![set.to_string()];
            let e = resolve(&UserLayers {
                preset: None,
                file: None,
                sets: &sets,
            })
            .unwrap_err()
            .to_string();
            assert!(e.contains(key), "{set}: {e}");
        }
    }
}
