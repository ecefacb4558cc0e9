#!/bin/bash
# Side-by-side timing against Mitsuba 3 on this machine: the same scene
# (written by `wavepath mitsuba`), the same resolution, samples per pixel
# and depth, both renderers on all cores, run alternately so that the VM's
# drift from hour to hour hits both alike. Prints each round and the
# medians; the ratio is the figure to quote (PERF.md, "Against Mitsuba").
#
# usage: benches/mitsuba.sh [ROUNDS] [scene.dae]   (from the repository root)
# env:   SPP (64), DEPTH (5), RES ("480 360"); EXPORT_ARGS, e.g. "--rr-depth 5"
#        for Mitsuba's own roulette default; ENVMAP, an environment map
#        (-e) for both, e.g. ENVMAP=scenes/sky.exr with scenes/outdoor.dae; WP, the wavepath binary to time
#        (default: the release build, which the script makes), e.g. the
#        profile-guided one of benches/pgo-build.sh
#
# Needs Python 3 with venv, network access to PyPI (mitsuba==3.9.1 is
# installed into target/mitsuba-venv on first use) and libLLVM 16 or newer
# for Mitsuba's LLVM backend; on Debian 12: apt-get install libllvm19.
set -euo pipefail
ROUNDS=${1:-5}
SCENE=${2:-../shared/scenes/cs184/sky/CBbunny.dae}
SPP=${SPP:-64}
DEPTH=${DEPTH:-5}
RES=${RES:-480 360}
HERE=$(cd "$(dirname "$0")" && pwd)
VENV=target/mitsuba-venv
OUT=target/mitsuba-compare
WP=${WP:-target/release/wavepath}
ENV_ARGS=${ENVMAP:+-e $ENVMAP}

fail() { echo "mitsuba.sh: $*" >&2; exit 1; }

if [ -z "${DRJIT_LIBLLVM_PATH:-}" ]; then
  shopt -s nullglob
  for v in 19 18 17 16; do
    for lib in /usr/lib/*/libLLVM.so."$v"* /usr/lib/*/libLLVM-"$v".so* /usr/lib/llvm-"$v"/lib/libLLVM*.so*; do
      export DRJIT_LIBLLVM_PATH=$lib
      break 2
    done
  done
  shopt -u nullglob
fi
[ -n "${DRJIT_LIBLLVM_PATH:-}" ] ||
  fail "Mitsuba's LLVM backend needs libLLVM 16 or newer (Debian 12: apt-get install libllvm19), or set DRJIT_LIBLLVM_PATH"
if ! "$VENV/bin/python" -c 'import mitsuba' 2>/dev/null; then
  python3 -m venv "$VENV" || fail "cannot create $VENV (Debian: apt-get install python3-venv)"
  "$VENV/bin/pip" install -q mitsuba==3.9.1 || fail "cannot install mitsuba==3.9.1 from PyPI"
fi
cargo build --release -q
[ -x "$WP" ] || fail "no wavepath binary at $WP (WP)"
# shellcheck disable=SC2086
$WP mitsuba -s "$SPP" -m "$DEPTH" -r $RES ${EXPORT_ARGS:-} $ENV_ARGS "$SCENE" "$OUT"

# Runs "$@", keeping its output in $OUT/log; prints the log and stops on failure.
run() {
  if ! "$@" > "$OUT/log" 2>&1; then
    cat "$OUT/log" >&2
    fail "failed: $*"
  fi
}
# The number after "$1 " in the last log, e.g. `render 2.31 s` → 2.31.
field() { grep -o "$1 [0-9.]* s" "$OUT/log" | head -1 | awk '{print $2}'; }
now() { date +%s.%N; }
sub() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.3f", a - b}'; }

wp_walls=(); wp_renders=(); mi_walls=(); mi_renders=()
for r in $(seq "$ROUNDS"); do
  t0=$(now)
  # shellcheck disable=SC2086
  run $WP -s "$SPP" -m "$DEPTH" -r $RES --no-adaptive $ENV_ARGS -f "$OUT/wavepath.exr" "$SCENE"
  t1=$(now)
  wp_walls+=("$(sub "$t1" "$t0")"); wp_renders+=("$(field render)")
  t1=$(now)
  run "$VENV/bin/python" "$HERE/mitsuba_render.py" "$OUT/scene.xml" "$OUT/mitsuba.exr"
  t2=$(now)
  mi_walls+=("$(sub "$t2" "$t1")"); mi_renders+=("$(field render)")
  echo "round $r: wavepath ${wp_walls[-1]} s wall (render ${wp_renders[-1]} s) | mitsuba ${mi_walls[-1]} s wall ($(cat "$OUT/log"))"
done
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.3f", a / b}'; }
wpw=$(median "${wp_walls[@]}"); miw=$(median "${mi_walls[@]}")
wpr=$(median "${wp_renders[@]}"); mir=$(median "${mi_renders[@]}")
echo "medians over $ROUNDS rounds: wall wavepath $wpw s, mitsuba $miw s: wavepath/mitsuba $(ratio "$wpw" "$miw")"
echo "                        render wavepath $wpr s, mitsuba $mir s (incl. its JIT): wavepath/mitsuba $(ratio "$wpr" "$mir")"
run $WP compare "$OUT/mitsuba.exr" "$OUT/wavepath.exr"
echo "last round, relMSE between the two images (both noisy): $(awk '$1 == "all" {print $3}' "$OUT/log")"
