#!/usr/bin/env python3
"""A linear Kalman filter of the rate matching alone, apart from the engine: on a recording
with truth.csv (the one scripts/truth-seeds-effect.sh simulates), states gyro bias, mounting,
flexure angle and rate (the exact sampled second-order mode per axis, from calibrate.toml's
flexure_gauss_markov) and the gyro scale factor; the rows are the engine's
(core/src/model.rs `rate_rows`), linearized once at the truth's mounting, no feedback, no
EKF. Prints the scale factor and its sigma every 30 s. The scale factor's column:

    (default)  diag of the slave's measured rate (what the engine used before session 18)
    wtrue      diag of the master's rate carried by the mounting, Exp(mu)^T w_m
    wpred      diag of the rate the filter predicts, Exp(mu)^T w_m + J thd^ + [w x] J th^
    scale=F    the filter's flexure sigma times F;  nodiff: no rate-diffusion noise

Needs numpy. docs/diagnosis.md "Session 18 (sf-flexure)" uses it.

    python3 scripts/rate-only-linear-kf.py OUT/seed1 [wtrue|wpred|scale=F|nodiff]
"""
import sys, tomllib
import numpy as np

from recording_truth import axes, column, exp_so3, load, right_jacobian, skew
def mexpm(A):
    M = np.eye(2); t = np.eye(2)
    for k in range(1, 30):
        t = t@A/k; M = M + t
    return M
d = sys.argv[1]
opts = sys.argv[2:]
hm, m = load(d + '/master.csv'); hi, imu = load(d + '/slave_imu.csv'); ht, tr = load(d + '/truth.csv')
cfg = tomllib.load(open(d + '/calibrate.toml', 'rb'))
col = column
tm = col(hm, m, 't'); wm = np.stack([col(hm, m, k) for k in ('wx', 'wy', 'wz')], 1)
ti = imu[:, 0]; dth = imu[:, 1:4]
T = lambda n: axes(ht, tr, n)
bg, mu, th, thd, sg = T('bg'), T('mu'), T('th'), T('thd'), T('sg')
expso3 = exp_so3
jr = right_jacobian
h = ti[2] - ti[1]; Tf = 0.01
gm = cfg['flexure_gauss_markov']
for o in opts:
    if o.startswith('scale='):  # scale filter's flexure sigma
        f = float(o[6:]); gm = [[w, z, s*f] for w, z, s in gm]
mu0 = mu[0]; J = jr(mu0); E0 = expso3(mu0)
N = 15
Phi = np.eye(N); Q = np.zeros((N, N)); P = np.zeros((N, N))
qd = []
for a, (w, z, s) in enumerate(gm):
    A = np.array([[0, 1], [-w*w, -2*z*w]])
    F = mexpm(A*Tf); Pinf = np.diag([s*s, w*w*s*s]); Qa = Pinf - F@Pinf@F.T
    i, j = 6+a, 9+a
    Phi[np.ix_([i, j], [i, j])] = F; Q[np.ix_([i, j], [i, j])] = Qa; P[np.ix_([i, j], [i, j])] = Pinf
    qd.append(4*z*w**3*s*s)
qd = np.array(qd)
P[0:3, 0:3] = np.eye(3)*cfg['initial_gyro_bias_radps']**2
P[3:6, 3:6] = np.eye(3)*cfg['initial_misalignment_rad']**2
sprior = 1e-3
P[12:15, 12:15] = np.eye(3)*sprior**2
x = np.zeros(N)
# nominal: bg_hat = 0, mu_hat = mu0 (truth, fixed); truth deviations: bg - 0, mu - mu0 = 0
rn = np.array(cfg['rate_noise_radps'])**2 + cfg['gyro_arw_rad_rs']**2/(2*h) + (J*J)@qd*h/6
if 'nodiff' in opts: rn = np.array(cfg['rate_noise_radps'])**2 + cfg['gyro_arw_rad_rs']**2/(2*h)
idx = {round(t / h): k for k, t in enumerate(ti)}
nis = []; out = []
for jm in range(1, len(tm)):
    x = Phi@x; P = Phi@P@Phi.T + Q
    k = idx.get(round(tm[jm]/h))
    if k is None or k < 2 or k+1 >= len(ti): continue
    ws = (dth[k] + dth[k+1])/(2*h)
    wmb = E0.T@wm[jm]
    z = ws - wmb
    H = np.zeros((3, N)); H[:, 0:3] = np.eye(3); H[:, 3:6] = skew(wmb)@J; H[:, 6:9] = skew(wmb)@J
    H[:, 9:12] = J; col = ws
    if 'wtrue' in opts: col = wmb
    if 'wpred' in opts: col = wmb + J@x[9:12] + skew(wmb)@J@x[6:9]
    H[:, 12:15] = np.diag(col)
    # sequential scalar updates
    for r in range(3):
        hr = H[r]; y = z[r] - hr@x; Sv = hr@P@hr + rn[r]
        K = P@hr/Sv; x = x + K*y; P = P - np.outer(K, hr@P); P = (P+P.T)/2
        nis.append(y*y/Sv)
    if jm % 3000 == 0 or jm == len(tm)-1:
        out.append((tm[jm], x[12:15].copy(), np.sqrt(np.diag(P)[12:15])))
for t, s, sd in out:
    print(f"{t:7.1f} s = {np.round(s*1e6).astype(int)} ppm  sigma = {np.round(sd*1e6).astype(int)}")
print("mean NIS", np.mean(nis), "bg err", (x[0:3]-bg[-1]), "th err rms at end", x[6:9]-th[-1])
