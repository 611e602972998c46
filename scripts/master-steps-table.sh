#!/usr/bin/env bash
# The table "A master whose attitude steps" of docs/diagnosis.md (issue 10, acceptance 5):
# per blind seed, a master whose attitude steps by STEP_DEG about a drawn axis at drawn
# times (mean interval 30 s), calibrated with nothing told about the steps, three ways:
#   out      the steps found before the filter and taken out (the default),
#   kept     `--keep-master-steps`: the attitude as recorded,
#   no-att   as recorded, the attitude matching off (velocity and rate only; a
#            `tune = true` configuration: learned from the file's defaults);
# and the same seed without steps (control: what the search reports there).
# One markdown row each, from summary.json and the drawn truth: steps drawn / found (a
# found step matches a drawn one when its time is within one master period after and its
# rotation within 0.5°; the largest rotation error among the matched), the largest
# |error|/σ of the gyro biases, accelerometer biases and misalignment, the filter's
# restarts (master messages that started the solution beyond the first), the mean NIS.
#
#   scripts/master-steps-table.sh OUT_DIR [STEP_DEG] [DURATION_S] [SEEDS...]
#
# Defaults: 10°, 120 s, seeds 1 to 10. VARIANTS (default "out kept no-att control") runs
# only the rows named. Uses target/release/flexcal (build it first:
# cargo build --release -p flexcal-sim) unless FLEXCAL names another; python3 (3.11, for
# tomllib) reads the TOML and JSON.
set -euo pipefail
out="${1:?OUT_DIR}"
step="${2:-10}"
dur="${3:-120}"
shift $(( $# < 3 ? $# : 3 ))
seeds=("$@")
[ ${#seeds[@]} -gt 0 ] || seeds=(1 2 3 4 5 6 7 8 9 10)
F="${FLEXCAL:-target/release/flexcal}"
variants=" ${VARIANTS:-out kept no-att control} "
mkdir -p "$out"
cat > "$out/no-attitude.toml" <<'EOF'
# The attitude matching off; the model learned (tune) from the built-in defaults.
matching = ["velocity", "angular_rate"]
tune = true
EOF
row() { # LABEL SUMMARY_JSON DRAWN_TOML
  python3 - "$@" <<'PY'
import json, math, sys, tomllib
label, path, drawn = sys.argv[1], sys.argv[2], sys.argv[3]
d = json.load(open(path))
sc = tomllib.load(open(drawn, 'rb'))
truth = ((sc.get('undeclared') or {}).get('master_attitude_steps') or {}).get('steps', [])
period = 1.0 / sc['master']['rate_hz']
st = d['pre_filter']['master_attitude_steps']
found = (st.get('found') or {}).get('steps', [])
matched, worst = 0, 0.0
for t in truth:
    tv = [math.radians(x) for x in t['rotation_deg']]
    for f in found:
        err = math.degrees(math.sqrt(sum((a - b) ** 2 for a, b in zip(f['rotation_rad'], tv))))
        if 0 <= f['t_s'] - t['t_s'] <= period + 1e-9 and err < 0.5:
            matched += 1
            worst = max(worst, err)
            break
e = d['errors']
z = lambda k: max(abs(e[k][a] / d[k + '_sigma'][a]) for a in range(3))
ini = d['inputs']['master']['initialized']
steps = f"{len(truth)} / {len(found)} ({matched} matched, ≤ {worst:.3f}°)" if 'found' in st else "— (not searched)"
print(f"| {label} | {steps} | {z('gyro_bias'):.2f} | {z('accel_bias'):.2f} | {z('misalignment'):.2f} | {e['nees_mean']:.1f} | {ini - 1} | {d['innovations']['nis_mean']:.3f} |")
PY
}
echo "| seed, handling | steps drawn / found | gyro bias max \|err\|/σ | accel bias max \|err\|/σ | misalignment max \|err\|/σ | NEES (9) | restarts | NIS |"
echo "|---|---|---|---|---|---|---|---|"
for s in "${seeds[@]}"; do
  r="$out/b$s"
  "$F" simulate --blind --seed "$s" --duration "$dur" --master-step-deg "$step" --out "$r" > /dev/null
  if [[ $variants == *" out "* ]]; then
    "$F" calibrate "$r" --out "$r-out" > /dev/null 2>&1 || true
    row "$s, out" "$r-out/summary.json" "$r.drawn.toml"
  fi
  if [[ $variants == *" kept "* ]]; then
    "$F" calibrate "$r" --keep-master-steps --out "$r-kept" > /dev/null 2>&1 || true
    row "$s, kept" "$r-kept/summary.json" "$r.drawn.toml"
  fi
  if [[ $variants == *" no-att "* ]]; then
    "$F" calibrate "$r" --keep-master-steps --config "$out/no-attitude.toml" --out "$r-noatt" > /dev/null 2>&1 || true
    row "$s, no-att" "$r-noatt/summary.json" "$r.drawn.toml"
  fi
  if [[ $variants == *" control "* ]]; then
    c="$out/c$s"
    "$F" simulate --blind --seed "$s" --duration "$dur" --out "$c" > /dev/null
    "$F" calibrate "$c" --out "$c-out" > /dev/null 2>&1 || true
    row "$s, no steps (control)" "$c-out/summary.json" "$c.drawn.toml"
  fi
done
