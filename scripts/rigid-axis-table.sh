#!/usr/bin/env bash
# Rows of docs/diagnosis.md's table of rigid and stiff flexure axes: a scenario (a blind
# draw's drawn.toml, edited) with its flexure's `sigma_arcmin` replaced, simulated (seed
# $SEED, 1 unless set) and calibrated with its own model (handed its truth: the scenario's mounting
# appended), the matching as declared or as given. Prints per row the filter's health
# (resets, refused non-finite steps, clamped variances), the mean NEES of the calibrated
# states, the misalignment's and the gyro bias's error/σ per axis, the channels whose mean NIS is out of its band, and the verdict.
#
#   scripts/rigid-axis-table.sh SCENARIO OUT_DIR 'SX, SY, SZ' [MATCHING]...
#
# CAL_ARGS: more arguments for `flexcal calibrate` (e.g. `--effects gyro_scale_factor`).
#
# MATCHING is a TOML list's content, e.g. '"velocity"' or '"attitude", "angular_rate"';
# none: the declared matching. Uses target/release/flexcal unless FLEXCAL names another.
set -uo pipefail
F=${FLEXCAL:-target/release/flexcal}
scen=$1
out=$2
sigma=$3
shift 3
[ $# -eq 0 ] && set -- ""
mkdir -p "$out"
tag=$(echo "$sigma" | tr -d ' ' | tr ',' '_')
sed "s/^sigma_arcmin = .*/sigma_arcmin = [$sigma]/" "$scen" > "$out/s$tag.toml"
rec=$out/r$tag
rm -rf "$rec"
"$F" simulate --scenario "$out/s$tag.toml" --seed "${SEED:-1}" --out "$rec" > /dev/null
python3 "$(dirname "$0")/drawn-mounting.py" "$out/s$tag.toml" >> "$rec/calibrate.toml"
for m in "$@"; do
  mtag=$(echo "${m:-declared}" | tr -d ' "' | tr ',' '+')
  cp "$rec/calibrate.toml" "$rec/calibrate.declared"
  [ -n "$m" ] && sed -i "s/^matching = .*/matching = [$m]/" "$rec/calibrate.toml"
  "$F" calibrate "$rec" ${CAL_ARGS:-} --out "$rec-$mtag" > /dev/null 2>&1
  mv "$rec/calibrate.declared" "$rec/calibrate.toml"
  python3 - "$rec-$mtag/summary.json" "$sigma" "${m:-declared}" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
h = s["health"]
v = s["verdict"]
nis = ["%s %.2f" % (f["where"], f["numbers"]["nis_mean"]) for f in v["findings"]
       if f["code"] == "nis_out_of_band"]
z = lambda k: " ".join("%.1f" % (e / sd) for e, sd in zip(s["errors"][k], s[k + "_sigma"]))
print("| %s | %s | %d | %d | %d | %.2f | %s | %s | %s | %s |" % (
    sys.argv[2], sys.argv[3], h["filter_resets"], h["non_finite"], h["variance_clamped"],
    s["errors"]["nees_mean"], z("misalignment"), z("gyro_bias"), ", ".join(nis) or "–",
    v["level"]))
PY
done
