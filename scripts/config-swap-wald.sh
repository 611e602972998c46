#!/usr/bin/env bash
# Which learned value costs an effect its evidence: a recording calibrated with its truth's
# model (handed on purpose) and with that model with one key at a time replaced by the learned
# model's, each with EFFECT_A and EFFECT_B carried; prints per variant each effect's Wald
# statistic, estimate and σ (×1e6) and the mean NIS. docs/diagnosis.md "Session 19" uses it on
# blind draw 107 (accelerometer scale factors against gyro ones).
#
#   scripts/config-swap-wald.sh REC TRUTH.toml LEARNED.toml OUT EFFECT_A EFFECT_B [KEY...]
#
# TRUTH.toml: e.g. the calibrate.toml `simulate --scenario DRAWN.toml` writes (with the
# mounting from scripts/drawn-mounting.py appended); LEARNED.toml: the model.toml `flexcal
# calibrate REC --out DIR` learns. KEYs default to the noise and flexure keys.
# Uses target/release/flexcal unless FLEXCAL names another.
set -euo pipefail
F=${FLEXCAL:-target/release/flexcal}
rec=$1; truth=$2; learned=$3; out=$4; ea=$5; eb=$6; shift 6
keys=("$@")
[[ ${#keys[@]} -eq 0 ]] && keys=(velocity_noise_mps rate_noise_radps accel_vrw_mps_rs attitude_noise_rad gyro_bias_rw flexure_gauss_markov)
mkdir -p "$out"
run() {
  local name=$1 conf=$2
  for e in "$ea" "$eb"; do
    "$F" calibrate "$rec" --config "$conf" --effects "$e" --out "$out/$name-$e" > /dev/null 2>&1
    python3 - "$out/$name-$e/summary.json" "$name" "$e" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); e = d['effects'][0]
print('%-22s %-20s Wald %8.1f' % (sys.argv[2], sys.argv[3], e['wald']),
      ['%.0f' % (x * 1e6) for x in e['estimate']], ['%.0f' % (x * 1e6) for x in e['sigma']],
      'NIS %.3f' % d['innovations']['nis_mean'])
PY
  done
}
run truth "$truth"
for k in "${keys[@]}"; do
  line=$(grep "^$k = " "$learned" || true)
  [[ -z $line ]] && { echo "$k: not in $learned" >&2; continue; }
  sed "s|^$k = .*|$line|" "$truth" > "$out/$k.toml"
  run "$k" "$out/$k.toml"
done
run learned "$learned"
