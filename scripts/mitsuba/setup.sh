#!/usr/bin/env bash
# Make the git-ignored Python environment .venv/ with the pinned Mitsuba 3, OpenImageIO,
# flip-evaluator and numpy of requirements.txt, and install libLLVM 19 (Debian's libllvm19)
# so that Mitsuba's llvm_ad_rgb variant works (the image's libLLVM 15 aborts on area-light
# scenes, see ../shared/notes/mitsuba.md). Without libLLVM 19 the scripts fall back to
# scalar_rgb. Idempotent: a second run checks the pins and returns.
#
#   scripts/mitsuba/setup.sh          # prints the python path and the variant on the last line
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT"
say() { printf '== mitsuba setup: %s\n' "$*" >&2; }
req="scripts/mitsuba/requirements.txt"
venv="$ROOT/.venv"
stamp="$venv/.rtdiff-requirements"

if [[ ! -x "$venv/bin/python" ]]; then
    say "creating $venv"
    python3 -m venv "$venv"
fi
if ! cmp -s "$req" "$stamp" 2>/dev/null; then
    say "installing $(grep -vc '^#' "$req") pinned packages"
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$req"
    cp "$req" "$stamp"
fi

llvm=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
if [[ ! -e "$llvm" ]] && command -v apt-get >/dev/null 2>&1 && [[ $(id -u) -eq 0 ]]; then
    say "installing libllvm19 (for the llvm_ad_rgb variant)"
    if ! { apt-get install -y -qq libllvm19 >/dev/null 2>&1 \
           || { apt-get update -qq >/dev/null 2>&1 && apt-get install -y -qq libllvm19 >/dev/null 2>&1; }; }; then
        say "libllvm19 could not be installed: Mitsuba will use scalar_rgb"
    fi
fi
if [[ -e "$llvm" ]]; then variant=llvm_ad_rgb; else variant=scalar_rgb; fi
"$venv/bin/python" - <<PY
import mitsuba, OpenImageIO, flip_evaluator, numpy
print("python", "$venv/bin/python", "mitsuba", mitsuba.__version__, "oiio", OpenImageIO.__version__, "variant", "$variant")
PY
