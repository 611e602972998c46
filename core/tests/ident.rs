//! AR identification and Ljung-Box: recursive vs batch least squares, order selection,
//! criteria formulas, degenerate series, forgetting, and no panics on any input.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
// The reference Householder QR is written with explicit indices, like the textbook algorithm.
#![allow(clippy::needless_range_loop)]

use flexcal_core::ident::{
    ar_residuals, ljung_box, ArIdentifier, ArResiduals, Criterion, FitError, LjungBoxAccumulator,
    LjungBoxError,
};
use flexcal_core::stats::{chi2_isf, chi2_sf};
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// Simulates `x_k = Σ a_i x_{k−i} + σ w_k` after a burn-in of 500 samples.
fn simulate_ar(a: &[f64], sigma: f64, n: usize, seed: u64) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    let w = Normal::new(0.0, sigma).unwrap();
    let burn = 500;
    let mut x = vec![0.0; n + burn];
    for k in 0..n + burn {
        let mut v = w.sample(&mut rng);
        for (i, ai) in a.iter().enumerate() {
            if k > i {
                v += ai * x[k - 1 - i];
            }
        }
        x[k] = v;
    }
    x.split_off(burn)
}

/// Weighted least squares `min Σ w_r (b_r − A_r x)²` by Householder QR on `sqrt(w)`-scaled rows
/// (a different method from the identifier's normal equations + Cholesky). Returns (x, RSS).
fn householder_ls(mut a: Vec<Vec<f64>>, mut b: Vec<f64>, w: &[f64]) -> (Vec<f64>, f64) {
    let m = b.len();
    let p = if m > 0 { a[0].len() } else { 0 };
    for r in 0..m {
        let s = w[r].sqrt();
        b[r] *= s;
        for c in 0..p {
            a[r][c] *= s;
        }
    }
    for j in 0..p {
        let norm = (j..m).map(|r| a[r][j] * a[r][j]).sum::<f64>().sqrt();
        let alpha = if a[j][j] > 0.0 { -norm } else { norm };
        let mut v: Vec<f64> = (j..m).map(|r| a[r][j]).collect();
        v[0] -= alpha;
        let vnorm2: f64 = v.iter().map(|x| x * x).sum();
        if vnorm2 == 0.0 {
            continue;
        }
        for c in j..p {
            let dot: f64 = (j..m).map(|r| v[r - j] * a[r][c]).sum();
            let f = 2.0 * dot / vnorm2;
            for r in j..m {
                a[r][c] -= f * v[r - j];
            }
        }
        let dot: f64 = (j..m).map(|r| v[r - j] * b[r]).sum();
        let f = 2.0 * dot / vnorm2;
        for r in j..m {
            b[r] -= f * v[r - j];
        }
    }
    let mut x = vec![0.0; p];
    for i in (0..p).rev() {
        let s: f64 = (i + 1..p).map(|k| a[i][k] * x[k]).sum();
        x[i] = (b[i] - s) / a[i][i];
    }
    let rss = b[p..].iter().map(|v| v * v).sum();
    (x, rss)
}

/// Batch conditional least squares of order `p` over the common range `k = pmax..n` (0-based),
/// with weights `λ^(n−1−k)`. Returns (coefficients, σ², n_eff).
fn batch_fit(x: &[f64], pmax: usize, p: usize, lambda: f64) -> (Vec<f64>, f64, f64) {
    let ks: Vec<usize> = (pmax..x.len()).collect();
    let a: Vec<Vec<f64>> = ks
        .iter()
        .map(|&k| (1..=p).map(|i| x[k - i]).collect())
        .collect();
    let b: Vec<f64> = ks.iter().map(|&k| x[k]).collect();
    let last = x.len() - 1;
    let w: Vec<f64> = ks.iter().map(|&k| lambda.powi((last - k) as i32)).collect();
    let n_eff: f64 = w.iter().sum();
    if p == 0 {
        let rss: f64 = b.iter().zip(&w).map(|(v, wi)| wi * v * v).sum();
        return (vec![], rss / n_eff, n_eff);
    }
    let (coef, rss) = householder_ls(a, b, &w);
    (coef, rss / n_eff, n_eff)
}

fn rel_err(a: f64, b: f64, scale: f64) -> f64 {
    (a - b).abs() / scale.max(b.abs())
}

#[test]
fn recursive_equals_batch_least_squares_f64() {
    const P: usize = 6;
    let x = simulate_ar(&[0.5, -0.2, 0.15], 0.7, 1500, 11);
    for &lambda in &[1.0, 0.995] {
        let mut id = ArIdentifier::<f64, P>::with_forgetting(lambda).unwrap();
        for &v in &x {
            assert!(id.push(v));
        }
        let fits = id.fit_all();
        let mut worst = 0.0_f64;
        for p in 0..=P {
            let f = fits.order(p).unwrap().as_ref().unwrap();
            let (coef, s2, n_eff) = batch_fit(&x, P, p, lambda);
            assert_eq!(f.coefficients().len(), p);
            for (got, want) in f.coefficients().iter().zip(&coef) {
                worst = worst.max(rel_err(*got, *want, 1e-3));
            }
            worst = worst.max(rel_err(f.sigma2, s2, 0.0));
            worst = worst.max(rel_err(f.n, n_eff, 0.0));
            assert!(f.coefficients[p..].iter().all(|&c| c == 0.0));
        }
        println!("lambda {lambda}: recursive vs Householder batch, worst relative error {worst:e}");
        assert!(worst < 1e-9, "worst {worst:e}");
    }
}

#[test]
fn gap_equals_batch_over_complete_windows() {
    const P: usize = 3;
    let x = simulate_ar(&[0.6, -0.3], 1.0, 800, 3);
    let mut id = ArIdentifier::<f64, P>::new();
    for (k, &v) in x.iter().enumerate() {
        id.push(v);
        if k == 400 {
            assert!(!id.push(f64::NAN));
        }
    }
    assert_eq!(id.rejected(), 1);
    // Windows: residuals k = 3..=400 of the first segment and k = 3.. of the second one.
    let (s1, s2) = x.split_at(401);
    assert_eq!(id.residual_count(), (s1.len() - P) + (s2.len() - P));
    let fit = id.fit(2).unwrap().unwrap();
    // Stack both segments' regressions.
    let mut rows = vec![];
    let mut rhs = vec![];
    for seg in [s1, s2] {
        for k in P..seg.len() {
            rows.push(vec![seg[k - 1], seg[k - 2]]);
            rhs.push(seg[k]);
        }
    }
    let w = vec![1.0; rhs.len()];
    let n = rhs.len() as f64;
    let (coef, rss) = householder_ls(rows, rhs, &w);
    for (g, c) in fit.coefficients().iter().zip(&coef) {
        assert!(rel_err(*g, *c, 1e-3) < 1e-9);
    }
    assert!(rel_err(fit.sigma2, rss / n, 0.0) < 1e-9);
}

#[test]
fn f32_agrees_with_f64() {
    const P: usize = 4;
    let x = simulate_ar(&[0.6, -0.3], 1.0, 2000, 5);
    let mut i64_ = ArIdentifier::<f64, P>::new();
    let mut i32_ = ArIdentifier::<f32, P>::new();
    for &v in &x {
        let v32 = v as f32;
        i64_.push(f64::from(v32));
        i32_.push(v32);
    }
    let (f64s, f32s) = (i64_.fit_all(), i32_.fit_all());
    let mut worst_coef = 0.0_f64;
    let mut worst_s2 = 0.0_f64;
    let mut worst_aic = 0.0_f64;
    for p in 0..=P {
        let a = f64s.order(p).unwrap().as_ref().unwrap();
        let b = f32s.order(p).unwrap().as_ref().unwrap();
        for (c64, c32) in a.coefficients().iter().zip(b.coefficients()) {
            worst_coef = worst_coef.max((c64 - f64::from(*c32)).abs());
        }
        worst_s2 = worst_s2.max(rel_err(f64::from(b.sigma2), a.sigma2, 0.0));
        worst_aic = worst_aic.max((f64::from(b.aic) - a.aic).abs());
    }
    println!(
        "f32 vs f64 (n=2000, AR(2)): coef abs {worst_coef:e}, sigma2 rel {worst_s2:e}, aic abs {worst_aic:e}"
    );
    assert!(worst_coef < 1e-4);
    assert!(worst_s2 < 1e-4);
    assert!(worst_aic < 0.2);
    assert_eq!(f64s.select(Criterion::Aic), f32s.select(Criterion::Aic));
    assert_eq!(f64s.select(Criterion::Bic), f32s.select(Criterion::Bic));
}

#[test]
fn ar2_order_selection_over_100_seeds() {
    const P: usize = 6;
    let mut aic = [0usize; P + 1];
    let mut bic = [0usize; P + 1];
    for seed in 0..100u64 {
        let x = simulate_ar(&[0.6, -0.3], 1.0, 2000, 1000 + seed);
        let mut id = ArIdentifier::<f64, P>::new();
        x.iter().for_each(|&v| {
            id.push(v);
        });
        let fits = id.fit_all();
        aic[fits.select(Criterion::Aic).unwrap()] += 1;
        bic[fits.select(Criterion::Bic).unwrap()] += 1;
    }
    println!("AR(2) a=[0.6,-0.3], n=2000, P_MAX=6, 100 seeds; selections by order 0..=6:");
    println!("  AIC {aic:?}");
    println!("  BIC {bic:?}");
    assert_eq!(aic[0] + aic[1], 0, "AIC under-fitted");
    assert_eq!(bic[0] + bic[1], 0, "BIC under-fitted");
    assert!(aic[2] >= 70, "AIC picked 2 only {} times", aic[2]);
    assert!(bic[2] >= 95, "BIC picked 2 only {} times", bic[2]);
}

#[test]
fn criteria_and_sigma2_match_their_formulas() {
    const P: usize = 5;
    let x = simulate_ar(&[0.6, -0.3], 0.5, 1000, 21);
    let mut id = ArIdentifier::<f64, P>::new();
    x.iter().for_each(|&v| {
        id.push(v);
    });
    let n_res = x.len() - P;
    for r in id.fit_all().iter() {
        let f = r.as_ref().unwrap();
        let p = f.order;
        // σ² from residuals recomputed with the returned coefficients over k = P..n.
        let rss: f64 = ar_residuals(&x[P - p..], f.coefficients())
            .map(|e| e * e)
            .sum();
        let n = n_res as f64;
        assert_eq!(f.n, n);
        assert_eq!(f.residuals, n_res);
        assert!(rel_err(f.sigma2, rss / n, 0.0) < 1e-10);
        let aic = n * f.sigma2.ln() + 2.0 * p as f64;
        let bic = n * f.sigma2.ln() + p as f64 * n.ln();
        assert!((f.aic - aic).abs() <= 1e-12 * aic.abs());
        assert!((f.bic - bic).abs() <= 1e-12 * bic.abs());
    }
}

/// Ljung-Box written out directly from the formula, in f64 with plain loops.
fn ljung_box_reference(e: &[f64], m: usize) -> f64 {
    let n = e.len();
    let c0: f64 = e.iter().map(|v| v * v).sum();
    let mut q = 0.0;
    for i in 1..=m {
        let mut ci = 0.0;
        for k in 0..n - i {
            ci += e[k] * e[k + i];
        }
        let eta = ci / c0;
        q += eta * eta / (n - i) as f64;
    }
    (n * (n + 2)) as f64 * q
}

#[test]
fn ljung_box_matches_formula_batch_and_streaming() {
    const P: usize = 4;
    let x = simulate_ar(&[0.6, -0.3], 1.0, 2000, 8);
    let mut id = ArIdentifier::<f64, P>::new();
    x.iter().for_each(|&v| {
        id.push(v);
    });
    let fits = id.fit_all();
    for p in 0..=P {
        let f = fits.order(p).unwrap().unwrap();
        let res: Vec<f64> = ar_residuals(&x, f.coefficients()).collect();
        assert_eq!(res.len(), x.len() - p);
        let lb = ljung_box(&res, 20, p, 0.05).unwrap();
        let q_ref = ljung_box_reference(&res, 20);
        assert!(rel_err(lb.q, q_ref, 0.0) < 1e-12);
        assert_eq!(lb.dof, 20 - p);
        assert_eq!(lb.critical, chi2_isf(0.05, (20 - p) as f64));
        assert_eq!(lb.white, lb.q <= lb.critical);
        assert!(rel_err(lb.p_value, chi2_sf(lb.q, (20 - p) as f64), 0.0) < 1e-15);

        // Board path: online residuals into the fixed-memory accumulator.
        let mut gen = ArResiduals::<f64, P>::new(f.coefficients()).unwrap();
        let mut acc = LjungBoxAccumulator::<f64, 20>::new();
        let mut online = vec![];
        for &v in &x {
            if let Some(e) = gen.push(v) {
                online.push(e);
                acc.push(e);
            }
        }
        assert_eq!(online.len(), res.len());
        for (a, b) in online.iter().zip(&res) {
            assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()));
        }
        let st = acc.result(p, 0.05).unwrap();
        assert!(rel_err(st.q, q_ref, 0.0) < 1e-10);
        assert_eq!(st.white, lb.white);
        println!(
            "order {p}: Q={:.2} dof={} critical={:.2} p={:.3e} white={}",
            lb.q, lb.dof, lb.critical, lb.p_value, lb.white
        );
        if p < 2 {
            assert!(
                !lb.white,
                "under-fitted AR residuals must fail the whiteness test"
            );
        }
    }
    // f32 streaming agrees with f64.
    let f = fits.order(2).unwrap().unwrap();
    let c32: Vec<f32> = f.coefficients().iter().map(|&c| c as f32).collect();
    let mut gen = ArResiduals::<f32, 2>::new(&c32).unwrap();
    let mut acc = LjungBoxAccumulator::<f32, 20>::new();
    x.iter().for_each(|&v| {
        if let Some(e) = gen.push(v as f32) {
            acc.push(e);
        }
    });
    let q32 = acc.result(2, 0.05).unwrap().q;
    let res: Vec<f64> = ar_residuals(&x, f.coefficients()).collect();
    let q64 = ljung_box_reference(&res, 20);
    println!("Ljung-Box f32 streaming Q={q32} vs f64 {q64}");
    assert!(rel_err(f64::from(q32), q64, 0.0) < 1e-3);
}

#[test]
fn ljung_box_guards() {
    let e = [1.0, -0.5, 0.25, 0.1, -0.3];
    assert_eq!(
        ljung_box(&e, 2, 2, 0.05),
        Err(LjungBoxError::NoDegreesOfFreedom { lags: 2, fitted: 2 })
    );
    assert_eq!(
        ljung_box(&e, 5, 1, 0.05),
        Err(LjungBoxError::TooFewResiduals { n: 5, lags: 5 })
    );
    assert_eq!(ljung_box(&e, 3, 1, 0.0), Err(LjungBoxError::InvalidAlpha));
    assert_eq!(
        ljung_box(&e, 3, 1, f64::NAN),
        Err(LjungBoxError::InvalidAlpha)
    );
    assert_eq!(
        ljung_box(&[0.0; 10], 3, 1, 0.05),
        Err(LjungBoxError::ZeroVariance)
    );
    assert_eq!(
        ljung_box(&[1.0, f64::NAN, 2.0, 3.0, 4.0], 2, 1, 0.05),
        Err(LjungBoxError::NonFinite)
    );
    assert!(ljung_box(&e, 3, 1, 0.05).is_ok());
    let acc = LjungBoxAccumulator::<f32, 0>::new();
    assert_eq!(
        acc.result(0, 0.05),
        Err(LjungBoxError::NoDegreesOfFreedom { lags: 0, fitted: 0 })
    );
    assert!(ArResiduals::<f64, 2>::new(&[0.1, 0.2, 0.3]).is_none());
    assert!(ArResiduals::<f64, 2>::new(&[f64::NAN]).is_none());
}

fn identify<const P: usize>(x: &[f64]) -> flexcal_core::ident::Fits<f64, P> {
    let mut id = ArIdentifier::<f64, P>::new();
    x.iter().for_each(|&v| {
        id.push(v);
    });
    id.fit_all()
}

#[test]
fn non_ar_series() {
    const P: usize = 6;
    let n = 2000;
    let mut rng = StdRng::seed_from_u64(77);
    let w = Normal::new(0.0, 1.0).unwrap();
    let noise: Vec<f64> = (0..n).map(|_| w.sample(&mut rng)).collect();

    // White noise: order 0, residuals white.
    let fits = identify::<P>(&noise);
    let (oa, ob) = (
        fits.select(Criterion::Aic).unwrap(),
        fits.select(Criterion::Bic).unwrap(),
    );
    println!("white noise: AIC {oa}, BIC {ob}");
    assert_eq!(ob, 0);
    assert!(oa <= 2);
    let lb = ljung_box(&noise[P..], 20, 0, 0.05).unwrap();
    assert!(lb.white, "{lb:?}");

    // Sine + small noise: a sinusoid is an AR(2) with roots on the unit circle; noise on it
    // makes the exact model an ARMA(2,2), approximated by a higher-order AR.
    let sine: Vec<f64> = (0..n)
        .map(|k| (0.1 * k as f64).sin() + 0.05 * noise[k])
        .collect();
    let fits = identify::<P>(&sine);
    let ob = fits.select(Criterion::Bic).unwrap();
    let oa = fits.select(Criterion::Aic).unwrap();
    println!("sine+noise: AIC {oa}, BIC {ob}");
    assert!(ob >= 2);
    let best = fits.best(Criterion::Bic).unwrap();
    let s0 = fits.order(0).unwrap().unwrap().sigma2;
    let res: Vec<f64> = ar_residuals(&sine, best.coefficients()).collect();
    let lb = ljung_box(&res, 20, best.order, 0.05).unwrap();
    println!(
        "sine+noise: sigma2 order 0 {s0:.4}, selected {:.2e}; Ljung-Box Q={:.1} (critical {:.1}) white={}",
        best.sigma2, lb.q, lb.critical, lb.white
    );
    // The AR model explains nearly all the variance (the noise alone is 0.0025 of it).
    assert!(best.sigma2 < 0.05 * s0);
    // But sine + white noise is ARMA(2,2), which no AR(≤ 6) whitens: the check must say so.
    assert!(!lb.white);

    // Pure sine: exactly AR(2); lags ≥ 3 are linear combinations → ill-conditioned.
    let pure: Vec<f64> = (0..n).map(|k| (0.1 * k as f64).sin()).collect();
    let fits = identify::<P>(&pure);
    assert!(matches!(
        fits.order(3).unwrap(),
        Err(FitError::IllConditioned { lag: 3, .. })
    ));
    assert!(matches!(
        fits.order(6).unwrap(),
        Err(FitError::IllConditioned { lag: 3, .. })
    ));
    assert_eq!(fits.select(Criterion::Aic), Some(2));
    let f2 = fits.order(2).unwrap().unwrap();
    assert!((f2.coefficients[0] - 2.0 * 0.1f64.cos()).abs() < 1e-9);
    assert!((f2.coefficients[1] + 1.0).abs() < 1e-9);

    // Random walk: order 1 with a ≈ 1.
    let mut s = 0.0;
    let walk: Vec<f64> = noise
        .iter()
        .map(|v| {
            s += v;
            s
        })
        .collect();
    let fits = identify::<P>(&walk);
    let ob = fits.select(Criterion::Bic).unwrap();
    assert_eq!(ob, 1);
    let a1 = fits.order(1).unwrap().unwrap().coefficients[0];
    println!("random walk: BIC {ob}, a1 = {a1}");
    assert!((a1 - 1.0).abs() < 0.01);

    // Constant: x_k = x_{k−1} exactly; order 1 fits perfectly (σ² floored), order ≥ 2 singular.
    let fits = identify::<P>(&vec![3.5; 500]);
    assert_eq!(fits.select(Criterion::Aic), Some(1));
    assert!((fits.order(1).unwrap().unwrap().coefficients[0] - 1.0).abs() < 1e-12);
    assert!(matches!(
        fits.order(2).unwrap(),
        Err(FitError::IllConditioned { lag: 2, .. })
    ));

    // All zero: no order can be fitted.
    let fits = identify::<P>(&[0.0; 500]);
    assert!(fits.iter().all(|r| *r == Err(FitError::ZeroVariance)));
    assert_eq!(fits.select(Criterion::Aic), None);

    // Fewer samples than P_MAX.
    let fits = identify::<P>(&noise[..4]);
    assert!(fits
        .iter()
        .all(|r| matches!(r, Err(FitError::NotEnoughData { residuals: 0, .. }))));
    assert_eq!(fits.select(Criterion::Bic), None);
    // Just enough for low orders only.
    let fits = identify::<P>(&noise[..P + 3]);
    assert!(fits.order(2).unwrap().is_ok());
    assert_eq!(
        *fits.order(3).unwrap(),
        Err(FitError::NotEnoughData {
            residuals: 3,
            needed: 4
        })
    );

    // NaN and ±inf inside an AR(2) series: gaps, the estimate stays close to the clean one.
    let x = simulate_ar(&[0.6, -0.3], 1.0, 2000, 9);
    let mut dirty = x.clone();
    dirty[100] = f64::NAN;
    dirty[900] = f64::INFINITY;
    dirty[901] = f64::NEG_INFINITY;
    let (clean, fits) = (identify::<P>(&x), identify::<P>(&dirty));
    assert_eq!(fits.select(Criterion::Bic), Some(2));
    let (a, b) = (
        clean.order(2).unwrap().unwrap(),
        fits.order(2).unwrap().unwrap(),
    );
    assert!((a.coefficients[0] - b.coefficients[0]).abs() < 0.01);
    assert!((a.coefficients[1] - b.coefficients[1]).abs() < 0.01);

    // Huge values overflow the sums: reported, not propagated as garbage.
    let huge: Vec<f64> = (0..30).map(|k| (1.0 + (k % 7) as f64) * 1e200).collect();
    let fits = identify::<P>(&huge);
    assert!(fits.iter().all(|r| *r == Err(FitError::NonFinite)));
    assert_eq!(fits.select(Criterion::Aic), None);
}

#[test]
fn forgetting_tracks_an_abrupt_change() {
    const P: usize = 4;
    let old = [0.6, -0.3];
    let new = [-0.4, 0.35];
    let x1 = simulate_ar(&old, 1.0, 4000, 31);
    let x2 = simulate_ar(&new, 1.0, 3000, 32);
    let mut forgetting = ArIdentifier::<f64, P>::with_forgetting(0.995).unwrap();
    let mut plain = ArIdentifier::<f64, P>::new();
    for &v in x1.iter().chain(&x2) {
        forgetting.push(v);
        plain.push(v);
    }
    let a = forgetting.fit(2).unwrap().unwrap();
    let b = plain.fit(2).unwrap().unwrap();
    let err = |f: &[f64]| (f[0] - new[0]).abs().max((f[1] - new[1]).abs());
    println!(
        "after change: forgetting (λ=0.995, n_eff={:.1}) a={:?} err {:.3}; no forgetting a={:?} err {:.3}",
        a.n,
        a.coefficients(),
        err(a.coefficients()),
        b.coefficients(),
        err(b.coefficients())
    );
    assert!(err(a.coefficients()) < 0.2);
    assert!(err(b.coefficients()) > 0.3);
    assert!((a.n - 200.0).abs() < 1.0);
    // λ outside (0, 1] is refused.
    assert!(ArIdentifier::<f64, P>::with_forgetting(0.0).is_none());
    assert!(ArIdentifier::<f64, P>::with_forgetting(1.5).is_none());
    assert!(ArIdentifier::<f64, P>::with_forgetting(f64::NAN).is_none());
}

fn any_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -10.0..10.0f64,
        1 => proptest::num::f64::ANY,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(0.0),
        1 => Just(f64::MAX),
        1 => Just(1e-310),
        1 => prop::num::f64::NORMAL.prop_map(|v| v * 1e150),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, ..ProptestConfig::default() })]
    #[test]
    fn never_panics(
        xs in prop::collection::vec(any_value(), 0..200),
        lambda in any_value(),
        tol in any_value(),
        lags in 0usize..30,
        fitted in 0usize..30,
        alpha in any_value(),
        coefs in prop::collection::vec(any_value(), 0..5),
    ) {
        let mut a = ArIdentifier::<f64, 4>::with_forgetting(lambda).unwrap_or_default();
        let mut b = ArIdentifier::<f32, 4>::new();
        let mut c = ArIdentifier::<f64, 0>::new();
        a.set_pivot_tolerance(tol);
        for &x in &xs {
            a.push(x);
            b.push(x as f32);
            c.push(x);
        }
        for crit in [Criterion::Aic, Criterion::Bic] {
            let fa = a.fit_all();
            if let Some(p) = fa.select(crit) {
                let f = fa.order(p).unwrap().unwrap();
                prop_assert!(f.aic.is_finite() && f.bic.is_finite() && f.sigma2 > 0.0);
            }
            let _ = b.fit_all().select(crit);
            let _ = c.fit_all().select(crit);
        }
        let _ = ljung_box(&xs, lags, fitted, alpha);
        let x32: Vec<f32> = xs.iter().map(|&v| v as f32).collect();
        let _ = ljung_box(&x32, lags, fitted, alpha as f32);
        let _: Vec<f64> = ar_residuals(&xs, &coefs).collect();
        let mut acc = LjungBoxAccumulator::<f32, 8>::new();
        if let Some(mut g) = ArResiduals::<f32, 4>::new(&coefs.iter().map(|&v| v as f32).collect::<Vec<_>>()) {
            for &x in &x32 {
                if let Some(e) = g.push(x) {
                    acc.push(e);
                }
            }
        }
        let _ = acc.result(fitted, alpha as f32);
        let _ = (chi2_isf(alpha, lambda), chi2_sf(tol, lambda));
    }
}

/// A physically plausible flexure (2nd-order Gauss-Markov, ω_n = 1 rad/s, ζ = 0.3) sampled at
/// 100 Hz is strongly oversampled: poles near 1. f64 identifies it; f32 reports where its
/// precision runs out instead of returning garbage (see the module docs: decimate on the board).
#[test]
fn oversampled_flexure_f64_and_f32() {
    const P: usize = 4;
    let (wn, zeta, dt) = (1.0f64, 0.3f64, 0.01f64);
    let r = (-zeta * wn * dt).exp();
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let a = [2.0 * r * (wd * dt).cos(), -r * r];
    let x = simulate_ar(&a, 1e-6, 20_000, 4);
    for decim in [1usize, 10] {
        let xs: Vec<f64> = x.iter().step_by(decim).copied().collect();
        let mut i64_ = ArIdentifier::<f64, P>::new();
        let mut i32_ = ArIdentifier::<f32, P>::new();
        for &v in &xs {
            i64_.push(v);
            i32_.push(v as f32);
        }
        let (f64s, f32s) = (i64_.fit_all(), i32_.fit_all());
        let mut loose = i32_;
        assert!(loose.set_pivot_tolerance(1e-6));
        println!(
            "  f32 with pivot tolerance 1e-6, order 2: {:?}",
            loose.fit(2)
        );
        println!(
            "flexure at {} Hz (n={}): f64 BIC order {:?}, f32 BIC order {:?}",
            100 / decim,
            xs.len(),
            f64s.select(Criterion::Bic),
            f32s.select(Criterion::Bic)
        );
        for p in 0..=P {
            println!(
                "  p={p}: f64 {:?}\n       f32 {:?}",
                f64s.order(p).unwrap(),
                f32s.order(p).unwrap()
            );
        }
        if decim == 1 {
            let f = f64s.order(2).unwrap().unwrap();
            assert_eq!(f64s.select(Criterion::Bic), Some(2));
            assert!(
                (f.coefficients[0] - a[0]).abs() < 2e-3 && (f.coefficients[1] - a[1]).abs() < 2e-3
            );
            // Lag 2 is 99.99 % explained by lag 1: beyond f32 (a looser tolerance gives
            // a1 ≈ 1.905 instead of 1.994 here), so f32 refuses orders ≥ 2.
            assert!(matches!(
                f32s.order(2).unwrap(),
                Err(FitError::IllConditioned { lag: 2, .. })
            ));
        } else {
            // Decimated (without anti-aliasing: the sampled model is no longer exactly AR(2)),
            // f32 and f64 agree on the order.
            assert_eq!(f64s.select(Criterion::Bic), f32s.select(Criterion::Bic));
        }
    }
}
