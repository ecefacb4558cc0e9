#!/usr/bin/env python3
"""Instructions per source line of one function, through inlining.

callgrind_annotate charges an inlined helper's instructions to the
helper's own file (core_arch, slice indexing, lanes.rs, ...), so a stage
whose work is all inlined into one function shows as dozens of small
library entries. This script charges every instruction of the function
to the outermost line of the given source files in its inline chain
(addr2line -i), i.e. to the call site in the stage's own code, and prints
the lines by cost, per item if a count is given.

usage:
  valgrind --tool=callgrind --dump-instr=yes --callgrind-out-file=cg.out \\
      BINARY ARGS...          # an x86-64-v3 build: valgrind has no AVX-512
  benches/callgrind-lines.py cg.out FUNCTION BINARY FILES [PER] [EXPAND]

  FUNCTION  substring of the demangled function name (its own samples only)
  FILES     comma-separated file names whose lines are reported (shade.rs)
  PER       divide the counts by this (e.g. the stage's item count)
  EXPAND    comma-separated file:line call sites to look inside
            (shade.rs:163 reports the lines of the function called there)

Example (PERF.md, Renderer, fifth session of 2026-11-27):
  benches/callgrind-lines.py cg.out wavefront::shade::shade \\
      target/release/wavepath shade.rs,paths.rs 2520000 shade.rs:163
"""
import collections
import re
import subprocess
import sys


def position(token, last):
    """A callgrind position: absolute, relative (+n/-n) or repeated (*)."""
    if token == "*":
        return last
    if token[0] in "+-":
        return last + int(token, 0)
    return int(token, 0)


def self_costs(path, pattern):
    """Instructions per address, of functions whose name contains pattern."""
    names, costs = {}, collections.Counter()
    function, address, line, after_call = "", 0, 0, False
    for raw in open(path):
        text = raw.rstrip("\n")
        if not text:
            continue
        named = re.match(r"(c?fn)=\((\d+)\)(?: (.*))?", text)
        if named:
            if named.group(3):
                names[named.group(2)] = named.group(3)
            if named.group(1) == "fn":
                function = names.get(named.group(2), "")
            continue
        if text.startswith("calls="):
            after_call = True  # the next line is the call's inclusive cost
            continue
        if text[0] in "0123456789+-*":
            fields = text.split()
            address = position(fields[0], address)
            line = position(fields[1], line)
            if after_call:
                after_call = False
            elif pattern in function and len(fields) > 2:
                costs[address] += int(fields[2])
    return costs


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    path, pattern, binary, files = sys.argv[1:5]
    per = float(sys.argv[5]) if len(sys.argv) > 5 else 1.0
    expand = set(sys.argv[6].split(",")) if len(sys.argv) > 6 else set()
    files = files.split(",")
    costs = self_costs(path, pattern)
    total = sum(costs.values())
    if total == 0:
        sys.exit(f"no instructions of a function matching {pattern!r} in {path}")
    addresses = sorted(costs)
    out = subprocess.run(
        ["addr2line", "-a", "-i", "-e", binary] + [hex(a) for a in addresses],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.splitlines()
    chains, current = {}, None
    for text in out:
        if text.startswith("0x"):
            current = int(text, 16)
            chains[current] = []
        elif current is not None:
            chains[current].append(re.sub(r" \(discriminator \d+\)", "", text).split("/")[-1])
    by_line = collections.Counter()
    for address, cost in costs.items():
        chain = chains.get(address, [])  # innermost frame first
        frames = [f for f in chain if any(f.startswith(name + ":") for name in files)]
        while len(frames) > 1 and frames[-1] in expand:
            frames.pop()
        by_line[frames[-1] if frames else "(other) " + (chain[-1] if chain else "?")] += cost
    print(f"{total:,} instructions in functions matching {pattern!r}")
    for where, cost in by_line.most_common(40):
        print(f"{cost / per:10.1f}  {100 * cost / total:5.1f}%  {where}")


if __name__ == "__main__":
    main()
