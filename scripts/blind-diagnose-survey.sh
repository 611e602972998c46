#!/usr/bin/env bash
# Blind `diagnose` survey (issue 9, acceptance 3; issue 10, acceptance 1-2): for each
# undeclared effect of docs/diagnosis.md, for none, and for two at once, simulate blind
# recordings (no calibrate.toml), run `flexcal diagnose` with no configuration, and print
# per recording the strongest round-1 candidate (largest Wald), what the final model
# carries (after the backward pass, from diagnosis.json), and the wall time.
#
#   scripts/blind-diagnose-survey.sh OUT_DIR [DURATION_S] [SEEDS...]
#   e.g. scripts/blind-diagnose-survey.sh out/blind-diag 300 101 102 103
#   EFFECTS="none" scripts/blind-diagnose-survey.sh out/clean 300 $(seq 104 110)
#
# EFFECTS (space separated; default: none, each single effect, and time-delay,lever-arm-error)
# chooses the cases; a comma joins effects drawn together. CANDIDATES (comma separated,
# e.g. the default eight and clock_drift) is passed to `diagnose --candidates` when set.
# Uses target/release/flexcal
# (build it first: cargo build --release -p flexcal-sim) unless FLEXCAL names another.
set -euo pipefail
out="${1:?OUT_DIR}"
duration="${2:-300}"
shift $(( $# > 1 ? 2 : 1 ))
seeds=("$@")
[[ ${#seeds[@]} -eq 0 ]] && seeds=(101 102 103)
F="${FLEXCAL:-target/release/flexcal}"
read -r -a effects <<< "${EFFECTS:-none time-delay lever-arm-error gyro-scale-factor accel-scale-factor gyro-nonorthogonality gyro-g-sensitivity time-delay,lever-arm-error}"
mkdir -p "$out"
for effect in "${effects[@]}"; do
  for seed in "${seeds[@]}"; do
    rec="$out/${effect//,/+}-$seed"
    args=(simulate --blind --seed "$seed" --duration "$duration" --out "$rec")
    [[ $effect != none ]] && args+=(--effect "$effect")
    "$F" "${args[@]}" > /dev/null
    t0=$(date +%s.%N)
    dargs=(diagnose "$rec" --out "$rec-diag")
    [[ -n ${CANDIDATES:-} ]] && dargs+=(--candidates "$CANDIDATES")
    "$F" "${dargs[@]}" > "$rec-diag.log" 2>&1 || true
    t1=$(date +%s.%N)
    top=$(grep -E '^  round 1:' "$rec-diag.log" |
      sed -E 's/^  round 1: ([a-z_]+) \(Wald ([0-9.]+).*/\2 \1/' | sort -rn | head -n 1 || true)
    adopted=$(python3 -c 'import json, sys
d = json.load(open(sys.argv[1]))
print(",".join(e["name"] for e in d["effects_found"]))' "$rec-diag/diagnosis.json" 2>/dev/null || true)
    printf '%-24s seed %-4s strongest: %-28s adopted: %-20s %6.1f s\n' \
      "$effect" "$seed" "${top:-(none significant)}" "${adopted:-none}" \
      "$(awk "BEGIN { print $t1 - $t0 }")"
  done
done
