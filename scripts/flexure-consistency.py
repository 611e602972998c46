#!/usr/bin/env python3
"""Is a run's flexure estimate as good as its σ says? For each calibrate output beside
its recording (the recording's truth.csv holds the flexure θ), the mean over the run
after its first 30 s of ((θ̂ − θ)/σ)² per axis (about 1 if consistent; serially
correlated, so a few tenths either way on one run).

    python3 scripts/flexure-consistency.py CALIBRATE_OUT:RECORDING_DIR ...

e.g. after `scripts/truth-floor-check.sh OUT 600 3 4`:
    python3 scripts/flexure-consistency.py OUT/c3-truth:OUT/t3 OUT/c4-truth:OUT/t4

Needs numpy (`pip install numpy` or Debian's python3-numpy).
"""
import sys

import numpy as np


def main(pairs):
    if not pairs:
        sys.exit(__doc__)
    for pair in pairs:
        out, rec = pair.split(':')
        est = np.genfromtxt(f'{out}/estimates.csv', delimiter=',', names=True)
        tru = np.genfromtxt(f'{rec}/truth.csv', delimiter=',', names=True)
        after = est['t'] > 30.0
        z2 = []
        for k in ('thx', 'thy', 'thz'):
            theta = np.interp(est['t'], tru['t'], tru[k])
            z = (est[k] - theta) / est[k + '_sigma']
            z2.append(float(np.mean(z[after] ** 2)))
        print(f'{out}: mean ((θ̂ − θ)/σ)² x, y, z: ' + ', '.join(f'{v:.2f}' for v in z2))


if __name__ == '__main__':
    main(sys.argv[1:])
