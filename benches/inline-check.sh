#!/bin/bash
# Lists the calls that the renderer's hot functions make to other Rust
# functions, apart from those meant to stay out of line, and exits 1 if
# there are any. Small helpers marked `#[inline]`, and array `map`s, have
# more than once been compiled out of line after unrelated changes
# elsewhere in the crate (codegen units and inlining thresholds moving):
# 2% of a render in one case, a third of maxplanck's camera-ray speed in
# another (PERF.md). Run it after changes that touch many files:
#
#   cargo build --release && bash benches/inline-check.sh [binary]
#
# Needs objdump (binutils). Reads the binary only; changes nothing.
set -euo pipefail
BIN=${1:-target/release/wavepath}
[ -x "$BIN" ] || { echo "inline-check.sh: no binary at $BIN" >&2; exit 2; }
command -v objdump > /dev/null || { echo "inline-check.sh: needs objdump (apt-get install binutils)" >&2; exit 2; }

# The stages' and traversals' entry points: every instruction a ray or a
# path vertex costs runs inside one of these.
HOT='^wavepath::(bvh::Bvh::(intersect|occluded)(_walk)?|bvh::traverse::Scene::leaf_closest_packet|wavefront::(shade::shade|surface::SurfacePoints::compute|compact::compact|generate::refill|shadow::resolve_[a-z_]+)|sampling::rng::pixel_offsets)$'
# Out of line on purpose or harmless: cold paths (exact-edge refinement,
# slivers' distances, second walks of rays that met slivers, brute force,
# a whole batch's walk called once per batch, a packet's sphere leaves,
# empty batch slots, growing a buffer, unwinding), the packet leaf test
# (kept apart so its registers do not crowd the single-ray loop), the
# wave's draws (one call per wave), and the environment map's weights
# (one call per eight paths, in scenes with a map).
ALLOWED='share_environment|refine_edges_f64|packet::closest::\{\{closure\}\}|Bvh::(intersect|occluded)_walk|group_slivers|ray_slivers|_careful|_brute|leaf_closest_packet|miss_slot|VertexDraws::draw|RawVec|finish_grow|_Unwind_Resume|^mem(cpy|set|move)|panic|handle_alloc_error|capacity_overflow'

found=$(objdump -d --no-show-raw-insn -C "$BIN" | awk -v hot="$HOT" -v allowed="$ALLOWED" '
  /^[0-9a-f]+ <.*>:$/ {
    name = $0; sub(/^[0-9a-f]+ </, "", name); sub(/>:$/, "", name)
    inside = (name ~ hot)
    next
  }
  inside && /\tcall +[0-9a-f]+ </ {
    target = $0; sub(/.*\tcall +[0-9a-f]+ </, "", target); sub(/>[^>]*$/, "", target)
    sub(/@plt$/, "", target)
    if (target !~ allowed) print name " -> " target
  }' | sort | uniq -c)

if [ -n "$found" ]; then
  echo "calls out of the hot functions (count, caller -> callee):"
  echo "$found"
  exit 1
fi
echo "inline-check: no unexpected calls in the hot functions of $BIN"
