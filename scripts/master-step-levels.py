#!/usr/bin/env python3
"""How well a master's attitude steps can be measured (docs/diagnosis.md, "A master whose
attitude steps", session 8), on a blind recording with steps (REC and REC.drawn.toml, as
`flexcal simulate --blind ... --master-step-deg D --out REC` writes them; the master must
give its rate).

The residual of each interval is the master's attitude change its own rate does not
explain (as calib/master_steps.rs: two-sample rotation of w_nb = w_ib - C^T (w_ie + w_en),
r = Log(C_b (C_a Exp(phi))^T), ENU); a step is the residual of its interval plus the
difference of the master's error levels after and before it, each level the mean (or the
end of a line fitted) over T seconds of the cumulated residuals. Prints, per estimator,
the RMS and each drawn step's error (deg, ENU); then the same estimator on the master with
the drawn steps undone (what is left is the master's own error, not the step); then its
RMS at random instants without a step.

    python3 scripts/master-step-levels.py REC
"""
import csv
import math
import random
import sys
import tomllib

W_IE = 7.292115e-5
R_E = 6378137.0


def qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


def qinv(a):
    return (a[0], -a[1], -a[2], -a[3])


def qexp(v):
    n = math.sqrt(sum(x * x for x in v))
    if n < 1e-15:
        return (1.0, v[0] / 2, v[1] / 2, v[2] / 2)
    s = math.sin(n / 2) / n
    return (math.cos(n / 2), v[0] * s, v[1] * s, v[2] * s)


def qlog(q):
    if q[0] < 0:
        q = tuple(-x for x in q)
    n = math.sqrt(q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    if n < 1e-15:
        return (2 * q[1], 2 * q[2], 2 * q[3])
    a = 2 * math.atan2(n, q[0])
    return (q[1] * a / n, q[2] * a / n, q[3] * a / n)


def nav_to_body(q, v):
    return qmul(qmul(qinv(q), (0.0,) + tuple(v)), q)[1:]


def residuals(master):
    """(time of the later message, residual rotation vector ENU) per interval."""
    out = []
    for a, b in zip(master, master[1:]):
        dt = b[0] - a[0]
        wa, wb = a[2], b[2]
        cr = (wa[1] * wb[2] - wa[2] * wb[1], wa[2] * wb[0] - wa[0] * wb[2], wa[0] * wb[1] - wa[1] * wb[0])
        phi = tuple((x + y) * 0.5 * dt + c * dt * dt / 12 for x, y, c in zip(wa, wb, cr))
        out.append((b[0], qlog(qmul(b[1], qinv(qmul(a[1], qexp(phi)))))))
    return out


def step_at(res, i0, span, kind):
    """The step of interval i0 (rad, ENU): its residual plus the level after minus before."""
    out = []
    for k in range(3):
        xa, ya, cum, j = [0.0], [0.0], 0.0, i0 + 1
        while j < len(res) and res[j][0] - res[i0][0] <= span:
            cum += res[j][1][k]
            xa.append(res[j][0] - res[i0][0])
            ya.append(cum)
            j += 1
        xb, yb, cum, j = [0.0], [0.0], 0.0, i0 - 1
        while j > 0 and res[i0 - 1][0] - res[j - 1][0] <= span:
            cum += res[j][1][k]
            xb.append(-(res[i0 - 1][0] - res[j - 1][0]))
            yb.append(-cum)
            j -= 1

        def level(x, y, at):
            n = len(x)
            my = sum(y) / n
            if kind == 'mean':
                return my
            mx = sum(x) / n
            sxx = sum((a - mx) ** 2 for a in x)
            sxy = sum((a - mx) * (b - my) for a, b in zip(x, y))
            return my + sxy / sxx * (at - mx)

        dt = res[i0][0] - res[i0 - 1][0]
        out.append(res[i0][1][k] + level(xa, ya, -dt / 2) - level(xb, yb, dt / 2))
    return out


def main():
    rec = sys.argv[1]
    steps = tomllib.load(open(rec + '.drawn.toml', 'rb'))['undeclared']['master_attitude_steps']['steps']
    master = []
    for r in csv.DictReader(open(rec + '/master.csv')):
        q = tuple(float(r[k]) for k in ('qw', 'qx', 'qy', 'qz'))
        lat, h = math.radians(float(r['lat_deg'])), float(r['height_m'])
        ve, vn = float(r['ve']), float(r['vn'])
        w_in = (-vn / (R_E + h), W_IE * math.cos(lat) + ve / (R_E + h),
                W_IE * math.sin(lat) + ve * math.tan(lat) / (R_E + h))
        w_ib = tuple(float(r[k]) for k in ('wx', 'wy', 'wz'))
        w_nb = tuple(a - b for a, b in zip(w_ib, nav_to_body(q, w_in)))
        master.append((float(r['t']), q, w_nb))
    estimators = [(2, 'mean'), (5, 'mean'), (10, 'mean'), (2, 'line'), (5, 'line'), (10, 'line'), (20, 'line')]
    res = residuals(master)
    index = [next(i for i, x in enumerate(res) if x[0] >= s['t_s']) for s in steps]
    print('steps as recorded: estimator, RMS error (deg), each step\'s error E/N/U (deg)')
    for span, kind in estimators:
        errs = [[round(math.degrees(a) - b, 4) for a, b in zip(step_at(res, i, span, kind), s['rotation_deg'])]
                for i, s in zip(index, steps)]
        rms = math.sqrt(sum(x * x for e in errs for x in e) / (3 * len(errs)))
        print(f'  {span} s {kind}: {rms:.4f} {errs}')
    drawn = [(s['t_s'], qexp([math.radians(x) for x in s['rotation_deg']])) for s in steps]
    undone = []
    for t, q, w in master:
        total = (1.0, 0.0, 0.0, 0.0)
        for ts, sq in drawn:
            if t >= ts:
                total = qmul(sq, total)
        undone.append((t, qmul(qinv(total), q), w))
    res = residuals(undone)
    print('drawn steps undone first (what the estimator reads there is the master\'s own error, deg):')
    for span, kind in estimators[:3]:
        print(f'  {span} s {kind}: ' + str([[round(math.degrees(a), 4) for a in step_at(res, i, span, kind)] for i in index]))
    print('the same at random instants without a step: RMS (deg), instants')
    random.seed(1)
    for span, kind in [(2, 'mean'), (5, 'mean'), (5, 'line')]:
        vals = []
        for _ in range(60):
            t = random.uniform(12, res[-1][0] - 12)
            if any(abs(t - s['t_s']) < span + 1 for s in steps):
                continue
            i = next(i for i, x in enumerate(res) if x[0] >= t)
            vals += [math.degrees(a) for a in step_at(res, i, span, kind)]
        print(f'  {span} s {kind}: {math.sqrt(sum(v * v for v in vals) / len(vals)):.4f} ({len(vals) // 3})')


if __name__ == '__main__':
    main()
