#!/bin/bash
# Issue 27's 20,000-encounter sets (docs/evaluation.md, "Issue 27's 20,000-encounter sets"), resumed from the
# Parquet partitions already in runs/: a partition is 100 encounters, written whole or not at all, so the script
# can be stopped at any time and started again. The sets advance together, ten partitions each in turn, so that at
# any stop they hold the same first encounters (`avionics evaluate --report runs/* --common` compares them). Run it
# from a checkout whose evaluated code gives the same records as the partitions' (tests/test_evaluation.py holds
# the compiled path to the reference's records).
#
#   runs/issue27.sh [AVIONICS]        # AVIONICS: the avionics command (default: avionics on PATH), run niced
set -u
AVIONICS=${1:-avionics}
RUNS=$(cd "$(dirname "$0")" && pwd)
SET="--model uncor_1200exclude_rotorcraft_v1p2.txt --ownship uav-survey --surveillance do365-adsb --seed 28"
SET="$SET --encounters 20000 --partition-size 100 --scheduler local:2 --max-partitions 10"
run() {  # NAME ARGS...: ten more partitions of one set into runs/NAME, its log beside
    local name=$1; shift
    nice -n 10 "$AVIONICS" evaluate $SET "$@" --out "$RUNS/$name" >> "$RUNS/$name.log" 2>&1 || exit $?
}
done_() { [ "$(wc -l < "$RUNS/$1/_partitions.jsonl" 2>/dev/null || echo 0)" -ge 200 ]; }
until done_ guided-small-uas && done_ bands-do365 && done_ std-small-uas && done_ std-do365; do
    run guided-small-uas --pilot guidance --vehicle multirotor --profiles small-uas
    run bands-do365 --pilot guidance --vehicle multirotor --guidance-bands --profiles do365
    run std-small-uas --pilot standard --profiles small-uas
    run std-do365 --pilot standard --profiles do365
done
