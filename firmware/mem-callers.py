#!/usr/bin/env python3
"""`memcpy`/`memset` instructions of the firmware image per call site, from QEMU's log.

Usage (the log and disassembly of exec-profile.py's docstring):
    firmware/mem-callers.py dis.txt /tmp/qemu-exec.log ELF [DEPTH] [--soft-float]

Walks the log's executed blocks in order: each run of blocks inside `__aeabi_mem*` or
`compiler_builtins::mem::*` is charged, with the instructions QEMU printed for them, to the
last instruction of the block that entered it (the call site). Prints the 40 costliest
sites: address, instructions, calls, the calling function and its inlined frames in this
workspace (`llvm-addr2line -i`, innermost first, DEPTH of them, default 3). Divide by the
replay's master updates for a per-update figure (docs/performance.md, "What issue12-s11
changed").

`--soft-float`: the same for the software floating point instead (`__aeabi_d*`, `__aeabi_f2d`,
`compiler_builtins::float::*`: the board's `f64` arithmetic, comparisons and conversions;
docs/performance.md, "What issue12-s19 changed").
"""
import bisect
import collections
import importlib.util
import os
import re
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location('exec_profile', os.path.join(here, 'exec-profile.py'))
ep = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ep)


def main():
    soft_float = '--soft-float' in sys.argv
    args = [a for a in sys.argv[1:] if a != '--soft-float']
    dis, log, elf = args[:3]
    depth = int(args[3]) if len(args) > 3 else 3
    ins = ep.read_disassembly(dis)
    starts = sorted(a for a, _, _, _ in ins)
    func_at = {a: f for a, _, _, f in ins}
    cache = {}

    def function(a):
        if a not in cache:
            i = bisect.bisect_right(starts, a) - 1
            cache[a] = func_at[starts[i]] if i >= 0 else '?'
        return cache[a]

    def is_mem(f):
        if soft_float:
            return f.startswith(('__aeabi_d', '__aeabi_f2d')) or 'compiler_builtins::float' in f
        return f.startswith('__aeabi_mem') or 'compiler_builtins::mem' in f or f in ('memcpy', 'memset')

    order, blocks = ep.read_log_in_order(log)
    cost, calls = collections.Counter(), collections.Counter()
    prev, site = None, None
    for pc in order:
        if is_mem(function(pc)):
            if site is None and prev is not None:
                site = blocks.get(prev, [prev])[-1]
                calls[site] += 1
            if site is not None:
                cost[site] += len(blocks.get(pc, [pc]))
        else:
            site = None
        prev = pc
    sites = [s for s, _ in cost.most_common(40)]
    out = subprocess.run(['llvm-addr2line', '-a', '-i', '-f', '-C', '-e', elf] + [hex(a) for a in sites],
                         capture_output=True, text=True, check=True).stdout
    frames, at = {}, None
    for line in out.splitlines():
        if line.startswith('0x'):
            at = int(line, 16)
            frames[at] = []
        elif at is not None:
            frames[at].append(line)
    print(f"{'soft-float' if soft_float else 'mem'} instructions {sum(cost.values())}")
    for s in sites:
        fr = frames.get(s, [])
        ours = [f"{re.sub(r'::h[0-9a-f]{16}', '', f)} @ {loc.split('/src/', 1)[-1]}"
                for f, loc in zip(fr[0::2], fr[1::2])
                if '/core/src/' in loc or '/firmware/src/' in loc][:depth]
        print(f"{s:08x} {cost[s]:>9} {calls[s]:>6} {function(s)}  |  " + ' <- '.join(ours))


if __name__ == '__main__':
    main()
