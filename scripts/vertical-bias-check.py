#!/usr/bin/env python3
"""The nav-vertical accelerometer bias error of a calibrated draw against the second-order
term 1/2 |nabla_h|^2 / g its horizontal bias errors predict (docs/model-learning.md,
"Session 12"). The slave's body up row is taken from the drawn mounting on a level ship,
row 3 of Exp(mu); the horizontal errors are the other two components of the error in the
nav frame.

    python3 scripts/vertical-bias-check.py RUN_DIR/summary.json DRAWN.toml
"""
import json
import sys
import tomllib

import numpy as np


def exp_so3(p):
    t = np.linalg.norm(p)
    k = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    return np.eye(3) + np.sin(t) / t * k + (1 - np.cos(t)) / t**2 * k @ k


summary, drawn = sys.argv[1], sys.argv[2]
d = json.load(open(summary))
mu = np.radians(tomllib.load(open(drawn, 'rb'))['misalignment_deg'])
c = exp_so3(mu)
e_n = c @ np.array(d['errors']['accel_bias'])
g = 9.80665
print(f"vertical bias error {e_n[2]:.3e} m/s^2, 1/2 |horizontal|^2 / g {0.5 * (e_n[0]**2 + e_n[1]**2) / g:.3e} m/s^2, NEES {d['errors']['nees_mean']:.1f}")
