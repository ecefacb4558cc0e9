#!/bin/bash
# An optional profile-guided build of wavepath: compile with counters,
# render the scenes shipped in scenes/ to train them, merge the counts with
# LLVM's llvm-profdata, and compile again using them. The result renders
# the same images bit for bit as the plain release build (the script
# checks), 1–6% faster in alternating runs on the project's machine
# (PERF.md, twentieth session). The plain `cargo build --release` stays
# the default: a profile is only valid for the source it was made from,
# so it is made here, never committed.
#
# usage: benches/pgo-build.sh            (from the repository root)
# out:   target/pgo/<host triple>/release/wavepath
# env:   LLVM_PROFDATA, an llvm-profdata that reads this rustc's profiles
#        (LLVM 19 or newer); else rustup's llvm-tools component or
#        llvm-profdata-NN on the PATH is used. On Debian 12:
#        apt-get install llvm-19; or: rustup component add llvm-tools.
set -euo pipefail
cd "$(dirname "$0")/.."

fail() { echo "pgo-build.sh: $*" >&2; exit 1; }

host=$(rustc -vV | sed -n 's/^host: //p')
[ -n "$host" ] || fail "cannot tell the host target from rustc -vV"
data=target/pgo-data
rm -rf "$data"
mkdir -p "$data"

# The flag of .cargo/config.toml (which these flags replace) and one
# more, passed unsplit (CARGO_ENCODED_RUSTFLAGS: the profile's path may
# hold spaces). Naming the target explicitly keeps the flags off build
# scripts and proc macros, so only wavepath itself is instrumented.
build() {
  CARGO_ENCODED_RUSTFLAGS=$(printf '%s\x1f' -C target-cpu=native -C)$1 \
    cargo build --release --locked --target "$host" --target-dir "$2"
}

echo "== instrumented build"
build "profile-generate=$PWD/$data" target/pgo-train
trainer=target/pgo-train/$host/release/wavepath

echo "== training renders (scenes/)"
for scene in scenes/*.dae; do
  "$trainer" -q -t 2 -s 16 -m 5 -r 240 180 -f "$data/train.png" "$scene"
  "$trainer" -q -t 2 -s 16 -l 4 -m 5 --no-adaptive -r 240 180 -f "$data/train.exr" "$scene"
done

echo "== merge"
profdata=""
candidates=("${LLVM_PROFDATA:-}")
shopt -s nullglob
candidates+=("$(rustc --print sysroot)"/lib/rustlib/*/bin/llvm-profdata)
shopt -u nullglob
for v in 23 22 21 20 19; do candidates+=("llvm-profdata-$v"); done
candidates+=(llvm-profdata)
for tool in "${candidates[@]}"; do
  [ -n "$tool" ] && command -v "$tool" >/dev/null || continue
  # Older tools reject newer raw profiles ("unsupported ... format version").
  if "$tool" merge -o "$data/merged.profdata" "$data"/*.profraw 2>/dev/null; then
    profdata=$tool
    break
  fi
done
[ -n "$profdata" ] ||
  fail "no llvm-profdata here reads this rustc's profiles; install one (Debian 12: apt-get install llvm-19; or rustup component add llvm-tools) or set LLVM_PROFDATA"
echo "merged with $profdata"

echo "== optimised build"
build "profile-use=$PWD/$data/merged.profdata" target/pgo
pgo=target/pgo/$host/release/wavepath

echo "== check: the same image as the plain release build"
cargo build --release --locked
check() { "$1" -q -t 2 -s 8 -m 5 -r 160 120 -f "$data/$2.exr" scenes/torus_knot.dae; }
check target/release/wavepath plain
check "$pgo" pgo
cmp "$data/plain.exr" "$data/pgo.exr" || fail "the profile-guided build renders a different image"
echo "ok: $pgo"
