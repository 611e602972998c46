//! Plausibility of a recording that parses: what the contract (`recording-v1`) cannot
//! refuse but physics or the file's own numbers contradict. Time spans, declared rates
//! against the timestamps, gaps, the master's first position against `site`, the lever
//! arm and heights against physical bounds, master attitude jumps, a last line without
//! its line end. Each finding names the file, the line and the time of the sample with
//! the values. Thresholds: `docs/verdict.md`.
//!
//! The recording is seen one sample at a time ([`Scan`]), while the filter runs over it
//! or in a read of its own ([`Scan::of_dir`]): memory does not grow with its length
//! beyond the first [`MEDIAN_INTERVALS`] intervals of each file (for their median) and
//! the first [`PREFIX_SAMPLES`] slave samples kept for the motion checks.

use super::{g3, Finding, Severity};
use crate::recording::{
    open_recording, ImuSample, MasterMsg, Recording, RecordingMeta, MASTER_FILE, META_FILE,
    SLAVE_FILE, TRUTH_FILE,
};
use crate::report::units::{show, RATE};
use serde_json::json;
use std::collections::VecDeque;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

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
/// Intervals of each file whose median is the nominal interval (655 s at 200 Hz): a
/// bounded sample of a regular clock gives its median; the gaps are judged against it.
pub const MEDIAN_INTERVALS: usize = 131_072;
/// Slave samples (and the master messages up to the last of them) kept for the motion
/// checks and the IMU noise ([`Scan::prefix`]): units do not change within a file, and
/// a clock offset is seen in any stretch with motion (1000 s at 200 Hz).
pub const PREFIX_SAMPLES: usize = 200_000;

/// Where a sample is: its time and its 1-based line in its file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Place {
    /// Time, s.
    pub t: f64,
    /// Line in the file.
    pub line: usize,
}

impl Place {
    /// `file line N (t = T s)`.
    fn at(self, file: &str) -> String {
        format!("{file} line {} (t = {} s)", self.line, self.t)
    }
}

/// Intervals longer than `GAP_FACTOR` median intervals: count, total, the longest.
#[derive(Clone, Debug)]
struct Gaps {
    count: usize,
    total_s: f64,
    longest_s: f64,
    /// The sample ending the longest.
    longest_at: Place,
    median_s: f64,
}

/// The intervals of one file's times, seen one at a time: their median over the first
/// [`MEDIAN_INTERVALS`], and the gaps against it (those seen before the median was
/// known are held until it is).
#[derive(Default)]
struct Intervals {
    prev: Option<f64>,
    pending: Vec<(f64, Place)>,
    median_s: Option<f64>,
    gaps: Option<Gaps>,
}

impl Intervals {
    fn push(&mut self, at: Place) {
        if let Some(prev) = self.prev.replace(at.t) {
            let d = at.t - prev;
            match self.median_s {
                Some(m) => self.judge(d, at, m),
                None => {
                    self.pending.push((d, at));
                    if self.pending.len() >= MEDIAN_INTERVALS {
                        self.settle();
                    }
                }
            }
        }
    }

    /// Takes the median of the intervals held and judges them.
    fn settle(&mut self) {
        let m = median(self.pending.iter().map(|p| p.0).collect());
        self.median_s = Some(m);
        for (d, at) in std::mem::take(&mut self.pending) {
            self.judge(d, at, m);
        }
    }

    fn judge(&mut self, d: f64, at: Place, median_s: f64) {
        if d > GAP_FACTOR * median_s {
            let g = self.gaps.get_or_insert(Gaps {
                count: 0,
                total_s: 0.0,
                longest_s: 0.0,
                longest_at: at,
                median_s,
            });
            g.count += 1;
            g.total_s += d - median_s;
            if d > g.longest_s {
                g.longest_s = d;
                g.longest_at = at;
            }
        }
    }

    /// The median interval (NaN without an interval) and the gaps, if any.
    fn finish(&mut self) -> (f64, Option<Gaps>) {
        if self.median_s.is_none() {
            self.settle();
        }
        (self.median_s.unwrap_or(f64::NAN), self.gaps.clone())
    }
}

/// The recording seen one sample at a time, in any interleaving of the two files
/// (each in its own order): what the plausibility checks need, in bounded memory.
pub struct Scan {
    dir: PathBuf,
    meta: RecordingMeta,
    slave_t0: f64,
    slave_last: Option<Place>,
    slave_done: bool,
    slave: Intervals,
    master: Intervals,
    master_total: usize,
    master_first: Option<(MasterMsg, Place)>,
    master_last: Option<Place>,
    master_before_slave: usize,
    /// Times of the master messages later than the slave's latest sample so far.
    master_ahead: VecDeque<f64>,
    master_after_slave: usize,
    bad_heights: usize,
    first_bad_height: Option<(f64, Place)>,
    jumps: usize,
    worst_jump: Option<(f64, Place)>,
    prev_attitude: Option<(f64, [f64; 4])>,
    prefix: Recording,
    prefix_end: Option<f64>,
}

impl Scan {
    /// A scan of the recording in `dir` described by `meta`, whose slave clock starts
    /// at `slave_t0` (its first line, line `t0_line`).
    pub fn new(dir: &Path, meta: RecordingMeta, slave_t0: f64, t0_line: usize) -> Self {
        let mut slave = Intervals::default();
        slave.push(Place {
            t: slave_t0,
            line: t0_line,
        });
        Self {
            dir: dir.to_path_buf(),
            prefix: Recording {
                meta: meta.clone(),
                imu_t0: slave_t0,
                imu: Vec::new(),
                master: Vec::new(),
                truth: None,
            },
            meta,
            slave_t0,
            slave_last: None,
            slave_done: false,
            slave,
            master: Intervals::default(),
            master_total: 0,
            master_first: None,
            master_last: None,
            master_before_slave: 0,
            master_ahead: VecDeque::new(),
            master_after_slave: 0,
            bad_heights: 0,
            first_bad_height: None,
            jumps: 0,
            worst_jump: None,
            prev_attitude: None,
            prefix_end: None,
        }
    }

    /// Reads the recording in `dir` once, one sample at a time, for its checks alone
    /// (the commands that hold it in memory for other reasons read it again this way, so
    /// that the findings name exact lines).
    pub fn of_dir(dir: &Path) -> Result<Self, String> {
        let mut stream = open_recording(dir).map_err(|e| e.to_string())?;
        let mut scan = Self::new(
            dir,
            stream.meta.clone(),
            stream.slave.t0(),
            stream.slave.line(),
        );
        while let Some(s) = stream.slave.next() {
            scan.slave(&s.map_err(|e| e.to_string())?, stream.slave.line());
        }
        scan.slave_finished();
        while let Some(m) = stream.master.next() {
            scan.master(&m.map_err(|e| e.to_string())?, stream.master.line());
        }
        Ok(scan)
    }

    /// A slave sample, at its line.
    pub fn slave(&mut self, s: &ImuSample, line: usize) {
        let at = Place { t: s.t, line };
        self.slave.push(at);
        self.slave_last = Some(at);
        while self.master_ahead.front().is_some_and(|&t| t <= s.t) {
            self.master_ahead.pop_front();
        }
        if self.prefix_end.is_none() {
            self.prefix.imu.push(s.clone());
            if self.prefix.imu.len() >= PREFIX_SAMPLES {
                self.prefix_end = Some(s.t);
            }
        }
    }

    /// Says that the slave has no more samples.
    pub fn slave_finished(&mut self) {
        self.slave_done = true;
        self.master_after_slave += self.master_ahead.len();
        self.master_ahead.clear();
    }

    /// A master message, at its line.
    pub fn master(&mut self, m: &MasterMsg, line: usize) {
        let at = Place { t: m.t, line };
        self.master.push(at);
        self.master_total += 1;
        if self.master_first.is_none() {
            self.master_first = Some((m.clone(), at));
        }
        self.master_last = Some(at);
        if m.t < self.slave_t0 {
            self.master_before_slave += 1;
        } else if self.slave_last.is_none_or(|s| m.t > s.t) {
            if self.slave_done {
                self.master_after_slave += 1;
            } else {
                self.master_ahead.push_back(m.t);
            }
        }
        let [lo, hi] = HEIGHT_RANGE_M;
        if !(lo..=hi).contains(&m.height_m) {
            self.bad_heights += 1;
            self.first_bad_height.get_or_insert((m.height_m, at));
        }
        if let Some((t, q)) = self.prev_attitude.replace((m.t, m.q_bm_n)) {
            let rate = angle_between(&q, &m.q_bm_n) / (m.t - t);
            if rate > ATTITUDE_JUMP_RADPS {
                self.jumps += 1;
                if self.worst_jump.is_none_or(|(w, _)| rate > w) {
                    self.worst_jump = Some((rate, at));
                }
            }
        }
        let keep = self.prefix_end.is_none_or(|end| m.t <= end);
        if keep && self.prefix.master.len() < PREFIX_SAMPLES {
            self.prefix.master.push(m.clone());
        }
    }

    /// The recording's description.
    pub fn meta(&self) -> &RecordingMeta {
        &self.meta
    }

    /// The first [`PREFIX_SAMPLES`] slave samples and the master messages up to the
    /// last of them (the whole recording when it is shorter): what the motion checks and
    /// the IMU noise from the increments look at.
    pub fn prefix(&self) -> &Recording {
        &self.prefix
    }

    /// Master messages in the file.
    pub fn master_total(&self) -> usize {
        self.master_total
    }

    /// Master messages later than the slave's last sample (never matched).
    pub fn master_after_slave(&self) -> usize {
        self.master_after_slave + self.master_ahead.len()
    }

    /// The slave's time span, s: its clock-starting line to its last sample.
    pub fn slave_span(&self) -> (f64, f64) {
        (
            self.slave_t0,
            self.slave_last.map_or(self.slave_t0, |p| p.t),
        )
    }

    /// Every plausibility finding of the recording.
    pub fn findings(&mut self) -> Vec<Finding> {
        let (slave_dt, slave_gaps) = self.slave.finish();
        let (master_dt, master_gaps) = self.master.finish();
        let mut out = Vec::new();
        out.extend(self.overlap());
        out.extend(declared_rates(&self.meta, slave_dt, master_dt));
        out.extend(slave_gaps.map(slave_gap_finding));
        out.extend(master_gaps.map(master_gap_finding));
        out.extend(self.site());
        out.extend(lever_arm(&self.meta));
        out.extend(self.heights());
        out.extend(self.attitude_jumps());
        for file in [SLAVE_FILE, MASTER_FILE, TRUTH_FILE] {
            out.extend(unterminated(&self.dir.join(file), file));
        }
        out
    }
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

impl Scan {
    /// The slave's and the master's time spans overlap, and by how much of the master's.
    fn overlap(&self) -> Option<Finding> {
        let (s0, s1) = (self.slave_t0, self.slave_last?.t);
        let (m0, m1) = (self.master_first.as_ref()?.1.t, self.master_last?.t);
        let common = (s1.min(m1) - s0.max(m0)).max(0.0);
        let total = self.master_total;
        let inside = total - self.master_before_slave - self.master_after_slave();
        let frac = inside as f64 / total as f64;
        let f = |sev, code, msg: String| {
            Finding::new(sev, code, msg)
                .num("slave_start_s", s0)
                .num("slave_end_s", s1)
                .num("master_start_s", m0)
                .num("master_end_s", m1)
                .num("overlap_s", common)
                .num("master_inside", inside as f64)
                .num("master_total", total as f64)
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
                total,
                100.0 * frac,
                g3(s0),
                g3(s1)
            ),
        ))
    }
}

/// The rates declared in `recording.toml` against the timestamps' median intervals (s).
fn declared_rates(meta: &RecordingMeta, slave_dt: f64, master_dt: f64) -> Vec<Finding> {
    let mut out = Vec::new();
    for (key, declared, dt) in [
        ("slave_imu.rate_hz", meta.slave_rate_hz, slave_dt),
        ("master.rate_hz", meta.master_rate_hz, master_dt),
    ] {
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

/// The finding of a file's gaps: `sev`, `code`, and what the gaps are of and mean.
fn gap_finding(g: Gaps, sev: Severity, code: &'static str, file: &str, what: String) -> Finding {
    Finding::new(sev, code, what)
        .at(g.longest_at.at(file))
        .num("gaps", g.count as f64)
        .num("missing_s", g.total_s)
        .num("longest_s", g.longest_s)
        .num("median_interval_s", g.median_s)
}

fn slave_gap_finding(g: Gaps) -> Finding {
    let sev = if g.longest_s > SLAVE_GAP_FAIL_S {
        Severity::Fail
    } else {
        Severity::Warn
    };
    let what = format!(
        "{} gap(s) in the slave samples ({} s missing in all); the longest, {} s, is integrated as a single increment",
        g.count,
        g3(g.total_s),
        g3(g.longest_s)
    );
    gap_finding(g, sev, "slave_gap", SLAVE_FILE, what)
}

fn master_gap_finding(g: Gaps) -> Finding {
    let what = format!(
        "{} gap(s) in the master messages ({} s without a message in all, the longest {} s)",
        g.count,
        g3(g.total_s),
        g3(g.longest_s)
    );
    gap_finding(g, Severity::Warn, "master_gap", MASTER_FILE, what)
}

/// Distance (m) between two nearby geodetic positions (degrees).
fn distance_m(lat1: f64, lon1: f64, lat2: f64, lon2: f64) -> f64 {
    let dlat = (lat2 - lat1).to_radians();
    let dlon = ((lon2 - lon1 + 540.0).rem_euclid(360.0) - 180.0).to_radians();
    let mid = (0.5 * (lat1 + lat2)).to_radians();
    EARTH_RADIUS_M * (dlat * dlat + (dlon * mid.cos()).powi(2)).sqrt()
}

impl Scan {
    /// `site` is the master's position at the start (recording-v1): the first master
    /// message must be there. This is what `site` is used for.
    fn site(&self) -> Option<Finding> {
        let (m, first) = self.master_first.as_ref()?;
        let s = &self.meta.site;
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
                .at(first.at(MASTER_FILE))
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
}

fn lever_arm(meta: &RecordingMeta) -> Option<Finding> {
    let r = meta.lever_arm_m;
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

impl Scan {
    fn heights(&self) -> Vec<Finding> {
        let [lo, hi] = HEIGHT_RANGE_M;
        let mut out = Vec::new();
        let h = self.meta.site.height_m;
        if !(lo..=hi).contains(&h) {
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
        let n = self.bad_heights;
        if let Some((h, at)) = self.first_bad_height {
            out.push(
                Finding::new(
                    Severity::Fail,
                    "height_implausible",
                    format!(
                        "{n} master message(s) give a height outside [{lo}, {hi}] m, the first {} m",
                        g3(h)
                    ),
                )
                .at(at.at(MASTER_FILE))
                .num("height_m", h)
                .num("count", n as f64),
            );
        }
        out
    }
}

/// The rotation angle (rad) between two attitude quaternions (scalar first).
pub fn angle_between(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    2.0 * dot.abs().min(1.0).acos()
}

impl Scan {
    fn attitude_jumps(&self) -> Option<Finding> {
        let count = self.jumps;
        let worst = self.worst_jump?;
        let frac = count as f64 / self.master_total as f64;
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
                    "the master's attitude jumps {count} time(s) faster than {}; the largest, {}, is at the message named",
                    show(ATTITUDE_JUMP_RADPS, RATE),
                    show(worst.0, RATE)
                ),
            )
            .at(worst.1.at(MASTER_FILE))
            .num("jumps", count as f64)
            .num("largest_radps", worst.0)
            .num("threshold_radps", ATTITUDE_JUMP_RADPS),
        )
    }
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

    fn gaps_of(t: &[f64]) -> Option<Gaps> {
        let mut iv = Intervals::default();
        for (i, &t) in t.iter().enumerate() {
            iv.push(Place { t, line: i + 2 });
        }
        iv.finish().1
    }

    #[test]
    fn gaps_counts_missing_samples() {
        let g = gaps_of(&[0.0, 1.0, 2.0, 6.0, 7.0, 8.0]).unwrap_or_else(|| panic!("a gap"));
        assert_eq!((g.count, g.longest_at.line), (1, 5));
        assert_eq!(g.total_s, 3.0);
        assert!(gaps_of(&[0.0, 1.0, 2.0, 3.0]).is_none());
    }
}
