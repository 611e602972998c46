#!/usr/bin/env bash
# One blind draw calibrated with its own drawn model (handed to the filter on purpose:
# this separates what the engine does with a flexing slave from what the learned model
# leaves) and one effect asked for; prints the effect's final estimate, σ and Wald.
# docs/diagnosis.md "Session 10" uses it to trace the clean seeds' spurious delays.
#
#   scripts/blind-truth-effect.sh OUT_DIR SEED [EFFECT] [MATCHING]
#   e.g. scripts/blind-truth-effect.sh out/t 107 time_delay '"attitude"'
#
# EFFECT defaults to time_delay; MATCHING (a TOML list body, e.g. '"velocity"') replaces
# the drawn model's matching when given. EDIT (sed expressions separated by ';;') edits
# the drawn scenario before it is simulated again, e.g.
#   EDIT='s/^sigma_arcmin = .*/sigma_arcmin = [0.001, 0.001, 0.001]/'
# DURATION (default 300 s) and EFFECT_DRAWN (a blind `--effect`, default none) choose the
# draw. Uses target/release/flexcal unless FLEXCAL names another.
set -euo pipefail
out="${1:?OUT_DIR}"
seed="${2:?SEED}"
effect="${3:-time_delay}"
matching="${4:-}"
F="${FLEXCAL:-target/release/flexcal}"
mkdir -p "$out"
tag="$seed-${effect}${matching:+-$(echo "$matching" | tr -dc 'a-z_,')}"
drawn="$out/draw-$seed.toml"
args=(simulate --blind --seed "$seed" --duration "${DURATION:-300}" --out "$out/blind-$seed" --drawn "$drawn")
if [[ -n ${EFFECT_DRAWN:-} ]]; then args+=(--effect "$EFFECT_DRAWN"); fi
"$F" "${args[@]}" > /dev/null
rm -rf "$out/blind-$seed"
scen="$out/scenario-$tag.toml"
cp "$drawn" "$scen"
if [[ -n ${EDIT:-} ]]; then
  IFS=$'\n' read -r -d '' -a edits < <(printf '%s' "$EDIT" | sed 's/;;/\n/g'; printf '\0') || true
  for e in "${edits[@]}"; do sed -i "$e" "$scen"; done
fi
rec="$out/truth-$tag"
rm -rf "$rec"
"$F" simulate --scenario "$scen" --seed "$seed" --out "$rec" > /dev/null
# The drawn mounting as the starting estimate (the drawn model declares none).
python3 "$(dirname "$0")/drawn-mounting.py" "$scen" >> "$rec/calibrate.toml"
if [[ -n $matching ]]; then
  sed -i "s/^matching = .*/matching = [$matching]/" "$rec/calibrate.toml"
fi
# A FAIL verdict (e.g. a NIS band the drawn model misses) still writes summary.json.
"$F" calibrate "$rec" --effects "$effect" --out "$rec-cal" > "$rec-cal.log" 2>&1 ||
  echo "calibrate exited $? (verdict in $rec-cal.log)" >&2
python3 - "$rec-cal/summary.json" "$tag" <<'EOF'
import json, sys
e = json.load(open(sys.argv[1]))["effects"][0]
print(sys.argv[2], e["name"], " ".join(f"{v:.4g}" for v in e["estimate"]), "±",
      " ".join(f"{v:.2g}" for v in e["sigma"]), f"Wald {e['wald']:.1f}")
EOF
