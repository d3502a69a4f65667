#!/usr/bin/env python3
"""Request traces for comparing `rtsim dram` with DRAMsim3 and USIMM (docs/DRAM.md, "Validation").

    scripts/dram_traces.py --preset ddr4-3200 --kind high --format dramsim3 \
        --requests 200000 --seed 11 > high.trc

Kinds (every address is a 64 B line inside the preset's capacity; rates are in memory cycles
and scale with the preset, so that a kind loads every preset alike):

  rand_rd   uniform random lines, reads only, at 60 % of the random-access rate R
  rand_mix  uniform random lines, 70 % reads, at 60 % of R
  low       uniform random lines, 70 % reads, at 10 % of R
  high      uniform random lines, 70 % reads, at 200 % of R (saturating: the queues stay full)
  seq       consecutive lines from a random start, reads, at 80 % of the peak line rate P
  strided   every eighth line from a random start, reads, at 80 % of P
  runs      runs of 4-32 consecutive lines starting inside a random 2 KB block (so a run stays
            in one row), 80 % reads, at 50 % of P
  treelets  32-256 distinct lines of a random 16 KB block in random order, reads, at 50 % of P

R is the rate at which random row misses can be served: one ACT per max(tRRD, tFAW / 4) per
rank, over all ranks and channels (for ddr3-1600 also the data bus, one line per 4 cycles).
P is one line per burst on every channel. Gaps between requests are exponential with those
means, rounded to whole cycles.

Formats: `dramsim3` ("<hex addr> <READ|WRITE> <cycle>", absolute memory cycles, at least one cycle apart:
DRAMsim3's trace front end offers at most one request per cycle) and `usimm`
("<gap> <R|W> <hex addr>", gap in cycles since the previous request; run rtsim with
`--set trace.requester_clock_mhz=<memory clock>` so that these are memory cycles). For `usimm`
the `high` kind has gap 0 throughout: the requester is limited only by its read limit and the
write queue, as USIMM's front end is by its ROB.
"""

import argparse
import random
import sys

LINE = 64

# capacity (bytes), random-access rate R (memory cycles per request, whole system),
# peak line rate P (memory cycles per line, whole system)
PRESETS = {
    # 16 ch x 16 banks x 8192 rows x 8 KB; max(tRRD 13, tFAW 80/4) = 20 per channel; burst 4
    "gddr5-trax": (1 << 34, 20 / 16, 4 / 16),
    # 2 ranks x 8 banks x 8192 rows x 8 KB; max(tRRD 6, tFAW 32/4) = 8 per rank, 2 ranks,
    # but the bus carries one line per 4 cycles: 4.5 allows for rank switches
    "ddr3-1600": (1 << 30, 4.5, 4.0),
    # 16 banks x 65536 rows x 8 KB; max(tRRD_S 4, tFAW 34/4) = 8.5; burst 4
    "ddr4-3200": (1 << 33, 8.5, 4.0),
    # 8 ch x 16 banks x 16384 rows x 8 KB; max(tRRD 11, tFAW 46/4) = 11.5 per channel; burst 2
    "gddr5-strata": (1 << 34, 11.5 / 8, 2 / 8),
}

KINDS = ("rand_rd", "rand_mix", "low", "high", "seq", "strided", "runs", "treelets")


def addresses(kind, capacity, n, rng):
    """Yield (is_write, byte address) for n requests."""
    lines = capacity // LINE
    if kind in ("rand_rd", "rand_mix", "low", "high"):
        wr = 0.0 if kind == "rand_rd" else 0.3
        for _ in range(n):
            yield rng.random() < wr, rng.randrange(lines) * LINE
    elif kind in ("seq", "strided"):
        step = 1 if kind == "seq" else 8
        start = rng.randrange(lines)
        for i in range(n):
            yield False, ((start + i * step) % lines) * LINE
    elif kind == "runs":
        done = 0
        block_lines = 2048 // LINE
        while done < n:
            k = rng.randint(4, 32)
            block = rng.randrange(lines // block_lines)
            first = rng.randint(0, block_lines - k)
            for j in range(min(k, n - done)):
                yield rng.random() < 0.2, (block * block_lines + first + j) * LINE
            done += k
    elif kind == "treelets":
        done = 0
        block_lines = 16384 // LINE
        while done < n:
            k = rng.randint(32, 256)
            block = rng.randrange(lines // block_lines)
            picked = rng.sample(range(block_lines), k)
            for j in picked[: n - done]:
                yield False, (block * block_lines + j) * LINE
            done += k
    else:
        raise ValueError(kind)


def mean_gap(kind, r_rand, p_line):
    return {
        "rand_rd": r_rand / 0.6,
        "rand_mix": r_rand / 0.6,
        "low": r_rand / 0.1,
        "high": r_rand / 2.0,
        "seq": p_line / 0.8,
        "strided": p_line / 0.8,
        "runs": p_line / 0.5,
        "treelets": p_line / 0.5,
    }[kind]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", required=True, choices=sorted(PRESETS))
    ap.add_argument("--kind", required=True, choices=KINDS)
    ap.add_argument("--format", required=True, choices=("dramsim3", "usimm"))
    ap.add_argument("--requests", type=int, default=200_000)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()

    capacity, r_rand, p_line = PRESETS[a.preset]
    rng = random.Random(f"{a.seed}:{a.preset}:{a.kind}")
    timing = random.Random(f"{a.seed}:{a.preset}:{a.kind}:t")
    mean = mean_gap(a.kind, r_rand, p_line)
    saturate = a.format == "usimm" and a.kind == "high"
    out = sys.stdout
    t = 0.0
    prev = 0
    out_count = 0
    for is_write, addr in addresses(a.kind, capacity, a.requests, rng):
        if not saturate:
            t += timing.expovariate(1.0 / mean)
        cycle = int(t)
        if a.format == "dramsim3" and out_count:
            # DRAMsim3's trace front end offers at most one request per cycle
            cycle = max(cycle, prev + 1)
            t = max(t, float(cycle))
        out_count += 1
        if a.format == "dramsim3":
            out.write(f"0x{addr:x} {'WRITE' if is_write else 'READ'} {cycle}\n")
        else:
            out.write(f"{cycle - prev} {'W' if is_write else 'R'} 0x{addr:x}\n")
        prev = cycle


if __name__ == "__main__":
    main()
