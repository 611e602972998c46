#!/usr/bin/env bash
# What is left when a master's attitude steps are taken out (docs/diagnosis.md, "A master
# whose attitude steps", session 8): on one blind recording with steps,
#   1. the steps taken out as found against the drawn ones (both through a `tune = true`
#      configuration that gives `master_attitude_steps`, so both learn from the same start;
#      the drawn rotations at the found times);
#   2. the learned model (`model.toml` of the default run) declared again with its
#      `master_attitude_error_rad` / `master_error_correlation_s` replaced by each pair in
#      MASTER_ERRORS (default "keep 0.0005,30 0.001,30 0.01,20 0.02,20").
# One line each: the largest |error|/σ of gyro bias, accelerometer bias, misalignment
# (per axis), the NEES of those nine, the mean NIS.
#
#   scripts/master-steps-causes.sh OUT_DIR SEED [DRIFT_DEG_S]
#
# 10° steps every 30 s on average, 120 s. Uses target/release/flexcal (build it first:
# cargo build --release -p flexcal-sim) unless FLEXCAL names another; python3 (3.11).
set -euo pipefail
out="${1:?OUT_DIR}"
seed="${2:?SEED}"
drift="${3:-0}"
F="${FLEXCAL:-target/release/flexcal}"
mkdir -p "$out"
r="$out/s$seed"
"$F" simulate --blind --seed "$seed" --duration 120 --master-step-deg 10 --master-drift-deg-s "$drift" --out "$r" > /dev/null
"$F" calibrate "$r" --out "$r-default" > /dev/null 2>&1 || true
line() { # LABEL SUMMARY_JSON
  python3 - "$@" <<'PY'
import json, sys
d = json.load(open(sys.argv[2]))
e = d['errors']
z = [[round(e[k][a] / d[k + '_sigma'][a], 2) for a in range(3)] for k in ('gyro_bias', 'accel_bias', 'misalignment')]
print(f"{sys.argv[1]}: gyro {z[0]}, accel {z[1]}, misalignment {z[2]} σ; NEES {e['nees_mean']:.1f}, NIS {d['innovations']['nis_mean']:.3f}")
PY
}
line "default (found, learned from nothing)" "$r-default/summary.json"
python3 - "$r" <<'PY'
import json, math, sys, tomllib
r = sys.argv[1]
found = json.load(open(r + '-default/summary.json'))['pre_filter']['master_attitude_steps']['found']['steps']
drawn = tomllib.load(open(r + '.drawn.toml', 'rb'))['undeclared']['master_attitude_steps']['steps']
assert len(found) == len(drawn), (found, drawn)
def write(name, rows):
    with open(f"{r}-{name}.toml", 'w') as f:
        f.write('tune = true\nmaster_attitude_steps = [' + ', '.join('[%r, %r, %r, %r]' % tuple(x) for x in rows) + ']\n')
write('drawn', [[f['t_s']] + [math.radians(x) for x in d['rotation_deg']] for f, d in zip(found, drawn)])
write('found', [[f['t_s']] + f['rotation_rad'] for f in found])
PY
for v in drawn found; do
  "$F" calibrate "$r" --config "$r-$v.toml" --out "$r-$v" > /dev/null 2>&1 || true
  line "tune, steps $v" "$r-$v/summary.json"
done
for pair in ${MASTER_ERRORS:-keep 0.0005,30 0.001,30 0.01,20 0.02,20}; do
  if [ "$pair" = keep ]; then
    cp "$r-default/model.toml" "$r-m.toml"
  else
    sed -e "s/^master_attitude_error_rad = .*/master_attitude_error_rad = ${pair%,*}/" \
        -e "s/^master_error_correlation_s = .*/master_error_correlation_s = ${pair#*,}.0/" \
        "$r-default/model.toml" > "$r-m.toml"
  fi
  "$F" calibrate "$r" --config "$r-m.toml" --out "$r-m" > /dev/null 2>&1 || true
  line "learned model, master attitude error (rad, s) $pair" "$r-m/summary.json"
done
