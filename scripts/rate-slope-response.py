#!/usr/bin/env python3
"""How well a least-squares polynomial through a master's past rates gives the angular
acceleration at the message (docs/diagnosis.md "Session 14"; `master_rate_slope` in
core/src/engine.rs): for a sinusoidal rate of frequency W, the slope's gain error and its
time shift, and the white noise gain of its weights (per unit rate noise).

    python3 scripts/rate-slope-response.py                  # the old and new choices
    python3 scripts/rate-slope-response.py --degree 4 --window 0.5 --period 0.1

The rates are at t − k·period (k = 1 … m, m the rates within the window, the newest one
period before the message, as the engine keeps them: the current message's rate is not
in its own column).
"""
import argparse

import numpy as np


def slope_weights(degree, window, period):
    """Weights on the rates at t − k·period giving the fit's derivative at t."""
    m = int(np.floor(window / period + 1e-9)) + 1
    k = np.arange(1, m + 1)
    u = -k * period
    basis = np.vander(u / window, degree + 1, increasing=True)
    return np.linalg.pinv(basis)[1] / window, u


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--degree", type=int)
    ap.add_argument("--window", type=float, help="s")
    ap.add_argument("--period", type=float, help="master period (s)")
    ap.add_argument("--omegas", default="0.5,1.14,1.57,2.1,4.0", help="rad/s")
    a = ap.parse_args()
    cases = [(a.degree, a.window, a.period)] if a.degree else [
        (d, w, p) for p in (0.01, 0.05, 0.1) for d, w in ((2, 0.645), (4, 0.5))]
    omegas = [float(x) for x in a.omegas.split(",")]
    print("degree window period noise/s  " + "  ".join(f"{w:>17} rad/s" for w in omegas))
    for degree, window, period in cases:
        w, u = slope_weights(degree, window, period)
        cells = []
        for om in omegas:
            h = np.sum(w * np.exp(1j * om * u)) / (1j * om)
            cells.append(f"{abs(h) - 1:+8.4%} {np.angle(h) / om * 1e3:+7.2f} ms")
        print(f"{degree:6d} {window:6.3f} {period:6.3f} {np.sqrt(np.sum(w**2)):7.0f}  " + "  ".join(cells))


if __name__ == "__main__":
    main()
