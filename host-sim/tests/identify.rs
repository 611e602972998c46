//! Tests of flexure identification on the desktop: the `identify.json` contract and its
//! formulas, the command line on series files and recordings, clear errors on bad input,
//! sensible behaviour on series that are not AR processes, the exact maximum likelihood,
//! and the sequences built from simulated recordings.

use flexcal_core::stats;
use flexcal_sim::identify::exact::{ar_to_pacf, exact_log_likelihood, pacf_to_ar};
use flexcal_sim::identify::{
    flexure_sequence, identify_series, parse_series_csv, simulate_ar, Criterion, IdentifyOptions,
    SequenceKind,
};
use flexcal_sim::sim::{simulate, Scenario};
use nalgebra::DMatrix;
use proptest::prelude::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_flexcal");

fn flexcal(args: &[&str]) -> Output {
    match Command::new(BIN).args(args).output() {
        Ok(o) => o,
        Err(e) => panic!("cannot run {BIN}: {e}"),
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn tmp() -> tempfile::TempDir {
    match tempfile::tempdir() {
        Ok(d) => d,
        Err(e) => panic!("tempdir: {e}"),
    }
}

fn write(path: &Path, text: &str) {
    if let Err(e) = std::fs::write(path, text) {
        panic!("{}: {e}", path.display());
    }
}

fn read_json(path: &Path) -> Value {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => panic!("{}: {e}", path.display()),
    };
    match serde_json::from_str(&text) {
        Ok(v) => v,
        Err(e) => panic!("{}: {e}", path.display()),
    }
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

fn u(v: &Value) -> usize {
    v.as_u64().map_or(usize::MAX, |x| x as usize)
}

/// A CSV with a time column, the series `y` and a decoy column, with comments and blank lines.
fn series_csv(y: &[f64]) -> String {
    let mut s = String::from("# flexure test series\nt, theta ,decoy\n\n");
    for (k, v) in y.iter().enumerate() {
        s.push_str(&format!("{},{v:e},{}\n", k as f64 * 0.01, (k % 7) as f64));
        if k == 10 {
            s.push_str("   # a comment in the middle\n");
        }
    }
    s
}

#[test]
fn cli_series_writes_the_contract_and_its_formulas_hold() {
    let dir = tmp();
    let y = simulate_ar(&[1.2, -0.5], 1e-3, 2000, 7);
    let csv = dir.path().join("s.csv");
    write(&csv, &series_csv(&y));
    let out = dir.path().join("out");
    let o = flexcal(&[
        "identify",
        "--series",
        &csv.display().to_string(),
        "--column",
        "theta",
        "--out",
        &out.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("AIC") && stdout.contains("BIC"), "{stdout}");
    assert!(out.join("prediction.svg").exists());

    let j = read_json(&out.join("identify.json"));
    assert!(j["tool_version"].is_string());
    let n = u(&j["n"]);
    // Default max order 6: the first 6 samples are initial conditions for every order.
    assert_eq!(n, 2000 - 6);
    let orders = j["orders"].as_array().cloned().unwrap_or_default();
    assert_eq!(orders.len(), 7);
    let nf = n as f64;
    let mean = f(&j["mean_removed"]);
    let x: Vec<f64> = y.iter().map(|v| v - mean).collect();
    for (p, o) in orders.iter().enumerate() {
        assert_eq!(u(&o["p"]), p);
        let sigma2 = f(&o["sigma2"]);
        let coeffs: Vec<f64> = o["coefficients"]
            .as_array()
            .map(|a| a.iter().map(f).collect())
            .unwrap_or_default();
        assert_eq!(coeffs.len(), p);
        // aic = n ln σ² + 2p and bic = n ln σ² + p ln n (exact in the library, see the property
        // test below; here within the last-digit rounding of serde_json's default float parser).
        let pf = p as f64;
        let (aic, bic) = (nf * sigma2.ln() + pf * 2.0, nf * sigma2.ln() + pf * nf.ln());
        assert!(
            (f(&o["aic"]) - aic).abs() <= 1e-14 * aic.abs(),
            "aic of order {p}"
        );
        assert!(
            (f(&o["bic"]) - bic).abs() <= 1e-14 * bic.abs(),
            "bic of order {p}"
        );
        // σ² = RSS / n over the common range k = 7..=2000 (1-based).
        let rss: f64 = (6..x.len())
            .map(|k| {
                let pred: f64 = (1..=p).map(|i| coeffs[i - 1] * x[k - i]).sum();
                (x[k] - pred).powi(2)
            })
            .sum();
        assert!(
            ((rss / nf) - sigma2).abs() <= 1e-9 * sigma2,
            "order {p}: {} vs {sigma2}",
            rss / nf
        );
    }
    let p = u(&j["selected_order"]);
    assert_eq!(j["selected_by"], "aic");
    assert!((2..=6).contains(&p), "selected {p}");
    // The selected order minimizes AIC.
    let best = orders
        .iter()
        .min_by(|a, b| f(&a["aic"]).total_cmp(&f(&b["aic"])))
        .map(|o| u(&o["p"]));
    assert_eq!(best, Some(p));
    let lb = &j["ljung_box"];
    assert_eq!(u(&lb["lags"]), 20);
    assert_eq!(u(&lb["dof"]), 20 - p);
    assert_eq!(f(&lb["alpha"]), 0.05);
    let critical = stats::chi2_isf(0.05, (20 - p) as f64);
    assert!((f(&lb["critical"]) - critical).abs() < 1e-9 * critical);
    assert_eq!(
        lb["white"].as_bool(),
        Some(f(&lb["q"]) <= f(&lb["critical"]))
    );
    assert_eq!(lb["white"].as_bool(), Some(true));
    // Extras: the exact-ML refinement of the selected order.
    let ml = &j["exact_ml"];
    assert_eq!(u(&ml["order"]), p);
    assert!(f(&ml["log_likelihood"]) >= f(&ml["conditional_ls_log_likelihood"]));
}

#[test]
fn cli_series_options_and_single_column() {
    let dir = tmp();
    let y = simulate_ar(&[0.6], 1.0, 500, 3);
    let mut text = String::from("x\n");
    for v in &y {
        text.push_str(&format!("{v}\r\n"));
    }
    let csv = dir.path().join("one.csv");
    write(&csv, &text);
    let out = dir.path().join("o");
    let fig = dir.path().join("figs/fig.svg");
    let o = flexcal(&[
        "identify",
        "--series",
        &csv.display().to_string(),
        "--out",
        &out.display().to_string(),
        "--max-order",
        "3",
        "--criterion",
        "bic",
        "--lags",
        "10",
        "--alpha",
        "0.01",
        "--figure",
        &fig.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(fig.exists());
    let j = read_json(&out.join("identify.json"));
    assert_eq!(j["selected_by"], "bic");
    assert_eq!(u(&j["selected_order"]), 1);
    assert_eq!(u(&j["n"]), 500 - 3);
    assert_eq!(j["orders"].as_array().map(Vec::len), Some(4));
    assert_eq!(u(&j["ljung_box"]["lags"]), 10);
    assert_eq!(u(&j["ljung_box"]["dof"]), 9);
    assert_eq!(f(&j["ljung_box"]["alpha"]), 0.01);
}

/// Runs the CLI on `text` as a series file and returns its error message.
fn csv_error(text: &str, extra: &[&str]) -> String {
    let dir = tmp();
    let csv = dir.path().join("bad.csv");
    write(&csv, text);
    let out = dir.path().join("o");
    let mut args = vec![
        "identify".to_string(),
        "--series".to_string(),
        csv.display().to_string(),
        "--out".to_string(),
        out.display().to_string(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = flexcal(&refs);
    assert!(!o.status.success(), "accepted: {text:?} {extra:?}");
    let e = stderr(&o);
    assert!(!e.contains("panicked"), "{e}");
    assert!(!out.join("identify.json").exists());
    e
}

#[test]
fn bad_csv_gives_clear_errors() {
    let good: String = (0..100)
        .map(|k| format!("{},{}\n", k, (k * 37 % 11) as f64))
        .collect();
    let e = csv_error(&format!("t,v\n{good}"), &["--column", "theta"]);
    assert!(
        e.contains("bad.csv") && e.contains("no column `theta`") && e.contains("t, v"),
        "{e}"
    );
    let e = csv_error(&format!("t,v\n{good}"), &[]);
    assert!(e.contains("--column"), "{e}");
    let e = csv_error("t,v\n0,1\n1,2\n2,abc\n3,4\n", &["--column", "v"]);
    assert!(
        e.contains("bad.csv, line 4, column 2 (v): `abc` is not a number"),
        "{e}"
    );
    let e = csv_error("t,v\n0,1\n1\n", &["--column", "v"]);
    assert!(
        e.contains("line 3") && e.contains("1 fields, the header has 2"),
        "{e}"
    );
    let e = csv_error("# only a comment\n\n", &[]);
    assert!(e.contains("empty file"), "{e}");
    let e = csv_error("v\n", &[]);
    assert!(e.contains("no data rows"), "{e}");
    let e = csv_error("v\n1\nNaN\n", &[]);
    assert!(
        e.contains("line 3") && e.contains("not a finite number"),
        "{e}"
    );
    let e = csv_error("v\n1\n1e999\n", &[]);
    assert!(
        e.contains("line 3") && e.contains("not a finite number"),
        "{e}"
    );
    let e = csv_error("a,,b\n1,2,3\n", &["--column", "a"]);
    assert!(
        e.contains("line 1, column 2") && e.contains("empty column name"),
        "{e}"
    );
    let e = csv_error("a,a\n1,2\n", &["--column", "a"]);
    assert!(e.contains("duplicate column name"), "{e}");
    let e = csv_error("v\n1\n2\n", &[]);
    assert!(
        e.contains("no AR order could be fitted") || e.contains("Ljung-Box"),
        "{e}"
    );
    let e = csv_error(&format!("v\n{}", "5\n".repeat(100)), &[]);
    assert!(e.contains("identically zero"), "{e}");
    // Option checks.
    let series: String = std::iter::once("v\n".to_string())
        .chain(
            simulate_ar(&[0.5], 1.0, 300, 1)
                .iter()
                .map(|v| format!("{v}\n")),
        )
        .collect();
    let e = csv_error(&series, &["--max-order", "13"]);
    assert!(e.contains("exceeds the largest supported order 12"), "{e}");
    let e = csv_error(&series, &["--lags", "6"]);
    assert!(e.contains("must exceed the max order 6"), "{e}");
    let e = csv_error(&series, &["--alpha", "1.5"]);
    assert!(e.contains("alpha"), "{e}");
    let e = csv_error(&series, &["--criterion", "hqc"]);
    assert!(e.contains("hqc"), "{e}");
    // A file that does not exist; neither input; both inputs.
    let dir = tmp();
    let missing = dir.path().join("missing.csv");
    let o = flexcal(&[
        "identify",
        "--series",
        &missing.display().to_string(),
        "--out",
        &dir.path().display().to_string(),
    ]);
    assert!(!o.status.success() && stderr(&o).contains("missing.csv"));
    let o = flexcal(&["identify", "--out", &dir.path().display().to_string()]);
    assert!(!o.status.success() && !stderr(&o).contains("panicked"));
    let o = flexcal(&[
        "identify",
        "somewhere",
        "--series",
        "x.csv",
        "--out",
        &dir.path().display().to_string(),
    ]);
    assert!(!o.status.success() && !stderr(&o).contains("panicked"));
}

#[test]
fn parse_errors_name_origin_line_and_column() {
    let e = parse_series_csv("mem", "a,b\n1,2\n3,x\n", Some("b"))
        .err()
        .unwrap_or_default();
    assert_eq!(e, "mem, line 3, column 2 (b): `x` is not a number");
    let ok = parse_series_csv("mem", " a , b \r\n# c\n1, 2\r\n\n3 ,4\n", Some("b"));
    assert_eq!(ok.map(|c| c.values), Ok(vec![2.0, 4.0]));
}

fn opts(max_order: usize, criterion: Criterion) -> IdentifyOptions {
    IdentifyOptions {
        max_order,
        criterion,
        ..IdentifyOptions::default()
    }
}

/// Standard normal noise from the AR simulator (an AR(0)).
fn noise(n: usize, seed: u64) -> Vec<f64> {
    simulate_ar(&[], 1.0, n, seed)
}

#[test]
fn white_noise_is_order_zero_and_white() {
    // Over many independent series: BIC picks order 0 nearly always, and the Ljung-Box test
    // rejects whiteness about α = 5 % of the time (its false-alarm rate), no more.
    let (mut zero, mut rejected, runs) = (0, 0, 40);
    for seed in 0..runs {
        let x: Vec<f64> = noise(2000, seed).iter().map(|v| 3.0 + 0.2 * v).collect();
        let r = identify_series(&x, &opts(6, Criterion::Bic)).unwrap_or_else(|e| panic!("{e}"));
        zero += usize::from(r.selected_order == 0);
        rejected += usize::from(!r.ljung_box.white);
        assert!((r.mean_removed - 3.0).abs() < 0.05);
    }
    eprintln!("white noise: BIC order 0 in {zero}/{runs}, whiteness rejected in {rejected}/{runs}");
    assert!(zero >= runs as usize - 2, "order 0 in {zero} of {runs}");
    assert!(rejected <= 6, "whiteness rejected in {rejected} of {runs}");
}

#[test]
fn random_walk_is_order_one_near_unit_root_and_white() {
    let steps = noise(3000, 11);
    let mut acc = 0.0;
    let x: Vec<f64> = steps
        .iter()
        .map(|s| {
            acc += s;
            acc
        })
        .collect();
    let r = identify_series(&x, &opts(6, Criterion::Bic)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.selected_order, 1);
    let a = r.selected().map(|o| o.coefficients[0]).unwrap_or(0.0);
    assert!((a - 1.0).abs() < 0.01, "a1 = {a}");
    assert!(r.ljung_box.white, "{:?}", r.ljung_box);
    // The exact likelihood keeps the model stationary: |a1| < 1.
    let ml = r
        .exact_ml
        .as_ref()
        .map(|m| m.coefficients[0])
        .unwrap_or(9.0);
    assert!(ml.abs() < 1.0 && (ml - a).abs() < 0.01, "ML a1 = {ml}");
}

#[test]
fn sine_plus_noise_needs_at_least_order_two() {
    // A sinusoid in noise is ARMA(2,2): the AR approximation needs order ≥ 2. With a strong
    // sinusoid, orders up to 6 leave correlated residuals: whiteness is (rightly) rejected.
    let e = noise(4000, 5);
    let strong: Vec<f64> = e
        .iter()
        .enumerate()
        .map(|(k, v)| 10.0 * (0.3 * k as f64).sin() + 0.5 * v)
        .collect();
    let r = identify_series(&strong, &opts(6, Criterion::Aic)).unwrap_or_else(|e| panic!("{e}"));
    assert!(r.selected_order >= 2, "order {}", r.selected_order);
    let a = r
        .order(2)
        .map(|o| o.coefficients.clone())
        .unwrap_or_default();
    // The AR(2)'s complex poles sit at the sinusoid's frequency: cos w = a1 / (2 sqrt(−a2)).
    // (The noise pulls them inside the unit circle.)
    let w = (a[0] / (2.0 * (-a[1]).sqrt())).acos();
    assert!((w - 0.3).abs() < 0.02 && a[1] < -0.8, "{a:?}: w = {w}");
    assert!(!r.ljung_box.white, "{:?}", r.ljung_box);
    // With a larger max order the residuals become white.
    let r12 = identify_series(
        &strong,
        &IdentifyOptions {
            max_order: 12,
            lags: 30,
            ..IdentifyOptions::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(r12.selected_order >= r.selected_order);
    // A weak sinusoid (amplitude 0.1 in unit noise) is barely visible: a low order is chosen
    // and its residuals pass.
    let weak: Vec<f64> = e
        .iter()
        .enumerate()
        .map(|(k, v)| 0.1 * (0.3 * k as f64).sin() + v)
        .collect();
    let r = identify_series(&weak, &opts(6, Criterion::Bic)).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        r.selected_order <= 2 && r.ljung_box.white,
        "{} {:?}",
        r.selected_order,
        r.ljung_box
    );
}

#[test]
fn ar2_order_and_coefficients_are_recovered() {
    let a = [1.2, -0.5];
    let x = simulate_ar(&a, 0.1, 5000, 21);
    let r = identify_series(&x, &opts(6, Criterion::Bic)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.selected_order, 2);
    let c = r
        .selected()
        .map(|o| o.coefficients.clone())
        .unwrap_or_default();
    assert!(
        (c[0] - a[0]).abs() < 0.03 && (c[1] - a[1]).abs() < 0.03,
        "{c:?}"
    );
    assert!(r.ljung_box.white);
}

#[test]
fn gaps_split_the_residual_range() {
    let mut x = simulate_ar(&[0.7], 1.0, 1000, 4);
    x[400] = f64::NAN;
    let r = identify_series(&x, &opts(3, Criterion::Aic)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.segments, 2);
    assert_eq!(r.samples, 999);
    assert_eq!(r.n, (400 - 3) + (599 - 3));
    assert_eq!(r.ljung_box.n, r.n);
}

/// The exact log-likelihood by brute force: dense autocovariance matrix, Cholesky.
fn dense_log_likelihood(u: &[f64], a: &[f64]) -> f64 {
    // Autocovariances of the AR with unit innovation variance, from a long MA(∞) expansion.
    let n = u.len();
    let m = 4000;
    let mut psi = vec![0.0; m];
    psi[0] = 1.0;
    for j in 1..m {
        psi[j] = (1..=a.len().min(j)).map(|i| a[i - 1] * psi[j - i]).sum();
    }
    let gamma: Vec<f64> = (0..n)
        .map(|h| (0..m - h).map(|j| psi[j] * psi[j + h]).sum())
        .collect();
    let g = DMatrix::from_fn(n, n, |i, j| gamma[i.abs_diff(j)]);
    let chol = g
        .cholesky()
        .unwrap_or_else(|| panic!("not positive definite"));
    let logdet: f64 = chol.l().diagonal().iter().map(|d| 2.0 * d.ln()).sum();
    let v = nalgebra::DVector::from_column_slice(u);
    let quad = v.dot(&chol.solve(&v));
    let nf = n as f64;
    -0.5 * nf * ((2.0 * std::f64::consts::PI).ln() + 1.0 + (quad / nf).ln()) - 0.5 * logdet
}

#[test]
fn exact_likelihood_matches_the_dense_formula() {
    let u = simulate_ar(&[0.9, -0.4, 0.1], 1.0, 12, 9);
    for a in [
        vec![],
        vec![0.5],
        vec![0.9, -0.4],
        vec![0.9, -0.4, 0.1],
        vec![-0.3, 0.2, 0.1, -0.2],
    ] {
        let (ll, _) = exact_log_likelihood(&[&u], &a).unwrap_or((f64::NAN, 0.0));
        let dense = dense_log_likelihood(&u, &a);
        assert!(
            (ll - dense).abs() < 1e-9 * dense.abs().max(1.0),
            "{a:?}: {ll} vs {dense}"
        );
    }
    assert!(exact_log_likelihood(&[&u], &[1.0]).is_none());
    let a = [0.9, -0.4, 0.1];
    let r = ar_to_pacf(&a).unwrap_or_default();
    for (x, y) in pacf_to_ar(&r).iter().zip(a.iter()) {
        assert!((x - y).abs() < 1e-12);
    }
}

#[test]
fn exact_ml_refines_short_series_and_agrees_on_long_ones() {
    let a = [1.2, -0.5];
    let mut differed = 0;
    for (seed, n) in [(1, 50), (2, 60), (3, 80), (4, 100), (5, 70)] {
        let x = simulate_ar(&a, 1.0, n, seed);
        let o = IdentifyOptions {
            max_order: 2,
            lags: 10,
            ..IdentifyOptions::default()
        };
        let r = identify_series(&x, &o).unwrap_or_else(|e| panic!("{e}"));
        let ls = r
            .order(2)
            .map(|o| o.coefficients.clone())
            .unwrap_or_default();
        let segs = [x.iter().map(|v| v - r.mean_removed).collect::<Vec<f64>>()];
        let refs: Vec<&[f64]> = segs.iter().map(Vec::as_slice).collect();
        let ml = flexcal_sim::identify::exact_ml(&refs, &ls).unwrap_or_else(|e| panic!("{e}"));
        let ll_ls = exact_log_likelihood(&refs, &ls).map_or(f64::NEG_INFINITY, |v| v.0);
        assert!(ml.log_likelihood >= ll_ls, "n = {n}");
        let diff = ml
            .coefficients
            .iter()
            .zip(ls.iter())
            .map(|(m, l)| (m - l).abs())
            .fold(0.0, f64::max);
        if diff > 1e-3 && ml.log_likelihood > ll_ls + 1e-6 {
            differed += 1;
        }
    }
    assert!(
        differed >= 4,
        "exact ML differed from conditional LS on {differed} of 5 short series"
    );
    let x = simulate_ar(&a, 1.0, 2000, 6);
    let o = IdentifyOptions {
        max_order: 2,
        criterion: Criterion::Bic,
        ..IdentifyOptions::default()
    };
    let r = identify_series(&x, &o).unwrap_or_else(|e| panic!("{e}"));
    let ls = r
        .order(2)
        .map(|o| o.coefficients.clone())
        .unwrap_or_default();
    let ml = r.exact_ml.unwrap_or_else(|| panic!("no exact ML"));
    for (m, l) in ml.coefficients.iter().zip(ls.iter()) {
        assert!((m - l).abs() < 5e-3, "{m} vs {l}");
    }
    assert!(ml.log_likelihood >= ml.start_log_likelihood.unwrap_or(f64::INFINITY));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Any series, however degenerate, gives a report or an error, never a panic, and every
    /// reported order satisfies the criteria formulas.
    #[test]
    fn any_series_never_panics(
        x in proptest::collection::vec(
            prop_oneof![
                -1e3..1e3f64,
                Just(0.0),
                Just(f64::NAN),
                Just(1e300),
                Just(-1e-300),
                Just(f64::INFINITY),
            ],
            0..120,
        ),
        max_order in 0usize..8,
        demean in any::<bool>(),
    ) {
        let o = IdentifyOptions { max_order, lags: 10, demean, ..IdentifyOptions::default() };
        if let Ok(r) = identify_series(&x, &o) {
            let n = r.n as f64;
            for row in &r.orders {
                prop_assert!(row.sigma2.is_finite() && row.sigma2 > 0.0);
                prop_assert_eq!(row.aic, n * row.sigma2.ln() + 2.0 * row.p as f64);
                prop_assert_eq!(row.bic, n * row.sigma2.ln() + row.p as f64 * n.ln());
            }
            prop_assert!(r.ljung_box.dof == 10 - r.selected_order);
        }
    }
}

/// A short simulated recording (`seconds` of the scenario).
fn recording(scenario: &str, seconds: f64, dir: &Path) -> PathBuf {
    let mut sc = Scenario::load(scenario).unwrap_or_else(|e| panic!("{e}"));
    sc.duration_s = seconds;
    let out = simulate(&sc, 3);
    let path = dir.join(scenario);
    flexcal_sim::recording::write_recording(&path, &out.recording)
        .unwrap_or_else(|e| panic!("{e}"));
    path
}

#[test]
fn sequences_from_a_simulated_recording() {
    let mut sc = Scenario::load("matched").unwrap_or_else(|e| panic!("{e}"));
    sc.duration_s = 60.0;
    let rec = simulate(&sc, 5).recording;
    let truth = flexure_sequence(&rec, SequenceKind::Truth, 0.01).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(truth.t.len(), 6001);
    let o = opts(4, Criterion::Bic);
    // The true flexure is the AR(2) [1.9939182643, −0.9940179641]: recovered.
    for ax in &truth.axes {
        let r = identify_series(ax, &o).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.selected_order, 2);
        let c = &r.orders[2].coefficients;
        assert!(
            (c[0] - 1.9939182643).abs() < 0.01 && (c[1] + 0.9940179641).abs() < 0.01,
            "{c:?}"
        );
        assert!(r.ljung_box.white);
    }
    // Ours follows the true flexure closely; its AR(2) has poles near the true ones.
    let ours = flexure_sequence(&rec, SequenceKind::RateIntegrated, 0.01)
        .unwrap_or_else(|e| panic!("{e}"));
    for (a, ax) in ours.axes.iter().enumerate() {
        let r = identify_series(ax, &o).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            r.selected_order >= 2,
            "axis {a}: order {}",
            r.selected_order
        );
        let c = &r.orders[2].coefficients;
        assert!(
            (c[0] - 1.9939).abs() < 0.02 && (c[1] + 0.9940).abs() < 0.02,
            "axis {a}: {c:?}"
        );
        // Correlation with the truth at the same instants.
        let (s, t) = (ax, &truth.axes[a]);
        let k0 = truth
            .t
            .iter()
            .position(|&x| (x - ours.t[0]).abs() < 1e-9)
            .unwrap_or(0);
        let pairs: Vec<(f64, f64)> = s
            .iter()
            .zip(t.iter().skip(k0))
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .map(|(a, b)| (*a, *b))
            .collect();
        let m =
            |f: &dyn Fn(&(f64, f64)) -> f64| pairs.iter().map(f).sum::<f64>() / pairs.len() as f64;
        let (ma, mb) = (m(&|p| p.0), m(&|p| p.1));
        let cov = m(&|p| (p.0 - ma) * (p.1 - mb));
        let corr = cov / (m(&|p| (p.0 - ma).powi(2)) * m(&|p| (p.1 - mb).powi(2))).sqrt();
        eprintln!("axis {a}: correlation {corr}");
        assert!(corr > 0.7, "axis {a}: correlation {corr}");
    }
    // The paper's gyro differences are dominated by the ship's motion: not white at any order.
    let d = flexure_sequence(&rec, SequenceKind::GyroDifference, 0.01)
        .unwrap_or_else(|e| panic!("{e}"));
    let r = identify_series(&d.axes[0], &o).unwrap_or_else(|e| panic!("{e}"));
    assert!(!r.ljung_box.white);
    // A period that is not a whole number of master periods is refused.
    let e = flexure_sequence(&rec, SequenceKind::Truth, 0.015)
        .err()
        .unwrap_or_default();
    assert!(e.contains("whole number"), "{e}");
}

#[test]
fn cli_on_a_recording_reports_every_axis_and_the_truth() {
    let dir = tmp();
    let rec = recording("moored", 30.0, dir.path());
    let out = dir.path().join("id");
    let o = flexcal(&[
        "identify",
        &rec.display().to_string(),
        "--out",
        &out.display().to_string(),
        "--axis",
        "y",
        "--max-order",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = read_json(&out.join("identify.json"));
    assert_eq!(j["sequence"], "rate-integrated");
    assert_eq!(j["axis"], "y");
    for k in [
        "n",
        "orders",
        "selected_order",
        "selected_by",
        "ljung_box",
        "tool_version",
    ] {
        assert!(!j[k].is_null(), "missing {k}");
    }
    for ax in ["x", "y", "z"] {
        assert!(j["axes"][ax]["orders"].is_array(), "axis {ax}");
    }
    assert_eq!(j["axes"]["y"]["selected_order"], j["selected_order"]);
    assert!(j["truth_reference"]["orders"].is_array());
    eprintln!("{}", j["sequence_vs_truth"]);
    assert!(f(&j["sequence_vs_truth"]["correlation"]) > 0.5);
    assert!(out.join("prediction.svg").exists());
    // Gyro differences and the truth itself through the command line.
    for kind in ["gyro-difference", "truth"] {
        let o = flexcal(&[
            "identify",
            &rec.display().to_string(),
            "--out",
            &out.display().to_string(),
            "--sequence",
            kind,
            "--no-exact-ml",
        ]);
        assert!(o.status.success(), "{kind}: {}", stderr(&o));
        assert_eq!(read_json(&out.join("identify.json"))["sequence"], kind);
    }
    // A directory that is not a recording.
    let o = flexcal(&[
        "identify",
        &dir.path().join("nothing").display().to_string(),
        "--out",
        &out.display().to_string(),
    ]);
    assert!(!o.status.success() && !stderr(&o).contains("panicked"));
}

/// Order selection over `runs` simulated AR series: counts of (under, exact, over) for AIC and
/// BIC, and how often Ljung-Box rejects the AIC-selected model.
fn selection_rates(a: &[f64], n: usize, runs: u64) -> ([usize; 3], [usize; 3], usize) {
    let (mut aic, mut bic, mut rejected) = ([0; 3], [0; 3], 0);
    let p_true = a.len();
    let o = IdentifyOptions {
        exact_ml: false,
        ..IdentifyOptions::default()
    };
    for seed in 0..runs {
        let x = simulate_ar(a, 1.0, n, 1000 + seed);
        let r = identify_series(&x, &o).unwrap_or_else(|e| panic!("{e}"));
        let slot = |p: usize| match p.cmp(&p_true) {
            std::cmp::Ordering::Less => 0,
            std::cmp::Ordering::Equal => 1,
            std::cmp::Ordering::Greater => 2,
        };
        aic[slot(r.selected_aic)] += 1;
        bic[slot(r.selected_bic)] += 1;
        rejected += usize::from(!r.ljung_box.white);
    }
    (aic, bic, rejected)
}

#[test]
fn aic_overfits_sometimes_bic_rarely() {
    let (aic, bic, _) = selection_rates(&[1.9939182643, -0.9940179641], 2000, 100);
    assert!(aic[0] == 0 && aic[2] >= 5 && aic[2] <= 50, "AIC {aic:?}");
    assert!(bic[0] == 0 && bic[2] <= 5, "BIC {bic:?}");
}

/// The AIC overfit table of docs/identification.md (run with `--ignored --nocapture`).
#[test]
#[ignore = "regenerates the AIC over-fit table of docs/identification.md (slow); run with --ignored --nocapture"]
fn aic_overfit_rate_table() {
    let runs = 200;
    println!("| model | n | AIC under/exact/over | BIC under/exact/over | Ljung-Box rejects (AIC order) |");
    println!("|---|---|---|---|---|");
    for (name, a) in [
        (
            "matched [1.9939182643, -0.9940179641]",
            [1.9939182643, -0.9940179641],
        ),
        ("paper eq. (32) [0.0035, 0.07]", [0.0035, 0.07]),
    ] {
        for n in [6_000, 60_000] {
            let (aic, bic, rej) = selection_rates(&a, n, runs);
            let pct = |c: usize| 100.0 * c as f64 / runs as f64;
            println!(
                "| {name} | {n} | {:.1} / {:.1} / {:.1} % | {:.1} / {:.1} / {:.1} % | {:.1} % |",
                pct(aic[0]),
                pct(aic[1]),
                pct(aic[2]),
                pct(bic[0]),
                pct(bic[1]),
                pct(bic[2]),
                pct(rej)
            );
        }
    }
}

/// The board's strategy (docs/identification.md): in f32 the strongly oversampled flexure
/// (poles near 1 at 100 Hz) fails the condition test from order 2 on; decimating by 10 or
/// identifying in f64 works.
#[test]
fn f32_on_an_oversampled_flexure_is_ill_conditioned() {
    use flexcal_core::ident::{ArIdentifier, FitError};
    let x = simulate_ar(&[1.9939182643, -0.9940179641], 3.2e-7, 20_000, 8);
    let mut id32 = ArIdentifier::<f32, 4>::new();
    let mut id64 = ArIdentifier::<f64, 4>::new();
    let mut dec32 = ArIdentifier::<f32, 4>::new();
    for (k, &v) in x.iter().enumerate() {
        id32.push(v as f32);
        id64.push(v);
        if k % 10 == 0 {
            dec32.push(v as f32);
        }
    }
    let f32_fits = id32.fit_all();
    assert!(matches!(
        f32_fits.order(2),
        Some(Err(FitError::IllConditioned { .. }))
    ));
    assert!(matches!(id64.fit_all().order(2), Some(Ok(_))));
    assert!(matches!(dec32.fit_all().order(2), Some(Ok(_))));
}

/// The exact-ML table of docs/identification.md (run with `--ignored --nocapture`).
#[test]
#[ignore = "regenerates the exact-ML table of docs/identification.md; run with --ignored --nocapture"]
fn exact_ml_table() {
    println!("| n | seed | conditional LS a1, a2 | exact ML a1, a2 | exact log-lik. LS -> ML |");
    println!("|---|---|---|---|---|");
    for (n, seed) in [(50, 1), (60, 2), (80, 3), (100, 4), (2000, 6)] {
        let x = simulate_ar(&[1.2, -0.5], 1.0, n, seed);
        let o = IdentifyOptions {
            max_order: 2,
            lags: 10,
            ..IdentifyOptions::default()
        };
        let r = identify_series(&x, &o).unwrap_or_else(|e| panic!("{e}"));
        let ls = r
            .order(2)
            .map(|o| o.coefficients.clone())
            .unwrap_or_default();
        let segs = [x.iter().map(|v| v - r.mean_removed).collect::<Vec<f64>>()];
        let refs: Vec<&[f64]> = segs.iter().map(Vec::as_slice).collect();
        let ml = flexcal_sim::identify::exact_ml(&refs, &ls).unwrap_or_else(|e| panic!("{e}"));
        let ll_ls = exact_log_likelihood(&refs, &ls).map_or(f64::NAN, |v| v.0);
        println!(
            "| {n} | {seed} | {:.4}, {:.4} | {:.4}, {:.4} | {:.3} -> {:.3} |",
            ls[0], ls[1], ml.coefficients[0], ml.coefficients[1], ll_ls, ml.log_likelihood
        );
    }
}
