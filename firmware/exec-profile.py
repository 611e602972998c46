#!/usr/bin/env python3
"""Instructions per function of the firmware image, from QEMU's execution log.

Usage (docs/performance.md):
    # a wrapper earlier in PATH adds the log to every qemu-system-arm run
    mkdir -p /tmp/qemu-wrap && printf '#!/bin/sh\\nexec /usr/bin/qemu-system-arm -d exec,nochain -D /tmp/qemu-exec.log "$@"\\n' \
        > /tmp/qemu-wrap/qemu-system-arm && chmod +x /tmp/qemu-wrap/qemu-system-arm
    flexcal simulate --scenario moored --duration 1 --out m1
    PATH=/tmp/qemu-wrap:$PATH flexcal replay m1 --qemu --transport semihosting --out r-m1
    llvm-objdump -d --demangle --no-show-raw-insn target/thumbv7em-none-eabihf/firmware/flexcal-firmware > dis.txt
    firmware/exec-profile.py dis.txt /tmp/qemu-exec.log [N]

Each executed translation block (its start address in the log) is charged the instructions
from that address to the next branch in the disassembly: QEMU ends its blocks at branches, so
this is exact up to blocks QEMU splits for other reasons. Prints the N (default 30) functions
with the most instructions; divide by the replay's master updates for a per-update figure.
"""
import collections
import re
import sys


def main():
    dis, log = sys.argv[1], sys.argv[2]
    top = int(sys.argv[3]) if len(sys.argv) > 3 else 30
    ins, func = [], None
    for line in open(dis):
        m = re.match(r'^([0-9a-f]{8}) <(.*)>:$', line)
        if m:
            if not m.group(2).startswith('$'):  # mapping symbols ($t, $d) are not functions
                func = m.group(2)
            continue
        m = re.match(r'^\s*([0-9a-f]+):\s+(\S+)(.*)$', line)
        if m and func:
            ins.append((int(m.group(1), 16), m.group(2), m.group(3), func))
    index = {a: i for i, (a, _, _, _) in enumerate(ins)}

    def ends_block(mn, ops):
        if mn.startswith('b') and not mn.startswith(('bic', 'bfi', 'bfc')):
            return True
        if mn in ('cbz', 'cbnz', 'tbb', 'tbh', 'svc', 'bkpt', 'wfi'):
            return True
        return mn.startswith(('pop', 'ldm')) and 'pc' in ops or (
            mn.startswith('ldr') and ops.strip().startswith('pc'))

    size = {}

    def block(pc):
        if pc not in size:
            i, n = index.get(pc), 0
            while i is not None and i < len(ins):
                n += 1
                if ends_block(ins[i][1], ins[i][2]) or n >= 512:
                    break
                i += 1
            size[pc] = (n, ins[index[pc]][3] if pc in index else '?')
        return size[pc]

    runs = collections.Counter()
    for line in open(log):
        m = re.search(r'\[[0-9a-f]+/([0-9a-f]+)/', line)
        if m:
            runs[int(m.group(1), 16)] += 1
    per_function = collections.Counter()
    for pc, count in runs.items():
        n, f = block(pc)
        per_function[f] += n * count
    total = sum(per_function.values())
    print(f"total instructions {total}")
    for f, v in per_function.most_common(top):
        print(f"{v:>12} {100 * v / total:5.1f}% {f}")


if __name__ == '__main__':
    main()
