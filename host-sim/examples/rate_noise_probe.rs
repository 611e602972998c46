//! Where the channels' innovation variance comes from: for a model (a learned
//! `model.toml`) and, given the blind draw's scenario, its declared truth, and each with
//! one piece of the other swapped in, the likelihood (−2 ln L), the mean NIS of the
//! velocity and attitude axes, and per rate axis the mean NIS, the RMS innovation and
//! the RMS predicted σ; then the model with its gyro ARW and its flexure damping scaled
//! (`docs/model-learning.md`, session 14).
//!
//!     cargo run --release -p flexcal-sim --example rate_noise_probe -- REC MODEL.toml [REC.drawn.toml]

use flexcal_sim::calib::config::CalibConfig;
use flexcal_sim::calib::run::{run, Precision};
use flexcal_sim::recording::read_recording;
use flexcal_sim::sim::scenario::Scenario;

fn report(label: &str, rec: &flexcal_sim::recording::Recording, cfg: &CalibConfig) {
    let res = match run(rec, cfg, Precision::F64) {
        Ok(r) => r,
        Err(e) => {
            println!("{label}: {e}");
            return;
        }
    };
    let neg2ll: f64 = res
        .innovations
        .iter()
        .map(|i| i.variance.ln() + i.value * i.value / i.variance)
        .sum();
    let mut line = format!("{label:>28}: -2lnL {neg2ll:.1}");
    for ch in 0..3 {
        for ax in 0..3 {
            let (mut n, mut nis, mut nu2, mut s) = (0usize, 0.0, 0.0, 0.0);
            for i in res
                .innovations
                .iter()
                .filter(|i| i.accepted && i.channel == ch && i.axis == ax)
            {
                n += 1;
                nis += i.value * i.value / i.variance;
                nu2 += i.value * i.value;
                s += i.variance;
            }
            let n = n.max(1) as f64;
            if ch == 2 {
                line += &format!(
                    " r{ax} nis {:.3} rms ν {:.2e} √s̄ {:.2e} |",
                    nis / n,
                    (nu2 / n).sqrt(),
                    (s / n).sqrt()
                );
            } else {
                line += &format!(" {:.2}", nis / n);
            }
        }
    }
    println!("{line}");
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rec = read_recording(std::path::Path::new(&args[0])).map_err(|e| e.to_string())?;
    let base = CalibConfig::load(std::path::Path::new(&args[1]))?;
    report("model", &rec, &base);
    if let Some(sc) = args.get(2) {
        let sc = Scenario::load(sc)?;
        let truth = CalibConfig::declared_for(&sc, base.filter_period_s);
        report("truth (declared)", &rec, &truth);
        let mut c = base.clone();
        c.flexure_gauss_markov = truth.flexure_gauss_markov;
        report("model, truth flexure", &rec, &c);
        let mut c = base.clone();
        c.gyro_arw_rad_rs = truth.gyro_arw_rad_rs;
        report("model, truth ARW", &rec, &c);
        // The truth with one of the model's pieces at a time.
        type Piece = (&'static str, fn(&mut CalibConfig, &CalibConfig));
        let pieces: [Piece; 9] = [
            ("velocity noise", |c, m| {
                c.velocity_noise_mps = m.velocity_noise_mps
            }),
            ("attitude noise", |c, m| {
                c.attitude_noise_rad = m.attitude_noise_rad
            }),
            ("rate noise", |c, m| c.rate_noise_radps = m.rate_noise_radps),
            ("lever-arm rate noise", |c, m| {
                c.lever_arm_rate_noise_radps = m.lever_arm_rate_noise_radps
            }),
            ("ARW, VRW", |c, m| {
                c.gyro_arw_rad_rs = m.gyro_arw_rad_rs;
                c.accel_vrw_mps_rs = m.accel_vrw_mps_rs
            }),
            ("flexure", |c, m| {
                c.flexure_gauss_markov = m.flexure_gauss_markov
            }),
            ("effects", |c, m| {
                c.effects = m.effects.clone();
                c.master_attitude_error_rad = m.master_attitude_error_rad;
                c.master_velocity_error_mps = m.master_velocity_error_mps;
                c.master_error_correlation_s = m.master_error_correlation_s;
            }),
            ("priors", |c, m| {
                c.initial_gyro_bias_radps = m.initial_gyro_bias_radps;
                c.initial_accel_bias_mps2 = m.initial_accel_bias_mps2;
                c.initial_misalignment_rad = m.initial_misalignment_rad;
                c.initial_flexure_rad = m.initial_flexure_rad;
            }),
            ("mounting", |c, m| {
                c.mounting_estimate_rad = m.mounting_estimate_rad
            }),
        ];
        for (name, f) in pieces {
            let mut c = truth.clone();
            f(&mut c, &base);
            report(&format!("truth + model's {name}"), &rec, &c);
        }
        let mut c = truth.clone();
        c.attitude_noise_rad = [1e-7; 3];
        report("truth, attitude noise 1e-7", &rec, &c);
        let mut c = truth.clone();
        c.gyro_arw_rad_rs *= 0.5;
        report("truth, ARW / 2", &rec, &c);
        for (name, f) in pieces {
            let mut c = base.clone();
            f(&mut c, &truth);
            report(&format!("model + truth's {name}"), &rec, &c);
        }
    }
    for k in [0.25, 0.5, 0.7, 1.4, 2.0] {
        let mut c = base.clone();
        c.gyro_arw_rad_rs *= k;
        report(&format!("ARW ×{k}"), &rec, &c);
    }
    for k in [0.25, 4.0] {
        let mut c = base.clone();
        if let Some(gm) = c.flexure_gauss_markov.as_mut() {
            for a in gm.iter_mut() {
                a[1] *= k; // damping: q ∝ ζ
            }
        }
        report(&format!("damping ×{k}"), &rec, &c);
    }
    Ok(())
}
