//! Chi-square distribution for the whiteness test (Ljung-Box), NEES bands and innovation gating.
//!
//! Everything here is written in `f64` with `libm`, `no_std`, allocation-free and panic-free.
//! The board (Cortex-M4F, single-precision FPU) runs these in software double precision: a
//! quantile costs a few Newton steps, each one incomplete-gamma evaluation of O(sqrt(dof))
//! soft-float terms plus a few `log`/`exp` (estimated well below a millisecond at 100+ MHz for
//! dof ≲ 500; not measured on hardware). That is fine for occasional calls (once per Ljung-Box
//! check, or once at start-up for a gate threshold; cache thresholds rather than recomputing
//! them per sample), and keeps one accurate implementation for both precisions.
//! Callers holding `f32` widen with [`crate::real::Real::to_f64`] and narrow with `Real::of`.
//!
//! Method (derived from the definitions, no tables):
//! - `ln Γ(a)`: Stirling's asymptotic series with Bernoulli-number terms for `a ≥ 15`, and the
//!   recurrence `Γ(a) = Γ(a + k) / (a (a+1) … (a+k−1))` below that.
//! - Regularized incomplete gamma `P(a, x)`, `Q(a, x) = 1 − P`: the power series of `γ(a, x)`
//!   for `x < a + 1`, the continued fraction of `Γ(a, x)` (modified Lentz) otherwise, each
//!   computing the smaller tail directly so that neither loses relative accuracy. The common
//!   factor `x^a e^{−x} / Γ(a)` is evaluated for large `a` as
//!   `exp(a ln(x/a) + (a − x) + ½ ln a − ½ ln 2π − S(a))`, `S` the Stirling correction (with
//!   `a ln(x/a) + a − x = a (log1p(t) − t)`, `t = (x − a)/a`, near `x = a`), which avoids the
//!   cancellation of `a ln x` against `ln Γ(a)` at large `a`.
//! - `χ²_k` CDF: `P(k/2, x/2)`; survival `Q(k/2, x/2)`.
//! - Quantile: Wilson–Hilferty start, then Newton's method on the logarithm of the smaller tail,
//!   safeguarded by bisection inside a maintained bracket.
//!
//! Accuracy (against mpmath at 50 digits, `core/tests/stats.rs`, dof 0.5..=5000, tails down to
//! 1e-12): worst relative error 1.3e-13 for CDF/survival and 1.1e-14 for quantiles (the test
//! asserts 1e-12 and 1e-11).
//! `dof` is an `f64` so that non-integer degrees of freedom are allowed; any `dof > 0` works,
//! iteration counts grow like `sqrt(dof)`, and are capped so that every call terminates.

const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8; // ½ ln(2π)
const STIRLING_MIN: f64 = 15.0;
const MAX_ITER: usize = 100_000;
const EPS: f64 = f64::EPSILON;

/// Stirling correction `S(a) = ln Γ(a) − ((a − ½) ln a − a + ½ ln 2π)` for `a ≥ 15`.
///
/// Terms `B_{2k} / (2k (2k−1) a^{2k−1})`, k = 1..6; the first omitted term is below 4e-18 at
/// `a = 15`.
fn stirling_correction(a: f64) -> f64 {
    let r = 1.0 / a;
    let r2 = r * r;
    // Horner in 1/a²: 1/12 − 1/(360 a²) + 1/(1260 a⁴) − 1/(1680 a⁶) + 1/(1188 a⁸) − 691/(360360 a¹⁰)
    let s = 1.0 / 12.0
        + r2 * (-1.0 / 360.0
            + r2 * (1.0 / 1260.0
                + r2 * (-1.0 / 1680.0 + r2 * (1.0 / 1188.0 + r2 * (-691.0 / 360_360.0)))));
    s * r
}

/// Natural logarithm of the gamma function for `a > 0` (NaN for `a ≤ 0` or NaN, +∞ for +∞).
///
/// Needed for the normalizing constant of the chi-square distribution. Relative accuracy about
/// 1e-15 except near the zeros of `ln Γ` at 1 and 2, where the absolute error is about 1e-15.
pub fn ln_gamma(a: f64) -> f64 {
    if a.is_nan() || a <= 0.0 {
        return f64::NAN;
    }
    if a == f64::INFINITY {
        return f64::INFINITY;
    }
    if a >= STIRLING_MIN {
        return (a - 0.5) * libm::log(a) - a + LN_SQRT_2PI + stirling_correction(a);
    }
    // Shift up: Γ(a) = Γ(a + k) / (a (a+1) … (a+k−1)); the product stays well inside f64 range.
    let mut prod = 1.0;
    let mut z = a;
    while z < STIRLING_MIN {
        prod *= z;
        z += 1.0;
    }
    (z - 0.5) * libm::log(z) - z + LN_SQRT_2PI + stirling_correction(z) - libm::log(prod)
}

/// `ln( x^a e^{−x} / Γ(a) )`, the common factor of both incomplete-gamma tails, for a, x > 0.
fn ln_gamma_kernel(a: f64, x: f64) -> f64 {
    if a >= STIRLING_MIN {
        // a ln(x/a) + (a − x): near x = a the two terms cancel, so use log1p there; far from it
        // (where x − a would lose the digits of a small x) use the direct form.
        let t = (x - a) / a;
        let main = if t.abs() < 0.5 {
            a * (libm::log1p(t) - t)
        } else {
            a * libm::log(x / a) + (a - x)
        };
        main + 0.5 * libm::log(a) - LN_SQRT_2PI - stirling_correction(a)
    } else {
        a * libm::log(x) - x - ln_gamma(a)
    }
}

/// Lower tail by the power series `P = k · Σ_n x^n / ((a+1)…(a+n)) / a`, k the kernel.
fn gamma_p_series(a: f64, x: f64, ln_kernel: f64) -> f64 {
    let mut term = 1.0 / a;
    let mut sum = term;
    let mut denom = a;
    for _ in 0..MAX_ITER {
        denom += 1.0;
        term *= x / denom;
        sum += term;
        if term.abs() <= sum.abs() * EPS * 0.5 {
            break;
        }
    }
    (libm::exp(ln_kernel) * sum).clamp(0.0, 1.0)
}

/// Upper tail by the continued fraction
/// `Q = k · 1/(x+1−a − 1(1−a)/(x+3−a − 2(2−a)/(x+5−a − …)))`, evaluated by modified Lentz.
fn gamma_q_cf(a: f64, x: f64, ln_kernel: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / TINY;
    let mut d = if b.abs() < TINY { 1.0 / TINY } else { 1.0 / b };
    let mut h = d;
    let mut n = 0.0;
    for _ in 0..MAX_ITER {
        n += 1.0;
        let an = -n * (n - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < TINY {
            d = TINY;
        }
        c = b + an / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() <= EPS {
            break;
        }
    }
    (libm::exp(ln_kernel) * h).clamp(0.0, 1.0)
}

/// Both regularized incomplete gamma tails `(P(a, x), Q(a, x))`, each accurate in its own tail.
fn gamma_pq(a: f64, x: f64) -> (f64, f64) {
    if a.is_nan() || x.is_nan() || a <= 0.0 || a == f64::INFINITY {
        return (f64::NAN, f64::NAN);
    }
    if x <= 0.0 {
        return (0.0, 1.0);
    }
    if x == f64::INFINITY {
        return (1.0, 0.0);
    }
    let lk = ln_gamma_kernel(a, x);
    if x < a + 1.0 {
        let p = gamma_p_series(a, x, lk);
        (p, 1.0 - p)
    } else {
        let q = gamma_q_cf(a, x, lk);
        (1.0 - q, q)
    }
}

/// Regularized lower incomplete gamma function `P(a, x) = γ(a, x) / Γ(a)`.
///
/// `0` for `x ≤ 0`, `1` for `x = +∞`, NaN for NaN arguments or `a ≤ 0`.
pub fn gamma_p(a: f64, x: f64) -> f64 {
    gamma_pq(a, x).0
}

/// Regularized upper incomplete gamma function `Q(a, x) = 1 − P(a, x)`, accurate in the far tail.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    gamma_pq(a, x).1
}

/// Chi-square cumulative distribution `Pr(X ≤ x)` for `X ~ χ²(dof)`.
///
/// Used for NEES/NIS consistency bands and p-values. Returns 0 for `x ≤ 0` and NaN for NaN
/// arguments or `dof ≤ 0`.
pub fn chi2_cdf(x: f64, dof: f64) -> f64 {
    gamma_p(0.5 * dof, 0.5 * x)
}

/// Chi-square survival function `Pr(X > x) = 1 − chi2_cdf(x, dof)`, accurate for tiny tails.
///
/// This is the p-value of an upper-tailed test statistic such as Ljung-Box `Q` or NIS.
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    gamma_q(0.5 * dof, 0.5 * x)
}

/// Chi-square density, from the shared kernel: `f(x) = exp(ln k(dof/2, x/2)) / x`.
fn chi2_pdf_over(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    libm::exp(ln_gamma_kernel(a, 0.5 * x)) / x
}

/// Standard normal quantile (used only to start the chi-square iteration).
///
/// Newton's method on `ln Φ(z) = ln q` for the lower tail `q ≤ ½`: `ln Φ` is concave, so from the
/// start `−sqrt(−2 ln q)` (left of the root) the iterates increase monotonically to the root.
fn normal_quantile(p: f64) -> f64 {
    if p.is_nan() {
        return f64::NAN;
    }
    let (q, sign) = if p <= 0.5 { (p, 1.0) } else { (1.0 - p, -1.0) };
    if q <= 0.0 {
        return -sign * f64::INFINITY;
    }
    let target = libm::log(q);
    let mut z = -libm::sqrt(-2.0 * target);
    for _ in 0..60 {
        let phi_cdf = 0.5 * libm::erfc(-z * core::f64::consts::FRAC_1_SQRT_2);
        if phi_cdf <= 0.0 {
            break;
        }
        let ln_pdf = -0.5 * z * z - LN_SQRT_2PI;
        let g = libm::log(phi_cdf) - target;
        let slope = libm::exp(ln_pdf - libm::log(phi_cdf));
        if slope.is_nan() || slope <= 0.0 || !g.is_finite() {
            break;
        }
        let step = g / slope;
        z -= step;
        if step.abs() <= 1e-13 * (1.0 + z.abs()) {
            break;
        }
    }
    sign * z
}

/// Quantile of χ²(dof) given both tail probabilities (`lower + upper = 1`), each exact as given.
///
/// Works on whichever tail is smaller so that extreme probabilities keep full relative accuracy.
fn chi2_quantile_tails(lower: f64, upper: f64, dof: f64) -> f64 {
    if lower.is_nan() || upper.is_nan() || dof.is_nan() || dof <= 0.0 || dof == f64::INFINITY {
        return f64::NAN;
    }
    if lower <= 0.0 {
        return 0.0;
    }
    if upper <= 0.0 {
        return f64::INFINITY;
    }
    let a = 0.5 * dof;
    let use_lower = lower <= upper;
    let ln_target = if use_lower {
        libm::log(lower)
    } else {
        libm::log(upper)
    };

    // Wilson–Hilferty: (X/k)^{1/3} ≈ N(1 − 2/(9k), 2/(9k)).
    let h = 2.0 / (9.0 * dof);
    let z = normal_quantile(lower);
    let cube = 1.0 - h + z * libm::sqrt(h);
    let mut x = dof * cube * cube * cube;
    if x.is_nan() || x <= 0.0 || !x.is_finite() {
        // Small-x expansion of the lower tail: P(a, x/2) ≈ (x/2)^a / Γ(a + 1).
        x = 2.0 * libm::exp((libm::log(lower) + ln_gamma(a + 1.0)) / a);
    }
    if x.is_nan() || x <= 0.0 || !x.is_finite() {
        x = dof;
    }

    // Safeguarded Newton on g(x) = ln(tail(x)) − ln(target); g increases with x on the lower tail
    // and decreases on the upper tail. The bracket [lo, hi] always contains the root.
    let mut lo = 0.0_f64;
    let mut hi = f64::INFINITY;
    for _ in 0..400 {
        let (p, q) = gamma_pq(a, 0.5 * x);
        let tail = if use_lower { p } else { q };
        let g = if tail > 0.0 {
            libm::log(tail) - ln_target
        } else {
            f64::NEG_INFINITY
        };
        if g == 0.0 {
            return x;
        }
        // Root lies to the right of x when the CDF is still too small.
        let root_right = if use_lower { g < 0.0 } else { g > 0.0 };
        if root_right {
            lo = x;
        } else {
            hi = x;
        }
        // d/dx ln tail = ± pdf / tail.
        let pdf = chi2_pdf_over(a, x);
        let slope = if tail > 0.0 { pdf / tail } else { 0.0 };
        let newton = if slope > 0.0 && g.is_finite() {
            if use_lower {
                x - g / slope
            } else {
                x + g / slope
            }
        } else {
            f64::NAN
        };
        let next = if newton > lo && newton < hi {
            newton
        } else if hi.is_finite() {
            0.5 * (lo + hi)
        } else {
            2.0 * x.max(1.0)
        };
        if (next - x).abs() <= 4.0 * EPS * x || (hi.is_finite() && (hi - lo) <= 4.0 * EPS * hi) {
            return next;
        }
        x = next;
    }
    x
}

/// Quantile (inverse CDF) of χ²(dof): the `x` with `chi2_cdf(x, dof) = p`.
///
/// Returns 0 for `p ≤ 0`, +∞ for `p ≥ 1`, NaN for NaN arguments, `dof ≤ 0` or infinite `dof`.
/// For an upper-tail critical value with a tiny significance `α` prefer [`chi2_isf`]`(α, dof)`,
/// which does not round `1 − α`.
pub fn chi2_quantile(p: f64, dof: f64) -> f64 {
    chi2_quantile_tails(p, 1.0 - p, dof)
}

/// Inverse survival function of χ²(dof): the `x` with `chi2_sf(x, dof) = alpha`.
///
/// This is the critical value of an upper-tailed test at significance `alpha` (Ljung-Box,
/// innovation gating). Returns +∞ for `alpha ≤ 0`, 0 for `alpha ≥ 1`.
pub fn chi2_isf(alpha: f64, dof: f64) -> f64 {
    chi2_quantile_tails(1.0 - alpha, alpha, dof)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edge_cases_do_not_panic() {
        assert_eq!(chi2_cdf(0.0, 3.0), 0.0);
        assert_eq!(chi2_cdf(-1.0, 3.0), 0.0);
        assert_eq!(chi2_cdf(f64::INFINITY, 3.0), 1.0);
        assert!(chi2_cdf(f64::NAN, 3.0).is_nan());
        assert!(chi2_cdf(1.0, 0.0).is_nan());
        assert!(chi2_quantile(0.5, -1.0).is_nan());
        assert_eq!(chi2_quantile(0.0, 3.0), 0.0);
        assert_eq!(chi2_quantile(1.0, 3.0), f64::INFINITY);
        assert_eq!(chi2_isf(0.0, 3.0), f64::INFINITY);
        assert!(ln_gamma(0.0).is_nan());
    }

    #[test]
    fn ln_gamma_integers() {
        let mut fact = 1.0_f64;
        for n in 1..30 {
            // Γ(n) = (n−1)!
            let got = ln_gamma(n as f64);
            assert!(
                (got - libm::log(fact)).abs() <= 1e-13 * (1.0 + got.abs()),
                "n={n}"
            );
            fact *= n as f64;
        }
        let half = ln_gamma(0.5);
        assert!((half - 0.5 * libm::log(core::f64::consts::PI)).abs() < 1e-15);
    }

    #[test]
    fn normal_quantile_round_trip() {
        for &p in &[1e-300, 1e-10, 0.01, 0.3, 0.5] {
            let z = normal_quantile(p);
            let back = 0.5 * libm::erfc(-z * core::f64::consts::FRAC_1_SQRT_2);
            assert!((back - p).abs() <= 1e-9 * p, "p={p}");
        }
    }
}
