#!/bin/sh
# The VM evaluation matrix (docs/performance.md, "Choosing the scripting VM"): builds the
# evaluation once per VM, then runs every configuration REPEATS times, interleaved (so a busy
# minute hits them all alike), 10,000 fish, 3 s measured each; results in ./results/, medians
# via summarize.py. Needs only cargo and a C/C++ compiler (mlua builds each VM from source).
#   CARGO_TARGET_DIR=/tmp/vm-eval-target REPEATS=3 benches/vm/run_all.sh
set -eu
cd "$(dirname "$0")"
T=${CARGO_TARGET_DIR:-target}
export CARGO_TARGET_DIR="$T"
FISH=${FISH:-10000}
SECONDS_MEASURED=${SECONDS_MEASURED:-3}
for vm in lua54 luajit luau luau-jit; do
  cargo build --release --quiet --features "$vm"
  mkdir -p "$T/bin-$vm" && cp "$T/release/shoal-vm-eval" "$T/bin-$vm/"
done
mkdir -p results
for rep in $(seq 1 "${REPEATS:-3}"); do
  for cfg in "lua54|" "lua54|--no-bound" "lua54|--no-memory-limit" \
             "luajit|" "luajit|--jit-big" "luajit|--no-bound --jit-big" "luajit|--jit-off" \
             "luau|" "luau|--no-bound" \
             "luau-jit|" "luau-jit|--no-bound" "luau-jit|--no-bound --no-memory-limit"; do
    vm=${cfg%%|*}; args=${cfg#*|}
    name=$(echo "$vm $args" | sed 's/ *$//; s/--//g; s/ /_/g')
    "$T/bin-$vm/shoal-vm-eval" --fish "$FISH" --seconds "$SECONDS_MEASURED" $args \
      > "results/$name-$rep.txt" 2>&1 || echo "$name-$rep failed: see results/$name-$rep.txt"
  done
done
python3 summarize.py results
