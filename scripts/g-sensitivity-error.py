#!/usr/bin/env python3
"""The gyro_g_sensitivity estimate of a calibrate summary.json against a known G.

    scripts/g-sensitivity-error.py SUMMARY_JSON "G00, G01, ..., G22"   (°/h/g, row-major)

Prints the estimate and σ in °/h/g, each entry's (estimate − G)/σ and the largest
|error|/σ (docs/diagnosis.md "Session 12")."""
import json
import math
import sys

K = math.pi / 180 / 3600 / 9.80665
e = next(x for x in json.load(open(sys.argv[1]))["effects"] if x["name"] == "gyro_g_sensitivity")
truth = [float(x) for x in sys.argv[2].split(",")]
est = [x / K for x in e["estimate"]]
sig = [x / K for x in e["sigma"]]
z = [(x - t) / s for x, s, t in zip(est, sig, truth)]
fmt = lambda v: "[" + ", ".join(f"{x:.1f}" for x in v) + "]"
print(f"G {fmt(est)} ± {fmt(sig)} °/h/g; error/σ {fmt(z)}; max {max(map(abs, z)):.1f}; Wald {e['wald']:.1f}")
