#!/usr/bin/env python3
"""Two calibrations of one recording side by side (issue 9, acceptance 4).

Reads the summary.json of two `flexcal calibrate` runs (A, then B) and prints, per
estimate, A ± σ, B ± σ and their difference over the larger of the two σ, in the
printed summary's units (°/h, mg, °). Exits 0; the verdict is the reader's.

    python3 scripts/estimate-agreement.py out/psins-learned/summary.json out/psins/summary.json
"""
import json
import math
import sys

G = 9.80665  # m/s² per g, the recording format's
BLOCKS = [
    ("gyro bias (°/h)", "gyro_bias", lambda x: math.degrees(x) * 3600.0),
    ("accelerometer bias (mg)", "accel_bias", lambda x: x / G * 1000.0),
    ("misalignment (°)", "misalignment", math.degrees),
]


def main(path_a, path_b):
    a = json.load(open(path_a))
    b = json.load(open(path_b))
    print(f"A: {path_a}\nB: {path_b}")
    print("| | A | B | (A − B) / larger σ |\n|---|---|---|---|")
    worst = 0.0
    for name, key, unit in BLOCKS:
        cells_a, cells_b, ratios = [], [], []
        for k in range(3):
            va, sa = unit(a[key][k]), unit(a[key + "_sigma"][k])
            vb, sb = unit(b[key][k]), unit(b[key + "_sigma"][k])
            r = (va - vb) / max(sa, sb)
            worst = max(worst, abs(r))
            cells_a.append(f"{va:.4g} ± {sa:.2g}")
            cells_b.append(f"{vb:.4g} ± {sb:.2g}")
            ratios.append(f"{r:+.2f}")
        print(f"| {name} x, y, z | {', '.join(cells_a)} | {', '.join(cells_b)} | {', '.join(ratios)} |")
    print(f"largest |difference| / larger σ: {worst:.2f}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: estimate-agreement.py A/summary.json B/summary.json")
    main(sys.argv[1], sys.argv[2])
