#!/usr/bin/env bash
# Blind `diagnose` survey (issue 9, acceptance 3): for each undeclared effect of
# docs/diagnosis.md and for none, simulate blind recordings (no calibrate.toml), run
# `flexcal diagnose` with no configuration, and print per recording the strongest round-1
# candidate (largest Wald), what was adopted, and the wall time.
#
#   scripts/blind-diagnose-survey.sh OUT_DIR [DURATION_S] [SEEDS...]
#   e.g. scripts/blind-diagnose-survey.sh out/blind-diag 300 101 102 103
#
# Uses target/release/flexcal (build it first: cargo build --release -p flexcal-sim).
set -euo pipefail
out="${1:?OUT_DIR}"
duration="${2:-300}"
shift $(( $# > 1 ? 2 : 1 ))
seeds=("$@")
[[ ${#seeds[@]} -eq 0 ]] && seeds=(101 102 103)
F="${FLEXCAL:-target/release/flexcal}"
mkdir -p "$out"
for effect in none time-delay lever-arm-error gyro-scale-factor accel-scale-factor \
  gyro-nonorthogonality gyro-g-sensitivity; do
  for seed in "${seeds[@]}"; do
    rec="$out/$effect-$seed"
    args=(simulate --blind --seed "$seed" --duration "$duration" --out "$rec")
    [[ $effect != none ]] && args+=(--effect "$effect")
    "$F" "${args[@]}" > /dev/null
    t0=$(date +%s.%N)
    "$F" diagnose "$rec" --out "$rec-diag" > "$rec-diag.log" 2>&1 || true
    t1=$(date +%s.%N)
    top=$(grep -E '^  round 1:' "$rec-diag.log" |
      sed -E 's/^  round 1: ([a-z_]+) \(Wald ([0-9.]+).*/\2 \1/' | sort -rn | head -n 1 || true)
    adopted=$(grep -E 'adopted: significant' "$rec-diag.log" |
      sed -E 's/^  round [0-9]+: ([a-z_]+).*/\1/' | paste -sd, - || true)
    printf '%-24s seed %-4s strongest: %-28s adopted: %-20s %6.1f s\n' \
      "$effect" "$seed" "${top:-(none significant)}" "${adopted:-none}" \
      "$(awk "BEGIN { print $t1 - $t0 }")"
  done
done
