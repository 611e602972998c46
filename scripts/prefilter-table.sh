#!/usr/bin/env bash
# The table "Any clock, any mounting" of docs/diagnosis.md (issue 10, acceptance 5): for a
# clock offset and a mounting each, simulate a recording, calibrate it with nothing told
# about either, and print one markdown row from summary.json: the clock found with its σ,
# the angle between the mounting found before the filter and the truth, the final
# misalignment, the largest |error|/σ over the nine calibrated states, the mean NIS.
#
#   scripts/prefilter-table.sh OUT_DIR
#
# Uses target/release/flexcal (build it first: cargo build --release -p flexcal-sim)
# unless FLEXCAL names another; python3 reads the JSON.
set -euo pipefail
out="${1:?OUT_DIR}"
F="${FLEXCAL:-target/release/flexcal}"
export FLEXCAL_SCRIPTS="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$out"
row() { # LABEL SUMMARY_JSON TAU MOUNTING_DEG
  python3 - "$@" <<'PY'
import json, math, os, sys
label, path, tau, deg = sys.argv[1], sys.argv[2], float(sys.argv[3]), [float(x) for x in sys.argv[4].split(',')]
d = json.load(open(path))
c = d['pre_filter']['clock'].get('found', {})
e = d['errors']
worst = max(abs(e[k][a] / d[k + '_sigma'][a]) for k in ('gyro_bias', 'accel_bias', 'misalignment') for a in range(3))
sys.path.insert(0, os.environ['FLEXCAL_SCRIPTS'])
from rotation_angle import angle_deg
m = d['pre_filter'].get('mounting') or {}
found = m.get('rotation_vector_rad')
mount = f"{angle_deg(found, [math.radians(x) for x in deg]):.3f}" if found else "—"
mis = ', '.join(f"{math.degrees(x):.3f}" for x in d['misalignment'])
print(f"| {label} | {tau:+.1f} | {1e3 * c.get('offset_s', math.nan):+.1f} ± {1e3 * c.get('sigma_s', math.nan):.1f} | {deg} | {mount} | [{mis}] | {worst:.2f} | {d['innovations']['nis_mean']:.3f} |")
PY
}
for tau in 0.4 -0.4; do
  "$F" simulate --scenario moored --duration 120 --clock-offset "$tau" --out "$out/m" > /dev/null
  "$F" calibrate "$out/m" --out "$out/m-c" > /dev/null 2>&1 || true
  row "moored, declared" "$out/m-c/summary.json" "$tau" 0.5,-0.3,1.0
done
for tau in 0.4 -0.4; do
  for m in 30,0,0 90,0,0 180,0,0 0,30,0 0,90,0 0,180,0 0,0,30 0,0,90 0,0,180; do
    "$F" simulate --blind --seed 3 --duration 120 --clock-offset "$tau" --mounting-deg "$m" --out "$out/r" > /dev/null
    "$F" calibrate "$out/r" --out "$out/r-c" > /dev/null 2>&1 || true
    row "blind 3" "$out/r-c/summary.json" "$tau" "$m"
  done
done
