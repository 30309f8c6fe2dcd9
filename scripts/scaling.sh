#!/usr/bin/env bash
# Scaling table for the README: the bench example on 1 and on all threads, 1 substep × 10
# iterations (the issue's "10 iterations"), cloths of growing size, a long rope, many ragdolls,
# and the sleeping scene. Prints Markdown. Usage: bash scripts/scaling.sh
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/bevy_verlet_physics/target}"
cargo build --release --example bench >&2
bench="$CARGO_TARGET_DIR/release/examples/bench"

field() { sed -E "s/.*$1 ([0-9.]+).*/\1/"; }

echo "| scene | particles | sticks | solve, 1 thread (µs/step) | solve, all threads | speed-up | ECS overhead (gather+solve+scatter / solve) |"
echo "|---|---:|---:|---:|---:|---:|---:|"
run() {
    local name="$1"; shift
    local one all
    one=$("$bench" "$@" --threads 1)
    all=$("$bench" "$@")
    local particles sticks s1 s2 overhead
    particles=$(echo "$one" | sed -E 's/^([0-9]+) particles.*/\1/')
    sticks=$(echo "$one" | sed -E 's/.* ([0-9]+) sticks.*/\1/')
    s1=$(echo "$one" | field "solve")
    s2=$(echo "$all" | field "solve")
    overhead=$(echo "$one" | sed -E 's/.*ECS overhead ([0-9.]+)×.*/\1/')
    printf "| %s | %s | %s | %s | %s | %s× | %s× |\n" "$name" "$particles" "$sticks" "$s1" "$s2" \
        "$(awk "BEGIN { printf \"%.2f\", $s1 / $s2 }")" "$overhead"
}
for n in 32 64 128 256 512; do
    steps=$(( 2000000 / (n * n) )); steps=$(( steps < 20 ? 20 : steps )); steps=$(( steps > 600 ? 600 : steps ))
    run "cloth ${n}²" cloth --cols "$n" --rows "$n" --steps "$steps" --iterations 10 --substeps 1
done
run "rope 10 000 links" rope --links 10000 --steps 200 --iterations 10 --substeps 1
run "100 ragdolls" ragdolls --count 100 --steps 300 --iterations 10 --substeps 1
echo
"$bench" sleeping --count 100 --steps 120
