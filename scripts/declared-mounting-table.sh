#!/usr/bin/env bash
# The table "A declared model names no mounting" of docs/diagnosis.md (issue 10,
# acceptance 5): a recording calibrated with its truth model declared (the
# `calibrate.toml` `flexcal simulate` writes: noise, flexure, master errors, no
# mounting), two ways:
#   found   the default: the mounting found before the filter is the filter's start,
#   zero    the same configuration with `mounting_estimate_rad = [0, 0, 0]` (what a
#           declared configuration did before: the filter starts at the nominal zero);
# on `moored` (120 s) and on blind seed 104's drawn model (120 s, declared: the drawn
# scenario simulated again with its own seed), each with its own mounting and with large
# ones. One markdown row each from summary.json: the angle between the mounting found
# before the filter and the truth, the final misalignment, the largest |error|/σ over
# the nine calibrated states, the NEES of those nine, the mean NIS.
#
#   scripts/declared-mounting-table.sh OUT_DIR
#
# Uses target/release/flexcal (build it first: cargo build --release -p flexcal-sim)
# unless FLEXCAL names another; python3 reads the JSON.
set -euo pipefail
out="${1:?OUT_DIR}"
F="${FLEXCAL:-target/release/flexcal}"
export FLEXCAL_SCRIPTS="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$out"
row() { # LABEL SUMMARY_JSON MOUNTING_DEG
  python3 - "$@" <<'PY'
import json, math, os, sys
label, path, deg = sys.argv[1], sys.argv[2], [float(x) for x in sys.argv[3].split(',')]
d = json.load(open(path))
e = d['errors']
worst = max(abs(e[k][a] / d[k + '_sigma'][a]) for k in ('gyro_bias', 'accel_bias', 'misalignment') for a in range(3))
sys.path.insert(0, os.environ['FLEXCAL_SCRIPTS'])
from rotation_angle import angle_deg
m = d['pre_filter'].get('mounting') or {}
found = m.get('rotation_vector_rad')
mount = f"{angle_deg(found, [math.radians(x) for x in deg]):.3f}" if found else "— (starts at 0)"
mis = ', '.join(f"{math.degrees(x):.3f}" for x in d['misalignment'])
tr = ', '.join(f"{x:.2f}" for x in deg)
print(f"| {label} | [{tr}] | {mount} | [{mis}] | {worst:.2f} | {e['nees_mean']:.1f} | {d['innovations']['nis_mean']:.3f} |")
PY
}
# CASE LABEL MOUNTING_DEG SIMULATE_ARGS...: the recording, then both rows.
case_rows() {
  local label="$1" deg="$2"
  shift 2
  "$F" simulate "$@" --duration 120 --out "$out/r" > /dev/null
  "$F" calibrate "$out/r" --out "$out/r-found" > /dev/null 2>&1 || true
  row "$label, found" "$out/r-found/summary.json" "$deg"
  { cat "$out/r/calibrate.toml"; echo 'mounting_estimate_rad = [0.0, 0.0, 0.0]'; } > "$out/zero.toml"
  "$F" calibrate "$out/r" --config "$out/zero.toml" --out "$out/r-zero" > /dev/null 2>&1 || true
  row "$label, zero" "$out/r-zero/summary.json" "$deg"
}
echo "| recording, start | mounting truth (°) | mounting found before the filter: error (°) | misalignment after (°) | max \|error\|/σ, 9 states | NEES (9) | NIS |"
echo "|---|---|---|---|---|---|---|"
case_rows "moored" 0.5,-0.3,1.0 --scenario moored
for m in 0,0,2 30,0,0 0,90,0 180,0,0 0,180,0 0,0,180; do
  case_rows "moored" "$m" --scenario moored --mounting-deg "$m"
done
"$F" simulate --blind --seed 104 --duration 120 --out "$out/b104" > /dev/null
drawn=$(python3 -c "import sys, tomllib; print(','.join(str(x) for x in tomllib.load(open(sys.argv[1], 'rb'))['misalignment_deg']))" "$out/b104.drawn.toml")
case_rows "blind 104, declared" "$drawn" --scenario "$out/b104.drawn.toml" --seed 104
for m in 30,0,0 0,90,0 0,0,180; do
  case_rows "blind 104, declared" "$m" --scenario "$out/b104.drawn.toml" --seed 104 --mounting-deg "$m"
done
