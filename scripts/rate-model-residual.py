#!/usr/bin/env python3
"""The engine's angular-rate matching model checked against a simulated recording with the truth's
states: per master message, the slave rate (the two IMU increments around the message, centred)
against (1) the full model ω_s = (I + diag(s)) (Exp(μ+θ)ᵀ ω_m + J_r(μ+θ) θ̇) + b_g and (2) the
engine's linear rows (core/src/model.rs `rate_rows`, the scale factor's column diag(ω_s));
prints each residual's RMS and its regression on the slave rate per axis (a scale the model
misses). Needs numpy. docs/diagnosis.md "Session 18" uses it.

    python3 scripts/rate-model-residual.py OUT/seed1   # a recording with truth.csv
"""
import sys

import numpy as np

from recording_truth import axes, column, exp_so3, load, right_jacobian, skew

d = sys.argv[1]
hm, m = load(d + '/master.csv'); hi, imu = load(d + '/slave_imu.csv'); ht, tr = load(d + '/truth.csv')
col = column
tm = col(hm, m, 't'); wm = np.stack([col(hm, m, k) for k in ('wx', 'wy', 'wz')], 1)
ti = imu[:, 0]; dth = imu[:, 1:4]
tt = col(ht, tr, 't')
T = lambda n: axes(ht, tr, n)
bg, mu, th, thd = T('bg'), T('mu'), T('th'), T('thd')
sg = T('sg')
expm = exp_so3
jr = right_jacobian
h = ti[2] - ti[1]
idx = {round(t / h): k for k, t in enumerate(ti)}
rows = []
for j in range(len(tm)):
    k = idx.get(round(tm[j] / h))
    if k is None or k < 2 or k + 1 >= len(ti): continue
    ws = (dth[k] + dth[k + 1]) / (2 * h)
    jt = np.searchsorted(tt, tm[j]); 
    if jt >= len(tt) or abs(tt[jt] - tm[j]) > 1e-9: continue
    phi = mu[jt] + th[jt]
    true_rate = expm(phi).T @ wm[j] + jr(phi) @ thd[jt]
    model_full = (np.eye(3) + np.diag(sg[jt])) @ true_rate + bg[jt]
    z = ws - bg[jt] - expm(mu[jt]).T @ wm[j]
    wmb = expm(mu[jt]).T @ wm[j]
    lin = np.diag(sg[jt]) @ ws + skew(wmb) @ jr(mu[jt]) @ th[jt] + jr(mu[jt]) @ thd[jt]
    rows.append(np.concatenate([ws - model_full, z - lin, ws]))
R = np.array(rows)
full, lin, ws = R[:, 0:3], R[:, 3:6], R[:, 6:9]
print('samples', len(R))
print('RMS full-model residual', full.std(0))
print('RMS linear-model residual', lin.std(0))
for a in range(3):
    for name, r in (('full', full), ('lin', lin)):
        c = np.dot(r[:, a], ws[:, a]) / np.dot(ws[:, a], ws[:, a])
        print(f'axis {a} {name}: residual regressed on w_s -> scale {c*1e6:9.1f} ppm')
