#!/usr/bin/env python3
"""Scores a `scripts/blind-diagnose-survey.sh` run for one effect: per seed, the master
rate, what the final model adopted, and the effect's estimate against the drawn truth
(from `diagnosis.json`'s `effects_found`, `error_over_sigma`), as markdown rows.

    python3 scripts/blind-survey-score.py OUT_DIR CASE EFFECT SEEDS...
    e.g. python3 scripts/blind-survey-score.py out/s9-drift clock-drift clock_drift 101 102
"""
import json
import re
import sys

out, case, effect, seeds = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
named = within = 0
for s in seeds:
    base = f"{out}/{case}-{s}"
    d = json.load(open(f"{base}-diag/diagnosis.json"))
    drawn = open(f"{base}.drawn.toml").read()
    hz = re.search(r"\[master\]\s*\nrate_hz = (\S+)", drawn).group(1)
    names = [e["name"] for e in d["effects_found"]]
    row = [s, f"{float(hz):.0f}", ", ".join(names) or "none"]
    found = next((e for e in d["effects_found"] if e["name"] == effect), None)
    if found:
        named += 1
        z = found.get("error_over_sigma") or []
        ok = bool(z) and all(abs(v) <= 3 for v in z)
        within += ok
        est = ", ".join(f"{v:.4g}" for v in found["estimate"])
        sig = ", ".join(f"{v:.2g}" for v in found["sigma"])
        tru = ", ".join(f"{v:.4g}" for v in (found.get("truth") or []))
        row += [f"[{est}] ± [{sig}]", f"[{tru}]", ", ".join(f"{v:.1f}" for v in z), "yes" if ok else "no"]
    else:
        row += ["–", "–", "–", "–"]
    print("| " + " | ".join(row) + " |")
print(f"named {effect}: {named} of {len(seeds)}; within 3σ: {within} of {len(seeds)}")
