#!/usr/bin/env python3
"""Session 21 (docs/model-learning.md): what the slave's own gyros can remove of the
accelerometers' high-frequency increments. Per blind recording DIR (scored against
DIR.drawn.toml): the per-axis accelerometer density over [fs/4, 0.45 fs] and the residual
after the part linearly coherent with the three gyro axes is removed per frequency bin
(S_aa - S_ag S_gg^-1 S_ga, Welch, 4096-sample Hann segments), both in units of the drawn
velocity random walk's density 2 VRW^2: the median over the band of the median axis, and
the least residual over 0.3 Hz - 0.45 fs (any axis).

    python3 scripts/vrw-coherence.py DIR...
"""
import re
import sys

import numpy as np


def drawn_density(d):
    t = open(d.rstrip('/') + '.drawn.toml').read()
    vrw = float(re.search(r'accel_vrw_mps_rh = ([-\d.e]+)', t).group(1)) / 60.0
    return 2.0 * vrw * vrw


def cross_spectra(x, fs, nseg=4096):
    w = np.hanning(nseg)
    acc, k = 0.0, 0
    for s in range(0, len(x) - nseg + 1, nseg // 2):
        seg = x[s:s + nseg] - x[s:s + nseg].mean(0)
        f = np.fft.rfft(seg * w[:, None], axis=0)
        acc = acc + np.einsum('fi,fj->fij', f, f.conj())
        k += 1
    return np.fft.rfftfreq(nseg, 1.0 / fs), acc * 2.0 / (fs * (w ** 2).sum() * k)


for d in sys.argv[1:]:
    a = np.loadtxt(d.rstrip('/') + '/slave_imu.csv', delimiter=',', skiprows=2)
    dt = np.median(np.diff(a[:, 0]))
    fs = 1.0 / dt
    f, s = cross_spectra(a[:, 1:7] / dt, fs)
    white = drawn_density(d)
    raw = np.real(np.einsum('fii->fi', s[:, 3:, 3:]))
    res = np.array([np.real(np.diag(si[3:, 3:] - si[3:, :3] @ np.linalg.solve(si[:3, :3], si[3:, :3].conj().T))) for si in s])
    top = (f >= 0.25 * fs) & (f <= 0.45 * fs)
    wide = (f >= 0.3) & (f <= 0.45 * fs)
    print('%s %4.0f Hz  per axis %.3g  coherent residual (top band) %.3g  least residual %.3g' % (
        d, fs, np.median(np.median(raw[top], 0)) / white, np.median(np.median(res[top], 0)) / white, res[wide].min() / white))
