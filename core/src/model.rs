//! The error-state model: state layout, transition Φ over one filter period, process
//! noise Q, and the measurement rows of velocity, attitude and angular-rate matching.
//!
//! The derivation, its convention and the paper's errors it corrects are written
//! down in `docs/error-model.md`; `core/tests/linearization.rs` checks every block
//! here against finite differences of the nonlinear mechanization and measurements.
//!
//! State (21, all in SI units):
//!
//! | block | meaning | frame |
//! |---|---|---|
//! | `V`   δv  | slave velocity error `v̂ − v` (m/s) | n (ENU) |
//! | `PSI` ψ   | slave attitude error, `Ĉ_bs^n = C_bs^n Exp(ψ)` (rad) | b_s |
//! | `MU`  δμ  | mounting misalignment error, `μ = μ̂ + δμ` (rad) | rotation vector of recording-v1 |
//! | `BG`  ε   | gyro bias error `b_g − b̂_g` (rad/s) | b_s |
//! | `BA`  ∇   | accelerometer bias error `b_a − b̂_a` (m/s²) | b_s |
//! | `TH`  θ   | flexure angle (rad) | b_s |
//! | `THD` θ̇  | mean flexure rate over the last period (rad/s) | b_s |
//!
//! The paper's ψ_a is our μ and its ψ_m is μ + θ + ψ (a linear change of variables).

use crate::augment::{self, Augmentation};
use crate::earth::{self, Position};
use crate::flexure::FlexureModel;
use crate::kalman::{Noise, Transition};
use crate::mat::{self, mul3, mul3v, neg3, transpose3, vec3, vget, zip3};
use crate::real::Real;
use crate::rotation::skew;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Number of states of the paper's layout with an AR(2) flexure block.
pub const N: usize = 21;
/// Offset of the velocity error block.
pub const V: usize = 0;
/// Offset of the slave attitude error block.
pub const PSI: usize = 3;
/// Offset of the misalignment error block.
pub const MU: usize = 6;
/// Offset of the gyro bias error block.
pub const BG: usize = 9;
/// Offset of the accelerometer bias error block.
pub const BA: usize = 12;
/// Offset of the flexure angle block.
pub const TH: usize = 15;
/// Offset of the flexure rate block.
pub const THD: usize = 18;

/// State vector of dimension `S` (the declared 21 states, then any augmented blocks).
pub type StateVec<T, const S: usize = N> = SVector<T, S>;
/// State-sized square matrix.
pub type StateMat<T, const S: usize = N> = SMatrix<T, S, S>;

/// What the slave sensed and was over one filter period: the linearization point of Φ.
#[derive(Clone, Copy, Debug)]
pub struct IntervalMeans<T: Real> {
    /// Mean specific force over the period, slave body frame (m/s²).
    pub f_b: Vector3<T>,
    /// The specific force the g-sensitivity's dynamics column `ψ̇ += G f` and the
    /// accelerometer scale factor's and non-orthogonality's `δv̇ += C diag(f) s_a`,
    /// `C N(f)` are made of, slave body (m/s²): the last matched master message's force
    /// carried to the slave without the flexure's motion where the engine has one
    /// (`augment::Signature::f_carried_bs`), else `f_b`.
    pub f_g_b: Vector3<T>,
    /// Mean angular rate ω_ib over the period, slave body frame (rad/s).
    pub w_ib_b: Vector3<T>,
    /// Slave attitude `C_bs^n` at the middle of the period (the attitude-dependent
    /// blocks are then accurate to second order in the rotation over the period).
    pub c_b_n: Matrix3<T>,
    /// Slave velocity, ENU (m/s).
    pub v_n: Vector3<T>,
    /// Slave position.
    pub pos: Position<T>,
}

/// Continuous-time white-noise densities driving the error states.
#[derive(Clone, Copy, Debug)]
pub struct ProcessNoise<T> {
    /// Accelerometer white noise (velocity random walk), m/s/√s.
    pub accel_vrw: T,
    /// Gyro white noise (angle random walk), rad/√s.
    pub gyro_arw: T,
    /// Gyro bias random walk, rad/s/√s (0: constant bias).
    pub gyro_bias_rw: T,
    /// Accelerometer bias random walk, m/s²/√s (0: constant bias).
    pub accel_bias_rw: T,
    /// Misalignment random walk, rad/√s (0: rigid mount).
    pub misalignment_rw: T,
}

/// Writes the 3 × 3 block `b` at row `r`, column `c` of `f`, `DYN` rows stored
/// column-major (`b`'s columns as arrays: nalgebra's column iterator is a loop of its
/// own on the board).
fn put<T: Real>(f: &mut [T], r: usize, c: usize, b: &Matrix3<T>) {
    for (k, col) in b.data.0.iter().enumerate() {
        let at = (c + k) * DYN + r;
        if let Some([d0, d1, d2]) = f.get_mut(at..at + 3) {
            [*d0, *d1, *d2] = *col;
        }
    }
}

/// Continuous-time error dynamics of the navigation and sensor states (the 15 before the
/// flexure block), written into the rows δv and ψ of `f` (`DYN` rows, column-major): the
/// only rows with dynamics (those of the sensors and the misalignment are zero). Elements
/// it does not set are left as they are (zero in a fresh matrix); no 15×15 temporary.
/// On slices, not on `F`'s matrix of `S` columns: one copy for every state dimension
/// (the board's two, "What issue12-s11 changed" in `docs/performance.md`).
#[inline(never)]
fn nav_dynamics_rows<T: Real>(m: &IntervalMeans<T>, f: &mut [T]) {
    let here = earth::Local::at(&m.pos);
    let w_ie = here.earth_rate_n();
    let w_en = here.transport_rate_n(&m.v_n);
    let d_wen_dv = here.transport_rate_jacobian();
    // δv̇ = (−[(2ω_ie+ω_en)×] + [v×] ∂ω_en/∂v) δv − C[f×] ψ + C ∇
    // (The negations, the sum and the transpose element by element: nalgebra's are a
    // loop each on the board.)
    let fvv = zip3(
        &skew(&(w_ie * T::of(2.0) + w_en)),
        &mul3(&skew(&m.v_n), &d_wen_dv),
        |_, _, a, b| -a + b,
    );
    put(f, V, V, &fvv);
    put(f, V, PSI, &neg3(&mul3(&m.c_b_n, &skew(&m.f_b))));
    put(f, V, BA, &m.c_b_n);
    // ψ̇ = −Cᵀ ∂ω_en/∂v δv − [ω_ib×] ψ + ε
    put(f, PSI, V, &neg3(&mul3(&transpose3(&m.c_b_n), &d_wen_dv)));
    put(f, PSI, PSI, &neg3(&skew(&m.w_ib_b)));
    put(f, PSI, BG, &Matrix3::identity());
}

/// Rows of the navigation dynamics that are not zero: only δv and ψ have dynamics
/// (`nav_dynamics_rows`); the sensor and misalignment rows are zero.
const DYN: usize = 6;

/// Rows of Φ that are not the identity's: δv, ψ (`DYN`) and the six flexure states.
pub const ACTIVE: usize = DYN + 6;

/// The transition Φ over one filter period, as the filter takes it.
pub type Phi<T, const S: usize> = Transition<T, S, ACTIVE>;

/// The process noise Q over one filter period, as the filter takes it: its diagonal and
/// the flexure blocks' off-diagonal (θ, θ̇) pairs.
pub type Qd<T, const S: usize> = Noise<T, S, 3>;

/// Continuous-time dynamics of the rows with dynamics (δv and ψ) over all `S` states:
/// the navigation block, then the augmented blocks' columns.
pub fn dynamics<T: Real, const S: usize>(
    m: &IntervalMeans<T>,
    aug: &Augmentation<T>,
) -> SMatrix<T, DYN, S> {
    let mut f = mat::zeros::<T, DYN, S>();
    nav_dynamics_rows(m, f.as_mut_slice());
    augment::add_dynamics(&mut f, aug, (V, PSI), &m.f_g_b, &m.w_ib_b, &m.c_b_n);
    f
}

/// Transition matrix Φ over one filter period `t` (s): third-order Taylor series of
/// the navigation and augmented blocks (the bias-to-velocity path runs through three
/// blocks), each flexure axis's exact discrete model on the flexure block; every other row is the
/// identity's. Only the rows with dynamics are computed, and their products only over
/// the columns where `F t` is not zero (`(F t)²` and `(F t)³` have no others).
pub fn transition<T: Real, const S: usize>(
    m: &IntervalMeans<T>,
    flex: &FlexureModel<T>,
    aug: &Augmentation<T>,
    t: T,
) -> Phi<T, S> {
    let mut phi = Phi::<T, S>::new(PHI_ROWS);
    transition_into(&mut phi, m, flex, aug, t);
    phi
}

/// The states of Φ's rows that are not the identity's, in the order of [`Phi`]'s rows: δv
/// and ψ, then the flexure's θ and θ̇ axis by axis (an axis's two rows share their two
/// columns, so the time update forms them as a pair: `Kalman::predict`).
pub const PHI_ROWS: [usize; ACTIVE] = [
    V,
    V + 1,
    V + 2,
    PSI,
    PSI + 1,
    PSI + 2,
    TH,
    THD,
    TH + 1,
    THD + 1,
    TH + 2,
    THD + 2,
];

/// [`transition`] written into `phi`, which [`Phi::new`] or [`Phi::zeroed`] built with
/// [`PHI_ROWS`]: every row rewritten in place (the time update's Φ without a copy of it).
pub fn transition_into<T: Real, const S: usize>(
    phi: &mut Phi<T, S>,
    m: &IntervalMeans<T>,
    flex: &FlexureModel<T>,
    aug: &Augmentation<T>,
    t: T,
) {
    let mut ft = dynamics::<T, S>(m, aug);
    // Element by element over the storage, each `F(i, j) · t` as nalgebra's `ft *= t`
    // formed it, which its iterator cost the board ≈ 8 instructions an element; a column
    // (`DYN` elements) a turn, written out: a loop over the elements took 7 instructions
    // an element (indexed loads and stores), the column ≈ 3.5. In the same turn, the
    // columns of F t's rows that are not zero are listed (δv and ψ's own always): a
    // second pass, each element through `mat::get`, cost the board ≈ 0.6k instructions a
    // time update more.
    let mut cols = [0usize; S];
    let mut n = 0;
    for (j, c) in ft.as_mut_slice().chunks_exact_mut(DYN).enumerate() {
        if let [a, b, c, d, e, f] = c {
            (*a, *b, *c, *d, *e, *f) = (*a * t, *b * t, *c * t, *d * t, *e * t, *f * t);
            let z = T::zero();
            let listed = j < DYN || *a != z || *b != z || *c != z || *d != z || *e != z || *f != z;
            if listed {
                if let Some(c) = cols.get_mut(n) {
                    *c = j;
                }
                n += 1;
            }
        }
    }
    let cols = cols.get(..n).unwrap_or(&[]);
    // Φ's first `DYN` rows, `I + F t + (F t)²/2 + (F t)³/6`, a column at a time into their
    // rows (no `DYN × S` temporaries for the powers, zeroed each time update, and no
    // pass of `set_row_at` a row, ≈ 28 instructions an element on the board).
    phi.clear_rows(DYN);
    taylor_columns(ft.as_slice(), cols, &mut |j, c| phi.push_column(j, c));
    // The flexure rows: θ_k (row DYN + 2k) and θ̇_k (row DYN + 2k + 1) of each axis's model.
    for (axis, ar) in flex.axes.iter().enumerate() {
        let a = ar.transition(flex.period_s);
        let (th, thd) = (TH + axis, THD + axis);
        for (r, row) in [(DYN + 2 * axis, 0), (DYN + 2 * axis + 1, 1)] {
            phi.set_row_at(r, &[th, thd], |j| {
                let col = if j == th { 0 } else { 1 };
                mat::get(&a, row, col)
            });
        }
    }
}

/// Column `j` of `left · F t` (see [`taylor_columns`]): `left` the left factor's first `DYN`
/// columns. Inlined into both of [`taylor_columns`]' products (as a closure it was called, ≈ 20
/// instructions a column; one loop over both products with one copy of it: ≈ 0.5k
/// instructions a time update more).
#[inline(always)]
fn times_ft<T: Real>(ft: &[T], left: &[[T; DYN]; DYN], j: usize) -> [T; DYN] {
    let mut acc = [T::zero(); DYN];
    // Written out over the six rows and the six terms: the size-optimized image does
    // not unroll, and the loops cost three times their multiply-adds (the same
    // arithmetic, element by element, k ascending). (A column out of range, never,
    // leaves the zeros.) A zero `F t(k, j)` is skipped: its terms `l · 0` are zeros,
    // and adding a zero to `acc` leaves it as it is (`acc` starts at +0 and a sum is
    // −0 only of two −0, so it is never −0); most of F's columns have one to three
    // non-zeros among the six rows (the biases' identity and attitude matrix, the
    // augmented columns).
    let term = |acc: &mut [T; DYN], lk: &[T; DYN], fkj: T| {
        if fkj != T::zero() {
            let ([a0, a1, a2, a3, a4, a5], [l0, l1, l2, l3, l4, l5]) = (acc, lk);
            *a0 += *l0 * fkj;
            *a1 += *l1 * fkj;
            *a2 += *l2 * fkj;
            *a3 += *l3 * fkj;
            *a4 += *l4 * fkj;
            *a5 += *l5 * fkj;
        }
    };
    let col = ft.get(j * DYN..j * DYN + DYN);
    if let (Some(&[c0, c1, c2, c3, c4, c5]), [k0, k1, k2, k3, k4, k5]) = (col, left) {
        term(&mut acc, k0, c0);
        term(&mut acc, k1, c1);
        term(&mut acc, k2, c2);
        term(&mut acc, k3, c3);
        term(&mut acc, k4, c4);
        term(&mut acc, k5, c5);
    }
    acc
}

/// Column `j` of `I + F t + (F t)²/2 + (F t)³/6` (its first `DYN` rows, the only ones
/// not the identity's) handed to `emit` for each `j` of `cols` (`F t` in `ft`, each column
/// `DYN` rows, column-major; `cols` ascending, the first `DYN` among them). Only F's first
/// `DYN` rows are not zero, so column j of a product is Σ_k (column k of the left
/// factor's first `DYN` columns) · F t(k, j), k ascending (the dense product's order):
/// `(F t)²`'s first `DYN` columns are formed first, then each column's square and cube
/// from them, and each element `((id + F t) + (F t)² · ½) + (F t)³ · ⅙`. On slices, with
/// `emit` called through a reference: one copy for every state dimension.
#[inline(never)]
fn taylor_columns<T: Real>(ft: &[T], cols: &[usize], emit: &mut dyn FnMut(usize, &[T; DYN])) {
    // Columns as arrays: the board's size-optimized image would otherwise bounds-check
    // every term.
    let column = |m: &[T], j: usize| -> [T; DYN] {
        m.get(j * DYN..j * DYN + DYN)
            .and_then(|src| <[T; DYN]>::try_from(src).ok())
            .unwrap_or([T::zero(); DYN])
    };
    let ft_cols: [[T; DYN]; DYN] = core::array::from_fn(|k| column(ft, k));
    let f2_cols: [[T; DYN]; DYN] = core::array::from_fn(|k| times_ft(ft, &ft_cols, k));
    let (half, sixth) = (T::of(0.5), T::of(1.0 / 6.0));
    for &j in cols {
        let f1 = column(ft, j);
        let f2 = match f2_cols.get(j) {
            Some(c) => *c,
            None => times_ft(ft, &ft_cols, j),
        };
        let f3 = times_ft(ft, &f2_cols, j);
        let id = |i: usize| if i == j { T::one() } else { T::zero() };
        let ([a0, a1, a2, a3, a4, a5], [b0, b1, b2, b3, b4, b5], [c0, c1, c2, c3, c4, c5]) =
            (f1, f2, f3);
        let phi = [
            id(0) + a0 + b0 * half + c0 * sixth,
            id(1) + a1 + b1 * half + c1 * sixth,
            id(2) + a2 + b2 * half + c2 * sixth,
            id(3) + a3 + b3 * half + c3 * sixth,
            id(4) + a4 + b4 * half + c4 * sixth,
            id(5) + a5 + b5 * half + c5 * sixth,
        ];
        emit(j, &phi);
    }
}

/// Discrete process noise Q over one filter period `t` (s); augmented blocks are constants.
pub fn process_noise<T: Real, const S: usize>(
    noise: &ProcessNoise<T>,
    flex: &FlexureModel<T>,
    t: T,
) -> Qd<T, S> {
    let mut q = Qd::<T, S> {
        diag: [T::zero(); S],
        pairs: [(0, 0, T::zero()); 3],
    };
    let diag = [
        (V, noise.accel_vrw),
        (PSI, noise.gyro_arw),
        (MU, noise.misalignment_rw),
        (BG, noise.gyro_bias_rw),
        (BA, noise.accel_bias_rw),
    ];
    for (block, density) in diag {
        for k in 0..3 {
            if let Some(e) = q.diag.get_mut(block + k) {
                *e = density * density * t;
            }
        }
    }
    for ((axis, ar), pair) in flex.axes.iter().enumerate().zip(q.pairs.iter_mut()) {
        let qb = ar.noise_covariance(flex.period_s);
        let (th, thd) = (TH + axis, THD + axis);
        if let Some(e) = q.diag.get_mut(th) {
            *e = mat::get(&qb, 0, 0);
        }
        if let Some(e) = q.diag.get_mut(thd) {
            *e = mat::get(&qb, 1, 1);
        }
        *pair = (th, thd, mat::get(&qb, 0, 1));
    }
    q
}

/// Measurement rows of one three-axis matching measurement.
pub type Rows<T, const S: usize = N> = [SVector<T, S>; 3];

/// The declared states' non-zero 3 × 3 blocks of one three-axis matching measurement's
/// rows: each block's first state and the block (row = axis), at most four. Built apart
/// from the rows ([`rows_from_blocks`]) because they do not depend on the state's
/// dimension: the board, which instantiates the engine at two dimensions, then holds one
/// copy of their algebra (`docs/performance.md`, "What issue12-s11 changed").
pub type Blocks<T> = heapless::Vec<(usize, Matrix3<T>), 4>;

fn blocks<T: Real>(list: &[(usize, Matrix3<T>)]) -> Blocks<T> {
    // Every caller lists at most four: never the empty fallback.
    Blocks::from_slice(list).unwrap_or_default()
}

/// The rows of dimension `S` holding `blocks` (zero elsewhere).
pub fn rows_from_blocks<T: Real, const S: usize>(blocks: &Blocks<T>) -> Rows<T, S> {
    let mut rows = [mat::zeros(), mat::zeros(), mat::zeros()];
    put_blocks(&mut rows, blocks);
    rows
}

/// Writes `blocks` into `rows` (the other elements left as they are): the engine's rows
/// built in place (returned by [`rows_from_blocks`], they were copied once more on the
/// board, 0.7k instructions per master update). Each block's row `axis` read from its
/// column arrays and written as three elements (element by element through nalgebra's
/// checked access it cost the board ≈ 0.7k instructions a master update as well).
pub fn put_blocks<T: Real, const S: usize>(rows: &mut Rows<T, S>, blocks: &Blocks<T>) {
    for (axis, row) in rows.iter_mut().enumerate() {
        for (offset, b) in blocks {
            let [c0, c1, c2] = &b.data.0;
            let at = |c: &[T; 3]| c.get(axis).copied().unwrap_or_else(T::zero);
            if let Some([e0, e1, e2]) = row.as_mut_slice().get_mut(*offset..offset + 3) {
                [*e0, *e1, *e2] = [at(c0), at(c1), at(c2)];
            }
        }
    }
}

/// Velocity matching `z_v = v̂_s − v_m − C_bm^n (ω_eb^bm × r0)` (m/s, ENU).
///
/// `c_bm_n`: master attitude; `w_eb_bm`: master body rate relative to the Earth (rad/s,
/// master body frame); `r_flex`: the matrix R of `r = r0 + R θ` (m/rad, master body
/// frame), or `None` to leave the dynamic lever arm out (the paper's baseline).
pub fn velocity_rows<T: Real, const S: usize>(
    c_bm_n: &Matrix3<T>,
    w_eb_bm: &Vector3<T>,
    r_flex: Option<&Matrix3<T>>,
) -> Rows<T, S> {
    rows_from_blocks(&velocity_blocks(c_bm_n, w_eb_bm, r_flex))
}

/// [`velocity_rows`]' blocks.
pub fn velocity_blocks<T: Real>(
    c_bm_n: &Matrix3<T>,
    w_eb_bm: &Vector3<T>,
    r_flex: Option<&Matrix3<T>>,
) -> Blocks<T> {
    match r_flex {
        Some(r) => blocks(&[
            (V, Matrix3::identity()),
            (TH, mul3(&mul3(c_bm_n, &skew(w_eb_bm)), r)),
            (THD, mul3(c_bm_n, r)),
        ]),
        None => blocks(&[(V, Matrix3::identity())]),
    }
}

/// Attitude matching `z_a = Log(Exp(−μ̂) C_bm^nᵀ Ĉ_bs^n)` (rad, slave body frame),
/// linearized where the filter stands: the flexure at its estimate θ̂, not at zero.
///
/// With `Ĉ_bs^n = C_bm^n Exp(μ + θ) Exp(ψ)`, `Exp(z) = Exp(a) Exp(ψ)` where
/// `Exp(a) = Exp(−μ̂) Exp(μ̂ + δμ + θ)`, so `∂z/∂ψ = J_r⁻¹(â)` and
/// `∂z/∂δμ = ∂z/∂θ = J_r⁻¹(â) J_r(μ̂ + θ̂)`, `â ≈ J_r(μ̂) θ̂` the residual the estimates
/// predict. At θ̂ = 0 these are `I` and `J_r(μ̂)`. The difference is of the size of θ̂
/// (a few 10⁻⁴ rad), but it is all that tells ψ, which the flexure turns with the slave's
/// body, from δμ, which it does not: the propagation turns ψ by the flexure's whole angle
/// (`Φ` holds the slave's rate), the measurement sees it turned by half (`½ θ × ψ` from
/// `J_r⁻¹`). Linearized at θ̂ = 0 the filter credited the flexure with twice the
/// separation it gives; handed its truth, a blind draw with flexure about x alone, no
/// motion and attitude matching only ended with the misalignment about y 6.4σ off
/// (`docs/model-learning.md`, session 10).
/// `jr_inv_a`: `J_r⁻¹(â)`; `jr_mu_theta`: `J_r(μ̂ + θ̂)`.
pub fn attitude_rows<T: Real, const S: usize>(
    jr_inv_a: &Matrix3<T>,
    jr_mu_theta: &Matrix3<T>,
) -> Rows<T, S> {
    rows_from_blocks(&attitude_blocks(jr_inv_a, jr_mu_theta))
}

/// [`attitude_rows`]' blocks.
pub fn attitude_blocks<T: Real>(jr_inv_a: &Matrix3<T>, jr_mu_theta: &Matrix3<T>) -> Blocks<T> {
    let j = mul3(jr_inv_a, jr_mu_theta);
    blocks(&[(PSI, *jr_inv_a), (MU, j), (TH, j)])
}

/// Angular-rate matching `z_ω = ω_s − b̂_g − Exp(μ̂)ᵀ ω_m` (rad/s, slave body frame),
/// both rates at the master message's time of validity (the slave's interpolated from
/// its increments). For a flexure linear over each filter period the rate there is
/// the period's θ̇. `w_m_bs`: `Exp(μ̂)ᵀ ω_m`.
pub fn rate_rows<T: Real, const S: usize>(w_m_bs: &Vector3<T>, jr_mu: &Matrix3<T>) -> Rows<T, S> {
    rows_from_blocks(&rate_blocks(w_m_bs, jr_mu))
}

/// [`rate_rows`]' blocks.
pub fn rate_blocks<T: Real>(w_m_bs: &Vector3<T>, jr_mu: &Matrix3<T>) -> Blocks<T> {
    let wj = mul3(&skew(w_m_bs), jr_mu);
    blocks(&[(MU, wj), (BG, Matrix3::identity()), (TH, wj), (THD, *jr_mu)])
}

/// The matrix R of the bent lever arm `r = r0 + R θ` (m/rad, master body frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeverBending {
    /// Eq. (21) as printed: `R = ½ [[0, z0, 0], [0, 0, x0], [y0, 0, 0]]`.
    Paper,
    /// A uniform circular bend of the whole arm: its end moves by `½ θ × r0`,
    /// so `R = −½ [r0×]`.
    UniformArc,
}

impl LeverBending {
    /// The matrix R for the static lever arm `r0` (m, master body frame).
    pub fn matrix<T: Real>(self, r0: &Vector3<T>) -> Matrix3<T> {
        let h = T::of(0.5);
        match self {
            Self::Paper => {
                let z = T::zero();
                let m = Matrix3::new(z, r0.z, z, z, z, r0.x, r0.y, z, z);
                zip3(&m, &m, |_, _, x, _| x * h)
            }
            Self::UniformArc => {
                let m = skew(r0);
                zip3(&m, &m, |_, _, x, _| -x * h)
            }
        }
    }
}

/// Nonlinear velocity-matching residual (m/s, ENU): the slave velocity minus the
/// master's carried to the slave by the *static* lever arm,
/// `v̂_s − v_m − C_bm^n (ω_eb^bm × r0)`.
pub fn velocity_residual<T: Real>(
    v_slave_n: &Vector3<T>,
    v_master_n: &Vector3<T>,
    c_bm_n: &Matrix3<T>,
    w_eb_bm: &Vector3<T>,
    r0_bm: &Vector3<T>,
) -> Vector3<T> {
    let lever = mul3v(c_bm_n, &w_eb_bm.cross(r0_bm));
    vec3(|i| (vget(v_slave_n, i) - vget(v_master_n, i)) - vget(&lever, i))
}

/// Nonlinear attitude-matching residual (rad, slave body): `Log(Exp(−μ̂) C_bm^nᵀ Ĉ_bs^n)`.
pub fn attitude_residual<T: Real>(
    mu_hat: &Vector3<T>,
    c_bm_n: &Matrix3<T>,
    c_bs_n_hat: &Matrix3<T>,
) -> Vector3<T> {
    crate::rotation::log_so3(&mul3(
        &mul3(&crate::rotation::exp_so3(&(-mu_hat)), &transpose3(c_bm_n)),
        c_bs_n_hat,
    ))
}

/// Nonlinear angular-rate-matching residual (rad/s, slave body): the slave's
/// bias-corrected mean rate minus the master's mean rate carried through `Exp(μ̂)`.
pub fn rate_residual<T: Real>(
    w_slave_corrected_bs: &Vector3<T>,
    mu_hat: &Vector3<T>,
    w_master_bm: &Vector3<T>,
) -> Vector3<T> {
    w_slave_corrected_bs - mul3v(&transpose3(&crate::rotation::exp_so3(mu_hat)), w_master_bm)
}
