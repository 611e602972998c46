#!/usr/bin/env python3
"""Prints the `mounting_estimate_rad = [...]` line of a drawn scenario's misalignment
(degrees in the scenario, radians out): the starting estimate appended to a drawn model's
calibrate.toml by the scripts that hand a draw its truth (blind-truth-effect.sh,
truth-seeds-effect.sh).

    python3 scripts/drawn-mounting.py SCENARIO.toml >> REC/calibrate.toml
"""
import math
import re
import sys

m = re.search(r"misalignment_deg = \[(.*?)\]", open(sys.argv[1]).read()).group(1)
print("mounting_estimate_rad = [" + ", ".join(repr(math.radians(float(x))) for x in m.split(",")) + "]")
