#!/usr/bin/env python3
"""Checks the mean of the velocity error rate's second-order terms against the nonlinear
mechanization (docs/model-learning.md, "Session 12").

The slave's velocity error rate is C (Exp(psi) (f + nabla) - f) in the filter's convention
(psi: attitude error, C_hat = C Exp(psi); nabla = b - b_hat). Its first-order part is
C (psi x f + nabla); the mean of the rest is, for zero-mean (psi, nabla) of covariance P,
    E[[psi x] nabla]_i = eps_ijk P(psi_j, nabla_k),  E[1/2 [psi x]^2 f] = 1/2 (P_pp - tr P_pp I) f.
Draws (psi, nabla) on the tilt-bias manifold a calm sea leaves (psi x f + nabla = 0
horizontally, horizontal biases of 1 mg), averages the exact second-order remainder and
prints it beside the formula and beside 1/2 |nabla_h|^2 / g.

    python3 scripts/second-order-mean-check.py
"""
import numpy as np


def exp_so3(p):
    t = np.linalg.norm(p)
    k = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    return np.eye(3) + np.sin(t) / t * k + (1 - np.cos(t)) / t**2 * k @ k


rng = np.random.default_rng(1)
g = 9.8
f = np.array([0.0, 0.0, g])
n = 50000
b = rng.normal(0, 0.01, (n, 3))
psi = np.stack([b[:, 1] / g, -b[:, 0] / g, rng.normal(0, 1e-3, n)], 1) + rng.normal(0, 1e-5, (n, 3))
rest = np.array([exp_so3(p) @ (f + bb) - f - (np.cross(p, f) + bb) for p, bb in zip(psi, b)])
x = np.hstack([psi, b])
p = x.T @ x / n
pp, pb = p[:3, :3], p[:3, 3:]
cross = np.array([pb[1, 2] - pb[2, 1], pb[2, 0] - pb[0, 2], pb[0, 1] - pb[1, 0]])
formula = cross + 0.5 * (pp @ f - f * np.trace(pp))
print("Monte Carlo mean of the remainder (m/s^2):", rest.mean(0))
print("formula from P                    (m/s^2):", formula)
print("1/2 |nabla_h|^2 / g, mean         (m/s^2):", 0.5 * (b[:, 0] ** 2 + b[:, 1] ** 2).mean() / g)
