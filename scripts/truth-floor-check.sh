#!/usr/bin/env bash
# Does the filter stay consistent when it is handed its data's truth (issue 9, acceptance 1)?
# For each blind seed: simulate the draw, write its truth model (the drawn scenario run
# again writes calibrate.toml; the drawn misalignment is appended as the mounting), then
# calibrate with that truth model twice: with the matching noise floors as written
# (velocity 1 mm/s, attitude 2 µrad where the draw has none) and with floors at the board's
# f32 resolution (1e-5 m/s, 1e-7 rad). Prints one markdown row per seed and floor: the
# master's drawn kind, NEES of the nine calibrated states, the largest |error|/σ among them,
# the mean NIS per channel axis.
# The filter is handed the truth here on purpose: the check is of the filter's own
# model, not of the learner.
#
#   scripts/truth-floor-check.sh OUT_DIR DURATION_S SEED...
#
# Variants, each an environment variable (unset: the draw and its truth model as they are):
#   IMU_RATE_HZ=400              the slave IMU's rate in the draw
#   MASTER_RATE_HZ=50            the master's message rate in the draw
#   FLEXURE_ARCMIN=0.001         the drawn flexure's σ on every axis
#   FLEXURE_ARCMIN_AXES='2, 0.001, 0.001'  the drawn flexure's σ per axis (x, y, z)
#   MATCHING='"attitude"'        the channels matched (a TOML list's items)
#   MISALIGNMENT_PRIOR_RAD=0.0017  the initial misalignment σ (the truth model's is 1°)
#   LEVER_ARM_M='0.0, 0.0, 0.0'  the drawn lever arm (m, master body)
#   FLEXURE_OMEGA='1.5, 1.5, 1.5', FLEXURE_DAMPING='0.3, 0.3, 0.3'   the drawn mode per axis
#   ROLL_AMP_DEG=0, PITCH_AMP_DEG=0, YAW_AMP_DEG=0   the ship's drawn motion amplitudes
#   MISALIGNMENT_DEG='0.0, 0.0, 0.0'  the drawn mounting (deg)
#   FLOORS=truth                 only the floors as written (truth-f32: only the f32 ones)
#   SMOOTH_ATTITUDE_ARCSEC=0.001, SMOOTH_VELOCITY_MPS=1e-6   a smooth master's drawn σ
#   MASTER_RATE_NOISE_DEG_H, MASTER_ATTITUDE_NOISE_DEG, MASTER_VELOCITY_NOISE_MPS   its white noise
#
# Uses target/release/flexcal (build it first: cargo build --release -p flexcal-sim)
# unless FLEXCAL names another; python3 reads the JSON.
set -euo pipefail
out="${1:?OUT_DIR}"
dur="${2:?DURATION_S}"
shift 2
F="${FLEXCAL:-target/release/flexcal}"
mkdir -p "$out"
echo "| seed | master | floors | NEES | largest error/σ | NIS velocity E, N, U | NIS attitude x, y, z | NIS rate x, y, z |"
echo "|---|---|---|---|---|---|---|---|"
for s in "$@"; do
  "$F" simulate --blind --seed "$s" --duration "$dur" --out "$out/b$s" > /dev/null
  sed -e "${FLEXURE_OMEGA:+s/^omega_rad_s = .*/omega_rad_s = [$FLEXURE_OMEGA]/}" \
      -e "${FLEXURE_DAMPING:+s/^damping = .*/damping = [$FLEXURE_DAMPING]/}" \
      -e "${ROLL_AMP_DEG:+s/^roll_amp_deg = .*/roll_amp_deg = $ROLL_AMP_DEG/}" \
      -e "${PITCH_AMP_DEG:+s/^pitch_amp_deg = .*/pitch_amp_deg = $PITCH_AMP_DEG/}" \
      -e "${YAW_AMP_DEG:+s/^yaw_amp_deg = .*/yaw_amp_deg = $YAW_AMP_DEG/}" \
      -e "${MISALIGNMENT_DEG:+s/^misalignment_deg = .*/misalignment_deg = [$MISALIGNMENT_DEG]/}" \
      -e "${MASTER_RATE_HZ:+/^\[master\]/,/^\[/ s/^rate_hz = .*/rate_hz = $MASTER_RATE_HZ/}" \
      -e "${IMU_RATE_HZ:+/^\[slave_imu\]/,/^\[/ s/^rate_hz = .*/rate_hz = $IMU_RATE_HZ/}" \
      -e "${FLEXURE_ARCMIN_AXES:+s/^sigma_arcmin = .*/sigma_arcmin = [$FLEXURE_ARCMIN_AXES]/}" \
      -e "${FLEXURE_ARCMIN:+s/^sigma_arcmin = .*/sigma_arcmin = [$FLEXURE_ARCMIN, $FLEXURE_ARCMIN, $FLEXURE_ARCMIN]/}" \
      -e "${LEVER_ARM_M:+s/^r0_m = .*/r0_m = [$LEVER_ARM_M]/}" \
      -e "${SMOOTH_ATTITUDE_ARCSEC:+s/^attitude_arcsec = .*/attitude_arcsec = $SMOOTH_ATTITUDE_ARCSEC/}" \
      -e "${SMOOTH_VELOCITY_MPS:+s/^velocity_mps = .*/velocity_mps = $SMOOTH_VELOCITY_MPS/}" \
      -e "${MASTER_RATE_NOISE_DEG_H:+s/^rate_noise_deg_h = .*/rate_noise_deg_h = $MASTER_RATE_NOISE_DEG_H/}" \
      -e "${MASTER_ATTITUDE_NOISE_DEG:+s/^attitude_noise_deg = .*/attitude_noise_deg = $MASTER_ATTITUDE_NOISE_DEG/}" \
      -e "${MASTER_VELOCITY_NOISE_MPS:+s/^velocity_noise_mps = .*/velocity_noise_mps = $MASTER_VELOCITY_NOISE_MPS/}" \
      "$out/b$s.drawn.toml" > "$out/v$s.drawn.toml"
  "$F" simulate --scenario "$out/v$s.drawn.toml" --seed "$s" --out "$out/t$s" > /dev/null
  python3 - "$out/v$s.drawn.toml" "$out/t$s/calibrate.toml" > "$out/t$s-truth.toml" <<'PY'
import math, os, re, sys, tomllib
drawn = tomllib.load(open(sys.argv[1], 'rb'))
text = open(sys.argv[2]).read().rstrip()
if os.environ.get('MATCHING'):
    text = re.sub(r'^matching = .*$', 'matching = [%s]' % os.environ['MATCHING'], text, flags=re.M)
if os.environ.get('MISALIGNMENT_PRIOR_RAD'):
    text = re.sub(r'^initial_misalignment_rad = .*$',
                  'initial_misalignment_rad = %s' % os.environ['MISALIGNMENT_PRIOR_RAD'], text, flags=re.M)
print(text)
mu = [math.radians(x) for x in drawn['misalignment_deg']]
print('mounting_estimate_rad = [%s]' % ', '.join(repr(x) for x in mu))
PY
  sed -e 's/^velocity_noise_mps = \[0.001, 0.001, 0.001\]/velocity_noise_mps = [0.00001, 0.00001, 0.00001]/' \
      -e 's/^attitude_noise_rad = \[0.000002, 0.000002, 0.000002\]/attitude_noise_rad = [0.0000001, 0.0000001, 0.0000001]/' \
      "$out/t$s-truth.toml" > "$out/t$s-truth-f32.toml"
  for floors in ${FLOORS:-truth truth-f32}; do
    "$F" calibrate "$out/t$s" --config "$out/t$s-$floors.toml" --out "$out/c$s-$floors" > /dev/null 2>&1 || true
    python3 - "$s" "$floors" "$out/v$s.drawn.toml" "$out/c$s-$floors/summary.json" <<'PY'
import json, sys, tomllib
seed, floors, drawn_path, summary = sys.argv[1:5]
m = tomllib.load(open(drawn_path, 'rb'))['master']
kind = 'smooth' if 'smooth_error' in m else ('white' if m.get('velocity_noise_mps', 0) > 0 else 'none')
d = json.load(open(summary))
nis = {(r['channel'], r['axis']): r['nis_mean'] for r in d['residuals']}
def row(ch):
    return ', '.join(f"{nis[(ch, a)]:.2f}" if (ch, a) in nis else '–' for a in range(3))
e = d['errors']
worst = max(abs(e[k][a] / d[k + '_sigma'][a]) for k in ('gyro_bias', 'accel_bias', 'misalignment') for a in range(3))
label = 'as written' if floors == 'truth' else 'f32 resolution'
print(f"| {seed} | {kind} | {label} | {e['nees_mean']:.1f} | {worst:.1f} | {row('velocity')} | {row('attitude')} | {row('angular_rate')} |")
PY
  done
done
