#!/usr/bin/env bash
# The oracle for a blind survey: each draw's own recording (the scenario it drew, simulated
# again with its seed: the same data, byte for byte) calibrated with its truth's model
# (handed on purpose) and the drawn effect asked for; prints per draw the effect's estimate,
# σ and Wald statistic. A draw whose Wald here is below diagnose's threshold (χ² at
# alpha / tests: 12.46 for one state, 18.11 for three, 30.13 for nine at the defaults) is
# beyond what the data shows even to a filter that knows everything else: no blind search
# can be asked to find it. docs/diagnosis.md "Session 19" uses it.
#
#   scripts/oracle-detectability.sh SURVEY_DIR CASE EFFECT OUT_DIR
#   e.g. scripts/oracle-detectability.sh out/sfS accel-scale-factor accel_scale_factor out/oracle-a
#
# SURVEY_DIR holds CASE-SEED.drawn.toml files (scripts/blind-diagnose-survey.sh writes them).
# Uses target/release/flexcal unless FLEXCAL names another.
set -euo pipefail
survey=$1; case_=$2; effect=$3; out=$4
mkdir -p "$out"
for drawn in "$survey/$case_"-[0-9]*.drawn.toml; do
  seed=${drawn##*-}; seed=${seed%.drawn.toml}
  printf '%s ' "$case_"
  "$(dirname "$0")/truth-seeds-effect.sh" "$drawn" "$out/$case_" "$effect" "$seed"
done
