"""A simulated recording's CSV files as numpy arrays, and the SO(3) helpers the truth
checks need (scripts/rate-model-residual.py, scripts/rate-only-linear-kf.py). Needs numpy."""
import csv

import numpy as np


def load(path):
    """Header and rows of a recording CSV (format v1), comment lines skipped."""
    r = csv.reader(open(path))
    h = next(r)
    a = np.array([[float(x) for x in row] for row in r if row and not row[0].startswith('#')])
    return h, a


def column(h, a, name):
    """Column `name` of a loaded CSV."""
    return a[:, h.index(name)]


def axes(h, a, prefix):
    """The three columns `prefix`x, y, z as an N×3 array (truth.csv's states)."""
    return np.stack([column(h, a, prefix + k) for k in 'xyz'], 1)


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def exp_so3(v):
    """Rotation matrix of rotation vector v."""
    a = np.linalg.norm(v); K = skew(v)
    if a < 1e-12: return np.eye(3) + K
    return np.eye(3) + np.sin(a)/a*K + (1-np.cos(a))/a**2*K@K


def right_jacobian(v):
    """SO(3)'s right Jacobian at rotation vector v."""
    a = np.linalg.norm(v); K = skew(v)
    if a < 1e-12: return np.eye(3) - 0.5*K
    return np.eye(3) - (1-np.cos(a))/a**2*K + (a-np.sin(a))/a**3*K@K
