#!/usr/bin/env python3
"""Code and data size per function name of two firmware images, and the difference.

Usage:
    firmware/flash-diff.py OLD.elf NEW.elf          # every name whose size changed
    firmware/flash-diff.py --copies ELF              # names held more than once

Sizes from `llvm-nm -S`, summed per demangled name without its hash, so the engine's
methods at its two sizes (`Engine<f32, 21>`, `Engine<f32, 33>`) count together; `--copies`
sums the copies beyond the largest of each name (what one copy per `T` would save at most;
docs/performance.md, "What issue12-s11 changed").
"""
import collections
import re
import subprocess
import sys


def sizes(elf):
    d = collections.defaultdict(list)
    out = subprocess.run(['llvm-nm', '-S', '-t', 'd', '--demangle', elf],
                         capture_output=True, text=True, check=True).stdout
    for line in out.splitlines():
        p = line.split(None, 3)
        if len(p) == 4 and p[2] in 'tTrRdD':
            d[re.sub(r'::h[0-9a-f]{16}$', '', p[3])].append(int(p[1]))
    return d


def main():
    args = sys.argv[1:]
    if args[0] == '--copies':
        d = sizes(args[1])
        extra = sorted(((sum(v) - max(v), k, len(v)) for k, v in d.items() if len(v) > 1), reverse=True)
        for e, k, n in extra:
            print(f'{e:7d} {n} copies  {k}')
        print('second copies', sum(e for e, _, _ in extra))
        return
    a, b = sizes(args[0]), sizes(args[1])
    rows = sorted((sum(b.get(k, [])) - sum(a.get(k, [])), k) for k in set(a) | set(b))
    for diff, k in rows:
        if diff:
            print(f'{diff:+7d} {sum(a.get(k, [])):7d} {sum(b.get(k, [])):7d} {k}')
    print('total', sum(map(sum, b.values())) - sum(map(sum, a.values())))


if __name__ == '__main__':
    main()
