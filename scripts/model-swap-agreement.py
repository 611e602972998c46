#!/usr/bin/env python3
"""Which part of a learned model moves the estimates away from a configured run's
(issue 9, acceptance 4).

Takes a learned `model.toml`, swaps one group of its values at a time for the
configuration's (or removes a piece the configuration does not have), calibrates the
recording with each variant, and prints per variant the largest difference, per block,
of its estimates from the configured run's over the larger σ
(`scripts/estimate-agreement.py`'s measure).

    python3 scripts/model-swap-agreement.py FLEXCAL REC LEARNED_MODEL.toml CONFIGURED_SUMMARY.json OUTDIR

e.g. with the binary `target/release/flexcal`, the measured recording, the model
`flexcal calibrate REC --out A` wrote (A/model.toml) and the summary of `flexcal
calibrate REC --config configs/mems-vehicle.toml --out B` (B/summary.json). The swapped
values are those of `configs/mems-vehicle.toml` (written below, one group per line).
"""
import os
import re
import subprocess
import sys

# Each variant: (name, [(regex over the learned model's lines, replacement)]).
VARIANTS = [
    ("learned, as it is", []),
    ("no smooth master error", [(r'^effects = \[.*\]$', "effects = []")]),
    ("velocity noise configured", [(r"^velocity_noise_mps = .*$", "velocity_noise_mps = 0.05")]),
    ("attitude noise configured", [(r"^attitude_noise_rad = .*$", "attitude_noise_rad = 5.0e-4")]),
    (
        "flexure configured",
        [
            (r"^flexure_gauss_markov = .*$", ""),
            (r"^flexure_ar = .*$", "flexure_ar = [0.5, 0.0]"),
            (r"^flexure_sigma_rad = .*$", "flexure_sigma_rad = 1.0e-4"),
        ],
    ),
    ("no dynamic lever arm", [(r"^dynamic_lever_arm = true$", "dynamic_lever_arm = false")]),
    (
        "priors configured",
        [
            (r"^initial_velocity_mps = .*$", "initial_velocity_mps = 0.5"),
            (r"^initial_misalignment_rad = .*$", "initial_misalignment_rad = 0.035"),
            (r"^initial_gyro_bias_radps = .*$", "initial_gyro_bias_radps = 2.5e-3"),
            (r"^initial_accel_bias_mps2 = .*$", "initial_accel_bias_mps2 = 0.5"),
        ],
    ),
    ("no delay", [(r"^initial_delay_s = .*$", "initial_delay_s = 0.0")]),
    (
        "ARW and VRW configured",
        [
            (r"^gyro_arw_rad_rs = .*$", "gyro_arw_rad_rs = 1.5e-4"),
            (r"^accel_vrw_mps_rs = .*$", "accel_vrw_mps_rs = 1.7e-3"),
        ],
    ),
    (
        "bias walks configured",
        [
            (r"^gyro_bias_rw = .*$", "gyro_bias_rw = 1.0e-6"),
            (r"^accel_bias_rw = .*$", "accel_bias_rw = 1.0e-4"),
        ],
    ),
]


def agreement(flexcal, rec, model_text, configured, out):
    path = out + ".toml"
    with open(path, "w") as f:
        f.write(model_text)
    run = subprocess.run(
        [flexcal, "calibrate", rec, "--config", path, "--out", out], capture_output=True, text=True
    )
    failed = ""
    if run.returncode != 0:
        failed = f" (exit {run.returncode}: {' '.join(run.stderr.strip().splitlines()[-1:])[:90]})"
        if not os.path.exists(out + "/summary.json"):
            return "no summary" + failed
    here = os.path.dirname(os.path.abspath(__file__))
    table = subprocess.run(
        ["python3", os.path.join(here, "estimate-agreement.py"), out + "/summary.json", configured],
        capture_output=True,
        text=True,
    ).stdout
    cells = []
    for line in table.splitlines():
        parts = [p.strip() for p in line.split("|")]
        if len(parts) > 4 and ("bias" in parts[1] or "misalignment" in parts[1]):
            cells.append(f"{parts[1].split(' (')[0]}: {parts[4]}")
    return "; ".join(cells) + failed


def main(flexcal, rec, learned, configured, outdir):
    os.makedirs(outdir, exist_ok=True)
    text = open(learned).read()
    for name, subs in VARIANTS:
        variant = text
        for pattern, replacement in subs:
            changed = re.sub(pattern, replacement, variant, flags=re.M)
            if changed == variant:
                print(f"  ({name}: nothing matched {pattern!r}; the variant is the learned model)")
            variant = changed
        out = os.path.join(outdir, re.sub(r"[^a-z]+", "_", name))
        print(f"{name:28s} {agreement(flexcal, rec, variant, configured, out)}")


if __name__ == "__main__":
    if len(sys.argv) != 6:
        sys.exit(__doc__)
    main(*sys.argv[1:])
