#!/usr/bin/env python3
"""Instructions per function of the firmware image, from QEMU's execution log.

Usage (docs/performance.md):
    # a wrapper earlier in PATH adds the log to every qemu-system-arm run
    mkdir -p /tmp/qemu-wrap && printf '#!/bin/sh\\nexec /usr/bin/qemu-system-arm -d in_asm,exec,nochain -D /tmp/qemu-exec.log "$@"\\n' \
        > /tmp/qemu-wrap/qemu-system-arm && chmod +x /tmp/qemu-wrap/qemu-system-arm
    flexcal simulate --scenario moored --duration 1 --out m1
    PATH=/tmp/qemu-wrap:$PATH flexcal replay m1 --qemu --transport semihosting --out r-m1
    llvm-objdump -d --demangle --no-show-raw-insn target/thumbv7em-none-eabihf/firmware/flexcal-firmware > dis.txt
    firmware/exec-profile.py dis.txt /tmp/qemu-exec.log [N]
    # inside the functions whose name contains FUNC: instructions per source line
    firmware/exec-profile.py dis.txt /tmp/qemu-exec.log [N] --lines ELF FUNC
    # their disassembly, each instruction with the times it ran
    firmware/exec-profile.py dis.txt /tmp/qemu-exec.log --annotate FUNC

Each executed translation block (its start address in the log's `exec` records) is charged
its instructions. With `in_asm` in the log, QEMU prints each block's instructions when it
translates it, and the count is exact. Without it, a block is taken to run from its address
to the next branch in the disassembly; QEMU also ends blocks elsewhere (around IT blocks,
for one), so that count runs high in such loops. Prints the N (default 30) functions with
the most instructions; divide by the replay's master updates for a per-update figure.

`--lines ELF FUNC`: the instructions executed inside functions whose name contains FUNC,
per source line (`llvm-addr2line -i` on ELF: the innermost inlined frame in this
workspace's `core/src` or `firmware/src`), the N largest.

`--annotate FUNC`: the disassembly of the functions whose name contains FUNC, each
instruction preceded by the times it ran (a loop's body by its count; sum a range of
addresses for a loop's or a set-up's share).
"""
import bisect
import collections
import re
import subprocess
import sys


def read_disassembly(path):
    ins, func = [], None
    for line in open(path):
        m = re.match(r'^([0-9a-f]{8}) <(.*)>:$', line)
        if m:
            if not m.group(2).startswith('$'):  # mapping symbols ($t, $d) are not functions
                func = m.group(2)
            continue
        m = re.match(r'^\s*([0-9a-f]+):\s+(\S+)(.*)$', line)
        if m and func:
            ins.append((int(m.group(1), 16), m.group(2), m.group(3), func))
    return ins


def ends_block(mn, ops):
    if mn.startswith('b') and not mn.startswith(('bic', 'bfi', 'bfc')):
        return True
    if mn in ('cbz', 'cbnz', 'tbb', 'tbh', 'svc', 'bkpt', 'wfi'):
        return True
    return mn.startswith(('pop', 'ldm')) and 'pc' in ops or (
        mn.startswith('ldr') and ops.strip().startswith('pc'))


def read_log_in_order(path):
    """The block starts in the order QEMU executed them, and the blocks' instruction
    addresses where `in_asm` printed them."""
    order, blocks, current = [], {}, None
    for line in open(path):
        if line.startswith('IN:'):
            current = []
            continue
        m = re.match(r'^0x([0-9a-f]{8}):\s', line)
        if m and current is not None:
            current.append(int(m.group(1), 16))
            continue
        if current:
            blocks[current[0]] = current
        current = None
        m = re.search(r'\[[0-9a-f]+/([0-9a-f]+)/', line)
        if m:
            order.append(int(m.group(1), 16))
    if current:
        blocks[current[0]] = current
    return order, blocks


def read_log(path):
    """Executions per block start, and the blocks' instruction addresses where `in_asm`
    printed them."""
    order, blocks = read_log_in_order(path)
    return collections.Counter(order), blocks


def main():
    args = sys.argv[1:]
    lines, annotate = None, None
    if '--annotate' in args:
        i = args.index('--annotate')
        annotate = args[i + 1]
        del args[i:i + 2]
    if '--lines' in args:
        i = args.index('--lines')
        lines = (args[i + 1], args[i + 2])
        del args[i:i + 3]
    dis, log = args[0], args[1]
    top = int(args[2]) if len(args) > 2 else 30
    ins = read_disassembly(dis)
    index = {a: i for i, (a, _, _, _) in enumerate(ins)}
    starts = sorted({a for a, _, _, f in ins if index.get(a) is not None})
    func_at = {a: f for a, _, _, f in ins}
    runs, blocks = read_log(log)

    def block(pc):
        """The block's instruction addresses: from `in_asm` if logged, else walked."""
        if pc in blocks:
            return blocks[pc]
        i, out = index.get(pc), []
        while i is not None and i < len(ins):
            out.append(ins[i][0])
            if ends_block(ins[i][1], ins[i][2]) or len(out) >= 512:
                break
            i += 1
        return out or [pc]

    per_addr = collections.Counter()
    for pc, count in runs.items():
        for a in block(pc):
            per_addr[a] += count

    def function(a):
        if a in func_at:
            return func_at[a]
        i = bisect.bisect_right(starts, a) - 1
        return func_at[starts[i]] if i >= 0 else '?'

    per_function = collections.Counter()
    for a, v in per_addr.items():
        per_function[function(a)] += v
    total = sum(per_function.values())
    exact = 'exact (in_asm)' if blocks else 'blocks walked to the next branch'
    print(f"total instructions {total} ({exact})")
    if annotate is not None:
        for a, mn, ops, f in ins:
            if annotate in f:
                print(f"{per_addr[a]:>10} {a:08x} {mn}{ops}")
        return
    if lines is None:
        for f, v in per_function.most_common(top):
            print(f"{v:>12} {100 * v / total:5.1f}% {f}")
        return
    elf, wanted = lines
    addrs = sorted(a for a in per_addr if wanted in function(a))
    out = subprocess.run(['llvm-addr2line', '-a', '-i', '-e', elf] + [hex(a) for a in addrs],
                         capture_output=True, text=True, check=True).stdout
    frames, current = {}, None
    for line in out.splitlines():
        if line.startswith('0x'):
            current = int(line, 16)
            frames[current] = []
        elif current is not None:
            frames[current].append(line)
    per_line = collections.Counter()
    for a in addrs:
        ours = [f for f in frames.get(a, [])
                if ('/core/src/' in f or '/firmware/src/' in f) and '/rustc/' not in f]
        key = ours[0].split('/src/', 1)[1] if ours else '?'
        per_line[key] += per_addr[a]
    inside = sum(per_addr[a] for a in addrs)
    print(f"in functions matching {wanted!r}: {inside}")
    for k, v in per_line.most_common(top):
        print(f"{v:>12} {100 * v / inside:5.1f}% {k}")


if __name__ == '__main__':
    main()
