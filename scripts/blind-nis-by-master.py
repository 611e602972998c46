#!/usr/bin/env python3
"""Blind Monte Carlo NIS by the master's drawn kind (issue 9, acceptance 1).

Reads the montecarlo.json of `flexcal montecarlo --blind` and prints, per master kind
(white, smooth, none), the number of runs, the mean NEES, the runs with all nine channel
axes in their NIS band, and per axis the percentage of runs in band; then the white runs
out of band with their NIS.

    python3 scripts/blind-nis-by-master.py out/mc-blind-s6/montecarlo.json
"""
import json
import sys


def inside(c):
    return c["band"][0] <= c["learned"] <= c["band"][1]


def main(path):
    d = json.load(open(path))
    runs = d["per_run"]
    print(f"mean NEES (all {len(runs)} runs): {d['learned']['nees']['mean']:.2f}, "
          f"band {d['learned']['nees']['band_95']}")
    for kind in ("white", "smooth", "none"):
        rs = [r for r in runs if r["master"] == kind]
        if not rs:
            continue
        nees = sum(r["learned"]["nees"] for r in rs) / len(rs)
        all9 = sum(1 for r in rs if all(inside(c) for c in r["nis"]))
        names = [c["channel"] for c in rs[0]["nis"]]
        per_axis = [100.0 * sum(1 for r in rs for c in r["nis"] if c["channel"] == n and inside(c)) / len(rs)
                    for n in names]
        print(f"{kind:7s} {len(rs):3d} runs, mean NEES {nees:6.2f}, all axes in band in {all9}; "
              + " ".join(f"{n} {p:.0f}%" for n, p in zip(names, per_axis)))
    for r in runs:
        if r["master"] != "white":
            continue
        out = [f"{c['channel']} {c['learned']:.3f}" for c in r["nis"] if not inside(c)]
        if out:
            print(f"  white seed {r['seed']}: " + ", ".join(out))


if __name__ == "__main__":
    main(sys.argv[1])
