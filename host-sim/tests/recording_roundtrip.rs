//! Property tests of recording I/O: valid recordings round-trip bit-exactly,
//! and no input, however broken, makes the reader panic.

use std::path::Path;

use flexcal_sim::recording::{
    read_recording, write_recording, ImuOutput, ImuSample, MasterMsg, Recording, RecordingMeta,
    Site, Truth, MASTER_FILE, META_FILE, SLAVE_FILE, TRUTH_FILE,
};
use proptest::collection::{btree_set, vec};
use proptest::num::f64 as pf64;
use proptest::prelude::*;
use proptest::sample::Index;

const FILES: [&str; 4] = [META_FILE, SLAVE_FILE, MASTER_FILE, TRUTH_FILE];

/// Any finite f64, including subnormals, zeros of both signs and extremes.
fn finite() -> impl Strategy<Value = f64> {
    pf64::POSITIVE | pf64::NEGATIVE | pf64::NORMAL | pf64::SUBNORMAL | pf64::ZERO
}

/// `n` finite, strictly increasing times (at least one), drawn over the whole range.
fn times(n: std::ops::Range<usize>) -> impl Strategy<Value = Vec<f64>> {
    vec(finite(), n).prop_map(|mut v| {
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    })
}

fn vec3() -> impl Strategy<Value = [f64; 3]> {
    [finite(), finite(), finite()]
}

/// A unit quaternion (normalised in f64, so its norm is 1 within a few ulp).
fn quaternion() -> impl Strategy<Value = [f64; 4]> {
    [-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64]
        .prop_filter("non-zero", |q| q.iter().map(|c| c * c).sum::<f64>() > 1e-6)
        .prop_map(|q| {
            let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
            q.map(|c| c / n)
        })
}

fn meta() -> impl Strategy<Value = RecordingMeta> {
    let rate = || pf64::POSITIVE | pf64::NORMAL | pf64::SUBNORMAL;
    (
        (-90.0..=90.0f64, finite(), finite()),
        vec3(),
        rate(),
        rate(),
        proptest::option::of(any::<String>()),
    )
        .prop_map(
            |((lat_deg, lon_deg, height_m), lever_arm_m, slave_rate_hz, master_rate_hz, notes)| {
                RecordingMeta {
                    site: Site {
                        lat_deg,
                        lon_deg,
                        height_m,
                    },
                    lever_arm_m,
                    slave_rate_hz,
                    slave_output: ImuOutput::Increments,
                    master_rate_hz,
                    notes,
                }
            },
        )
}

fn imu() -> impl Strategy<Value = (f64, Vec<ImuSample>)> {
    times(2..24)
        .prop_filter("a clock start and a sample", |t| t.len() >= 2)
        .prop_flat_map(|t| {
            let n = t.len() - 1;
            (Just(t), vec((vec3(), vec3()), n))
        })
        .prop_map(|(t, inc)| {
            let samples = t
                .iter()
                .skip(1)
                .zip(inc)
                .map(|(&t, (dtheta_rad, dv_mps))| ImuSample {
                    t,
                    dtheta_rad,
                    dv_mps,
                })
                .collect();
            (t[0], samples)
        })
}

fn master() -> impl Strategy<Value = Vec<MasterMsg>> {
    (times(1..12), any::<bool>())
        .prop_flat_map(|(t, with_rate)| {
            let n = t.len();
            let row = (
                quaternion(),
                vec3(),
                -90.0..=90.0f64,
                finite(),
                finite(),
                vec3(),
            );
            (Just(t), Just(with_rate), vec(row, n))
        })
        .prop_map(|(t, with_rate, rows)| {
            t.into_iter()
                .zip(rows)
                .map(|(t, (q, v, lat, lon, h, w))| MasterMsg {
                    t,
                    q_bm_n: q,
                    v_n_mps: v,
                    lat_deg: lat,
                    lon_deg: lon,
                    height_m: h,
                    omega_ib_bm_radps: with_rate.then_some(w),
                })
                .collect()
        })
}

fn truth() -> impl Strategy<Value = Truth> {
    let name = "[a-zA-Zµθ_][a-zA-Z0-9_.µθ]{0,7}".prop_filter("not the time", |n| n != "t");
    (times(1..10), btree_set(name, 0..5))
        .prop_flat_map(|(t, names)| {
            let rows = t.len();
            let cols = names.len();
            (Just(t), Just(names), vec(vec(finite(), rows), cols))
        })
        .prop_map(|(t, names, columns)| Truth {
            names: names.into_iter().collect(),
            t,
            columns,
        })
}

fn recording() -> impl Strategy<Value = Recording> {
    (meta(), imu(), master(), proptest::option::of(truth())).prop_map(
        |(meta, (imu_t0, imu), master, truth)| Recording {
            meta,
            imu_t0,
            imu,
            master,
            truth,
        },
    )
}

/// Reads `dir`; the only requirement is that it returns.
fn read_without_panic(dir: &Path) {
    let _ = read_recording(dir).map(|rec| rec.imu.len());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn valid_recordings_round_trip_bit_exactly(rec in recording()) {
        let dir = tempfile::tempdir().unwrap();
        write_recording(dir.path(), &rec).unwrap();
        let back = read_recording(dir.path()).unwrap();
        // Debug prints every f64 in its shortest round-trip form, sign of zero
        // included: equal strings mean equal bits.
        prop_assert_eq!(format!("{back:?}"), format!("{rec:?}"));
        prop_assert_eq!(back, rec);
    }

    #[test]
    fn arbitrary_contents_never_panic(
        file in 0..FILES.len(),
        bytes in prop_oneof![
            vec(any::<u8>(), 0..300),
            "[-+0-9.,eEinfatdhxyzqwvgul_#\n\r ]{0,300}".prop_map(String::into_bytes),
            any::<String>().prop_map(String::into_bytes),
        ],
    ) {
        let dir = tempfile::tempdir().unwrap();
        let rec = fixture();
        write_recording(dir.path(), &rec).unwrap();
        std::fs::write(dir.path().join(FILES[file]), bytes).unwrap();
        read_without_panic(dir.path());
    }

    #[test]
    fn one_mutated_byte_never_panics(
        rec in recording(),
        file in 0..FILES.len(),
        at in any::<Index>(),
        byte in any::<u8>(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        write_recording(dir.path(), &rec).unwrap();
        let path = dir.path().join(FILES[file]);
        if let Ok(mut bytes) = std::fs::read(&path) {
            let i = at.index(bytes.len().max(1));
            if let Some(b) = bytes.get_mut(i) {
                *b = byte;
            }
            std::fs::write(&path, bytes).unwrap();
        }
        read_without_panic(dir.path());
    }
}

/// A small valid recording with truth and master rate, as a base to corrupt.
fn fixture() -> Recording {
    Recording {
        meta: RecordingMeta {
            site: Site {
                lat_deg: 37.5,
                lon_deg: 121.4,
                height_m: 0.0,
            },
            lever_arm_m: [10.0, 4.0, 15.0],
            slave_rate_hz: 200.0,
            slave_output: ImuOutput::Increments,
            master_rate_hz: 100.0,
            notes: Some("moored".into()),
        },
        imu_t0: 0.0,
        imu: (1..4)
            .map(|i| ImuSample {
                t: f64::from(i) * 0.005,
                dtheta_rad: [1e-6, -2e-6, 3e-6],
                dv_mps: [0.01, 0.02, 0.049],
            })
            .collect(),
        master: (0..2)
            .map(|i| MasterMsg {
                t: f64::from(i) * 0.01,
                q_bm_n: [1.0, 0.0, 0.0, 0.0],
                v_n_mps: [0.1, 0.2, 0.0],
                lat_deg: 37.5,
                lon_deg: 121.4,
                height_m: 0.0,
                omega_ib_bm_radps: Some([0.0, 0.0, 7.29e-5]),
            })
            .collect(),
        truth: Some(Truth {
            names: vec!["thx".into(), "thy".into()],
            t: vec![0.0, 0.01],
            columns: vec![vec![1e-4, 2e-4], vec![-1e-4, 0.0]],
        }),
    }
}
