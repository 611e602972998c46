#!/usr/bin/env python3
"""The engine's covariance replayed from a dump of its Φ, Q, h and r (docs/diagnosis.md,
"Session 14"): which element of the filter's model gives a state its information.

The dump comes from a scratch build (never merged) that writes every input of the filter:

    git apply scripts/filter-dump.patch      # on a clean tree; `git apply -R` after
    cargo build --release -p flexcal-sim
    target/release/flexcal calibrate REC --effects time_delay --out OUT 2> DUMP

This replays P (not the estimate: σ is a property of the model alone) in f64 and prints
the σ of one state, optionally with pieces of the model swapped, one option each:

    python3 scripts/filter-replay.py DUMP                       # the engine's σ
    python3 scripts/filter-replay.py DUMP --keep 5,8,11,17,20,21 --rows 2,5
    python3 scripts/filter-replay.py DUMP --keep ... --rows 2,5 --rate-column-from-attitude 1

Rows are numbered within each time step in the order the engine makes them (attitude
x, y, z, then rate x, y, z when those two channels are matched).
"""
import argparse
import importlib.util
import pathlib

import numpy as np


def mode_block(w, z, s, dt):
    """Φ and Q of a second-order mode (ω, ζ, σ) over dt, by Van Loan."""
    here = pathlib.Path(__file__).with_name("delay-1d-reference.py")
    spec = importlib.util.spec_from_file_location("reference", here)
    ref = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ref)
    f = np.array([[0.0, 1.0], [-w * w, -2 * z * w]])
    m = np.zeros((4, 4))
    m[:2, :2] = -f
    m[1, 3] = 4 * z * w**3 * s**2
    m[2:, 2:] = f.T
    e = ref.expm(m * dt)
    phi = e[2:, 2:].T
    return phi, phi @ e[:2, 2:]


def column_series(path, row, state):
    """Row `row`'s coefficient on `state` at each time step."""
    out, k = [], 0
    for line in open(path):
        if line.startswith("PH"):
            k = 0
        elif line.startswith("UP"):
            if k == row:
                out.append(float(line.split()[5 + state]))
            k += 1
    return np.array(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dump")
    ap.add_argument("--state", type=int, default=21, help="the state whose σ is printed (the delay: 21)")
    ap.add_argument("--period", type=float, default=0.05, help="filter period (s)")
    ap.add_argument("--keep", default="", help="states kept (comma list); the others are dropped")
    ap.add_argument("--rows", default="", help="rows used within each step (comma list); default all")
    ap.add_argument("--rate-noise", type=float, help="every rate row's r replaced (rad²/s²)")
    ap.add_argument("--mode", help="ω,ζ,σ: the yaw flexure block's Φ and Q replaced by Van Loan's")
    ap.add_argument("--p0-diagonal", action="store_true", help="P₀'s correlations dropped")
    ap.add_argument("--rate-column-from-attitude", type=float, metavar="GAIN",
                    help="the z rate row's column on STATE := GAIN × d/dt of the z attitude row's")
    ap.add_argument("--shift", type=float, default=0.0, help="s: that column read at t + shift")
    ap.add_argument("--zero-until", type=float, default=0.0, help="s: that column zero before")
    ap.add_argument("--rate-rows-from", type=float, default=0.0, help="s: rate rows skipped before")
    ap.add_argument("--every", type=float, default=60.0, help="s between printed σ")
    a = ap.parse_args()
    keep = [int(x) for x in a.keep.split(",") if x]
    rows = {int(x) for x in a.rows.split(",") if x}
    column = None
    if a.rate_column_from_attitude is not None:
        att = column_series(a.dump, 2, a.state)
        t = np.arange(len(att)) * a.period
        column = a.rate_column_from_attitude * np.gradient(att, a.period)
        column = np.interp(t + a.shift, t, column)
        column[t < a.zero_until] = 0.0
    mode = mode_block(*map(float, a.mode.split(",")), a.period) if a.mode else None
    p = q = phi = mask = None
    step, k = 0, 0
    for line in open(a.dump):
        tag = line[:2]
        if tag not in ("R0", "PH", "QD", "QP", "UP", "FR", "DK", "R1"):
            continue
        v = np.array(line.split()[1:], dtype=float)
        if tag == "R0":
            n = int(v[1])
            floor = v[2]
            p = v[3 + n:].reshape(n, n)
            if a.p0_diagonal:
                p = np.diag(np.diag(p))
            mask = np.zeros(n, bool) if keep else np.ones(n, bool)
            mask[keep] = True
            p = p * np.outer(mask, mask)
        elif tag == "DK":
            i, d = int(v[1]), v[2]
            p[i, :] *= d
            p[:, i] *= d
        elif tag == "R1":
            c = np.zeros(n)
            for i, ci in v[2:].reshape(-1, 2):
                c[int(i)] += ci
            p = p + v[1] * np.outer(c, c)
        elif tag == "FR":
            for i in range(int(v[1]), int(v[2])):
                p[i, :] = p[:, i] = 0.0
                p[i, i] = v[3]
        elif tag == "PH":
            phi = np.eye(n)
            for i, j, x in v[1:].reshape(-1, 3):
                phi[int(i), int(j)] = x
        elif tag == "QD":
            q = np.diag(v[1:])
        elif tag == "QP":
            for i, j, x in v[1:].reshape(-1, 3):
                q[int(i), int(j)] = q[int(j), int(i)] = x
            if mode is not None:
                b = [17, 20]
                phi[np.ix_(b, b)], q[np.ix_(b, b)] = mode
            mm = np.outer(mask, mask)
            phi = phi * mm + np.diag(~mask)
            p = phi @ p @ phi.T + q * mm
            step += 1
            k = 0
            if step % max(1, round(a.every / a.period)) == 0:
                print(f"{step * a.period:7.1f} s: σ {np.sqrt(p[a.state, a.state]):.4e}")
        elif tag == "UP":
            r, h = v[2], v[4:] * mask
            row = k
            k += 1
            t = (step - 1) * a.period
            rate = row >= 3
            if (rows and row not in rows) or (rate and t < a.rate_rows_from):
                continue
            if rate and a.rate_noise is not None:
                r = a.rate_noise
            if column is not None and row == 5:
                h[a.state] = column[max(step - 1, 0)]
            ph = p @ h
            p = p - np.outer(ph, ph) / (h @ ph + r)
            p = 0.5 * (p + p.T)
    print(f"final: σ of state {a.state} {np.sqrt(p[a.state, a.state]):.4e}")


if __name__ == "__main__":
    main()
