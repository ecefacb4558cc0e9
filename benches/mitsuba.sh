#!/bin/bash
# Side-by-side timing against Mitsuba 3 on this machine: the same scene
# (exported by `wavepath mitsuba`), the same resolution, samples per pixel
# and depth, both renderers on all cores, run alternately so that the VM's
# drift from hour to hour hits both alike. Prints each round and the
# medians; the ratio is the figure to quote (PERF.md, "Against Mitsuba").
#
# usage: benches/mitsuba.sh [ROUNDS] [scene.dae]   (from the repository root)
# env:   SPP (64), DEPTH (5), RES ("480 360"), WAVEPATH_ARGS (extra flags)
#
# Needs Python 3 with venv, network access to PyPI (mitsuba==3.9.1 is
# installed into target/mitsuba-venv on first use) and LLVM ≥ 16 for
# Mitsuba's LLVM backend; on Debian 12: apt-get install libllvm19.
set -euo pipefail
ROUNDS=${1:-5}
SCENE=${2:-../shared/scenes/cs184/sky/CBbunny.dae}
SPP=${SPP:-64}
DEPTH=${DEPTH:-5}
RES=${RES:-480 360}
HERE=$(cd "$(dirname "$0")" && pwd)
VENV=target/mitsuba-venv

if [ -z "${DRJIT_LIBLLVM_PATH:-}" ]; then
  for lib in /usr/lib/x86_64-linux-gnu/libLLVM.so.{19,18,17,16}* /usr/lib/llvm-{19,18,17,16}/lib/libLLVM*.so*; do
    if [ -e "$lib" ]; then export DRJIT_LIBLLVM_PATH=$lib; break; fi
  done
fi
if [ -z "${DRJIT_LIBLLVM_PATH:-}" ]; then
  echo "mitsuba.sh: Mitsuba's LLVM backend needs libLLVM 16 or newer (Debian 12: apt-get install libllvm19)" >&2
  exit 1
fi
if [ ! -x "$VENV/bin/python" ]; then
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install -q mitsuba==3.9.1
fi
cargo build --release -q
WP=target/release/wavepath
OUT=target/mitsuba-compare
# shellcheck disable=SC2086
$WP mitsuba -s "$SPP" -m "$DEPTH" -r $RES "$SCENE" "$OUT" 2>/dev/null

wp_walls=(); wp_renders=(); mi_walls=(); mi_renders=()
for r in $(seq "$ROUNDS"); do
  t0=$(date +%s.%N)
  # shellcheck disable=SC2086
  wp_line=$($WP -s "$SPP" -m "$DEPTH" -r $RES --no-adaptive ${WAVEPATH_ARGS:-} -f "$OUT/wavepath.exr" "$SCENE" 2>&1 | grep -o 'render [0-9.]* s')
  t1=$(date +%s.%N)
  mi_line=$("$VENV/bin/python" "$HERE/mitsuba_render.py" "$OUT/scene.xml" "$OUT/mitsuba.exr")
  t2=$(date +%s.%N)
  wp_walls+=("$(echo "$t1 - $t0" | bc -l)"); mi_walls+=("$(echo "$t2 - $t1" | bc -l)")
  wp_renders+=("$(echo "$wp_line" | awk '{print $2}')")
  mi_renders+=("$(echo "$mi_line" | grep -o 'render [0-9.]* s' | awk '{print $2}')")
  printf "round %d: wavepath %.3f s wall (%s) | mitsuba %.3f s wall (%s)\n" "$r" "${wp_walls[-1]}" "$wp_line" "${mi_walls[-1]}" "$mi_line"
done
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
wpw=$(median "${wp_walls[@]}"); miw=$(median "${mi_walls[@]}")
wpr=$(median "${wp_renders[@]}"); mir=$(median "${mi_renders[@]}")
printf "medians over %d rounds: wall wavepath %.3f s, mitsuba %.3f s: wavepath/mitsuba %.3f\n" "$ROUNDS" "$wpw" "$miw" "$(echo "$wpw / $miw" | bc -l)"
printf "                        render wavepath %.3f s, mitsuba %.3f s (incl. its JIT): wavepath/mitsuba %.3f\n" "$wpr" "$mir" "$(echo "$wpr / $mir" | bc -l)"
$WP compare "$OUT/mitsuba.exr" "$OUT/wavepath.exr" | tail -1 | awk '{print "last round, relMSE between the two images (both noisy):", $3}'
