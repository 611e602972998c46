//! Column names of the CSV files and the mapping between rows and samples,
//! shared by the reader and the writer so both follow the same contract.

use super::{ImuSample, MasterMsg};

/// Columns of `slave_imu.csv` when `output = "increments"`.
pub(crate) const SLAVE_INCREMENT_COLUMNS: [&str; 7] =
    ["t", "dthx", "dthy", "dthz", "dvx", "dvy", "dvz"];

/// Columns of `slave_imu.csv` when `output = "rates"`.
pub(crate) const SLAVE_RATE_COLUMNS: [&str; 7] = ["t", "gx", "gy", "gz", "ax", "ay", "az"];

/// Required columns of `master.csv`.
pub(crate) const MASTER_COLUMNS: [&str; 11] = [
    "t", "qw", "qx", "qy", "qz", "ve", "vn", "vu", "lat_deg", "lon_deg", "height_m",
];

/// Optional columns of `master.csv`: the master's angular rate, all or none.
pub(crate) const MASTER_RATE_COLUMNS: [&str; 3] = ["wx", "wy", "wz"];

/// Position of `qw` in [`MASTER_COLUMNS`] (the quaternion is `qw..qz`).
pub(crate) const MASTER_QW: usize = 1;

/// Position of `lat_deg` in [`MASTER_COLUMNS`].
pub(crate) const MASTER_LAT: usize = 8;

/// The time column of every file.
pub(crate) const TIME_COLUMN: &str = "t";

/// A slave sample from its row, in the order of [`SLAVE_INCREMENT_COLUMNS`].
pub(crate) fn imu_from_row(v: [f64; 7]) -> ImuSample {
    let [t, gx, gy, gz, ax, ay, az] = v;
    ImuSample {
        t,
        dtheta_rad: [gx, gy, gz],
        dv_mps: [ax, ay, az],
    }
}

/// The row of a slave sample, in the order of [`SLAVE_INCREMENT_COLUMNS`].
pub(crate) fn imu_to_row(s: &ImuSample) -> [f64; 7] {
    let [gx, gy, gz] = s.dtheta_rad;
    let [ax, ay, az] = s.dv_mps;
    [s.t, gx, gy, gz, ax, ay, az]
}

/// A master message from its row, in the order of [`MASTER_COLUMNS`].
pub(crate) fn master_from_row(v: [f64; 11], rate: Option<[f64; 3]>) -> MasterMsg {
    let [t, qw, qx, qy, qz, ve, vn, vu, lat_deg, lon_deg, height_m] = v;
    MasterMsg {
        t,
        q_bm_n: [qw, qx, qy, qz],
        v_n_mps: [ve, vn, vu],
        lat_deg,
        lon_deg,
        height_m,
        omega_ib_bm_radps: rate,
    }
}

/// The row of a master message, in the order of [`MASTER_COLUMNS`].
pub(crate) fn master_to_row(m: &MasterMsg) -> [f64; 11] {
    let [qw, qx, qy, qz] = m.q_bm_n;
    let [ve, vn, vu] = m.v_n_mps;
    [
        m.t, qw, qx, qy, qz, ve, vn, vu, m.lat_deg, m.lon_deg, m.height_m,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_name_their_columns() {
        assert_eq!(MASTER_COLUMNS[MASTER_QW], "qw");
        assert_eq!(MASTER_COLUMNS[MASTER_LAT], "lat_deg");
    }
}
