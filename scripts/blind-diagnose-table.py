#!/usr/bin/env python3
"""Tabulates a blind `diagnose` survey (scripts/blind-diagnose-survey.sh): per recording,
the effects drawn (from its .drawn.toml) and each effect the final model carries with
its estimate, σ and (estimate − truth)/σ as diagnosis.json reports them.

    python3 scripts/blind-diagnose-table.py out/s6-delay
"""
import glob
import json
import os
import sys


def main(root):
    for diag in sorted(glob.glob(os.path.join(root, "*-diag", "diagnosis.json"))):
        name = os.path.basename(os.path.dirname(diag))[: -len("-diag")]
        d = json.load(open(diag))
        found = []
        for e in d.get("effects_found", []):
            est = ", ".join(f"{v:.4g}" for v in e["estimate"])
            sig = ", ".join(f"{v:.2g}" for v in e["sigma"])
            eos = e.get("error_over_sigma")
            eos = ", ".join(f"{v:+.1f}" for v in eos) if eos else "n/a"
            found.append(f"{e['name']} [{est}] ± [{sig}] {e['unit']} (error/σ {eos})")
        print(f"{name:32s} " + ("; ".join(found) if found else "none"))


if __name__ == "__main__":
    main(sys.argv[1])
