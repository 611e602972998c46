#!/usr/bin/env bash
# Blind `diagnose` on draws carrying a gyro g-sensitivity larger than the blind draw's
# 0.5 °/h/g (which no rule finds in 300 s: docs/diagnosis.md), to tell whether the
# g-sensitivity is still found when present (docs/diagnosis.md "Session 12").
#
#   scripts/blind-g-sensitivity-survey.sh OUT_DIR [DURATION_S] [SEEDS...]
#
# For each seed: the blind draw (`simulate --blind --drawn`), its
# `gyro_g_sensitivity_deg_h_per_g` replaced by G (default the row-major
# "20.0, 5.0, 0.0, -10.0, 20.0, 0.0, 0.0, 8.0, -20.0" °/h/g), simulated again and its
# calibrate.toml removed (blind: `diagnose` learns the model), then `diagnose` with no
# configuration. Prints what the final model adopts and, for gyro_g_sensitivity, its
# largest |error|/σ against G. Uses target/release/flexcal unless FLEXCAL names another.
set -euo pipefail
out="${1:?OUT_DIR}"
duration="${2:-300}"
shift $(( $# > 1 ? 2 : 1 ))
seeds=("$@")
[[ ${#seeds[@]} -eq 0 ]] && seeds=(101 102 103)
F="${FLEXCAL:-target/release/flexcal}"
G="${G:-20.0, 5.0, 0.0, -10.0, 20.0, 0.0, 0.0, 8.0, -20.0}"
mkdir -p "$out"
for seed in "${seeds[@]}"; do
  rec="$out/g-$seed"
  "$F" simulate --blind --seed "$seed" --duration "$duration" --out "$rec" --drawn "$out/draw-$seed.toml" > /dev/null
  rm -rf "$rec"
  sed "s/^gyro_g_sensitivity_deg_h_per_g = .*/gyro_g_sensitivity_deg_h_per_g = [$G]/" \
    "$out/draw-$seed.toml" > "$out/scenario-$seed.toml"
  "$F" simulate --scenario "$out/scenario-$seed.toml" --seed "$seed" --out "$rec" > /dev/null
  rm -f "$rec/calibrate.toml"
  t0=$(date +%s.%N)
  "$F" diagnose "$rec" --out "$rec-diag" > "$rec-diag.log" 2>&1 || true
  t1=$(date +%s.%N)
  python3 - "$rec-diag/diagnosis.json" "$seed" "$G" "$(awk "BEGIN { print $t1 - $t0 }")" <<'PY'
import json, math, sys
d = json.load(open(sys.argv[1]))
k = math.pi / 180 / 3600 / 9.80665
truth = [float(x) for x in sys.argv[3].split(",")]
names = ",".join(e["name"] for e in d["effects_found"]) or "none"
line = f"seed {sys.argv[2]}  adopted: {names:<40}"
for e in d["effects_found"]:
    if e["name"] == "gyro_g_sensitivity":
        z = [(x / k - t) / (s / k) for x, s, t in zip(e["estimate"], e["sigma"], truth)]
        line += " G (°/h/g) [" + ", ".join(f"{x / k:.1f}" for x in e["estimate"]) + "]"
        line += f" max |err|/σ {max(abs(v) for v in z):.1f}"
        if e.get("error_over_sigma"):
            line += f" (diagnosis.json {max(abs(v) for v in e['error_over_sigma']):.1f})"
print(line + f"  {float(sys.argv[4]):.1f} s")
PY
done
