#!/usr/bin/env bash
# The DRAM regression matrix: 192 synthetic cases (6 presets x stream/random x read ratio 1/0.7
# x fr-fcfs/fcfs x open/closed page x row-hit protection on/off) plus 12 extra cases that reach
# the other paths (USIMM and DRAMsim3 traces with read limits, power-down, row-hit cap, paced
# traffic, strided). Every case's dram_stats.json is written without the wall-time fields and
# without the echo of the resolved configuration (the input, which gains keys as the model
# does), so that two builds that simulate identically produce byte-identical files: `run` and
# the whole `report`, every raw counter and histogram included.
#
#   scripts/dram_matrix.sh record DIR [--set k=v ...]    run the matrix into DIR
#   scripts/dram_matrix.sh compare REF NEW [--set ...]   run into NEW and diff against REF
#
# Extra `--set` arguments are appended to every case (e.g. to pin a policy whose default has
# changed since REF was recorded). RTSIM selects the binary (default target/release/rtsim).
# Used to show that a restructuring of the simulator is bit-identical (docs/DRAM.md, "Speed").
set -euo pipefail

RTSIM=$(realpath "${RTSIM:-target/release/rtsim}")
N=${N:-20000}
mode=${1:?record|compare}
shift
if [[ $mode == compare ]]; then
    ref=${1:?reference dir}
    shift
fi
out=${1:?output dir}
shift
extra=("$@")

mkdir -p "$out"
out=$(realpath "$out")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# One case: name, then rtsim dram arguments.
run_case() {
    local name=$1
    shift
    # Traces are named relative to $work, so that `run.source` is the same in every run.
    (cd "$work" && "$RTSIM" dram "$@" "${extra[@]}" --out "$work/$name" >/dev/null)
    # Strip the wall-clock fields (the only nondeterministic output) and the config echo.
    jq -S 'del(.run.wall_seconds, .run.requests_per_second, .config)' \
        "$work/$name/dram_stats.json" >"$out/$name.json"
}

presets=(gddr5-trax gddr5-strata gddr5-8gb-x32 lpddr3-1600 ddr3-1600 ddr4-3200)
for p in "${presets[@]}"; do
    for pat in stream random; do
        for rr in 1 0.7; do
            for s in fr-fcfs fcfs; do
                for rp in open closed; do
                    for prot in true false; do
                        run_case "$p-$pat-$rr-$s-$rp-$prot" --preset "$p" --synthetic "$pat" \
                            --requests "$N" --read-ratio "$rr" --seed 7 \
                            --set controller.scheduler=$s --set controller.row_policy=$rp \
                            --set controller.protect_row_hits=$prot
                    done
                done
            done
        done
    done
done

# Traces for the extra cases, generated deterministically.
awk 'BEGIN { srand(3); for (i = 0; i < 20000; i++) {
        a = int(rand() * 2^24) * 64; if (rand() < 0.3) op = "W"; else op = "R";
        printf "%d %s 0x%x\n", int(rand() * 6), op, a } }' >"$work/usimm.trc"
awk 'BEGIN { srand(5); c = 0; for (i = 0; i < 20000; i++) {
        c += int(rand() * 4); row = int(rand() * 64);
        a = (row * 2^16 + int(rand() * 32) * 64); if (rand() < 0.25) op = "WRITE"; else op = "READ";
        printf "0x%x %s %d\n", a, op, c } }' >"$work/ds3.trc"

for p in ddr3-1600 gddr5-trax lpddr3-1600; do
    run_case "$p-usimm" --preset "$p" --trace usimm.trc --format usimm \
        --max-outstanding 64 --set controller.protect_row_hits=false
    run_case "$p-dramsim3" --preset "$p" --trace ds3.trc --format dramsim3 \
        --set controller.row_hit_cap=3
done
for p in ddr4-3200 lpddr3-1600; do
    run_case "$p-powerdown" --preset "$p" --synthetic random --requests "$N" --interval 40 \
        --read-ratio 0.8 --seed 9 --set controller.power_down=fast \
        --set controller.power_down_idle=20
done
run_case ddr3-1600-strided --preset ddr3-1600 --synthetic strided --stride 4096 \
    --requests "$N" --read-ratio 0.9 --seed 2
run_case gddr5-trax-paced --preset gddr5-trax --synthetic random --requests "$N" --interval 3 \
    --read-ratio 0.6 --seed 4 --set refresh.stagger_ranks=false
run_case ddr3-1600-cap --preset ddr3-1600 --synthetic random --requests "$N" --read-ratio 0.5 \
    --seed 8 --set controller.row_hit_cap=2 --set mapping=row:column:rank:bank:channel:offset
run_case ddr4-3200-noforward --preset ddr4-3200 --synthetic random --requests "$N" \
    --read-ratio 0.5 --seed 6 --set controller.forward_reads=false \
    --set controller.merge_reads=false --set controller.merge_writes=false \
    --set controller.write_queue=8 --set controller.write_high_watermark=6 \
    --set controller.write_low_watermark=2

count=$(ls "$out" | wc -l)
echo "$count cases in $out"
if [[ $mode == compare ]]; then
    if diff -rq "$ref" "$out"; then
        echo "bit-identical: all $count cases match $ref"
    else
        echo "DIFFERENT from $ref" >&2
        exit 1
    fi
fi
