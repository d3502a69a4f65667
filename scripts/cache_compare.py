#!/usr/bin/env python3
"""Run pycachesim (PyPI `pycachesim`) on an `rtsim cache` trace and print its counts as JSON.

The hierarchy is one L1, optionally an L2, then main memory, as pycachesim supports (a single
chain). Policies map to pycachesim as documented in docs/CACHES.md:
  write-around -> write_back=False, write_allocate=False
  write-back   -> write_back=True,  write_allocate=True
  lru / fifo   -> "LRU" / "FIFO"   (random is not compared: pycachesim uses C rand())
Every access is a 1-byte load or store, so it touches exactly one line.

Usage:
  python3 scripts/cache_compare.py --trace t.trc --line 64 \
      --l1 SIZE WAYS --l2 SIZE WAYS --replacement lru --write-policy write-around

Output: {"levels": [{"name", "LOAD", "STORE", "HIT", "MISS", "EVICT"}, ...],
         "memory": {"LOAD", "STORE"}}  (counts, not bytes)
"""
import argparse
import json
import sys

from cachesim import Cache, CacheSimulator, MainMemory


def read_trace(path):
    with open(path) as f:
        for n, line in enumerate(f, 1):
            text = line.split("#", 1)[0].split()
            if not text:
                continue
            op = text[0].upper()
            addr = int(text[1], 16)
            if len(text) > 3 and int(text[3]) != 0:
                sys.exit(f"{path}:{n}: pycachesim models one L1; only l1 = 0 is supported")
            if op in ("R", "READ", "LOAD"):
                yield False, addr
            elif op in ("W", "WRITE", "STORE"):
                yield True, addr
            else:
                sys.exit(f"{path}:{n}: expected R or W, found {text[0]}")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trace", required=True)
    p.add_argument("--line", type=int, default=64)
    p.add_argument("--l1", type=int, nargs=2, metavar=("SIZE", "WAYS"), required=True)
    p.add_argument("--l2", type=int, nargs=2, metavar=("SIZE", "WAYS"))
    p.add_argument("--replacement", choices=["lru", "fifo"], default="lru")
    p.add_argument("--write-policy", choices=["write-around", "write-back"], default="write-around")
    a = p.parse_args()

    wb = a.write_policy == "write-back"
    policy = a.replacement.upper()

    def cache(name, size, ways, **links):
        sets = size // (ways * a.line)
        return Cache(name, sets, ways, a.line, policy,
                     write_back=wb, write_allocate=wb, **links)

    mem = MainMemory()
    if a.l2:
        l2 = cache("L2", *a.l2)
        mem.load_to(l2)
        mem.store_from(l2)
        l1 = cache("L1", *a.l1, load_from=l2, store_to=l2)
    else:
        l1 = cache("L1", *a.l1)
        mem.load_to(l1)
        mem.store_from(l1)
    cs = CacheSimulator(l1, mem)
    for write, addr in read_trace(a.trace):
        if write:
            cs.store(addr, length=1)
        else:
            cs.load(addr, length=1)
    out = {"levels": [], "memory": {}}
    for s in cs.stats():
        counts = {k: s[k + "_count"] for k in ("LOAD", "STORE", "HIT", "MISS", "EVICT")}
        if s["name"] == "MEM":
            out["memory"] = {"LOAD": counts["LOAD"], "STORE": counts["STORE"]}
        else:
            out["levels"].append(dict(name=s["name"], **counts))
    json.dump(out, sys.stdout)
    print()


if __name__ == "__main__":
    main()
