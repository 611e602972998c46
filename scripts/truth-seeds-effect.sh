#!/usr/bin/env bash
# One scenario (e.g. a blind draw's drawn.toml, edited) simulated with several seeds and
# calibrated with its own model (handed to the filter on purpose: this measures how the
# engine's estimate of one effect spreads against its claimed σ, apart from the learner)
# and one effect asked for; prints per seed the estimate, σ and Wald.
# docs/diagnosis.md "Session 13" uses it on blind draw 129's model.
#
#   scripts/truth-seeds-effect.sh SCENARIO OUT_DIR EFFECT SEED...
#
# CONF_EDIT (a sed script) edits each calibrate.toml before the run, e.g.
#   CONF_EDIT='s/^matching = .*/matching = ["attitude", "angular_rate"]/'
# Uses target/release/flexcal unless FLEXCAL names another.
set -uo pipefail
F=${FLEXCAL:-target/release/flexcal}
scen=$1
out=$2
effect=$3
shift 3
mkdir -p "$out"
for seed in "$@"; do
  rec=$out/seed$seed
  rm -rf "$rec"
  "$F" simulate --scenario "$scen" --seed "$seed" --out "$rec" > /dev/null
  python3 "$(dirname "$0")/drawn-mounting.py" "$scen" >> "$rec/calibrate.toml"
  if [ -n "${CONF_EDIT:-}" ]; then sed -i "$CONF_EDIT" "$rec/calibrate.toml"; fi
  "$F" calibrate "$rec" --effects "$effect" --out "$rec-cal" > /dev/null 2>&1
  python3 - "$rec-cal/summary.json" "$seed" <<'EOF'
import json, sys
e = json.load(open(sys.argv[1]))["effects"][0]
print(sys.argv[2], ["%.4g" % x for x in e["estimate"]], ["%.2g" % x for x in e["sigma"]],
      "%.1f" % e["wald"])
EOF
done
