//! Rendering identification results: the `identify.json` object (keys of
//! `formats/outputs.md` plus extras), the AIC/BIC table in the shape of the paper's Table 3,
//! and the one-step-prediction figure in the shape of its Fig. 3.

use super::{criterion_name, ExactMl, IdentifyReport, LjungBoxReport};
use crate::plot::{Figure, Panel, Series};
use serde_json::{json, Value};
use std::fmt::Write as _;

fn ljung_box_json(lb: &LjungBoxReport) -> Value {
    json!({
        "lags": lb.lags,
        "q": lb.q,
        "dof": lb.dof,
        "critical": lb.critical,
        "alpha": lb.alpha,
        "white": lb.white,
        "p_value": lb.p_value,
        "n": lb.n,
    })
}

fn exact_json(e: &ExactMl, order: usize) -> Value {
    json!({
        "order": order,
        "coefficients": e.coefficients,
        "pacf": e.pacf,
        "sigma2": e.sigma2,
        "log_likelihood": e.log_likelihood,
        "conditional_ls_log_likelihood": e.start_log_likelihood,
        "n": e.n,
        "evaluations": e.evaluations,
        "converged": e.converged,
    })
}

/// The identification of one series as the `identify.json` object: the contract's keys
/// (`n`, `orders`, `selected_order`, `selected_by`, `ljung_box`) and extras (`samples`,
/// `segments`, `mean_removed`, `max_order`, `selected_aic`, `selected_bic`, `failed_orders`,
/// `exact_ml`, and per order `min_pivot_ratio` and its own `ljung_box`).
/// `tool_version` and the input description are added by the caller.
pub fn report_json(r: &IdentifyReport) -> Value {
    let orders: Vec<Value> = r
        .orders
        .iter()
        .map(|o| {
            json!({
                "p": o.p,
                "sigma2": o.sigma2,
                "aic": o.aic,
                "bic": o.bic,
                "coefficients": o.coefficients,
                "min_pivot_ratio": o.min_pivot_ratio,
                "ljung_box": o.ljung_box.as_ref().map(ljung_box_json),
            })
        })
        .collect();
    let failed: Vec<Value> = r
        .failures
        .iter()
        .map(|f| json!({ "p": f.p, "reason": f.reason }))
        .collect();
    json!({
        "n": r.n,
        "orders": orders,
        "selected_order": r.selected_order,
        "selected_by": criterion_name(r.options.criterion),
        "ljung_box": ljung_box_json(&r.ljung_box),
        "samples": r.samples,
        "segments": r.segments,
        "mean_removed": r.mean_removed,
        "max_order": r.options.max_order,
        "selected_aic": r.selected_aic,
        "selected_bic": r.selected_bic,
        "failed_orders": failed,
        "exact_ml": r.exact_ml.as_ref().map(|e| exact_json(e, r.selected_order)),
        "exact_ml_error": r.exact_ml_error,
    })
}

/// The AIC/BIC table (the paper's Table 3, extended with σ², the Ljung-Box verdict and the
/// coefficients of each order), followed by the selection, the whiteness test of the selected
/// order and its exact-ML refinement. `title` heads the table.
pub fn table(r: &IdentifyReport, title: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{title}");
    let _ = writeln!(
        s,
        "  {} samples in {} segment(s), mean removed {:.6e}; n = {} residuals (common range, max order {})",
        r.samples, r.segments, r.mean_removed, r.n, r.options.max_order
    );
    let _ = writeln!(
        s,
        "  {:>2}  {:>13}  {:>18}  {:>18}  {:>9}  {:>5}  coefficients a_1..a_p",
        "p", "sigma2", "AIC", "BIC", "LB Q", "white"
    );
    for o in &r.orders {
        let (q, w) = o.ljung_box.as_ref().map_or(("-".to_string(), "-"), |lb| {
            (format!("{:.2}", lb.q), if lb.white { "yes" } else { "no" })
        });
        let mark = if o.p == r.selected_order { "*" } else { " " };
        let coeffs: Vec<String> = o.coefficients.iter().map(|c| format!("{c:.6}")).collect();
        let _ = writeln!(
            s,
            "{mark} {:>2}  {:>13.6e}  {:>18.6}  {:>18.6}  {:>9}  {:>5}  [{}]",
            o.p,
            o.sigma2,
            o.aic,
            o.bic,
            q,
            w,
            coeffs.join(", ")
        );
    }
    for f in &r.failures {
        let _ = writeln!(s, "  {:>2}  not fitted: {}", f.p, f.reason);
    }
    let lb = &r.ljung_box;
    let _ = writeln!(
        s,
        "  selected p = {} by {} (AIC: {}, BIC: {}); Ljung-Box Q = {:.3}, dof {}, critical {:.3} at alpha = {}: {} (p-value {:.3})",
        r.selected_order,
        criterion_name(r.options.criterion).to_uppercase(),
        r.selected_aic,
        r.selected_bic,
        lb.q,
        lb.dof,
        lb.critical,
        lb.alpha,
        if lb.white { "white" } else { "NOT white" },
        lb.p_value
    );
    match (&r.exact_ml, &r.exact_ml_error) {
        (Some(e), _) => {
            let coeffs: Vec<String> = e.coefficients.iter().map(|c| format!("{c:.6}")).collect();
            let start = e
                .start_log_likelihood
                .map_or("undefined (not stationary)".to_string(), |v| {
                    format!("{v:.4}")
                });
            let _ = writeln!(
                s,
                "  exact ML (p = {}): a = [{}], sigma2 = {:.6e}, log-likelihood {:.4} (conditional LS: {})",
                r.selected_order,
                coeffs.join(", "),
                e.sigma2,
                e.log_likelihood,
                start
            );
        }
        (None, Some(err)) => {
            let _ = writeln!(s, "  exact ML: not computed: {err}");
        }
        (None, None) => {}
    }
    s
}

/// The paper's Fig. 3: a series and the identified model's one-step prediction over a window,
/// with the prediction error below. `scale` converts the values into the plotted unit `unit`.
#[allow(clippy::too_many_arguments)]
pub fn prediction_figure(
    title: &str,
    t: &[f64],
    actual: &[f64],
    predicted: &[f64],
    actual_name: &str,
    predicted_name: &str,
    scale: f64,
    unit: &str,
) -> Figure {
    let s = |v: &[f64]| v.iter().map(|x| x * scale).collect::<Vec<f64>>();
    let err: Vec<f64> = actual
        .iter()
        .zip(predicted.iter())
        .map(|(a, p)| (a - p) * scale)
        .collect();
    Figure {
        title: title.to_string(),
        x_label: "time (s)".to_string(),
        panels: vec![
            Panel {
                title: "One-step prediction of the identified model".to_string(),
                y_label: unit.to_string(),
                series: vec![Series {
                    name: predicted_name.to_string(),
                    x: t.to_vec(),
                    y: s(predicted),
                }],
                bands: vec![],
                dashed: vec![Series {
                    name: actual_name.to_string(),
                    x: t.to_vec(),
                    y: s(actual),
                }],
            },
            Panel {
                title: "Prediction error".to_string(),
                y_label: unit.to_string(),
                series: vec![Series {
                    name: "error".to_string(),
                    x: t.to_vec(),
                    y: err,
                }],
                bands: vec![],
                dashed: vec![],
            },
        ],
    }
}
