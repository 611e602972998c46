//! Plausibility of a recording that parses: what the contract (`recording-v1`) cannot
//! refuse but physics or the file's own numbers contradict. Time spans, declared rates
//! against the timestamps, gaps, the master's first position against `site`, the lever
//! arm and heights against physical bounds, master attitude jumps, a last line without
//! its line end. Each finding names the file and the sample (its time, and its line when
//! the file has no comment lines) with the values. Thresholds: `docs/verdict.md`.

use super::{g3, Finding, Severity};
use crate::recording::{Recording, MASTER_FILE, META_FILE, SLAVE_FILE, TRUTH_FILE};
use serde_json::json;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// Below this fraction of the master's span covered by the slave's, FAIL.
pub const OVERLAP_FAIL: f64 = 0.5;
/// Below this fraction, WARN.
pub const OVERLAP_WARN: f64 = 0.9;
/// A declared rate off the timestamps' by more than this fraction: WARN.
pub const RATE_WARN: f64 = 0.05;
/// By more than this fraction: FAIL (the learner's filter period and identification use it).
pub const RATE_FAIL: f64 = 0.5;
/// An interval longer than this many median intervals is a gap (at least two samples missing).
pub const GAP_FACTOR: f64 = 3.0;
/// A slave gap longer than this (s) cannot be one increment of a moving body: FAIL.
pub const SLAVE_GAP_FAIL_S: f64 = 1.0;
/// The master's first position farther than this from `site` (m): WARN.
pub const SITE_WARN_M: f64 = 1_000.0;
/// Farther than this (m): FAIL.
pub const SITE_FAIL_M: f64 = 100_000.0;
/// Largest lever arm between two points of one structure (m): the longest ships are ~460 m.
pub const LEVER_ARM_MAX_M: f64 = 500.0;
/// Heights outside this range (m) are not on or above the Earth's surface as vehicles go.
pub const HEIGHT_RANGE_M: [f64; 2] = [-1_000.0, 30_000.0];
/// A master attitude change faster than this (rad/s, ~115 °/s) between two messages is a jump.
pub const ATTITUDE_JUMP_RADPS: f64 = 2.0;
/// Mean Earth radius for distances between nearby positions (m).
const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// Every plausibility finding of the recording in `dir`.
pub fn check(dir: &Path, rec: &Recording) -> Vec<Finding> {
    let mut out = Vec::new();
    out.extend(overlap(rec));
    out.extend(declared_rates(rec));
    out.extend(slave_gaps(rec));
    out.extend(master_gaps(rec));
    out.extend(site(rec));
    out.extend(lever_arm(rec));
    out.extend(heights(rec));
    out.extend(attitude_jumps(rec));
    for file in [SLAVE_FILE, MASTER_FILE, TRUTH_FILE] {
        out.extend(unterminated(&dir.join(file), file));
    }
    out
}

/// The median of `v` (NaN when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Where slave sample `i` (0-based, after the clock-starting line) is.
fn slave_at(rec: &Recording, i: usize) -> String {
    let t = rec.imu.get(i).map_or(f64::NAN, |s| s.t);
    format!(
        "{SLAVE_FILE} t = {} s (line {} without comment lines)",
        t,
        i + 3
    )
}

/// Where master message `i` (0-based) is.
fn master_at(rec: &Recording, i: usize) -> String {
    let t = rec.master.get(i).map_or(f64::NAN, |m| m.t);
    format!(
        "{MASTER_FILE} t = {} s (line {} without comment lines)",
        t,
        i + 2
    )
}

/// The slave's and the master's time spans overlap, and by how much of the master's.
fn overlap(rec: &Recording) -> Option<Finding> {
    let (s0, s1) = (rec.imu_t0, rec.imu.last()?.t);
    let (m0, m1) = (rec.master.first()?.t, rec.master.last()?.t);
    let common = (s1.min(m1) - s0.max(m0)).max(0.0);
    let inside = rec.master.iter().filter(|m| m.t >= s0 && m.t <= s1).count();
    let frac = inside as f64 / rec.master.len() as f64;
    let f = |sev, code, msg: String| {
        Finding::new(sev, code, msg)
            .num("slave_start_s", s0)
            .num("slave_end_s", s1)
            .num("master_start_s", m0)
            .num("master_end_s", m1)
            .num("overlap_s", common)
            .num("master_inside", inside as f64)
            .num("master_total", rec.master.len() as f64)
    };
    if inside == 0 {
        return Some(f(
            Severity::Fail,
            "time_no_overlap",
            format!(
                "no master message falls in the slave's time span: slave [{}, {}] s, master [{}, {}] s; nothing can be matched (a clock offset or the wrong files?)",
                g3(s0), g3(s1), g3(m0), g3(m1)
            ),
        ));
    }
    let sev = if frac < OVERLAP_FAIL {
        Severity::Fail
    } else if frac < OVERLAP_WARN {
        Severity::Warn
    } else {
        return None;
    };
    Some(f(
        sev,
        "time_overlap_low",
        format!(
            "only {inside} of {} master messages ({:.1}%) fall in the slave's time span [{}, {}] s; the others are never matched",
            rec.master.len(),
            100.0 * frac,
            g3(s0),
            g3(s1)
        ),
    ))
}

/// The rates declared in `recording.toml` against the timestamps' median interval.
fn declared_rates(rec: &Recording) -> Vec<Finding> {
    let slave_t: Vec<f64> = std::iter::once(rec.imu_t0)
        .chain(rec.imu.iter().map(|s| s.t))
        .collect();
    let master_t: Vec<f64> = rec.master.iter().map(|m| m.t).collect();
    let mut out = Vec::new();
    for (key, declared, t) in [
        ("slave_imu.rate_hz", rec.meta.slave_rate_hz, &slave_t),
        ("master.rate_hz", rec.meta.master_rate_hz, &master_t),
    ] {
        let dt = median(t.windows(2).map(|w| w[1] - w[0]).collect());
        if dt.is_nan() || dt <= 0.0 {
            continue;
        }
        let measured = 1.0 / dt;
        let off = (declared / measured - 1.0).abs();
        let sev = if off > RATE_FAIL {
            Severity::Fail
        } else if off > RATE_WARN {
            Severity::Warn
        } else {
            continue;
        };
        out.push(
            Finding::new(
                sev,
                "rate_mismatch",
                format!(
                    "`{key}` declares {} Hz but the timestamps' median interval says {} Hz; the timestamps are integrated, the declared rate sets the learned filter period and the identification's sampling",
                    g3(declared),
                    g3(measured)
                ),
            )
            .at(format!("{META_FILE} {key}"))
            .num("declared_hz", declared)
            .num("from_timestamps_hz", measured),
        );
    }
    out
}

/// Intervals longer than `GAP_FACTOR` median intervals: count, total, the longest.
struct Gaps {
    count: usize,
    total_s: f64,
    longest_s: f64,
    longest_index: usize,
    median_s: f64,
}

/// Gaps of a time series; `index` of the longest is that of the sample ending it.
fn gaps(t: &[f64]) -> Option<Gaps> {
    let d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let median_s = median(d.clone());
    let mut g = Gaps {
        count: 0,
        total_s: 0.0,
        longest_s: 0.0,
        longest_index: 0,
        median_s,
    };
    for (i, &x) in d.iter().enumerate() {
        if x > GAP_FACTOR * median_s {
            g.count += 1;
            g.total_s += x - median_s;
            if x > g.longest_s {
                g.longest_s = x;
                g.longest_index = i + 1;
            }
        }
    }
    (g.count > 0).then_some(g)
}

fn slave_gaps(rec: &Recording) -> Option<Finding> {
    let t: Vec<f64> = std::iter::once(rec.imu_t0)
        .chain(rec.imu.iter().map(|s| s.t))
        .collect();
    let g = gaps(&t)?;
    // Index into `t` counts the clock-starting line: sample `longest_index - 1`.
    let sev = if g.longest_s > SLAVE_GAP_FAIL_S {
        Severity::Fail
    } else {
        Severity::Warn
    };
    Some(
        Finding::new(
            sev,
            "slave_gap",
            format!(
                "{} gap(s) in the slave samples ({} s missing in all); the longest, {} s, is integrated as a single increment",
                g.count,
                g3(g.total_s),
                g3(g.longest_s)
            ),
        )
        .at(slave_at(rec, g.longest_index.saturating_sub(1)))
        .num("gaps", g.count as f64)
        .num("missing_s", g.total_s)
        .num("longest_s", g.longest_s)
        .num("median_interval_s", g.median_s),
    )
}

fn master_gaps(rec: &Recording) -> Option<Finding> {
    let t: Vec<f64> = rec.master.iter().map(|m| m.t).collect();
    let g = gaps(&t)?;
    Some(
        Finding::new(
            Severity::Warn,
            "master_gap",
            format!(
                "{} gap(s) in the master messages ({} s without a message in all, the longest {} s)",
                g.count,
                g3(g.total_s),
                g3(g.longest_s)
            ),
        )
        .at(master_at(rec, g.longest_index))
        .num("gaps", g.count as f64)
        .num("missing_s", g.total_s)
        .num("longest_s", g.longest_s)
        .num("median_interval_s", g.median_s),
    )
}

/// Distance (m) between two nearby geodetic positions (degrees).
fn distance_m(lat1: f64, lon1: f64, lat2: f64, lon2: f64) -> f64 {
    let dlat = (lat2 - lat1).to_radians();
    let dlon = ((lon2 - lon1 + 540.0).rem_euclid(360.0) - 180.0).to_radians();
    let mid = (0.5 * (lat1 + lat2)).to_radians();
    EARTH_RADIUS_M * (dlat * dlat + (dlon * mid.cos()).powi(2)).sqrt()
}

/// `site` is the master's position at the start (recording-v1): the first master
/// message must be there. This is what `site` is used for.
fn site(rec: &Recording) -> Option<Finding> {
    let m = rec.master.first()?;
    let s = &rec.meta.site;
    let d = distance_m(s.lat_deg, s.lon_deg, m.lat_deg, m.lon_deg);
    let radians = (m.lat_deg.abs() <= std::f64::consts::FRAC_PI_2
        && m.lon_deg.abs() <= std::f64::consts::PI)
        && distance_m(
            s.lat_deg,
            s.lon_deg,
            m.lat_deg.to_degrees(),
            m.lon_deg.to_degrees(),
        ) < SITE_WARN_M;
    let f = |sev, code, msg: String| {
        Finding::new(sev, code, msg)
            .at(master_at(rec, 0))
            .num("site_lat_deg", s.lat_deg)
            .num("site_lon_deg", s.lon_deg)
            .num("master_lat_deg", m.lat_deg)
            .num("master_lon_deg", m.lon_deg)
            .num("distance_m", d)
    };
    if radians && d > SITE_WARN_M {
        return Some(f(
            Severity::Fail,
            "master_position_radians",
            format!(
                "the master's latitude and longitude ({}, {}) are `site` ({}, {}) in radians: `lat_deg` and `lon_deg` must be degrees (gravity and Earth rate follow from them)",
                g3(m.lat_deg), g3(m.lon_deg), g3(s.lat_deg), g3(s.lon_deg)
            ),
        ));
    }
    let sev = if d > SITE_FAIL_M {
        Severity::Fail
    } else if d > SITE_WARN_M {
        Severity::Warn
    } else {
        return None;
    };
    Some(f(
        sev,
        "site_mismatch",
        format!(
            "the master's first position ({}, {}) is {} km from `site` ({}, {}) of {META_FILE}, which is the master's position at the start",
            g3(m.lat_deg), g3(m.lon_deg), g3(d / 1000.0), g3(s.lat_deg), g3(s.lon_deg)
        ),
    ))
}

fn lever_arm(rec: &Recording) -> Option<Finding> {
    let r = rec.meta.lever_arm_m;
    let n = r.iter().map(|x| x * x).sum::<f64>().sqrt();
    (n > LEVER_ARM_MAX_M).then(|| {
        Finding::new(
            Severity::Fail,
            "lever_arm_implausible",
            format!(
                "the lever arm is {} m long; master and slave on one structure are at most {} m apart (millimetres written as metres?)",
                g3(n),
                LEVER_ARM_MAX_M
            ),
        )
        .at(format!("{META_FILE} lever_arm.r0_m"))
        .val("r0_m", json!(r))
        .num("length_m", n)
        .num("max_m", LEVER_ARM_MAX_M)
    })
}

fn heights(rec: &Recording) -> Vec<Finding> {
    let [lo, hi] = HEIGHT_RANGE_M;
    let bad = |h: f64| !(lo..=hi).contains(&h);
    let mut out = Vec::new();
    let h = rec.meta.site.height_m;
    if bad(h) {
        out.push(
            Finding::new(
                Severity::Fail,
                "height_implausible",
                format!("`site.height_m` is {} m, outside [{lo}, {hi}] m", g3(h)),
            )
            .at(format!("{META_FILE} site.height_m"))
            .num("height_m", h),
        );
    }
    let n = rec.master.iter().filter(|m| bad(m.height_m)).count();
    if let Some(i) = rec.master.iter().position(|m| bad(m.height_m)) {
        let h = rec.master[i].height_m;
        out.push(
            Finding::new(
                Severity::Fail,
                "height_implausible",
                format!(
                    "{n} master message(s) give a height outside [{lo}, {hi}] m, the first {} m",
                    g3(h)
                ),
            )
            .at(master_at(rec, i))
            .num("height_m", h)
            .num("count", n as f64),
        );
    }
    out
}

/// The rotation angle (rad) between two attitude quaternions (scalar first).
pub fn angle_between(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    2.0 * dot.abs().min(1.0).acos()
}

fn attitude_jumps(rec: &Recording) -> Option<Finding> {
    let mut count = 0;
    let mut worst = (0.0, 0usize);
    for (i, w) in rec.master.windows(2).enumerate() {
        let rate = angle_between(&w[0].q_bm_n, &w[1].q_bm_n) / (w[1].t - w[0].t);
        if rate > ATTITUDE_JUMP_RADPS {
            count += 1;
            if rate > worst.0 {
                worst = (rate, i + 1);
            }
        }
    }
    if count == 0 {
        return None;
    }
    let frac = count as f64 / rec.master.len() as f64;
    let sev = if frac > 0.01 {
        Severity::Fail
    } else {
        Severity::Warn
    };
    Some(
        Finding::new(
            sev,
            "master_attitude_jump",
            format!(
                "the master's attitude jumps {count} time(s) faster than {ATTITUDE_JUMP_RADPS} rad/s; the largest, {} °/s, is at the message named",
                g3(worst.0.to_degrees())
            ),
        )
        .at(master_at(rec, worst.1))
        .num("jumps", count as f64)
        .num("largest_radps", worst.0)
        .num("threshold_radps", ATTITUDE_JUMP_RADPS),
    )
}

/// A file whose last byte is not a line end: its last line may have been cut short
/// (a number cut short still parses).
fn unterminated(path: &Path, file: &str) -> Option<Finding> {
    let mut f = std::fs::File::open(path).ok()?;
    let len = f.metadata().ok()?.len();
    if len == 0 {
        return None;
    }
    f.seek(SeekFrom::End(-1)).ok()?;
    let mut last = [0u8; 1];
    f.read_exact(&mut last).ok()?;
    if last[0] == b'\n' {
        return None;
    }
    let lines =
        std::io::BufRead::lines(std::io::BufReader::new(std::fs::File::open(path).ok()?)).count();
    Some(
        Finding::new(
            Severity::Warn,
            "last_line_cut",
            format!("{file} does not end with a line end: its last line ({lines}) may have been cut short, and a number cut short still parses"),
        )
        .at(format!("{file} line {lines}"))
        .num("line", lines as f64),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_distance() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        // One degree of latitude is 111 km.
        let d = distance_m(0.0, 0.0, 1.0, 0.0);
        assert!((d - 111_195.0).abs() < 1.0, "{d}");
        assert!(distance_m(10.0, 179.9, 10.0, -179.9) < 30_000.0);
    }

    #[test]
    fn gaps_counts_missing_samples() {
        let t = [0.0, 1.0, 2.0, 6.0, 7.0, 8.0];
        let g = gaps(&t).unwrap_or_else(|| panic!("a gap"));
        assert_eq!((g.count, g.longest_index), (1, 3));
        assert_eq!(g.total_s, 3.0);
        assert!(gaps(&[0.0, 1.0, 2.0, 3.0]).is_none());
    }
}
