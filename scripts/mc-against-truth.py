#!/usr/bin/env python3
"""RMS of error/σ per calibrated state: a blind Monte Carlo's learned model (and, given a
second montecarlo.json, another learner's) against the same draws handed their truth
(scripts/truth-floor-check.sh), per state, per master kind, and the runs with the largest
|error|/σ of one state (default bay).

    python3 scripts/mc-against-truth.py MC/montecarlo.json TRUTH_DIR [OTHER_MC/montecarlo.json] [--state bay]

MC: `flexcal montecarlo --blind --runs 50 --duration 600 --out MC` (seeds 1-50).
TRUTH_DIR: `scripts/truth-floor-check.sh TRUTH_DIR 600 $(seq 1 50)` (reads
TRUTH_DIR/c<seed>-truth/summary.json and c<seed>-truth-f32/summary.json).
"""
import json
import math
import os
import sys

NAMES = ['bgx', 'bgy', 'bgz', 'bax', 'bay', 'baz', 'mux', 'muy', 'muz']


def rms(v):
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else float('nan')


def learned_z(mc):
    out = {}
    for i, r in enumerate(mc['per_run']):
        vrw = next(p for p in r['parameters'] if p['param'] == 'accel_vrw')
        out[mc['first_seed'] + i] = (
            r['master'],
            vrw['truth'],
            vrw['learned'],
            [e / s for e, s in zip(r['learned']['error'], r['learned']['sigma'])],
        )
    return out


def truth_z(root, seed, floors):
    p = f'{root}/c{seed}-{floors}/summary.json'
    if not os.path.exists(p):
        return None
    d = json.load(open(p))
    e = d['errors']
    return [e[k][a] / d[k + '_sigma'][a] for k in ('gyro_bias', 'accel_bias', 'misalignment') for a in range(3)]


def main(argv):
    state = 'bay'
    if '--state' in argv:
        i = argv.index('--state')
        state = argv[i + 1]
        del argv[i:i + 2]
    a = learned_z(json.load(open(argv[0])))
    root = argv[1]
    b = learned_z(json.load(open(argv[2]))) if len(argv) > 2 else None
    seeds = [s for s in a if truth_z(root, s, 'truth') and truth_z(root, s, 'truth-f32')]
    t = {s: truth_z(root, s, 'truth') for s in seeds}
    t32 = {s: truth_z(root, s, 'truth-f32') for s in seeds}
    print(f'{len(seeds)} runs; RMS of error/sigma: learned' + (' / other' if b else '') + ' / truth (floors as written) / truth (f32 floors)')
    for j, n in enumerate(NAMES):
        other = f' / {rms([b[s][3][j] for s in seeds]):.2f}' if b else ''
        print(f'  {n}: {rms([a[s][3][j] for s in seeds]):.2f}{other} / {rms([t[s][j] for s in seeds]):.2f} / {rms([t32[s][j] for s in seeds]):.2f}')
    j = NAMES.index(state)
    for kind in ('white', 'none', 'smooth'):
        g = [s for s in seeds if a[s][0] == kind]
        other = f' / {rms([b[s][3][j] for s in g]):.2f}' if b else ''
        print(f'  {state}, {kind} masters ({len(g)}): {rms([a[s][3][j] for s in g]):.2f}{other} / {rms([t[s][j] for s in g]):.2f} / {rms([t32[s][j] for s in g]):.2f}')
    print(f'largest |{state} error/sigma| learned:')
    for s in sorted(seeds, key=lambda s: -abs(a[s][3][j]))[:12]:
        other = f' other {b[s][3][j]:+.2f} (VRW {b[s][2]:.2e})' if b else ''
        print(f'  seed {s:2d} {a[s][0]:6s} VRW drawn {a[s][1]:.2e} learned {a[s][2]:.2e}: {a[s][3][j]:+.2f}{other} truth {t[s][j]:+.2f} f32 {t32[s][j]:+.2f}')


if __name__ == '__main__':
    main(sys.argv[1:])
