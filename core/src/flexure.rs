//! The flexure model the filter carries, per axis one of two two-state models:
//!
//! - **AR(2)** identified at the filter period `T` (orders 0 and 1 are AR(2) with
//!   trailing zero coefficients),
//!
//!   ```text
//!   θ_{k+1} = a1 θ_k + a2 θ_{k−1} + η_k,   η_k ~ N(0, σ²)
//!   ```
//!
//!   kept discrete (paper-notes item 6) in the coordinates the error model needs: the
//!   angle `θ_k` and the mean flexure rate over the last filter interval
//!   `θ̇_k = (θ_k − θ_{k−1}) / T`. That rate is *exactly* the mean of dθ/dt over
//!   `(t_{k−1}, t_k]` for any trajectory.
//! - **Second-order Gauss-Markov**, `θ̈ + 2ζω θ̇ + ω² θ = w` (`w` white), the continuous
//!   model a hull's bending mode is (`docs/error-model.md`), sampled exactly: the state
//!   is `[θ(t_k), θ̇(t_k)]` (the rate *at* `t_k`, what the rate matching compares),
//!   `Φ = e^{AT}` and `Q = P∞ − Φ P∞ Φᵀ` with `P∞ = diag(σ², ω²σ²)` (the process is
//!   stationary: that is its discrete Lyapunov equation). A sampled continuous
//!   second-order process is an ARMA(2,1), which no AR(2) of `θ` alone is: the AR(2)
//!   with the same poles and variance overstates the one-step prediction variance of
//!   `θ` 1.6× and carries the mean rate over the interval where the rate matching sees
//!   the rate at its end (test
//!   `gauss_markov_ar2_overstates_the_one_step_variance_by_the_moving_average_factor`).
//!   The model learner identifies ω, ζ, σ per axis and the filter carries this form.

use crate::real::Real;
use nalgebra::{Matrix2, Vector2};

/// One axis of the flexure model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AxisModel<T> {
    /// AR(2) at the filter period; state `[θ_k, mean rate over the last interval]`.
    Ar(ArAxis<T>),
    /// Second-order Gauss-Markov sampled exactly; state `[θ(t_k), θ̇(t_k)]`.
    SecondOrder(SecondOrderAxis<T>),
}

impl<T: Real> AxisModel<T> {
    /// Whether the axis is rigid: a stationary model without driving noise (σ = 0, a
    /// stiff mount, or a scenario without flexure about the axis), whose angle and rate
    /// are zero at all times. The filter holds such an axis's θ and θ̇ out of the
    /// estimation (the engine's initial factor, its measurement rows, and
    /// [`AxisModel::transition`]): carried as states with zero variance, they took the
    /// scale of a zero variance (1), so the variance floor, which is relative to the
    /// scale, lifted them by an absolute 1e-12 rad² (f64) every step, and the time
    /// update divided by those floor-sized variances (docs/diagnosis.md, "The rigid
    /// flexure axis"). A non-stationary AR(2) without noise (a constant or drifting angle
    /// from the prior) is not rigid.
    pub fn is_rigid(&self) -> bool {
        match self {
            AxisModel::Ar(a) => a.sigma_rad == T::zero() && a.is_stationary(),
            AxisModel::SecondOrder(g) => g.sigma_rad == T::zero(),
        }
    }

    /// Transition of the axis's two states over one period `t` (a second-order axis
    /// was discretized at its model's period, which the engine requires to be `t`). A
    /// rigid axis's ([`AxisModel::is_rigid`]) is the identity: its states are inert in
    /// the filter (zero, with a fixed variance no row reads), and the mode's transition
    /// would move that variance between them.
    pub fn transition(&self, t: T) -> Matrix2<T> {
        if self.is_rigid() {
            return Matrix2::identity();
        }
        match self {
            AxisModel::Ar(a) => a.transition(t),
            AxisModel::SecondOrder(g) => g.phi,
        }
    }

    /// Covariance of the process noise the axis's two states take over one period `t`
    /// (rad², rad²/s, rad²/s²).
    pub fn noise_covariance(&self, t: T) -> Matrix2<T> {
        match self {
            AxisModel::Ar(a) => {
                let g = a.noise_gain(t);
                g * g.transpose() * (a.sigma_rad * a.sigma_rad)
            }
            AxisModel::SecondOrder(g) => g.q,
        }
    }

    /// Stationary covariance of the two states, or `None` for a non-stationary model.
    pub fn stationary_covariance(&self, t: T) -> Option<Matrix2<T>> {
        match self {
            AxisModel::Ar(a) => a.stationary_covariance(t),
            AxisModel::SecondOrder(g) => Some(g.stationary_covariance()),
        }
    }

    /// The flexure's angular acceleration as the model predicts it from its states,
    /// `θ̈ = α θ + β θ̇`, as `(α, β)` (1/s², 1/s). A second-order axis's is its equation,
    /// `(−ω², −2ζω)`; an AR(2)'s the change of its rate state over one period `t`,
    /// `(Φ₂₁, Φ₂₂ − 1) / t`. The engine needs it where it reads the states at a matching
    /// time off their epoch: the rate there is `θ̇ − lag θ̈`, not `θ̇`.
    pub fn acceleration(&self, t: T) -> (T, T) {
        match self {
            AxisModel::Ar(a) => {
                let phi = a.transition(t);
                let (p21, p22) = (crate::mat::get(&phi, 1, 0), crate::mat::get(&phi, 1, 1));
                (p21 / t, (p22 - T::one()) / t)
            }
            AxisModel::SecondOrder(g) => {
                let w = g.omega_rad_s;
                (-(w * w), -(T::of(2.0) * g.damping * w))
            }
        }
    }

    /// The density `q` of the white angular acceleration that drives the flexure rate
    /// (rad²/s³): over a short time `s` the rate moves by `N(0, q s)`. A second-order
    /// axis's is `4ζω³σ²` (its stationary `ω²σ²` = `q / (4ζω)`); an AR(2) at the filter
    /// period says nothing of the rate inside a period (its rate state is the period's
    /// mean), so its is zero. The rate matching needs it: the slave's rate is a mean over
    /// IMU intervals, the state the rate at one instant (`align::RateAt::departure_gain`).
    pub fn rate_diffusion(&self) -> T {
        match self {
            AxisModel::Ar(_) => T::zero(),
            AxisModel::SecondOrder(g) => {
                let w = g.omega_rad_s;
                T::of(4.0) * g.damping * w * w * w * g.sigma_rad * g.sigma_rad
            }
        }
    }
}

/// A second-order Gauss-Markov flexure axis, `θ̈ + 2ζω θ̇ + ω² θ = w`, with its exact
/// discretization at the period it was built for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SecondOrderAxis<T> {
    /// Natural frequency ω (rad/s), > 0.
    pub omega_rad_s: T,
    /// Damping ratio ζ, > 0.
    pub damping: T,
    /// Stationary σ of θ (rad), ≥ 0.
    pub sigma_rad: T,
    /// `e^{AT}` of `[θ, θ̇]`.
    phi: Matrix2<T>,
    /// Process noise over one period: `P∞ − Φ P∞ Φᵀ`.
    q: Matrix2<T>,
}

impl<T: Real> SecondOrderAxis<T> {
    /// The axis sampled at period `t` (s), or `None` unless ω > 0, ζ > 0, σ ≥ 0, t > 0
    /// (all finite). Computed in `f64` whatever `T` (once per configuration): in `f32`
    /// the difference `P∞ − Φ P∞ Φᵀ` would lose the angle's part, `q t³/3`, which is
    /// about `(ωt)³` of `σ²`.
    pub fn new(omega_rad_s: T, damping: T, sigma_rad: T, t: T) -> Option<Self> {
        let (w, z, s, dt) = (
            omega_rad_s.to_f64(),
            damping.to_f64(),
            sigma_rad.to_f64(),
            t.to_f64(),
        );
        let valid = [w, z, s, dt].iter().all(|v| v.is_finite())
            && w > 0.0
            && z > 0.0
            && s >= 0.0
            && dt > 0.0;
        if !valid {
            return None;
        }
        let a = Matrix2::new(0.0, 1.0, -w * w, -2.0 * z * w);
        let phi = expm2(&(a * dt))?;
        let p_inf = Matrix2::new(s * s, 0.0, 0.0, (w * s) * (w * s));
        let q = p_inf - phi * p_inf * phi.transpose();
        // Exactly symmetric.
        let q = (q + q.transpose()) * 0.5;
        Some(Self {
            omega_rad_s,
            damping,
            sigma_rad,
            phi: phi.map(T::of),
            q: q.map(T::of),
        })
    }

    /// `diag(σ², ω²σ²)`: θ and θ̇ of a stationary second-order process are uncorrelated.
    pub fn stationary_covariance(&self) -> Matrix2<T> {
        let (s, w) = (self.sigma_rad, self.omega_rad_s);
        Matrix2::new(s * s, T::zero(), T::zero(), (w * s) * (w * s))
    }
}

/// `e^M` of a 2×2 matrix by scaling and squaring a Taylor series (no trigonometry: the
/// board computes it too); `None` for a matrix too large to be a flexure mode's `AT`.
fn expm2(m: &Matrix2<f64>) -> Option<Matrix2<f64>> {
    let norm = m.iter().fold(0.0f64, |a, v| a.max(v.abs())) * 2.0;
    if !norm.is_finite() || norm > 1e6 {
        return None;
    }
    let mut squarings = 0u32;
    let mut scale = 1.0;
    while norm * scale > 0.25 {
        scale *= 0.5;
        squarings += 1;
    }
    let small = m * scale;
    let (mut e, mut term) = (Matrix2::identity(), Matrix2::identity());
    for k in 1..=12 {
        term = term * small / f64::from(k);
        e += term;
    }
    for _ in 0..squarings {
        e = e * e;
    }
    Some(e)
}

/// AR(2) flexure model of one axis at the filter period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArAxis<T> {
    /// `a1` of θ_{k+1} = a1 θ_k + a2 θ_{k−1} + η.
    pub a1: T,
    /// `a2`.
    pub a2: T,
    /// Standard deviation of the driving noise η (rad).
    pub sigma_rad: T,
}

/// The three-axis flexure model (axes of the slave body frame) at period `T`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlexureModel<T> {
    /// Per-axis model.
    pub axes: [AxisModel<T>; 3],
    /// Sample period the coefficients belong to, which is the filter period (s).
    pub period_s: T,
}

impl<T: Real> ArAxis<T> {
    /// Transition of `[θ_k, θ̇_k]` over one period `t`.
    pub fn transition(&self, t: T) -> Matrix2<T> {
        let s = self.a1 + self.a2;
        Matrix2::new(s, -self.a2 * t, (s - T::one()) / t, -self.a2)
    }

    /// How the driving noise η enters `[θ_k, θ̇_k]`: `[1, 1/T]`.
    pub fn noise_gain(&self, t: T) -> Vector2<T> {
        Vector2::new(T::one(), T::one() / t)
    }

    /// Whether both roots of z² − a1 z − a2 lie strictly inside the unit circle.
    pub fn is_stationary(&self) -> bool {
        // Stability triangle of a second-order AR process.
        self.a2.abs() < T::one() && self.a2 + self.a1 < T::one() && self.a2 - self.a1 < T::one()
    }

    /// Stationary covariance of `[θ, θ̇]` (rad², rad²/s), or `None` for a
    /// non-stationary model (the caller then uses its configured prior).
    pub fn stationary_covariance(&self, t: T) -> Option<Matrix2<T>> {
        if !self.is_stationary() {
            return None;
        }
        // Autocovariances of AR(2) from the Yule-Walker equations.
        let (a1, a2, s2) = (self.a1, self.a2, self.sigma_rad * self.sigma_rad);
        let one = T::one();
        let g0 = (one - a2) * s2 / ((one + a2) * ((one - a2) * (one - a2) - a1 * a1));
        let g1 = a1 * g0 / (one - a2);
        if !(g0.is_finite() && g1.is_finite()) || g0 <= T::zero() {
            return None;
        }
        // θ̇ = (θ_k − θ_{k−1})/T: var = 2(γ0 − γ1)/T², cov(θ, θ̇) = (γ0 − γ1)/T.
        let c = (g0 - g1) / t;
        Some(Matrix2::new(g0, c, c, T::of(2.0) * (g0 - g1) / (t * t)))
    }
}

impl<T: Real> ArAxis<T> {
    /// The AR(2) model whose poles are those of a second-order Gauss-Markov process
    /// `θ̈ + 2ζω θ̇ + ω² θ = w` sampled at period `t`, with the driving noise chosen so
    /// the stationary standard deviation of θ is `sigma_theta_rad`.
    ///
    /// The sampled process is exactly ARMA(2,1); this AR(2) has the same poles and
    /// variance, which is the approximation the filter makes on such truth.
    pub fn from_gauss_markov(omega_n: T, zeta: T, sigma_theta_rad: T, t: T) -> Self {
        let one = T::one();
        let r = (-zeta * omega_n * t).exp();
        let a1 = if zeta < one {
            let wd = omega_n * (one - zeta * zeta).sqrt();
            T::of(2.0) * r * (wd * t).cos()
        } else {
            let wd = omega_n * (zeta * zeta - one).sqrt();
            T::of(2.0) * r * (wd * t).cosh()
        };
        let a2 = -r * r;
        // Invert the AR(2) variance formula for σ_η.
        let g0_per_s2 = (one - a2) / ((one + a2) * ((one - a2) * (one - a2) - a1 * a1));
        let sigma = sigma_theta_rad / g0_per_s2.sqrt();
        Self {
            a1,
            a2,
            sigma_rad: sigma,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The angular acceleration each model predicts from its states: the mode's own
    /// equation for a second-order axis, and for the AR(2) with the same poles the change
    /// of its rate state over a period, which tends to it as the period shrinks.
    #[test]
    fn acceleration_is_the_modes_equation_and_the_ar_tends_to_it() {
        let (w, z, s) = (1.44_f64, 0.2, 3.85e-4);
        let exact = AxisModel::SecondOrder(SecondOrderAxis::new(w, z, s, 0.05).unwrap());
        let (a, b) = exact.acceleration(0.05);
        assert_eq!((a, b), (-(w * w), -2.0 * z * w));
        for t in [0.01, 0.001] {
            let ar = AxisModel::Ar(ArAxis::from_gauss_markov(w, z, s, t));
            let (a_ar, b_ar) = ar.acceleration(t);
            assert!(
                (a_ar - a).abs() < 2.0 * w * w * w * t,
                "{t}: α {a_ar} against {a}"
            );
            assert!(
                (b_ar - b).abs() < 4.0 * (z * w) * (z * w) * t,
                "{t}: β {b_ar} against {b}"
            );
        }
        // The rate diffusion: 4ζω³σ² for the mode, none said by an AR(2).
        assert!((exact.rate_diffusion() - 4.0 * z * w.powi(3) * s * s).abs() < 1e-20);
        let ar = AxisModel::Ar(ArAxis::from_gauss_markov(w, z, s, 0.05));
        assert_eq!(ar.rate_diffusion(), 0.0);
    }

    /// A rigid axis (σ = 0, second-order or a stationary AR(2)) holds its states: the
    /// identity and no process noise, in both precisions; a flexing axis keeps its
    /// mode's transition, and an AR(2) without noise that is not stationary (an angle
    /// held from its prior) is not rigid.
    #[test]
    fn a_rigid_axis_holds_its_states() {
        fn check<T: Real>() {
            let t = T::of(0.01);
            let (w, z) = (T::of(1.5), T::of(0.3));
            let zero = Matrix2::<T>::zeros();
            let rigid_gm =
                AxisModel::SecondOrder(SecondOrderAxis::new(w, z, T::zero(), t).unwrap());
            let ar = |a1: f64, a2: f64, s: f64| {
                AxisModel::Ar(ArAxis {
                    a1: T::of(a1),
                    a2: T::of(a2),
                    sigma_rad: T::of(s),
                })
            };
            for m in [rigid_gm, ar(1.9, -0.91, 0.0)] {
                assert!(m.is_rigid());
                assert_eq!(m.transition(t), Matrix2::identity());
                assert_eq!(m.noise_covariance(t), zero);
            }
            let g = SecondOrderAxis::new(w, z, T::of(1e-4), t).unwrap();
            let flexing = AxisModel::SecondOrder(g);
            assert!(!flexing.is_rigid());
            assert_eq!(flexing.transition(t), g.phi);
            assert!(!ar(1.9, -0.91, 1e-6).is_rigid());
            assert!(!ar(1.0, 0.0, 0.0).is_rigid());
        }
        check::<f32>();
        check::<f64>();
    }

    #[test]
    fn transition_matches_ar_recursion() {
        let ax = ArAxis {
            a1: 1.9_f64,
            a2: -0.92,
            sigma_rad: 0.0,
        };
        let t = 0.01;
        let (th_prev, th) = (0.3, 0.5);
        let x = Vector2::new(th, (th - th_prev) / t);
        let y = ax.transition(t) * x;
        let th_next = 1.9 * th - 0.92 * th_prev;
        assert!((y[0] - th_next).abs() < 1e-12);
        assert!((y[1] - (th_next - th) / t).abs() < 1e-9);
    }

    #[test]
    fn stationary_covariance_is_fixed_point_of_propagation() {
        let ax = ArAxis::from_gauss_markov(1.0_f64, 0.2, 3e-4, 0.01);
        let t = 0.01;
        let p = ax.stationary_covariance(t).unwrap();
        let phi = ax.transition(t);
        let g = ax.noise_gain(t);
        let next = phi * p * phi.transpose() + g * g.transpose() * ax.sigma_rad * ax.sigma_rad;
        assert!(((next - p).norm() / p.norm()) < 1e-9);
        assert!((p[(0, 0)].sqrt() - 3e-4).abs() < 1e-12);
    }

    /// Φ and Q of the continuous mode sampled at period `t`, by Van Loan's matrix
    /// exponential (a Taylor series: `t` is small): the reference the tests hold the
    /// filter's models to.
    fn van_loan(omega: f64, zeta: f64, sigma: f64, t: f64) -> (Matrix2<f64>, Matrix2<f64>) {
        use nalgebra::Matrix4;
        let q = 4.0 * zeta * omega.powi(3) * sigma * sigma;
        let a = Matrix2::new(0.0, 1.0, -omega * omega, -2.0 * zeta * omega);
        let mut m = Matrix4::zeros();
        m.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-a));
        m[(1, 3)] = q;
        m.fixed_view_mut::<2, 2>(2, 2).copy_from(&a.transpose());
        let (mut e, mut term) = (Matrix4::identity(), Matrix4::identity());
        for k in 1..60 {
            term = term * m * (t / k as f64);
            e += term;
        }
        let phi: Matrix2<f64> = e.fixed_view::<2, 2>(2, 2).transpose();
        let qd = phi * e.fixed_view::<2, 2>(0, 2);
        (phi, qd)
    }

    /// The exact one-step prediction variance of θ sampled from the continuous process
    /// (the ARMA(2,1)'s innovation variance): the steady-state Kalman prediction variance
    /// of θ observed without noise, with Φ and Q of the sampled `[θ, θ̇]` ([`van_loan`]).
    fn exact_one_step_variance(omega: f64, zeta: f64, sigma: f64, t: f64) -> f64 {
        let (phi, qd) = van_loan(omega, zeta, sigma, t);
        let mut p = Matrix2::new(sigma * sigma, 0.0, 0.0, (omega * sigma).powi(2));
        for _ in 0..20_000 {
            let k = p.column(0) / p[(0, 0)];
            let updated = p - k * p.row(0);
            p = phi * updated * phi.transpose() + qd;
        }
        p[(0, 0)]
    }

    /// The approximation the filter makes on a Gauss-Markov flexure, measured: its AR(2)
    /// driving variance is the one-step prediction variance it assumes, and the sampled
    /// process's exact one is (1 + (2 − √3))² ≈ 1.61 times smaller (the ARMA(2,1)'s
    /// moving-average zero at −(2 − √3) for small ωt). `docs/model-learning.md` says what
    /// that does with a noiseless master and why the Yule-Walker AR(2) did not replace it.
    #[test]
    fn gauss_markov_ar2_overstates_the_one_step_variance_by_the_moving_average_factor() {
        let factor = (1.0 + (2.0 - 3f64.sqrt())).powi(2);
        for &(omega, zeta, t) in &[(1.43, 0.33, 0.02), (0.5, 0.1, 0.01), (2.5, 0.5, 0.1)] {
            let sigma = 5e-4;
            let ax = ArAxis::from_gauss_markov(omega, zeta, sigma, t);
            let ratio =
                ax.sigma_rad * ax.sigma_rad / exact_one_step_variance(omega, zeta, sigma, t);
            assert!(
                (ratio / factor - 1.0).abs() < 0.03,
                "{omega} {zeta} {t}: {ratio}"
            );
        }
    }

    /// Φ against the closed form of an under-damped oscillator's `e^{At}`, Q against
    /// the Van Loan integral (`exact_one_step_variance`'s series), and the stationary
    /// covariance a fixed point of the propagation; also for an over-damped axis.
    #[test]
    fn second_order_axis_is_the_exact_sampled_process() {
        for &(w, z, s, t) in &[
            (1.43f64, 0.33, 5e-4, 0.02),
            (0.5, 0.1, 1e-3, 0.01),
            (2.5, 1.6, 2e-4, 0.1),
        ] {
            let g = SecondOrderAxis::new(w, z, s, t).expect("valid");
            if z < 1.0 {
                let (a, wd) = (z * w, w * (1.0 - z * z).sqrt());
                let (c, sn, e) = ((wd * t).cos(), (wd * t).sin(), (-a * t).exp());
                let closed = Matrix2::new(
                    e * (c + a / wd * sn),
                    e * sn / wd,
                    -e * w * w * sn / wd,
                    e * (c - a / wd * sn),
                );
                assert!((g.phi - closed).norm() < 1e-12 * closed.norm(), "{w} {z}");
            }
            let (_, q_ref) = van_loan(w, z, s, t);
            for (i, j) in [(0, 0), (0, 1), (1, 1)] {
                let rel = (g.q[(i, j)] - q_ref[(i, j)]).abs() / q_ref[(i, j)].abs();
                assert!(
                    rel < 1e-6,
                    "{w} {z} Q({i},{j}): {} vs {}",
                    g.q[(i, j)],
                    q_ref[(i, j)]
                );
            }
            let p = g.stationary_covariance();
            let next = g.phi * p * g.phi.transpose() + g.q;
            assert!((next - p).norm() < 1e-12 * p.norm());
            let m = AxisModel::SecondOrder(g);
            assert_eq!(m.transition(t), g.phi);
            assert_eq!(m.noise_covariance(t), g.q);
        }
    }

    /// The same axis built in `f32` (the board) keeps the angle's small process noise:
    /// it is computed in `f64` and rounded once.
    #[test]
    fn second_order_axis_in_f32_keeps_the_angle_noise() {
        let g64 = SecondOrderAxis::new(1.0f64, 0.3, 3e-4, 0.01).expect("valid");
        let g32 = SecondOrderAxis::new(1.0f32, 0.3, 3e-4, 0.01).expect("valid");
        for (i, j) in [(0, 0), (0, 1), (1, 1)] {
            let rel = (f64::from(g32.q[(i, j)]) - g64.q[(i, j)]).abs() / g64.q[(i, j)].abs();
            assert!(rel < 1e-6, "Q({i},{j}) {rel}");
        }
    }

    #[test]
    fn second_order_axis_refuses_what_is_not_a_damped_mode() {
        assert!(SecondOrderAxis::new(0.0f64, 0.3, 1e-4, 0.01).is_none());
        assert!(SecondOrderAxis::new(1.0f64, 0.0, 1e-4, 0.01).is_none());
        assert!(SecondOrderAxis::new(1.0f64, 0.3, -1e-4, 0.01).is_none());
        assert!(SecondOrderAxis::new(1.0f64, 0.3, 1e-4, 0.0).is_none());
        assert!(SecondOrderAxis::new(f64::NAN, 0.3, 1e-4, 0.01).is_none());
        assert!(SecondOrderAxis::new(1e30f64, 0.3, 1e-4, 0.01).is_none());
    }

    #[test]
    fn non_stationary_models_have_no_stationary_covariance() {
        assert!(ArAxis {
            a1: 1.0_f64,
            a2: 0.0,
            sigma_rad: 1.0
        }
        .stationary_covariance(0.01)
        .is_none());
        assert!(ArAxis {
            a1: 0.5_f64,
            a2: 0.6,
            sigma_rad: 1.0
        }
        .stationary_covariance(0.01)
        .is_none());
    }
}
