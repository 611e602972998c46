//! The master's past angular rates and the quartic through them: the delay's rate column
//! and the lever-arm columns' instrument ([`PastRates::fit`]).
//!
//! The rates' times are kept twice: in `f64` as the master stamped them, and in `T`
//! relative to an epoch near the newest, so that the fit, formed at every master
//! message over the 64 rates of a 100 Hz master, does its arithmetic in `T`. With the
//! times' differences, scaling and conversion in software `f64` for every rate it cost
//! the board ≈ 45k instructions an update (`docs/performance.md`, "What issue12-s17
//! changed").

use super::{RATE_HISTORY, RATE_MIN, RATE_TERMS, RATE_TERM_SHRINK, RATE_WINDOW_S};
use crate::real::Real;
use heapless::Deque;
use nalgebra::Vector3;

/// How far (s) the newest rate's time may be from the epoch before the epoch moves to
/// it: the window's `T` times are then within 1 s + `RATE_WINDOW_S` of zero, in `f32`
/// within 6·10⁻⁸ s of their `f64` difference (the rate's own `f64` time as the master
/// stamped it, at 10⁵ s, is within 7·10⁻¹² s).
const EPOCH_REACH_S: f64 = 1.0;

/// One kept master rate.
#[derive(Clone, Copy, Debug)]
struct PastRate<T> {
    /// Its time (s).
    t: f64,
    /// Its time since [`PastRates`]' epoch (s).
    tau: T,
    /// `ω_ib^bm` (rad/s, master body).
    w: Vector3<T>,
}

/// The master's last `RATE_HISTORY` angular rates `(t, ω_ib^bm)`, for the delay's rate
/// column, the lever-arm columns' instrument and the g-sensitivity's rate column. In
/// `f32` a rate takes 24 B, as `(f64, Vector3<f32>)` did with its padding.
#[derive(Clone, Debug)]
pub(super) struct PastRates<T: Real> {
    rates: Deque<PastRate<T>, RATE_HISTORY>,
    /// The time (s) the rates' `tau` count from.
    epoch: f64,
}

impl<T: Real> PastRates<T> {
    pub(super) fn new() -> Self {
        Self {
            rates: Deque::new(),
            epoch: 0.0,
        }
    }

    pub(super) fn clear(&mut self) {
        self.rates.clear();
    }

    /// Keeps the rate `w` at `t`, dropping the oldest when full. Where `t` is
    /// `EPOCH_REACH_S` or more from the epoch (or the first), the epoch moves to `t`
    /// and the kept rates' `tau` by the same `T` step (once a second at any master rate;
    /// 64 subtractions).
    pub(super) fn push(&mut self, t: f64, w: Vector3<T>) {
        if self.rates.is_empty() {
            self.epoch = t;
        }
        let reach = t - self.epoch;
        if reach.abs() >= EPOCH_REACH_S {
            let step = T::of(reach);
            for r in self.rates.iter_mut() {
                r.tau -= step;
            }
            self.epoch = t;
        }
        if self.rates.is_full() {
            let _ = self.rates.pop_front();
        }
        let tau = T::of(t - self.epoch);
        let _ = self.rates.push_back(PastRate { t, tau, w });
    }

    /// The master's angular acceleration from its two previous rates (rad/s², master
    /// body): their difference over their interval, which belongs to its middle (1.5
    /// master periods before the message). `None` with fewer than two, or a gap of more
    /// than 2.5 filter periods `period_s` between them.
    pub(super) fn difference(&self, period_s: f64) -> Option<Vector3<T>> {
        let mut newest = self.rates.iter().rev();
        let (r1, r0) = (newest.next()?, newest.next()?);
        let dt = r1.t - r0.t;
        (dt > 0.0 && dt <= 2.5 * period_s).then(|| (r1.w - r0.w) / T::of(dt))
    }

    /// The master's rate and angular acceleration at `t_msg`, the stamp of the message
    /// being matched (master body): the value and derivative there of a least-squares
    /// quartic through the kept rates of the last `RATE_WINDOW_S` before the newest (a
    /// straight line's slope would belong to the window's middle; a parabola's is 6 %
    /// large and 16 ms late at a ship's 1.14 rad/s, and the attitude and rate rows
    /// together must see the delay as the derivative of one column in the other). The
    /// window is a time, not a count: at 10 Hz the 64 rates spanned 6.4 s, longer than
    /// a ship's roll period, and the parabola's slope was no angular acceleration (a
    /// constant 17 ms delay, blind draw 102 with a 10 Hz master: 13.75 ± 0.04 ms with
    /// the rate channel, 17.00 ± 0.07 without it). `noise_var`: the rates' white noise
    /// variance (rad²/s²), which shrinks the cubic and quartic terms. `None` with fewer
    /// than `RATE_MIN` rates in the window (asked only once `RateRun` covers it).
    ///
    /// Least squares in the Legendre polynomials of `u = (τ − τ_mid) / half` over the
    /// window's span: their normal matrix is nearly diagonal, so single precision solves
    /// it (monomials would need `f64`, software arithmetic on the board). Everything in
    /// `T` from the rates' `tau`; the window's membership is `tau ≥ τ₁ − RATE_WINDOW_S`
    /// in `T` (a rate within 10⁻⁷ s of the window's edge may fall either side in `f32`).
    pub(super) fn fit(&self, t_msg: f64, noise_var: T) -> Option<RateFit<T>> {
        let t1 = self.rates.back()?.tau;
        let from = t1 - T::of(RATE_WINDOW_S);
        // The window is the newest rates: counted from the newest, summed from the
        // oldest as the rates came, over the deque's two slices.
        let (older, newer) = self.rates.as_slices();
        let in_window = newer.iter().rev().chain(older.iter().rev());
        let (count, t0) = in_window
            .take_while(|r| r.tau >= from)
            .fold((0, t1), |(n, _), r| (n + 1, r.tau));
        if count < RATE_MIN || t1 <= t0 {
            return None;
        }
        let half = (t1 - t0) * T::of(0.5);
        let mid = t0 + half;
        let inv_half = T::one() / half;
        let older = older
            .get(
                older
                    .len()
                    .saturating_sub(count.saturating_sub(newer.len()))..,
            )
            .unwrap_or_default();
        let newer = newer
            .get(newer.len().saturating_sub(count)..)
            .unwrap_or_default();
        let mut sums = Sums {
            n: T::of(count as f64),
            ..Sums::default()
        };
        for part in [older, newer] {
            sums.normal = normal_sums(part, mid, inv_half, sums.normal);
            sums.rhs = rhs_sums(part, mid, inv_half, sums.rhs);
        }
        let coef = sums.solve(noise_var)?;
        let u_msg = (T::of(t_msg - self.epoch) - mid) * inv_half;
        let (p, dp) = legendre(u_msg);
        let value = coef.transpose() * p;
        let slope = coef.transpose() * dp * inv_half;
        let finite = value.iter().chain(slope.iter()).all(|v| v.is_finite());
        finite.then_some(RateFit { value, slope })
    }
}

/// The master's rate and angular acceleration at `t_msg` from its previous rates.
#[derive(Clone, Copy, Debug)]
pub(super) struct RateFit<T: Real> {
    /// The fitted rate at `t_msg` (rad/s, master body): the lever-arm columns'
    /// instrument. The rate of the message at `t_msg` carries noise that is also in its
    /// own velocity residual (through the arm, `C [n×] r0`); a column built from it is
    /// correlated with that residual's noise, and on a long arm, where the flexure's rate
    /// can take most of the lever arm's velocity, that errors-in-variables bias was
    /// −3.7 cm on a 12 m arm with a 184 °/h master. A parabola through the three previous
    /// rates has 19 times their noise variance and read a 0.43 m arm there up to 2.5 %
    /// short (attenuated); a line through two is 1 % large at 1 rad/s and a 10 Hz master
    /// (docs/diagnosis.md "Session 16").
    pub(super) value: Vector3<T>,
    /// The fitted angular acceleration at `t_msg` (rad/s², master body): the delay's.
    pub(super) slope: Vector3<T>,
}

/// The fit's normal matrix and right-hand side summed over the window's rates.
#[derive(Default)]
struct Sums<T> {
    /// The rates' count, the normal matrix's `(0, 0)`.
    n: T,
    /// The rest of its lower triangle ([`normal_sums`]).
    normal: [T; 14],
    /// The right-hand side ([`rhs_sums`]).
    rhs: [T; 15],
}

/// Adds to `s` the window's rates `rates`' terms of the fit's normal matrix, the lower
/// triangle of `Σ P_i P_j` but `(0, 0)`, row by row: `Σ P_1`, `Σ P_1²`, `Σ P_2`, `Σ P_2
/// P_1`, `Σ P_2²`, … (`P_0 = 1`), `P_i` at `u = (τ − mid) inv_half`. Each sum in its
/// own variable, apart from the right-hand side's ([`rhs_sums`]): together they are
/// more than the FPU's 32 registers, and as nalgebra's outer products (a loop each on
/// the board) they cost ten times the arithmetic.
#[inline(never)]
fn normal_sums<T: Real>(rates: &[PastRate<T>], mid: T, inv_half: T, s: [T; 14]) -> [T; 14] {
    let [mut s10, mut s11, mut s20, mut s21, mut s22, mut s30, mut s31, mut s32, mut s33, mut s40, mut s41, mut s42, mut s43, mut s44] =
        s;
    for r in rates {
        let [p1, p2, p3, p4] = legendre_values((r.tau - mid) * inv_half);
        s10 += p1;
        s11 += p1 * p1;
        s20 += p2;
        s21 += p2 * p1;
        s22 += p2 * p2;
        s30 += p3;
        s31 += p3 * p1;
        s32 += p3 * p2;
        s33 += p3 * p3;
        s40 += p4;
        s41 += p4 * p1;
        s42 += p4 * p2;
        s43 += p4 * p3;
        s44 += p4 * p4;
    }
    [
        s10, s11, s20, s21, s22, s30, s31, s32, s33, s40, s41, s42, s43, s44,
    ]
}

/// Adds to `s` the window's rates `rates`' terms of the fit's right-hand side, `Σ P_i
/// ω` for i = 0 … 4, three axes each (as [`normal_sums`]).
#[inline(never)]
fn rhs_sums<T: Real>(rates: &[PastRate<T>], mid: T, inv_half: T, s: [T; 15]) -> [T; 15] {
    let [mut x0, mut y0, mut z0, mut x1, mut y1, mut z1, mut x2, mut y2, mut z2, mut x3, mut y3, mut z3, mut x4, mut y4, mut z4] =
        s;
    for r in rates {
        let [p1, p2, p3, p4] = legendre_values((r.tau - mid) * inv_half);
        let (x, y, z) = (r.w.x, r.w.y, r.w.z);
        x0 += x;
        y0 += y;
        z0 += z;
        x1 += p1 * x;
        y1 += p1 * y;
        z1 += p1 * z;
        x2 += p2 * x;
        y2 += p2 * y;
        z2 += p2 * z;
        x3 += p3 * x;
        y3 += p3 * y;
        z3 += p3 * z;
        x4 += p4 * x;
        y4 += p4 * y;
        z4 += p4 * z;
    }
    [x0, y0, z0, x1, y1, z1, x2, y2, z2, x3, y3, z3, x4, y4, z4]
}

impl<T: Real> Sums<T> {
    /// The least-squares coefficients, their cubic and quartic terms shrunk by their
    /// noise (`RATE_TERM_SHRINK`, the rates' white noise `noise_var` through the fit):
    /// against a noiseless master the quartic whole, against a noisy one (20 °/h at 100
    /// Hz) nearly the parabola, whose slope weighs the newest rates less. The quartic's
    /// weights on them carried their noise, which the flexure states had taken into the
    /// innovation, into the column: a 10 ms delay read as 10.9 ± 0.1 ms
    /// (docs/diagnosis.md "Session 14"). `None` if the normal matrix is not positive
    /// definite.
    /// A row per Legendre polynomial, a column per axis.
    fn solve(&self, noise_var: T) -> Option<nalgebra::SMatrix<T, RATE_TERMS, 3>> {
        let [p1, a11, p2, a21, a22, p3, a31, a32, a33, p4, a41, a42, a43, a44] = self.normal;
        // The lower triangle, all `Cholesky::new` reads.
        let z = T::zero();
        #[rustfmt::skip]
        let normal = nalgebra::SMatrix::<T, RATE_TERMS, RATE_TERMS>::new(
            self.n, z, z, z, z,
            p1, a11, z, z, z,
            p2, a21, a22, z, z,
            p3, a31, a32, a33, z,
            p4, a41, a42, a43, a44,
        );
        let [x0, y0, z0, x1, y1, z1, x2, y2, z2, x3, y3, z3, x4, y4, z4] = self.rhs;
        #[rustfmt::skip]
        let rhs = nalgebra::SMatrix::<T, RATE_TERMS, 3>::new(
            x0, y0, z0,
            x1, y1, z1,
            x2, y2, z2,
            x3, y3, z3,
            x4, y4, z4,
        );
        let chol = nalgebra::linalg::Cholesky::new(normal)?;
        let mut coef = chol.solve(&rhs);
        // The variances of the cubic and quartic coefficients are `noise_var` times the
        // diagonal of the inverse normal matrix, from its factor `L` (`N⁻¹ = L⁻ᵀ L⁻¹`):
        // `1 / L₄₄²` and `(1 + (L₄₃ / L₄₄)²) / L₃₃²`.
        let l = chol.l_dirty();
        let (l33, l43, l44) = (*l.get((3, 3))?, *l.get((4, 3))?, *l.get((4, 4))?);
        let q = l43 / l44;
        let inverse_diagonal = [(T::one() + q * q) / (l33 * l33), T::one() / (l44 * l44)];
        for (k, d) in (3..RATE_TERMS).zip(inverse_diagonal) {
            let var = T::of(RATE_TERM_SHRINK) * noise_var * d;
            for c in coef.row_mut(k).iter_mut() {
                let c2 = *c * *c;
                *c = if c2 > var {
                    *c * (T::one() - var / c2)
                } else {
                    T::zero()
                };
            }
        }
        Some(coef)
    }
}

/// The Legendre polynomials `P_1 … P_4` at `u` (`P_0 = 1`).
fn legendre_values<T: Real>(u: T) -> [T; 4] {
    let c = |x: f64| T::of(x);
    let u2 = u * u;
    [
        u,
        (c(3.0) * u2 - T::one()) * c(0.5),
        (c(5.0) * u2 - c(3.0)) * u * c(0.5),
        ((c(35.0) * u2 - c(30.0)) * u2 + c(3.0)) * c(0.125),
    ]
}

/// The Legendre polynomials `P_0 … P_4` at `u` and their derivatives in `u`.
fn legendre<T: Real>(
    u: T,
) -> (
    nalgebra::SVector<T, RATE_TERMS>,
    nalgebra::SVector<T, RATE_TERMS>,
) {
    let c = |x: f64| T::of(x);
    let [p1, p2, p3, p4] = legendre_values(u);
    let u2 = u * u;
    let p = nalgebra::SVector::<T, RATE_TERMS>::new(T::one(), p1, p2, p3, p4);
    let dp = nalgebra::SVector::<T, RATE_TERMS>::new(
        T::zero(),
        T::one(),
        c(3.0) * u,
        (c(15.0) * u2 - c(3.0)) * c(0.5),
        (c(35.0) * u2 - c(15.0)) * u * c(0.5),
    );
    (p, dp)
}
