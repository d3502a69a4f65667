#!/usr/bin/env python3
"""Compare `rtsim dram` with DRAMsim3 and USIMM on the same traces (docs/DRAM.md, "Validation").

    DRAMSIM3_RUN=/path/ds3_run USIMM_RUN=/path/usimm_run scripts/dram_oracle_compare.py [ds3|usimm|all]

The reference simulators are not part of this repository; docs/DRAM.md ("Reproducing DRAMsim3
and USIMM") says how they were built. This script only needs two programs:

  $DRAMSIM3_RUN CONFIG.ini TRACE        DRAMsim3's controllers behind its trace CPU; prints one
                                        JSON object with read_hit_rate, mean_read_latency
                                        (memory cycles), bandwidth_gbs and activates
  $USIMM_RUN TRACE KEY=VALUE ...        USIMM 1.3's controller behind a DRAM-only driver with
                                        `rtsim dram --format usimm` semantics; prints one JSON
                                        object with read_hit_rate_usimm, mean_read_latency,
                                        bandwidth_gbs and activates

It writes the traces (scripts/dram_traces.py, seed 12, 200 000 requests) into $WORK (default
/tmp/dram-oracle), runs rtsim with the reproducing settings below, and prints one JSON line per
case. RTSIM selects the binary (default target/release/rtsim).
"""

import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RTSIM = os.environ.get("RTSIM", os.path.join(ROOT, "target/release/rtsim"))
WORK = os.environ.get("WORK", "/tmp/dram-oracle")
SEED, REQUESTS = 12, 200_000

# DRAMsim3: the ini files beside this script describe each preset; these keys make rtsim's
# controller DRAMsim3's (docs/DRAM.md, "Reproducing DRAMsim3 and USIMM").
DS3_MAP = {"gddr5-trax": "rorabgbachco", "ddr3-1600": "rorabgbachco",
           "ddr4-3200": "rorabacobgch", "gddr5-strata": "rorabgbachco"}
DS3_SET = ["controller.read_queue=32", "controller.write_queue=32",
           "controller.write_high_watermark=32", "controller.write_low_watermark=8",
           "controller.command_queue_depth=8", "controller.write_drain=dramsim3",
           "controller.bank_arbitration=round-robin", "controller.admission_delay=2",
           "controller.row_hit_cap=3", "timing.tRTRS_W2W=0", "trace.max_per_cycle=1"]
DS3_KINDS = ("rand_rd", "rand_mix", "low", "high", "seq", "strided", "runs")

# USIMM: its parameters for each preset (DRAM cycles), and the keys that make rtsim's
# controller USIMM's FR-FCFS.
US_SET = ["controller.protect_row_hits=false", "controller.write_drain=writes-only",
          "controller.admission_delay=1", "refresh.batch=8", "refresh.stagger_ranks=false"]
US_PARAMS = {
    "ddr3-1600": dict(NUM_CHANNELS=1, NUM_RANKS=2, NUM_BANKS=8, NUM_ROWS=8192,
                      NUM_COLUMNS=128, T_RCD=11, T_RP=11, T_CAS=11, T_RAS=28, T_RC=39,
                      T_CWD=8, T_WR=12, T_WTR=6, T_RTRS=2, T_DATA_TRANS=4, T_RTP=6,
                      T_CCD=4, T_RRD=6, T_FAW=32, T_REFI=6240, T_RFC=88, WQ_CAPACITY=64,
                      TCK_NS=1.25),
    "gddr5-trax": dict(NUM_CHANNELS=16, NUM_RANKS=1, NUM_BANKS=16, NUM_ROWS=8192,
                       NUM_COLUMNS=128, T_RCD=28, T_RP=28, T_CAS=28, T_RAS=70, T_RC=98,
                       T_CWD=13, T_WR=30, T_WTR=15, T_RTRS=2, T_DATA_TRANS=4, T_RTP=15,
                       T_CCD=4, T_RRD=13, T_FAW=80, T_REFI=15600, T_RFC=220,
                       WQ_CAPACITY=96, TCK_NS=0.5),
}
US_KINDS = ("rand_rd", "high", "runs", "treelets")
CLOCK = {"ddr3-1600": 800, "gddr5-trax": 2000, "ddr4-3200": 1600, "gddr5-strata": 2000}


def trace(preset, kind, fmt):
    path = os.path.join(WORK, f"{fmt}-{preset}-{kind}.trc")
    if not os.path.exists(path):
        with open(path, "w") as f:
            subprocess.run([sys.executable, os.path.join(ROOT, "scripts/dram_traces.py"),
                            "--preset", preset, "--kind", kind, "--format", fmt,
                            "--requests", str(REQUESTS), "--seed", str(SEED)],
                           check=True, stdout=f)
    return path


def rtsim(preset, path, fmt, sets, name, extra=()):
    out = os.path.join(WORK, "out", name)
    cmd = [RTSIM, "dram", "--preset", preset, "--trace", path, "--format", fmt, *extra]
    for s in sets:
        cmd += ["--set", s]
    cmd += ["--out", out]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    r = json.load(open(os.path.join(out, "dram_stats.json")))["report"]
    return dict(hit=r["row_hit_rate"]["reads"], hit_usimm=r["row_hit_rate"]["reads_by_activates"],
                lat=r["read_latency"]["mem_cycles"]["mean"], bw=r["bandwidth"]["achieved_gbps"],
                acts=r["activates"])


def run(cmd):
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)


def ds3(preset, kind):
    path = trace(preset, kind, "dramsim3")
    ini = os.path.join(ROOT, "scripts/dramsim3", f"{preset}.ini")
    d = run([os.environ["DRAMSIM3_RUN"], ini, path])
    r = rtsim(preset, path, "dramsim3", DS3_SET + [f"mapping={DS3_MAP[preset]}"],
              f"ds3-{preset}-{kind}")
    return dict(ref="dramsim3", preset=preset, kind=kind, ref_hit=d["read_hit_rate"],
                ref_lat=d["mean_read_latency"], ref_bw=d["bandwidth_gbs"],
                ref_acts=d["activates"], **{"rt_" + k: v for k, v in r.items()})


def usimm(preset, kind, refresh):
    path = trace(preset, kind, "usimm")
    p = dict(US_PARAMS[preset])
    sets = US_SET + [f"trace.requester_clock_mhz={CLOCK[preset]}"]
    if not refresh:
        p["T_REFI"] = 200_000_000  # no refresh deadline within the run
        sets.append("refresh.enabled=false")
    d = run([os.environ["USIMM_RUN"], path, *[f"{k}={v}" for k, v in p.items()], "MAX_OUT=64"])
    r = rtsim(preset, path, "usimm", sets, f"us-{preset}-{kind}-{int(refresh)}",
              extra=("--max-outstanding", "64"))
    return dict(ref="usimm", preset=preset, kind=kind, refresh=refresh,
                ref_hit=d["read_hit_rate_usimm"], ref_lat=d["mean_read_latency"],
                ref_bw=d["bandwidth_gbs"], ref_acts=d["activates"],
                **{"rt_" + k: v for k, v in r.items()})


def main():
    os.makedirs(os.path.join(WORK, "out"), exist_ok=True)
    what = sys.argv[1] if len(sys.argv) > 1 else "all"
    if what in ("all", "ds3"):
        for p in DS3_MAP:
            for k in DS3_KINDS:
                print(json.dumps(ds3(p, k)), flush=True)
    if what in ("all", "usimm"):
        for p in US_PARAMS:
            for refresh in (False, True):
                for k in US_KINDS:
                    print(json.dumps(usimm(p, k, refresh)), flush=True)


if __name__ == "__main__":
    main()
