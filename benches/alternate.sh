#!/bin/bash
# Times two or more wavepath binaries on the same render, alternately, so
# that the VM's drift (runs of one binary here spread by 10–25% within
# an hour; PERF.md) hits them alike. Prints each binary's median, range
# and, for each binary after the first, the median over rounds of its
# time divided by the first binary's in the same round: a ratio of
# neighbouring runs, steadier than the ratio of the two medians. It also
# checks that every binary wrote the same image, byte for byte, as a
# change meant to be a pure speed-up must.
#
# usage: benches/alternate.sh [-n ROUNDS] BINARY_A BINARY_B [...] -- RENDER ARGS...
#        (from the repository root; ROUNDS defaults to 7)
# e.g.:  cp target/release/wavepath /tmp/before; (make the change; build)
#        benches/alternate.sh -n 9 /tmp/before target/release/wavepath -- \
#            -s 64 -m 5 -r 480 360 -t 2 --no-adaptive ../shared/scenes/cs184/sky/CBbunny.dae
#
# The render arguments must not name an output (-f): each binary writes
# its own PNG under target/alternate/, which is how the images are
# compared. Exit status 1 if the images differ or a render fails.
set -euo pipefail

fail() { echo "alternate.sh: $*" >&2; exit 2; }

ROUNDS=7
if [ "${1:-}" = "-n" ]; then
  [ $# -ge 2 ] || fail "-n needs a number"
  ROUNDS=$2
  shift 2
fi
[[ "$ROUNDS" =~ ^[1-9][0-9]*$ ]] || fail "rounds must be a positive whole number, not '$ROUNDS'"

BINS=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
  [ -x "$1" ] || fail "no executable at $1"
  BINS+=("$1")
  shift
done
[ "${1:-}" = "--" ] || fail "usage: alternate.sh [-n ROUNDS] BINARY_A BINARY_B [...] -- RENDER ARGS..."
shift
[ ${#BINS[@]} -ge 2 ] || fail "give at least two binaries to compare"
[ $# -ge 1 ] || fail "give the render's arguments after --"
for a in "$@"; do
  case "$a" in -f|--output|--output=*) fail "the render arguments must not name an output (-f): the script writes each binary's own" ;; esac
done

OUT=target/alternate
mkdir -p "$OUT"
declare -a TIMES
for ((r = 1; r <= ROUNDS; r++)); do
  line="round $r:"
  for k in "${!BINS[@]}"; do
    start=$(date +%s.%N)
    if ! "${BINS[$k]}" "$@" -q -f "$OUT/$k.png" > "$OUT/$k.log" 2>&1; then
      echo "alternate.sh: ${BINS[$k]} failed; its output:" >&2
      cat "$OUT/$k.log" >&2
      exit 1
    fi
    end=$(date +%s.%N)
    t=$(awk -v s="$start" -v e="$end" 'BEGIN { printf "%.3f", e - s }')
    TIMES[k]="${TIMES[k]:-} $t"
    line="$line ${t} s"
  done
  echo "$line"
done

median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{ v[NR] = $1 } END { if (NR % 2) print v[(NR + 1) / 2]; else printf "%.4f\n", (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
range() { tr ' ' '\n' | grep -v '^$' | sort -g | awk 'NR == 1 { lo = $1 } { hi = $1 } END { print lo "–" hi }'; }

status=0
for k in "${!BINS[@]}"; do
  summary="${BINS[$k]}: median $(echo "${TIMES[k]}" | median) s (runs $(echo "${TIMES[k]}" | range) s)"
  if [ "$k" -gt 0 ]; then
    ratios=$(paste -d' ' <(echo "${TIMES[0]}" | tr ' ' '\n' | grep -v '^$') \
                         <(echo "${TIMES[k]}" | tr ' ' '\n' | grep -v '^$') |
             awk '{ printf "%.4f ", $2 / $1 }')
    summary="$summary; per-round time / first binary's: median $(echo "$ratios" | median) (range $(echo "$ratios" | range))"
    if ! cmp -s "$OUT/0.png" "$OUT/$k.png"; then
      summary="$summary; IMAGE DIFFERS from the first binary's"
      status=1
    fi
  fi
  echo "$summary"
done
exit $status
