//! Reading a recording folder, checking it against the contract: one sample at a
//! time ([`open_recording`], [`SlaveReader`], [`MasterReader`], [`TruthReader`]), in
//! memory bounded by the longest line whatever the files' lengths, or whole into
//! memory ([`read_recording`]) for the tools that make several passes over it.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use super::csv::{open, CsvReader};
use super::error::{ErrorKind, RecordingError};
use super::layout::{
    imu_from_row, master_from_row, MASTER_COLUMNS, MASTER_RATE_COLUMNS, SLAVE_INCREMENT_COLUMNS,
    SLAVE_RATE_COLUMNS, TIME_COLUMN,
};
use super::rules::{self, TimeOrder};
use super::text::read_text;
use super::{
    meta, ImuOutput, ImuSample, MasterMsg, Recording, RecordingMeta, Truth, MASTER_FILE, META_FILE,
    SLAVE_FILE, TRUTH_FILE,
};

/// Reads the recording in folder `dir` (format version 1) whole into memory.
///
/// `truth.csv` is read if present. Slave rates are converted to increments
/// with `dt = t - t_prev`. Any departure from the contract is an error that
/// names the file, line, column or key; nothing is guessed or dropped. The
/// files are read one after the other with the readers of [`open_recording`],
/// so the errors are the same either way.
pub fn read_recording(dir: &Path) -> Result<Recording, RecordingError> {
    let meta = read_meta(dir)?;
    let mut slave = SlaveReader::open(&dir.join(SLAVE_FILE), meta.slave_output)?;
    let imu = slave.by_ref().collect::<Result<Vec<_>, _>>()?;
    let master = MasterReader::open(&dir.join(MASTER_FILE))?.collect::<Result<Vec<_>, _>>()?;
    let truth = match TruthReader::open_if_present(&dir.join(TRUTH_FILE))? {
        Some(reader) => Some(reader.collect_truth()?),
        None => None,
    };
    Ok(Recording {
        meta,
        imu_t0: slave.t0(),
        imu,
        master,
        truth,
    })
}

/// A recording opened for reading one sample at a time: its description, read
/// whole, and a reader on each of its files, each at its first data line.
pub struct RecordingStream {
    /// The session description (`recording.toml`).
    pub meta: RecordingMeta,
    /// The slave IMU's samples.
    pub slave: SlaveReader,
    /// The master's messages.
    pub master: MasterReader,
    /// The simulator truth, if `truth.csv` is present.
    pub truth: Option<TruthReader>,
}

/// Opens the recording in folder `dir` for reading in one pass: checks
/// `recording.toml`, and the header (and, for the slave, the clock-starting
/// line) of each CSV file. The data lines are checked as they are read, with the
/// same errors as [`read_recording`].
pub fn open_recording(dir: &Path) -> Result<RecordingStream, RecordingError> {
    let meta = read_meta(dir)?;
    let slave = SlaveReader::open(&dir.join(SLAVE_FILE), meta.slave_output)?;
    let master = MasterReader::open(&dir.join(MASTER_FILE))?;
    let truth = TruthReader::open_if_present(&dir.join(TRUTH_FILE))?;
    Ok(RecordingStream {
        meta,
        slave,
        master,
        truth,
    })
}

/// Reads and checks `recording.toml` in `dir`.
fn read_meta(dir: &Path) -> Result<RecordingMeta, RecordingError> {
    let path = dir.join(META_FILE);
    meta::parse(&path, &read_text(&path)?)
}

/// `slave_imu.csv` read one sample at a time, as increments.
///
/// The first line's values are checked like any other (a malformed line is an
/// error wherever it is), then dropped: only its time is kept ([`Self::t0`]).
/// Yields an error (and then nothing) at the first departure from the contract,
/// or at the end when no sample followed the first line.
pub struct SlaveReader {
    csv: CsvReader<BufReader<File>>,
    cols: [usize; 7],
    output: ImuOutput,
    order: TimeOrder,
    t0: f64,
    prev: f64,
    line: usize,
    ends: Ends,
}

impl SlaveReader {
    /// Opens `path`, checks its header and reads its clock-starting line.
    pub fn open(path: &Path, output: ImuOutput) -> Result<Self, RecordingError> {
        let mut csv = CsvReader::new(path, open(path)?)?;
        let cols = csv.require(match output {
            ImuOutput::Increments => SLAVE_INCREMENT_COLUMNS,
            ImuOutput::Rates => SLAVE_RATE_COLUMNS,
        })?;
        let (t0, line) = match csv.next_row() {
            Some(row) => {
                let row = row?;
                let [t, ..] = row.numbers(&cols)?;
                (t, row.line())
            }
            None => return Err(no_slave_samples(path)),
        };
        let mut order = TimeOrder::default();
        order
            .next(t0)
            .map_err(|kind| RecordingError::new(path, kind).at_line(line))?;
        Ok(Self {
            csv,
            cols,
            output,
            order,
            t0,
            prev: t0,
            line,
            ends: Ends::new(SLAVE_NEEDED),
        })
    }

    /// Time of the first line, which only starts the clock (s).
    pub fn t0(&self) -> f64 {
        self.t0
    }

    /// The 1-based line of the sample returned last (of the first line before any).
    pub fn line(&self) -> usize {
        self.line
    }

    /// Bytes of the file read so far (for progress against the file's size).
    pub fn bytes_read(&self) -> u64 {
        self.csv.bytes_read()
    }

    fn read(&mut self) -> Option<Result<ImuSample, RecordingError>> {
        let row = match self.csv.next_row()? {
            Ok(row) => row,
            Err(e) => return Some(Err(e)),
        };
        let sample = (|| {
            let mut v = row.numbers(&self.cols)?;
            let [t, ..] = v;
            let [t_col, ..] = self.cols;
            self.order.next(t).map_err(|kind| row.error(t_col, kind))?;
            if self.output == ImuOutput::Rates {
                let dt = t - self.prev;
                for (x, &col) in v.iter_mut().zip(&self.cols).skip(1) {
                    *x = rules::finite(*x * dt).map_err(|kind| row.error(col, kind))?;
                }
            }
            self.prev = t;
            Ok(imu_from_row(v))
        })();
        self.line = row.line();
        Some(sample)
    }
}

/// What a slave file needs at least.
const SLAVE_NEEDED: &str = "a line that starts the clock and at least one sample after it";

/// The error of a slave file without a sample after its first line.
fn no_slave_samples(path: &Path) -> RecordingError {
    RecordingError::new(
        path,
        ErrorKind::NoSamples {
            needed: SLAVE_NEEDED,
        },
    )
}

impl Iterator for SlaveReader {
    type Item = Result<ImuSample, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        let read = if self.ends.done() { None } else { self.read() };
        self.ends.step(read, self.csv.path())
    }
}

/// How a reader ends: an error (and then nothing) at the first departure from the
/// contract; at the end of the file, [`ErrorKind::NoSamples`] saying what was `needed`
/// when nothing was read.
#[derive(Debug)]
struct Ends {
    needed: &'static str,
    count: usize,
    done: bool,
}

impl Ends {
    fn new(needed: &'static str) -> Self {
        Self {
            needed,
            count: 0,
            done: false,
        }
    }

    /// Whether the reader has ended.
    fn done(&self) -> bool {
        self.done
    }

    /// What the reader yields for what it read (`None`: the end of `path`).
    fn step<T>(
        &mut self,
        read: Option<Result<T, RecordingError>>,
        path: &Path,
    ) -> Option<Result<T, RecordingError>> {
        if self.done {
            return None;
        }
        let item = match read {
            Some(item) => item,
            None if self.count == 0 => Err(RecordingError::new(
                path,
                ErrorKind::NoSamples {
                    needed: self.needed,
                },
            )),
            None => {
                self.done = true;
                return None;
            }
        };
        self.done = item.is_err();
        self.count += 1;
        Some(item)
    }
}

/// `master.csv` read one message at a time. Yields an error (and then nothing)
/// at the first departure from the contract, or at the end when it held no message.
pub struct MasterReader {
    csv: CsvReader<BufReader<File>>,
    cols: [usize; 11],
    rate_cols: Option<[usize; 3]>,
    order: TimeOrder,
    line: usize,
    ends: Ends,
}

impl MasterReader {
    /// Opens `path` and checks its header.
    pub fn open(path: &Path) -> Result<Self, RecordingError> {
        let csv = CsvReader::new(path, open(path)?)?;
        let cols = csv.require(MASTER_COLUMNS)?;
        let rate_cols = master_rate_columns(&csv)?;
        Ok(Self {
            csv,
            cols,
            rate_cols,
            order: TimeOrder::default(),
            line: 0,
            ends: Ends::new("at least one message"),
        })
    }

    /// Whether the header has the master's angular rate `wx,wy,wz` (every
    /// message then gives it: the columns are all there or none is).
    pub fn has_rate(&self) -> bool {
        self.rate_cols.is_some()
    }

    /// The 1-based line of the message returned last (0 before any).
    pub fn line(&self) -> usize {
        self.line
    }

    fn read(&mut self) -> Option<Result<MasterMsg, RecordingError>> {
        let row = match self.csv.next_row()? {
            Ok(row) => row,
            Err(e) => return Some(Err(e)),
        };
        let msg = (|| {
            let v = row.numbers(&self.cols)?;
            let [t, qw, qx, qy, qz, _, _, _, lat, _, _] = v;
            let [t_col, qw_col, _, _, _, _, _, _, lat_col, _, _] = self.cols;
            self.order.next(t).map_err(|kind| row.error(t_col, kind))?;
            rules::unit_quaternion([qw, qx, qy, qz]).map_err(|kind| row.error(qw_col, kind))?;
            rules::latitude(lat).map_err(|kind| row.error(lat_col, kind))?;
            let rate = self.rate_cols.map(|c| row.numbers(&c)).transpose()?;
            Ok(master_from_row(v, rate))
        })();
        self.line = row.line();
        Some(msg)
    }
}

impl Iterator for MasterReader {
    type Item = Result<MasterMsg, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        let read = if self.ends.done() { None } else { self.read() };
        self.ends.step(read, self.csv.path())
    }
}

/// The column indices of `wx,wy,wz` if the header has all three, `None` if
/// it has none; an error naming the first missing one otherwise.
fn master_rate_columns<R: std::io::BufRead>(
    csv: &CsvReader<R>,
) -> Result<Option<[usize; 3]>, RecordingError> {
    let found = MASTER_RATE_COLUMNS.map(|name| csv.find(name));
    if found.iter().all(Option::is_none) {
        return Ok(None);
    }
    let mut out = [0; 3];
    for ((slot, index), name) in out.iter_mut().zip(found).zip(MASTER_RATE_COLUMNS) {
        *slot = index.ok_or_else(|| {
            csv.header_error(ErrorKind::IncompleteMasterRate {
                missing: name.to_owned(),
            })
        })?;
    }
    Ok(Some(out))
}

/// One line of `truth.csv`: its time and the values of [`TruthReader::names`].
#[derive(Debug, Clone, PartialEq)]
pub struct TruthRow {
    /// Time, seconds.
    pub t: f64,
    /// The values, in the order of the names.
    pub values: Vec<f64>,
}

/// `truth.csv` read one line at a time, every column besides `t` kept in file
/// order. Yields an error (and then nothing) at the first departure from the
/// contract, or at the end when it held no line of values.
pub struct TruthReader {
    csv: CsvReader<BufReader<File>>,
    t_col: usize,
    data_cols: Vec<usize>,
    names: Vec<String>,
    order: TimeOrder,
    ends: Ends,
}

impl TruthReader {
    /// Opens `path` and checks its header; `None` when the file does not exist.
    pub fn open_if_present(path: &Path) -> Result<Option<Self>, RecordingError> {
        let input = match open(path) {
            Ok(input) => input,
            Err(e) if matches!(e.kind(), ErrorKind::MissingFile) => return Ok(None),
            Err(e) => return Err(e),
        };
        let csv = CsvReader::new(path, input)?;
        let [t_col] = csv.require([TIME_COLUMN])?;
        let (data_cols, names) = csv
            .names()
            .iter()
            .enumerate()
            .filter(|(_, name)| *name != TIME_COLUMN)
            .map(|(i, name)| (i, name.clone()))
            .unzip();
        Ok(Some(Self {
            csv,
            t_col,
            data_cols,
            names,
            order: TimeOrder::default(),
            ends: Ends::new("at least one line of values"),
        }))
    }

    /// Column names besides `t`, in file order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Reads every remaining line into a [`Truth`] table.
    pub fn collect_truth(mut self) -> Result<Truth, RecordingError> {
        let mut t = Vec::new();
        let mut columns = vec![Vec::new(); self.names.len()];
        for row in self.by_ref() {
            let row = row?;
            t.push(row.t);
            for (column, v) in columns.iter_mut().zip(row.values) {
                column.push(v);
            }
        }
        Ok(Truth {
            names: self.names,
            t,
            columns,
        })
    }

    fn read(&mut self) -> Option<Result<TruthRow, RecordingError>> {
        let row = match self.csv.next_row()? {
            Ok(row) => row,
            Err(e) => return Some(Err(e)),
        };
        Some((|| {
            let t = row.number(self.t_col)?;
            self.order
                .next(t)
                .map_err(|kind| row.error(self.t_col, kind))?;
            let values = self
                .data_cols
                .iter()
                .map(|&col| row.number(col))
                .collect::<Result<_, _>>()?;
            Ok(TruthRow { t, values })
        })())
    }
}

impl Iterator for TruthReader {
    type Item = Result<TruthRow, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        let read = if self.ends.done() { None } else { self.read() };
        self.ends.step(read, self.csv.path())
    }
}
