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

/// How far (s) the newest rate's time may be past the epoch before the epoch moves to
/// it: the window's `T` times are then within 1 s of zero, in `f32` within 6·10⁻⁸ s of
/// their `f64` difference (the rate's own `f64` time as the master stamped it, at 10⁵ s,
/// is within 7·10⁻¹² s).
const EPOCH_REACH_S: f64 = 1.0;

/// How far (relative) a spacing of the master's stamps may be from the first of its run
/// for the run to be evenly spaced (`PastRates::even`): a window of 64 such rates is then
/// within 6.3·10⁻⁸ s of its even grid at 100 Hz, the `f32` times' own rounding (`f64`
/// stamps at 10⁵ s are 1.5·10⁻¹¹ s coarse, 1.5·10⁻⁹ of a 100 Hz spacing).
const EVEN_TOLERANCE: f64 = 1e-7;

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
    /// How many of the newest rates are within `RATE_WINDOW_S` of the newest: the fit's
    /// window.
    window: usize,
    /// How many of the newest rates are evenly spaced: each spacing within
    /// `EVEN_TOLERANCE` of `spacing`.
    even: usize,
    /// The first spacing of the even run (s).
    spacing: f64,
    /// The normal matrix's factor for `n` evenly spaced rates, `(n, factor)`, formed on
    /// the first evenly spaced window of `n` rates: in `u`, over the window's span, the
    /// normal matrix of evenly spaced rates depends on their count only, so it holds for
    /// every later such window of `n` rates, whatever their spacing. 68 B in `f32`.
    grid: Option<(usize, Ldl<T>)>,
}

impl<T: Real> PastRates<T> {
    pub(super) fn new() -> Self {
        Self {
            rates: Deque::new(),
            epoch: 0.0,
            window: 0,
            even: 0,
            spacing: 0.0,
            grid: None,
        }
    }

    /// Forgets the rates (the engine's reset; a stamp not after the newest). The factor
    /// kept for a count of evenly spaced rates stays good: it depends on the count only.
    pub(super) fn clear(&mut self) {
        self.rates.clear();
        self.window = 0;
        self.even = 0;
    }

    /// Keeps the rate `w` at `t`, dropping the oldest when full. A time not after the
    /// newest (a master re-stamped, a replay looped) starts the history again, as it
    /// starts [`super::RateRun`]'s run: the window is then always the newest rates.
    /// Where `t` is `EPOCH_REACH_S` or more past the epoch, the epoch moves to `t` and
    /// the kept rates' `tau` by the same `T` step (once a second at any master rate; 64
    /// subtractions). Then the window gains the rate and loses those now too old, and
    /// where its rates are evenly spaced and their count is new (the window filling at
    /// the start or after a gap, a master that changes its rate), the normal matrix's
    /// factor for their count is formed (≈ 2k instructions on the board).
    pub(super) fn push(&mut self, t: f64, w: Vector3<T>) {
        match self.rates.back() {
            Some(r) if t > r.t => {
                let spacing = t - r.t;
                if self.even >= 2 && (spacing - self.spacing).abs() <= EVEN_TOLERANCE * self.spacing
                {
                    self.even += 1;
                } else {
                    self.even = 2;
                    self.spacing = spacing;
                }
            }
            _ => {
                self.clear();
                self.epoch = t;
                self.even = 1;
            }
        }
        let reach = t - self.epoch;
        let tau = if reach >= EPOCH_REACH_S {
            let step = T::of(reach);
            for r in self.rates.iter_mut() {
                r.tau -= step;
            }
            self.epoch = t;
            T::zero()
        } else {
            T::of(reach)
        };
        if self.rates.is_full() {
            let _ = self.rates.pop_front();
        }
        let _ = self.rates.push_back(PastRate { t, tau, w });
        self.even = self.even.min(self.rates.len());
        // The window gains the new rate and loses its oldest ones before `from` (the
        // times increase).
        let from = tau - T::of(RATE_WINDOW_S);
        self.window = (self.window + 1).min(self.rates.len());
        while self.oldest_in_window().is_some_and(|r| r.tau < from) {
            self.window -= 1;
        }
        let n = self.window;
        if n >= RATE_MIN && n <= self.even && self.grid.is_none_or(|g| g.0 != n) {
            self.grid = self.span().and_then(|(mid, inv_half)| {
                let normal = normal_sums(self.window_parts(), mid, inv_half);
                Ldl::of(T::of(n as f64), &normal).map(|f| (n, f))
            });
        }
    }

    /// The window's oldest rate.
    fn oldest_in_window(&self) -> Option<&PastRate<T>> {
        let [older, newer] = self.window_parts();
        older.first().or(newer.first())
    }

    /// The window's middle and the reciprocal of its half-span (`u = (τ − mid) inv_half`
    /// runs from −1 to 1 over it), if it holds `RATE_MIN` rates and spans a time.
    fn span(&self) -> Option<(T, T)> {
        let [older, newer] = self.window_parts();
        let t0 = older.first().or(newer.first())?.tau;
        let t1 = newer.last().or(older.last())?.tau;
        (self.window >= RATE_MIN && t1 > t0).then(|| {
            let half = (t1 - t0) * T::of(0.5);
            (t0 + half, T::one() / half)
        })
    }

    /// The window's rates in the deque's two slices, the oldest first.
    fn window_parts(&self) -> [&[PastRate<T>]; 2] {
        let (older, newer) = self.rates.as_slices();
        let in_older = self.window.saturating_sub(newer.len());
        [
            older
                .get(older.len().saturating_sub(in_older)..)
                .unwrap_or_default(),
            newer
                .get(newer.len().saturating_sub(self.window)..)
                .unwrap_or_default(),
        ]
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
    /// Of evenly spaced rates (`EVEN_TOLERANCE`) only the right-hand side is summed, the
    /// normal matrix's factor kept from the first window of their count. The test below
    /// holds it to main's direct fit over rates of every kind.
    pub(super) fn fit(&self, t_msg: f64, noise_var: T) -> Option<RateFit<T>> {
        let (mid, inv_half) = self.span()?;
        let parts = self.window_parts();
        // Evenly spaced rates: the normal matrix's factor `push` formed on the first
        // window of their count (in `u` it is the same for any spacing).
        let count = self.window;
        let grid = self.grid.filter(|g| count <= self.even && g.0 == count);
        let factor = match grid {
            Some((_, factor)) => factor,
            None => Ldl::of(T::of(count as f64), &normal_sums(parts, mid, inv_half))?,
        };
        let rhs = rhs_sums(parts, mid, inv_half);
        // The cubic and quartic terms shrunk by their noise (`RATE_TERM_SHRINK`, the
        // rates' white noise `noise_var` through the fit): against a noiseless master the
        // quartic whole, against a noisy one (20 °/h at 100 Hz) nearly the parabola,
        // whose slope weighs the newest rates less. The quartic's weights on them carried
        // their noise, which the flexure states had taken into the innovation, into the
        // column: a 10 ms delay read as 10.9 ± 0.1 ms (docs/diagnosis.md "Session 14").
        let kappa = T::of(RATE_TERM_SHRINK) * noise_var;
        let [inv3, inv4] = factor.inverse_diagonal_34();
        let var = [kappa * inv3, kappa * inv4];
        let u_msg = (T::of(t_msg - self.epoch) - mid) * inv_half;
        let (p, dp) = legendre(u_msg);
        let [x0, y0, z0, x1, y1, z1, x2, y2, z2, x3, y3, z3, x4, y4, z4] = rhs;
        let axis = |b: [T; RATE_TERMS]| {
            let coef = shrink(factor.solve(b), &var);
            (dot5(&coef, &p), dot5(&coef, &dp) * inv_half)
        };
        let (vx, sx) = axis([x0, x1, x2, x3, x4]);
        let (vy, sy) = axis([y0, y1, y2, y3, y4]);
        let (vz, sz) = axis([z0, z1, z2, z3, z4]);
        let finite = [vx, vy, vz, sx, sy, sz].iter().all(|v| v.is_finite());
        finite.then(|| RateFit {
            value: Vector3::new(vx, vy, vz),
            slope: Vector3::new(sx, sy, sz),
        })
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

/// The fit's normal matrix, the lower triangle of `Σ P_i P_j` but `(0, 0)` (the count),
/// row by row: `Σ P_1`, `Σ P_1²`, `Σ P_2`, `Σ P_2 P_1`, `Σ P_2²`, … (`P_0 = 1`), over
/// the window's rates `parts` (the oldest first), `P_i` at `u = (τ − mid) inv_half`.
/// Each sum in its own variable, apart from the right-hand side's ([`rhs_sums`]):
/// together they are more than the FPU's 32 registers, and as nalgebra's outer products
/// (a loop each on the board) they cost ten times the arithmetic.
#[inline(never)]
fn normal_sums<T: Real>(parts: [&[PastRate<T>]; 2], mid: T, inv_half: T) -> [T; 14] {
    let [mut s10, mut s11, mut s20, mut s21, mut s22, mut s30, mut s31, mut s32, mut s33, mut s40, mut s41, mut s42, mut s43, mut s44] =
        [T::zero(); 14];
    for part in parts {
        for r in part {
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
    }
    [
        s10, s11, s20, s21, s22, s30, s31, s32, s33, s40, s41, s42, s43, s44,
    ]
}

/// The fit's right-hand side, `Σ P_i ω` for i = 0 … 4, three axes each, row by row (as
/// [`normal_sums`]).
#[inline(never)]
fn rhs_sums<T: Real>(parts: [&[PastRate<T>]; 2], mid: T, inv_half: T) -> [T; 15] {
    let [mut x0, mut y0, mut z0, mut x1, mut y1, mut z1, mut x2, mut y2, mut z2, mut x3, mut y3, mut z3, mut x4, mut y4, mut z4] =
        [T::zero(); 15];
    for part in parts {
        for r in part {
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
    }
    [x0, y0, z0, x1, y1, z1, x2, y2, z2, x3, y3, z3, x4, y4, z4]
}

/// The fit's normal matrix as `L D Lᵀ` (`L` unit lower triangular, `D` diagonal), in
/// straight-line code: nalgebra's Cholesky and its solves, loops over a 5 × 5 matrix,
/// cost the board ≈ 1.5k instructions an update, with five software square roots.
#[derive(Clone, Copy, Debug)]
struct Ldl<T> {
    /// `L` below its diagonal, row by row: `l10`, `l20`, `l21`, `l30`, … `l43`.
    l: [T; 10],
    /// `1 / D`.
    inv_d: [T; RATE_TERMS],
}

impl<T: Real> Ldl<T> {
    /// The factor of the normal matrix whose `(0, 0)` is `n` and the rest of whose lower
    /// triangle is `normal` ([`normal_sums`]); `None` unless every pivot is positive
    /// and finite (not positive definite).
    #[inline(never)]
    fn of(n: T, normal: &[T; 14]) -> Option<Self> {
        let [n10, n11, n20, n21, n22, n30, n31, n32, n33, n40, n41, n42, n43, n44] = *normal;
        let pivot = |d: T| (d > T::zero() && d.is_finite()).then(|| T::one() / d);
        // Column by column; `e_ij = l_ij d_j`.
        let i0 = pivot(n)?;
        let (l10, l20, l30, l40) = (n10 * i0, n20 * i0, n30 * i0, n40 * i0);
        let d1 = n11 - l10 * n10;
        let i1 = pivot(d1)?;
        let (e21, e31, e41) = (n21 - l20 * n10, n31 - l30 * n10, n41 - l40 * n10);
        let (l21, l31, l41) = (e21 * i1, e31 * i1, e41 * i1);
        let d2 = n22 - l20 * n20 - l21 * e21;
        let i2 = pivot(d2)?;
        let e32 = n32 - l30 * n20 - l31 * e21;
        let e42 = n42 - l40 * n20 - l41 * e21;
        let (l32, l42) = (e32 * i2, e42 * i2);
        let d3 = n33 - l30 * n30 - l31 * e31 - l32 * e32;
        let i3 = pivot(d3)?;
        let e43 = n43 - l40 * n30 - l41 * e31 - l42 * e32;
        let l43 = e43 * i3;
        let d4 = n44 - l40 * n40 - l41 * e41 - l42 * e42 - l43 * e43;
        let i4 = pivot(d4)?;
        Some(Self {
            l: [l10, l20, l21, l30, l31, l32, l40, l41, l42, l43],
            inv_d: [i0, i1, i2, i3, i4],
        })
    }

    /// The solution of `N x = b`.
    fn solve(&self, b: [T; RATE_TERMS]) -> [T; RATE_TERMS] {
        let [l10, l20, l21, l30, l31, l32, l40, l41, l42, l43] = self.l;
        let [i0, i1, i2, i3, i4] = self.inv_d;
        let [b0, b1, b2, b3, b4] = b;
        let y1 = b1 - l10 * b0;
        let y2 = b2 - l20 * b0 - l21 * y1;
        let y3 = b3 - l30 * b0 - l31 * y1 - l32 * y2;
        let y4 = b4 - l40 * b0 - l41 * y1 - l42 * y2 - l43 * y3;
        let x4 = y4 * i4;
        let x3 = y3 * i3 - l43 * x4;
        let x2 = y2 * i2 - l32 * x3 - l42 * x4;
        let x1 = y1 * i1 - l21 * x2 - l31 * x3 - l41 * x4;
        let x0 = b0 * i0 - l10 * x1 - l20 * x2 - l30 * x3 - l40 * x4;
        [x0, x1, x2, x3, x4]
    }

    /// The inverse normal matrix's `(3, 3)` and `(4, 4)`, the cubic and quartic
    /// coefficients' variances per unit noise variance (`N⁻¹ = L⁻ᵀ D⁻¹ L⁻¹`, `L⁻¹`'s
    /// last two rows `[…, 1, 0]` and `[…, −l43, 1]`).
    fn inverse_diagonal_34(&self) -> [T; 2] {
        let [.., l43] = self.l;
        let [.., i3, i4] = self.inv_d;
        [i3 + l43 * l43 * i4, i4]
    }
}

/// The coefficients `c` with their cubic and quartic terms shrunk to `c (1 − var / c²)`,
/// zero where `c² ≤ var` (`var`: their variances times `RATE_TERM_SHRINK`).
fn shrink<T: Real>(c: [T; RATE_TERMS], var: &[T; 2]) -> [T; RATE_TERMS] {
    let [c0, c1, c2, c3, c4] = c;
    let term = |c: T, var: T| {
        let c2 = c * c;
        if c2 > var {
            c * (T::one() - var / c2)
        } else {
            T::zero()
        }
    };
    [c0, c1, c2, term(c3, var[0]), term(c4, var[1])]
}

/// `Σ a_i b_i`, in order.
fn dot5<T: Real>(a: &[T; RATE_TERMS], b: &[T; RATE_TERMS]) -> T {
    let ([a0, a1, a2, a3, a4], [b0, b1, b2, b3, b4]) = (*a, *b);
    a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3 + a4 * b4
}

/// The Legendre polynomials `P_1 … P_4` at `u` (`P_0 = 1`), each in `u²` with its
/// coefficients divided out (exact binary fractions), a multiply-add each.
fn legendre_values<T: Real>(u: T) -> [T; 4] {
    let c = |x: f64| T::of(x);
    let u2 = u * u;
    [
        u,
        c(1.5) * u2 - c(0.5),
        (c(2.5) * u2 - c(1.5)) * u,
        (c(4.375) * u2 - c(3.75)) * u2 + c(0.375),
    ]
}

/// The Legendre polynomials `P_0 … P_4` at `u` and their derivatives in `u`.
fn legendre<T: Real>(u: T) -> ([T; RATE_TERMS], [T; RATE_TERMS]) {
    let c = |x: f64| T::of(x);
    let [p1, p2, p3, p4] = legendre_values(u);
    let u2 = u * u;
    let p = [T::one(), p1, p2, p3, p4];
    let dp = [
        T::zero(),
        T::one(),
        c(3.0) * u,
        (c(15.0) * u2 - c(3.0)) * c(0.5),
        (c(35.0) * u2 - c(15.0)) * u * c(0.5),
    ];
    (p, dp)
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    /// The fit as main formed it before `PastRates` (`master_rate_fit`, issue12-s16's
    /// review): `f64` times, each rate's difference from the window's middle in `f64`,
    /// nalgebra's Cholesky and solves (the shrinkage's variances by two more).
    fn direct_fit<T: Real>(
        rates: &Deque<(f64, Vector3<T>), RATE_HISTORY>,
        t_msg: f64,
        noise_var: T,
    ) -> Option<(Vector3<T>, Vector3<T>)> {
        let &(t1, _) = rates.back()?;
        let from = t1 - RATE_WINDOW_S;
        let window = rates.iter().filter(|r| r.0 >= from);
        let t0 = window.clone().next()?.0;
        if window.count() < RATE_MIN || t1 <= t0 {
            return None;
        }
        let (t_mid, half) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
        let mut normal = nalgebra::SMatrix::<T, RATE_TERMS, RATE_TERMS>::zeros();
        let mut rhs = nalgebra::SMatrix::<T, RATE_TERMS, 3>::zeros();
        let exact = |u: T| {
            // Main's polynomials, as written there.
            let c = |x: f64| T::of(x);
            let u2 = u * u;
            nalgebra::SVector::<T, RATE_TERMS>::new(
                T::one(),
                u,
                (c(3.0) * u2 - T::one()) * c(0.5),
                (c(5.0) * u2 - c(3.0)) * u * c(0.5),
                ((c(35.0) * u2 - c(30.0)) * u2 + c(3.0)) * c(0.125),
            )
        };
        for &(t, w) in rates.iter().filter(|r| r.0 >= t0) {
            let p = exact(T::of((t - t_mid) / half));
            normal += p * p.transpose();
            rhs += p * w.transpose();
        }
        let chol = nalgebra::linalg::Cholesky::new(normal)?;
        let mut coef = chol.solve(&rhs);
        for k in 3..RATE_TERMS {
            let mut unit = nalgebra::SVector::<T, RATE_TERMS>::zeros();
            unit[k] = T::one();
            let var = T::of(RATE_TERM_SHRINK) * noise_var * chol.solve(&unit)[k];
            for axis in 0..3 {
                let c = coef[(k, axis)];
                let c2 = c * c;
                coef[(k, axis)] = if c2 > var {
                    c * (T::one() - var / c2)
                } else {
                    T::zero()
                };
            }
        }
        let u = T::of((t_msg - t_mid) / half);
        let (p, dp) = (exact(u), nalgebra::SVector::from(legendre(u).1));
        Some((coef.transpose() * p, coef.transpose() * dp / T::of(half)))
    }

    /// 24 000 master stamps over ≈ 760 s from a day into the run (each `f64` a few 10⁻¹²
    /// s coarse): 100 Hz, jittered 100 Hz (±30 % of the period), 20 Hz and 10 Hz, gaps
    /// of 0.3 s and 3 s, a stamp that steps back 2 s (the history starts again), and
    /// a ship's rates (1.14 rad/s, a 7 s roll and a 13 s pitch) with a little noise.
    fn stamps() -> impl Iterator<Item = (f64, Vector3<f64>)> {
        let mut t = 86_400.0;
        let mut k = 0_u64;
        let mut noise = 0x2545_f491_4f6c_dd1d_u64;
        core::iter::from_fn(move || {
            k += 1;
            let segment = (k / 4000) % 6;
            let period = match segment {
                0 => 0.01,
                1 => 0.01 * (1.0 + 0.3 * libm::sin(k as f64 * 1.7)),
                2 => 0.05,
                3 => 0.1,
                _ => 0.01,
            };
            t += period;
            match k % 4000 {
                1500 if segment == 4 => t += 0.3,
                2500 if segment == 4 => t += 3.0,
                3000 if segment == 5 => t -= 2.0,
                _ => {}
            }
            let mut n = || {
                noise ^= noise << 13;
                noise ^= noise >> 7;
                noise ^= noise << 17;
                (noise >> 11) as f64 / (1_u64 << 53) as f64 - 0.5
            };
            let (roll, pitch) = (
                core::f64::consts::TAU / 7.0 * t,
                core::f64::consts::TAU / 13.0 * t,
            );
            let w = Vector3::new(
                1.14 * libm::sin(roll) + 1e-3 * n(),
                0.4 * libm::cos(pitch) + 1e-3 * n(),
                0.05 * libm::sin(roll + pitch) + 1e-3 * n(),
            );
            (k <= 24_000).then_some((t, w))
        })
    }

    /// The largest differences from the direct fit in `f64` over [`stamps`] (the message
    /// 10 ms after each rate), value (rad/s) and slope (rad/s²): of `PastRates::fit` in
    /// `T`, and of the direct fit in `T`; the count of fits, and of those on the even
    /// grid.
    fn largest_differences<T: Real>(noise_var: f64) -> ([f64; 2], [f64; 2], [usize; 2]) {
        let mut rates = PastRates::<T>::new();
        let mut reference = Deque::<(f64, Vector3<T>), RATE_HISTORY>::new();
        let mut exact = Deque::<(f64, Vector3<f64>), RATE_HISTORY>::new();
        let (mut new_err, mut direct_err, mut fits) = ([0.0_f64; 2], [0.0_f64; 2], 0);
        let mut even = 0;
        for (t, w) in stamps() {
            rates.push(t, w.map(T::of));
            if exact.back().is_some_and(|r| t <= r.0) {
                reference.clear();
                exact.clear();
            }
            if exact.is_full() {
                reference.pop_front();
                exact.pop_front();
            }
            reference.push_back((t, w.map(T::of))).unwrap();
            exact.push_back((t, w)).unwrap();
            let t_msg = t + 0.01;
            let new = rates.fit(t_msg, T::of(noise_var));
            let on_grid = rates.grid.as_ref().is_some_and(|g| g.0 == rates.window);
            even += usize::from(new.is_some() && on_grid && rates.window <= rates.even);
            let direct = direct_fit(&reference, t_msg, T::of(noise_var));
            let truth = direct_fit(&exact, t_msg, noise_var);
            assert_eq!(new.is_some(), truth.is_some(), "at {t}");
            if let (Some(new), Some(direct), Some((value, slope))) = (new, direct, truth) {
                fits += 1;
                let err = |v: Vector3<T>, s: Vector3<T>, e: &mut [f64; 2]| {
                    e[0] = e[0].max((v.map(T::to_f64) - value).amax());
                    e[1] = e[1].max((s.map(T::to_f64) - slope).amax());
                };
                err(new.value, new.slope, &mut new_err);
                err(direct.0, direct.1, &mut direct_err);
            }
        }
        (new_err, direct_err, [fits, even])
    }

    #[test]
    fn fit_agrees_with_the_direct_fit_over_a_long_irregular_run() {
        // The lever arm's rate noise of the layouts (20 °/h at 100 Hz is ≈ 1e-4 rad/s
        // a rate) and a noisy master's, which shrinks the cubic and quartic terms.
        for noise_var in [1e-8, 1e-6] {
            let (new, _, [fits, even]) = largest_differences::<f64>(noise_var);
            // The jittered rates and those after a gap and a step back not on the grid.
            assert!(fits > 20_000 && even > fits * 3 / 4 && even < fits - 3000);
            std::println!("noise {noise_var:e}: f64 {new:?} (rad/s, rad/s²)");
            assert!(new[0] < 1e-10 && new[1] < 1e-9);
            // In `f32`, no farther from the `f64` fit than the direct fit in `f32`.
            let (new, direct, _) = largest_differences::<f32>(noise_var);
            std::println!("noise {noise_var:e}: f32 {new:?}, direct in f32 {direct:?}");
            assert!(new[0] < 2.0 * direct[0] && new[1] < 2.0 * direct[1]);
        }
    }
}
