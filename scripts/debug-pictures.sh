#!/usr/bin/env bash
# Every overlay of `rtdiff debug --draw` on the Cornell box and the dragon, and
# the dragon's heatmaps for the reports' BVH variants (median/basic, sah/basic,
# sah/fast) on one colour scale, written to OUT (default debug-pictures/).
# Needs the dragon (scripts/fetch-assets.sh) and a release build.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-debug-pictures}"
mkdir -p "$out"
bin=target/release/rtdiff
[[ -x "$bin" ]] || cargo build --release --locked
draw() { # scene name pixel-x pixel-y
    local scene=$1 name=$2 px=$3 py=$4
    for what in bvh-level=3 bvh-leaf=2 traversal rays normals sah-splits focal-plane; do
        local tag=${what%%=*}
        local extra=()
        case $what in traversal | rays | normals) extra=(--pixel "$px" "$py") ;; esac
        "$bin" debug "scenes/$scene.json" --draw "$what" "${extra[@]}" --quiet \
            -o "$out/$name-$tag.png" --obj "$out/$name-$tag.obj"
    done
    # The ray tree seen from the side: the camera ray becomes visible.
    "$bin" debug "scenes/$scene.json" --draw rays --pixel "$px" "$py" --orbit 40 --quiet -o "$out/$name-rays-orbit.png"
}
draw cornell_box cornell 330 420
draw dragon dragon 400 400
# One scale for the three heatmaps, so that colours compare across them.
for bt in median/basic sah/basic sah/fast; do
    b=${bt%/*} t=${bt#*/}
    "$bin" debug scenes/dragon.json --heatmap nodes --builder "$b" --traversal "$t" --scale-max 160 \
        -o "$out/dragon-heatmap-nodes-$b-$t.png"
done
echo "debug-pictures: wrote $(ls "$out" | wc -l) files to $out"
