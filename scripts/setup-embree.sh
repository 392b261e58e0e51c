#!/usr/bin/env bash
# Fetch Intel Embree 4.4 (official release build, shipped inside the PyPI wheel
# embreex==4.4.0.post1) and put libembree4 + libtbb into third_party/embree/lib,
# where build.rs links them with an rpath. Idempotent: returns at once when the
# libraries are already in place. See /work/shared/notes/embree.md for why this
# wheel (Debian only packages Embree 3; no crate bundles Embree 4).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
dest="$root/third_party/embree/lib"
wheel_sha256="2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f"
embree_so="libembree4-4aef3270.so.4"
tbb_so="libtbb-dcf63f8c.so.12"

if [[ -f "$dest/$embree_so" && -f "$dest/$tbb_so" && -L "$dest/libembree4.so" ]]; then
  echo "setup-embree: Embree 4.4 already in $dest"
  exit 0
fi

case "$(uname -s)-$(uname -m)" in
  Linux-x86_64) ;;
  *) echo "setup-embree: only Linux x86_64 is supported (the wheel is manylinux_2_28_x86_64)" >&2; exit 1 ;;
esac

pip_cmd=()
if command -v pip3 >/dev/null 2>&1; then pip_cmd=(pip3)
elif command -v pip >/dev/null 2>&1; then pip_cmd=(pip)
elif command -v python3 >/dev/null 2>&1; then pip_cmd=(python3 -m pip)
else echo "setup-embree: pip is needed to download the embreex wheel (apt-get install python3-pip)" >&2; exit 1
fi

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

echo "setup-embree: downloading embreex==4.4.0.post1 (Embree 4.4.0 release build, ~15 MB)"
"${pip_cmd[@]}" download --quiet --no-deps --only-binary=:all: --python-version 3.11 \
  --platform manylinux_2_28_x86_64 embreex==4.4.0.post1 -d "$work"

# The file name carries several platform tags (manylinux_2_27...manylinux_2_28): match it.
shopt -s nullglob
wheels=("$work"/embreex-4.4.0.post1-*.whl)
shopt -u nullglob
if [[ ${#wheels[@]} -ne 1 ]]; then
  echo "setup-embree: pip did not produce exactly one embreex-4.4.0.post1 wheel in $work" >&2
  exit 1
fi
wheel="${wheels[0]}"
echo "$wheel_sha256  $wheel" | sha256sum --check --quiet - || {
  echo "setup-embree: checksum mismatch for $(basename "$wheel") (expected $wheel_sha256)" >&2
  exit 1
}

python3 - "$wheel" "$work/x" "$embree_so" "$tbb_so" <<'PY'
import sys, zipfile
wheel, out, *names = sys.argv[1:]
with zipfile.ZipFile(wheel) as z:
    for n in names:
        z.extract("embreex.libs/" + n, out)
PY

mkdir -p "$dest"
for f in "$embree_so" "$tbb_so"; do
  install -m 0755 "$work/x/embreex.libs/$f" "$dest/$f.tmp"
  mv -f "$dest/$f.tmp" "$dest/$f"
done
ln -sfn "$embree_so" "$dest/libembree4.so"
echo "setup-embree: Embree 4.4 installed in $dest"
