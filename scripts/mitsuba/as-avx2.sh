#!/usr/bin/env bash
# Run a command with Mitsuba generating code as on a CPU with AVX2 but without AVX-512: Dr.Jit's
# LLVM backend targets haswell with 8-wide vectors (RTDIFF_MITSUBA_ISA, read by
# scripts/mitsuba/rtdiff_mitsuba.py) and Embree inside Mitsuba is capped at AVX2 (max_isa, through
# a preloaded shim built from embree_max_isa.c). Dr.Jit's kernel cache goes to a fresh folder so
# that no kernel compiled for this host is reused. rtdiff itself is not affected.
#
#   scripts/mitsuba/as-avx2.sh .venv/bin/python scripts/mitsuba/make_references.py --only cube --out /tmp/r
#   scripts/mitsuba/as-avx2.sh cargo test --features embree --test mitsuba_live references_regenerate
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
[[ $# -gt 0 ]] || { echo "usage: $0 COMMAND [ARGS...]" >&2; exit 2; }
shim="$ROOT/target/embree_max_isa.so"
if [[ ! -e "$shim" || "$HERE/embree_max_isa.c" -nt "$shim" ]]; then
    mkdir -p "$ROOT/target"
    cc -shared -fPIC -O2 -o "$shim" "$HERE/embree_max_isa.c" -ldl
fi
cache="$(mktemp -d)"
trap 'rm -rf "$cache"' EXIT
export RTDIFF_MITSUBA_ISA=avx2 RTDIFF_EMBREE_CONFIG=max_isa=avx2 DRJIT_CACHE_DIR="$cache"
export LD_PRELOAD="$shim${LD_PRELOAD:+:$LD_PRELOAD}"
"$@"
