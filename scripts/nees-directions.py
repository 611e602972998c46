#!/usr/bin/env python3
"""Where a set of runs' NEES comes from: each run's NEES of the nine calibrated states
split over the eigen-directions of its correlation matrix (each direction contributes
(uᵀz)²/λ, z the errors over their σ; χ²(1) on average if the filter is consistent),
the directions named by their two largest components ('bay-mux': the accelerometer's y
bias against the misalignment about x, the tilt it mimics; 'gyro': gyro biases only).
Prints the mean NEES and the mean contribution of the largest groups, and with
--per-run each run's NEES and tilt share (the two bias-tilt directions).

    python3 scripts/nees-directions.py [--per-run] RUN_DIR/summary.json ...

Reads summary.json's `errors` (present when the recording has truth.csv) and
`calibrated_covariance`. Needs numpy (`pip install numpy` or Debian's python3-numpy).
"""
import collections
import json
import sys

import numpy as np

NAMES = ['bgx', 'bgy', 'bgz', 'bax', 'bay', 'baz', 'mux', 'muy', 'muz']
TILT = ({'bay', 'mux'}, {'bax', 'muy'})


def directions(path):
    d = json.load(open(path))
    e = np.array(d['errors']['gyro_bias'] + d['errors']['accel_bias'] + d['errors']['misalignment'])
    p = np.array(d['calibrated_covariance']['matrix'])
    sig = np.sqrt(np.diag(p))
    w, v = np.linalg.eigh(p / np.outer(sig, sig))
    contrib = (v.T @ (e / sig)) ** 2 / w
    for i in range(9):
        top = [NAMES[k] for k in np.argsort(-abs(v[:, i]))[:2]]
        if all(t.startswith('bg') for t in top):
            key = 'gyro'
        elif abs(v[:, i]).max() >= 0.9:
            key = NAMES[int(np.argmax(abs(v[:, i])))]
        else:
            key = '-'.join(sorted(top))
        yield key, set(top), contrib[i]


def main(argv):
    per_run = '--per-run' in argv
    paths = [a for a in argv if a != '--per-run']
    groups = collections.Counter()
    totals = []
    for path in paths:
        parts = list(directions(path))
        total = sum(c for _, _, c in parts)
        tilt = sum(c for _, top, c in parts if top in TILT)
        totals.append(total)
        for key, _, c in parts:
            groups[key] += c
        if per_run:
            print(f'{path}: NEES {total:.2f}, bias-tilt directions {tilt:.2f}')
    n = len(totals)
    if n == 0:
        sys.exit('no summary.json given')
    top = ', '.join(f'{k} {v / n:.2f}' for k, v in groups.most_common(6))
    print(f'runs {n}: mean NEES {np.mean(totals):.2f}; mean per direction: {top}')


if __name__ == '__main__':
    main(sys.argv[1:])
