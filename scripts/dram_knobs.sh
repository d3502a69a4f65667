#!/usr/bin/env bash
# The DRAM knob cases beside the regression matrix (scripts/dram_matrix.sh): the paths the
# matrix does not reach, each with random and streaming traffic of 70 % reads on gddr5-trax and
# ddr4-3200, saturated (--interval 0) and paced (--interval 2): 11 settings x 2 presets x 2
# patterns x 2 intervals = 88 cases. Settings: command queues (depth 8; depth 4 with FCFS and
# writes-only drain), mixed drain with and without row-hit protection, USIMM's FCFS with open and
# closed pages, two ranks with bank_xor under FR-FCFS and FCFS, checking mode with power-down on
# one and two ranks, DRAMsim3's controller (docs/DRAM.md, "Reproducing DRAMsim3 and USIMM").
# Output as in dram_matrix.sh (wall time and config echo stripped).
#
#   scripts/dram_knobs.sh record DIR
#   scripts/dram_knobs.sh compare REF NEW
#
# RTSIM selects the binary (default target/release/rtsim). Used with dram_matrix.sh to show
# that a restructuring is bit-identical (docs/DRAM.md, "Speed").
set -euo pipefail

RTSIM=$(realpath "${RTSIM:-target/release/rtsim}")
mode=${1:?record|compare}
shift
if [[ $mode == compare ]]; then
    ref=${1:?reference dir}
    shift
fi
out=${1:?output dir}

mkdir -p "$out"
out=$(realpath "$out")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

run_case() {
    local name=$1
    shift
    "$RTSIM" dram "$@" --out "$work/$name" >/dev/null
    jq -S 'del(.run.wall_seconds, .run.requests_per_second, .config)' \
        "$work/$name/dram_stats.json" >"$out/$name.json"
}

names=(cq cq-wo mixed-prot mixed-noprot usimm-open usimm-closed xor2-frfcfs xor2-fcfs
    check-pd1 check-pd2 dramsim3)
settings() {
    case $1 in
    cq) echo "--set controller.command_queue_depth=8" ;;
    cq-wo) echo "--set controller.command_queue_depth=4 --set controller.write_drain=writes-only \
--set controller.scheduler=fcfs" ;;
    mixed-prot) echo "--set controller.write_drain=mixed" ;;
    mixed-noprot) echo "--set controller.write_drain=mixed --set controller.protect_row_hits=false" ;;
    usimm-open) echo "--set controller.scheduler=usimm-fcfs --set controller.row_policy=open" ;;
    usimm-closed) echo "--set controller.scheduler=usimm-fcfs --set controller.row_policy=closed" ;;
    xor2-frfcfs) echo "--set organisation.ranks=2 --set bank_xor=true \
--set controller.scheduler=fr-fcfs" ;;
    xor2-fcfs) echo "--set organisation.ranks=2 --set bank_xor=true --set controller.scheduler=fcfs" ;;
    check-pd1) echo "--set check=true --set controller.power_down=fast \
--set controller.power_down_idle=20" ;;
    check-pd2) echo "--set check=true --set controller.power_down=fast \
--set controller.power_down_idle=20 --set organisation.ranks=2" ;;
    dramsim3) echo "--set controller.command_queue_depth=8 --set controller.write_drain=dramsim3 \
--set controller.bank_arbitration=round-robin --set controller.admission_delay=2 \
--set controller.row_hit_cap=3 --set timing.tRTRS_W2W=0" ;;
    esac
}

for iv in 0 2; do
    for p in gddr5-trax ddr4-3200; do
        for pat in random stream; do
            for k in "${names[@]}"; do
                # shellcheck disable=SC2046 # the settings are separate words
                run_case "$p-$pat-$k-i$iv" --preset "$p" --synthetic "$pat" --requests 20000 \
                    --read-ratio 0.7 --seed 11 --interval "$iv" $(settings "$k")
            done
        done
    done
done

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
