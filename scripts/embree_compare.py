#!/usr/bin/env python3
"""Independent oracle and speed reference for `rtsim trace`: Embree 4 through embreex.

Usage:
  pip install embreex numpy
  rtsim export-triangles --scene sibenik --out tris.bin
  rtsim bench --scene sibenik --save-rays rays/          # or any rays.bin
  rtsim trace --scene sibenik --threads 1 --rays rays/diffuse.bin --out hits.bin
  python3 scripts/embree_compare.py --tris tris.bin --rays rays/diffuse.bin --hits hits.bin

Embree traces the same rays on one thread (embreex loops over rtcIntersect1 per ray, so its
figure is a lower bound on native Embree). With --hits, rtsim's answers are compared ray by
ray: hit or miss, triangle id (a different id at the same t counts as a shared-edge tie), and
t within 1e-4 relative. Formats are documented in rtsim's README.
"""
import argparse
import sys
import time

import numpy as np


def load_tris(path):
    with open(path, "rb") as f:
        n = int(np.frombuffer(f.read(8), dtype="<u8")[0])
        data = np.frombuffer(f.read(), dtype="<f4")
    if data.size != n * 9:
        sys.exit(f"{path}: expected {n} triangles")
    return data.reshape(n, 3, 3)


def load_rays(path):
    with open(path, "rb") as f:
        n = int(np.frombuffer(f.read(8), dtype="<u8")[0])
        data = np.frombuffer(f.read(), dtype="<f4")
    if data.size != n * 8:
        sys.exit(f"{path}: expected {n} rays")
    return data.reshape(n, 8)


def load_hits(path, n):
    raw = np.fromfile(path, dtype=np.dtype([("t", "<f4"), ("id", "<i4"), ("u", "<f4"), ("v", "<f4")]))
    if raw.size != n:
        sys.exit(f"{path}: expected {n} hits, found {raw.size}")
    return raw


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tris", required=True)
    ap.add_argument("--rays", required=True)
    ap.add_argument("--hits", help="rtsim's hits.bin for the same rays, to compare")
    ap.add_argument("--any-hit", action="store_true", help="occlusion queries (compare hit/miss only)")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()

    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh

    tris = load_tris(a.tris)
    rays = load_rays(a.rays)
    t0 = time.perf_counter()
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, tris.astype(np.float32))
    build = time.perf_counter() - t0
    if np.any(rays[:, 6] != 0.0):
        print("note: embreex has no tnear parameter; rays with tmin != 0 are traced from 0", file=sys.stderr)
    origins = np.ascontiguousarray(rays[:, 0:3])
    dirs = np.ascontiguousarray(rays[:, 3:6])
    dists = np.ascontiguousarray(np.minimum(rays[:, 7], np.float32(3.0e38)))
    query = "OCCLUDED" if a.any_hit else "INTERSECT"
    best = None
    best_cpu = None
    for _ in range(a.repeat):
        t0 = time.perf_counter()
        c0 = time.process_time()
        res = scene.run(origins, dirs, dists=dists.copy(), query=query, output=None if a.any_hit else 1)
        dt = time.perf_counter() - t0
        dc = time.process_time() - c0
        best = dt if best is None else min(best, dt)
        best_cpu = dc if best_cpu is None else min(best_cpu, dc)
    n = len(rays)
    print(
        f"embree: {n} rays, build {build:.3f} s, trace {best:.3f} s wall ({n / best / 1e6:.2f} Mrays/s), "
        f"{best_cpu:.3f} s CPU ({n / best_cpu / 1e6:.2f} Mrays/s per CPU second), 1 thread"
    )

    if a.hits:
        h = load_hits(a.hits, n)
        rt_hit = h["id"] >= 0
        if a.any_hit:
            em_hit = np.asarray(res) >= 0 if np.asarray(res).dtype != bool else np.asarray(res)
            agree = np.mean(rt_hit == em_hit)
            print(f"hit/miss agreement: {100 * agree:.4f} %")
            return
        em_id = res["primID"].astype(np.int64)
        em_hit = res["geomID"] != -1 if res["geomID"].dtype.kind == "i" else res["geomID"] != 0xFFFFFFFF
        em_id = np.where(em_hit, em_id, -1)
        em_t = res["tfar"]
        both = rt_hit & em_hit
        hm_agree = rt_hit == em_hit
        rel = np.zeros(n)
        rel[both] = np.abs(h["t"][both] - em_t[both]) / np.maximum(np.abs(em_t[both]), 1e-30)
        t_ok = rel <= 1e-4
        id_same = h["id"] == em_id
        # A different id at the same t is a tie on a shared edge or vertex.
        tie = both & ~id_same & t_ok
        ok = hm_agree & (~both | (t_ok & (id_same | tie)))
        print(f"hit/miss agreement:     {100 * hm_agree.mean():.4f} % ({(~hm_agree).sum()} differ)")
        print(f"same triangle id:       {100 * (id_same | ~both)[both | ~rt_hit].mean():.4f} % of rays ({tie.sum()} same-t ties)")
        print(f"t within 1e-4 relative: {100 * t_ok[both].mean() if both.any() else 100:.4f} % of common hits")
        print(f"rays fully agreeing:    {100 * ok.mean():.4f} %")


if __name__ == "__main__":
    main()
