#!/usr/bin/env python3
"""What the delay's σ and estimate should be when a flexure mode can mimic it: a 1-D
reference Kalman filter written apart from the engine (docs/diagnosis.md "Session 13").

One axis (yaw): the ship turns as amp·sin(Ω t); the slave's flexure about that axis is a
second-order Gauss-Markov mode (ω, ζ, σ), simulated on a fine grid; a noiseless master
delayed by τ. Measurements every T: attitude `μ + θ − ∫b + [yaw(t) − yaw(t − τ)]` and
rate `θ̇ + b + [ω(t) − ω(t − τ)]`. The filter carries [θ, θ̇, μ, b, τ, ψ] with the mode
sampled exactly (Van Loan), attitude noise 2 µrad (the engine's floor), rate noise
`--rate-noise`, and the delay's columns ω(t) and `gain`·ω̇(t + shift): exact by default.

    python3 scripts/delay-1d-reference.py                       # exact columns
    python3 scripts/delay-1d-reference.py --rate-column-gain 1.05
    python3 scripts/delay-1d-reference.py --rate-column-shift -0.05 --channels attitude

Prints, per seed and true delay (0 and 5 ms), the estimate and its σ.
"""
import argparse

import numpy as np


def expm(m):
    """e^M by scaling and squaring a Taylor series (M small after scaling)."""
    norm = np.abs(m).sum(axis=1).max()
    n = int(np.ceil(np.log2(norm / 0.1))) if norm > 0.1 else 0
    x = m / 2**n
    e = np.eye(len(m))
    term = np.eye(len(m))
    for k in range(1, 20):
        term = term @ x / k
        e = e + term
    for _ in range(n):
        e = e @ e
    return e


def run(seed, tau_true, a):
    rng = np.random.default_rng(seed)
    t_f, w, z, sig = a.period, a.omega, a.damping, a.sigma
    h = t_f / a.substeps
    f = np.array([[0.0, 1.0], [-w * w, -2.0 * z * w]])
    q = 4.0 * z * w**3 * sig**2
    ph = expm(f * h)
    lh = np.linalg.cholesky(np.array([[h**3 / 3, h * h / 2], [h * h / 2, h]]) * q)
    n = int(a.duration / t_f)
    x = np.array([rng.normal() * sig, rng.normal() * sig * w])
    th, thd = np.zeros(n + 1), np.zeros(n + 1)
    th[0], thd[0] = x
    for k in range(n):
        for _ in range(a.substeps):
            x = ph @ x + lh @ rng.normal(size=2)
        th[k + 1], thd[k + 1] = x
    t = np.arange(n + 1) * t_f
    om_s = 2 * np.pi / a.ship_period
    amp = np.radians(a.ship_amp_deg)
    yaw = lambda s: amp * np.sin(om_s * s)
    om = lambda s: amp * om_s * np.cos(om_s * s)
    omd = lambda s: -amp * om_s**2 * np.sin(om_s * s)
    mu, b = 0.0195, 1e-6
    za = mu - b * t + th + (yaw(t) - yaw(t - tau_true))
    zr = thd + b + (om(t) - om(t - tau_true)) + rng.normal(size=n + 1) * a.rate_noise
    # Van Loan: Φ and Q of the mode over one filter period.
    m = np.zeros((4, 4))
    m[:2, :2] = -f
    m[1, 3] = q
    m[2:, 2:] = f.T
    e = expm(m * t_f)
    phi_t = e[2:, 2:].T
    q_t = phi_t @ e[:2, 2:]
    big_f = np.eye(6)
    big_f[:2, :2] = phi_t
    big_f[5, 3] = -t_f
    big_q = np.zeros((6, 6))
    big_q[:2, :2] = q_t
    big_q[5, 5] = (2.14e-7) ** 2 * t_f
    p = np.diag([sig**2, (sig * w) ** 2, 0.017**2, (5e-6) ** 2, 0.1**2, 0.01**2])
    xh = np.zeros(6)
    for k in range(n + 1):
        if k > 0:
            xh = big_f @ xh
            p = big_f @ p @ big_f.T + big_q
        rows = []
        if "attitude" in a.channels:
            rows.append((za[k], np.array([1, 0, 1, 0, om(t[k]), 1.0]), 2e-6**2))
        if "rate" in a.channels:
            col = a.rate_column_gain * omd(t[k] + a.rate_column_shift)
            rows.append((zr[k], np.array([0, 1, 0, 1, col, 0.0]), a.rate_noise**2))
        for zz, hh, r in rows:
            s = hh @ p @ hh + r
            kk = p @ hh / s
            xh = xh + kk * (zz - hh @ xh)
            p = p - np.outer(kk, hh @ p)
    return xh[4], np.sqrt(p[4, 4])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=300.0)
    ap.add_argument("--period", type=float, default=0.05, help="filter and master period (s)")
    ap.add_argument("--substeps", type=int, default=400)
    ap.add_argument("--omega", type=float, default=1.44)
    ap.add_argument("--damping", type=float, default=0.2)
    ap.add_argument("--sigma", type=float, default=3.85e-4, help="flexure σ (rad)")
    ap.add_argument("--ship-period", type=float, default=5.51)
    ap.add_argument("--ship-amp-deg", type=float, default=3.49)
    ap.add_argument("--rate-noise", type=float, default=3e-6, help="rad/s per sample")
    ap.add_argument("--rate-column-gain", type=float, default=1.0)
    ap.add_argument("--rate-column-shift", type=float, default=0.0, help="s")
    ap.add_argument("--channels", default="attitude,rate")
    a = ap.parse_args()
    for tau in (0.0, 0.005):
        for seed in range(1, a.seeds + 1):
            est, sd = run(seed, tau, a)
            print(f"tau {tau * 1e3:.0f} ms  seed {seed}: {est * 1e3:.3f} ± {sd * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
