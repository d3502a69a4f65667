//! A validated configuration resolved into what the simulator uses: the organisation's derived
//! sizes ([`Org`]), timing in whole memory cycles ([`Timings`]), the constraint table resolved
//! for those timings ([`constraints`]), the address mapper, the two clocks and the per-event
//! energies ([`power`]).

pub mod constraints;
pub mod power;

use crate::config::{ControllerConfig, DramConfig, RefreshConfig};
use crate::mapping::AddressMapper;
use constraints::{Constraint, Param};
use power::EventEnergy;
use rtsim_config::{ConfigError, Validate};
use rtsim_core::Clock;
pub use rtsim_sim::Ratio;

/// Sizes derived from the organisation.
#[derive(Clone, Debug, PartialEq)]
pub struct Org {
    pub channels: u32,
    pub ranks: u32,
    pub bank_groups: u32,
    pub banks_per_group: u32,
    /// Banks in one rank (all groups).
    pub banks_per_rank: u32,
    pub rows: u32,
    pub line_bytes: u32,
    /// Bytes of one row across the rank.
    pub row_bytes: u64,
    pub lines_per_row: u32,
    /// Bursts needed for one line.
    pub bursts_per_line: u32,
    /// Memory cycles the data bus is busy for one line.
    pub burst_cycles: u32,
    pub devices_per_rank: u32,
    /// Bytes per memory cycle per channel at full bus use.
    pub peak_bytes_per_cycle: u32,
    pub capacity_bytes: u64,
}

/// Timing parameters in memory cycles, with optional variants filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct Timings {
    pub cl: u64,
    pub cwl: u64,
    pub rcd: u64,
    pub rcdwr: u64,
    pub rp: u64,
    pub ras: u64,
    pub rc: u64,
    pub rrd: u64,
    pub rrd_l: u64,
    pub faw: u64,
    pub a32w: u64,
    pub wr: u64,
    pub wtr: u64,
    pub wtr_l: u64,
    pub rtp: u64,
    pub ccd: u64,
    pub ccd_l: u64,
    pub rtrs: u64,
    pub rtrs_w2w: u64,
    pub ppd: u64,
    pub rfc: u64,
    pub refi: u64,
    pub xp: u64,
    pub cke: u64,
    pub burst: u64,
}

impl Timings {
    /// The value of one parameter.
    pub fn get(&self, p: Param) -> u64 {
        match p {
            Param::CL => self.cl,
            Param::CWL => self.cwl,
            Param::RCD => self.rcd,
            Param::RCDWR => self.rcdwr,
            Param::RP => self.rp,
            Param::RAS => self.ras,
            Param::RC => self.rc,
            Param::RRD => self.rrd,
            Param::RRDL => self.rrd_l,
            Param::FAW => self.faw,
            Param::A32W => self.a32w,
            Param::WR => self.wr,
            Param::WTR => self.wtr,
            Param::WTRL => self.wtr_l,
            Param::RTP => self.rtp,
            Param::CCD => self.ccd,
            Param::CCDL => self.ccd_l,
            Param::RTRS => self.rtrs,
            Param::RTRSW2W => self.rtrs_w2w,
            Param::PPD => self.ppd,
            Param::RFC => self.rfc,
            Param::XP => self.xp,
            Param::CKE => self.cke,
            Param::Burst => self.burst,
            Param::One => 1,
        }
    }
}

/// Who talks to the memory: the requester's clock (the chip's, or a trace's) and how many
/// requester tags its requests may carry (`MemRequest::tag` in `0..tags`; stats are kept per
/// tag). Chip models pass their own clock here, so the DRAM config holds no requester clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Requester {
    pub clock: Clock,
    /// 1..=[`MAX_TAGS`].
    pub tags: u32,
}

/// Most requester tags a DRAM model keeps statistics for (per-tag counters are kept per
/// channel, so this bounds their memory).
pub const MAX_TAGS: u32 = 4096;

impl Requester {
    /// A requester with one tag.
    pub fn new(clock: Clock) -> Self {
        Requester { clock, tags: 1 }
    }
    /// A requester at `mhz` MHz (rounded to whole hertz) with one tag.
    pub fn mhz(mhz: f64) -> Self {
        Requester::new(mhz_to_clock(mhz))
    }
    pub fn with_tags(self, tags: u32) -> Self {
        Requester { tags, ..self }
    }
}

/// Everything the simulator needs, derived once from a validated [`DramConfig`].
#[derive(Clone, Debug)]
pub struct DramSpec {
    pub config: DramConfig,
    pub org: Org,
    pub t: Timings,
    pub mem_clock: Clock,
    pub req_clock: Clock,
    /// Requester tags accepted (`0..tags`).
    pub tags: u32,
    /// Requester cycles → memory cycles.
    pub req_to_mem: Ratio,
    /// Memory cycles → requester cycles.
    pub mem_to_req: Ratio,
    pub constraints: Vec<Constraint>,
    pub mapper: AddressMapper,
    pub energy: EventEnergy,
}

/// MHz (validated finite and positive) to a clock rounded to whole hertz.
pub fn mhz_to_clock(mhz: f64) -> Clock {
    Clock::from_hz((mhz * 1e6).round() as u64)
}

impl DramSpec {
    /// Validate `config` and the requester, and resolve them.
    pub fn new(config: &DramConfig, requester: Requester) -> Result<Self, ConfigError> {
        config.validate()?;
        let mem_hz = mhz_to_clock(config.timing.clock_mhz).hz;
        let req_hz = requester.clock.hz;
        if req_hz == 0
            || req_hz > mem_hz.saturating_mul(1024)
            || mem_hz > req_hz.saturating_mul(1024)
        {
            return Err(ConfigError::range(
                "requester clock",
                format!("{} MHz", req_hz as f64 / 1e6),
                format!(
                    "within a factor of 1024 of the DRAM's timing.clock_mhz = {}",
                    config.timing.clock_mhz
                ),
            ));
        }
        rtsim_config::check_range("requester tags", requester.tags, 1, MAX_TAGS)?;
        let o = &config.organisation;
        let bus_bytes = o.bus_width / 8;
        let burst_bytes = bus_bytes * o.burst_length;
        let bursts_per_line = o.line_bytes / burst_bytes;
        let burst_cycles = bursts_per_line * (o.burst_length / o.data_rate);
        let row_bytes = u64::from(o.columns) * u64::from(bus_bytes);
        let banks_per_rank = o.bank_groups * o.banks_per_group;
        let org = Org {
            channels: o.channels,
            ranks: o.ranks,
            bank_groups: o.bank_groups,
            banks_per_group: o.banks_per_group,
            banks_per_rank,
            rows: o.rows,
            line_bytes: o.line_bytes,
            row_bytes,
            lines_per_row: (row_bytes / u64::from(o.line_bytes)) as u32,
            bursts_per_line,
            burst_cycles,
            devices_per_rank: o.devices_per_rank,
            peak_bytes_per_cycle: bus_bytes * o.data_rate,
            capacity_bytes: u64::from(o.channels)
                * u64::from(o.ranks)
                * u64::from(banks_per_rank)
                * u64::from(o.rows)
                * row_bytes,
        };
        let c = &config.timing;
        let t = Timings {
            cl: c.cl.into(),
            cwl: c.cwl.into(),
            rcd: c.t_rcd.into(),
            rcdwr: c.rcdwr().into(),
            rp: c.t_rp.into(),
            ras: c.t_ras.into(),
            rc: c.t_rc.into(),
            rrd: c.t_rrd.into(),
            rrd_l: c.rrd_l().into(),
            faw: c.t_faw.into(),
            a32w: c.t_32aw.into(),
            wr: c.t_wr.into(),
            wtr: c.t_wtr.into(),
            wtr_l: c.wtr_l().into(),
            rtp: c.t_rtp.into(),
            ccd: c.t_ccd.into(),
            ccd_l: c.ccd_l().into(),
            rtrs: c.t_rtrs.into(),
            rtrs_w2w: c.rtrs_w2w().into(),
            ppd: c.t_ppd.into(),
            rfc: c.t_rfc.into(),
            refi: c.t_refi.into(),
            xp: c.t_xp.into(),
            cke: c.t_cke.into(),
            burst: burst_cycles.into(),
        };
        let constraints = constraints::resolve(|p| t.get(p));
        let mapper = AddressMapper::new(&config.mapping, config.bank_xor, o)?;
        let mem_clock = mhz_to_clock(c.clock_mhz);
        let req_clock = requester.clock;
        let energy = EventEnergy::new(&config.current, &t, &org, mem_clock)?;
        Ok(DramSpec {
            config: config.clone(),
            org,
            t,
            mem_clock,
            req_clock,
            tags: requester.tags,
            req_to_mem: Ratio::new(req_clock, mem_clock),
            mem_to_req: Ratio::new(mem_clock, req_clock),
            constraints,
            mapper,
            energy,
        })
    }

    pub fn controller(&self) -> &ControllerConfig {
        &self.config.controller
    }

    pub fn refresh(&self) -> &RefreshConfig {
        &self.config.refresh
    }

    /// Peak bandwidth of the whole memory in bytes per second.
    pub fn peak_bytes_per_second(&self) -> f64 {
        f64::from(self.org.peak_bytes_per_cycle)
            * f64::from(self.org.channels)
            * self.mem_clock.hz as f64
    }

    /// Unloaded read latency in memory cycles for a row hit, a closed bank and a row conflict
    /// (the analytic sums the tests check against).
    pub fn unloaded_read_latency(&self) -> [u64; 3] {
        let t = &self.t;
        let hit = t.cl + t.burst;
        [hit, t.rcd + hit, t.rp + t.rcd + hit]
    }
}
