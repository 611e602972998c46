//! Recordings, format version 1 (the contract `recording-v1.md`):
//! one folder per session holding what the slave IMU and the master INS
//! produced, as plain text that any tool can write and read.
//!
//! | file | content |
//! | --- | --- |
//! | `recording.toml` | site, lever arm, nominal rates ([`RecordingMeta`]) |
//! | `slave_imu.csv` | slave IMU increments or rates ([`ImuSample`]) |
//! | `master.csv` | master INS navigation messages ([`MasterMsg`]) |
//! | `truth.csv` | optional, simulator truth for scoring ([`Truth`]) |
//!
//! [`read_recording`] checks every file against the contract and reports any
//! departure as a [`RecordingError`] naming file, line, column or key; it
//! never panics, guesses or drops data. [`open_recording`] reads the same files
//! one sample at a time with the same checks, in memory that does not grow with
//! their length (the CSV is parsed by hand, line by line: `csv.rs` says why). [`write_recording`] writes files that
//! read back bit-exactly. All quantities are `f64` in SI units (angles in
//! rad, except latitude and longitude in degrees).

mod check;
mod csv;
mod error;
mod layout;
mod meta;
mod reader;
mod rules;
mod text;
mod writer;

pub use error::{Column, ErrorKind, RecordingError};
pub use reader::{
    open_recording, read_recording, MasterReader, RecordingStream, SlaveReader, TruthReader,
    TruthRow,
};
pub use rules::QUATERNION_NORM_TOLERANCE;
pub use writer::write_recording;

/// File name of the session description.
pub const META_FILE: &str = "recording.toml";
/// File name of the slave IMU output.
pub const SLAVE_FILE: &str = "slave_imu.csv";
/// File name of the master INS messages.
pub const MASTER_FILE: &str = "master.csv";
/// File name of the optional simulator truth.
pub const TRUTH_FILE: &str = "truth.csv";

/// What the slave IMU's columns hold (`slave_imu.output` in `recording.toml`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImuOutput {
    /// Angle and velocity increments over each interval: `dth*` (rad), `dv*` (m/s).
    Increments,
    /// Mean angular rate and specific force over each interval: `g*` (rad/s), `a*` (m/s²).
    Rates,
}

/// Where the master INS was at the start of the session.
#[derive(Debug, Clone, PartialEq)]
pub struct Site {
    /// Geodetic latitude, degrees, in [-90, 90].
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Height above the ellipsoid, metres.
    pub height_m: f64,
}

/// Contents of `recording.toml`: what the session was.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingMeta {
    /// Master INS position at the start.
    pub site: Site,
    /// Lever arm `r0` from the master INS to the slave IMU reference point,
    /// resolved in the master body frame, metres, as surveyed (it may be wrong).
    pub lever_arm_m: [f64; 3],
    /// Nominal slave IMU sample rate, Hz (positive).
    pub slave_rate_hz: f64,
    /// What the slave file's columns hold. After reading, [`Recording::imu`]
    /// is in increments either way; the writer always writes increments.
    pub slave_output: ImuOutput,
    /// Nominal master message rate, Hz (positive).
    pub master_rate_hz: f64,
    /// Free text for people (`[notes] text`).
    pub notes: Option<String>,
}

/// One slave IMU sample: integrals of `omega_ib^bs` (rad) and of the specific
/// force `f^bs` (m/s) over `(t_prev, t]`.
#[derive(Debug, Clone, PartialEq)]
pub struct ImuSample {
    /// End of the interval, seconds.
    pub t: f64,
    /// Angle increment, rad, slave body frame.
    pub dtheta_rad: [f64; 3],
    /// Velocity increment, m/s, slave body frame.
    pub dv_mps: [f64; 3],
}

/// One master INS navigation message.
#[derive(Debug, Clone, PartialEq)]
pub struct MasterMsg {
    /// Time of validity, seconds, on the slave's nominal time base.
    pub t: f64,
    /// Attitude `q_bm^n` as `(qw, qx, qy, qz)`: Hamilton, scalar first, unit
    /// norm within [`QUATERNION_NORM_TOLERANCE`] (kept as written, not renormalised).
    pub q_bm_n: [f64; 4],
    /// Velocity relative to the Earth in ENU, m/s.
    pub v_n_mps: [f64; 3],
    /// Geodetic latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Height above the ellipsoid, metres.
    pub height_m: f64,
    /// Angular rate `omega_ib^bm`, rad/s, if the master gives it.
    pub omega_ib_bm_radps: Option<[f64; 3]>,
}

impl MasterMsg {
    /// The attitude `q_bm^n`, normalized.
    pub fn attitude(&self) -> nalgebra::UnitQuaternion<f64> {
        let [w, x, y, z] = self.q_bm_n;
        nalgebra::UnitQuaternion::new_normalize(nalgebra::Quaternion::new(w, x, y, z))
    }

    /// The navigation frame's rate `ω_in^n = ω_ie^n + ω_en^n` (rad/s, ENU) at the
    /// message's position and velocity.
    pub fn nav_frame_rate_n(&self) -> nalgebra::Vector3<f64> {
        use flexcal_core::earth::{self, Position};
        let pos = Position {
            lat_rad: self.lat_deg.to_radians(),
            lon_rad: self.lon_deg.to_radians(),
            height_m: self.height_m,
        };
        earth::earth_rate_n(pos.lat_rad)
            + earth::transport_rate_n(&pos, &nalgebra::Vector3::from(self.v_n_mps))
    }
}

/// Contents of `truth.csv`: the time column and every other column by name,
/// in file order, including columns this code does not know.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// Column names besides `t`, in file order.
    pub names: Vec<String>,
    /// Times, seconds, strictly increasing.
    pub t: Vec<f64>,
    /// `columns[i]` holds the values of `names[i]`, one per time.
    pub columns: Vec<Vec<f64>>,
}

impl Truth {
    /// The values of column `name` (`"t"` gives the times), if present.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        if name == layout::TIME_COLUMN {
            return Some(&self.t);
        }
        let i = self.names.iter().position(|n| n == name)?;
        self.columns.get(i).map(Vec::as_slice)
    }

    /// Three columns at one row, e.g. `["thx", "thy", "thz"]`; `None` if a
    /// column is absent or `row` is out of range.
    pub fn vec3(&self, names: [&str; 3], row: usize) -> Option<[f64; 3]> {
        let [a, b, c] = names.map(|name| self.column(name).and_then(|col| col.get(row).copied()));
        Some([a?, b?, c?])
    }

    /// Number of rows (times).
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
}

/// A whole recording in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The session description.
    pub meta: RecordingMeta,
    /// Time of the first slave line, which only starts the clock: its values
    /// cover an unknown interval and are not kept.
    pub imu_t0: f64,
    /// Slave samples after the first line, always as increments (rates are
    /// converted with `dt = t - t_prev`).
    pub imu: Vec<ImuSample>,
    /// Master messages.
    pub master: Vec<MasterMsg>,
    /// Simulator truth, if `truth.csv` is present. Never used to estimate.
    pub truth: Option<Truth>,
}

impl Recording {
    /// Whether the master gives its angular rate (`wx,wy,wz`) in every message.
    pub fn master_has_rate(&self) -> bool {
        !self.master.is_empty() && self.master.iter().all(|m| m.omega_ib_bm_radps.is_some())
    }

    /// Index of the master's message at or just after `t` (s).
    pub fn master_index(&self, t: f64) -> Option<usize> {
        let k = self.master.partition_point(|m| m.t < t);
        (k < self.master.len()).then_some(k)
    }

    /// The master's rotation over `[a, b]` (s) as a rotation vector (rad) in its body
    /// frame at `a`, from its attitudes at the messages at or just after `a` and `b`.
    pub fn master_rotation(&self, a: f64, b: f64) -> Option<nalgebra::Vector3<f64>> {
        let (i, j) = (self.master_index(a)?, self.master_index(b)?);
        let q = |k: usize| Some(self.master.get(k)?.attitude());
        (j > i)
            .then(|| Some((q(i)?.inverse() * q(j)?).scaled_axis()))
            .flatten()
    }
}
