//! A run's outputs gathered as the run goes, in memory that does not grow with its
//! length: `estimates.csv` written row by row, the rows thinned to at most
//! [`THIN_CAPACITY`] for the plots (the last one always kept), the last estimate of
//! each augmented effect, and the truth thinned the same way for the plots with the
//! row nearest the end kept for the score.

use super::summary::EstimatesCsv;
use crate::calib::run::{EffectRow, EstimateRow, Innovation, RunSink};
use crate::recording::{RecordingError, Truth, TruthReader};

/// Rows kept for the plots: every row of a run up to this many (655 s of master
/// updates at 100 Hz), then every second, fourth, …; the plots draw at most
/// 4000 points per series (`plot::points`), so nothing visible is lost.
pub const THIN_CAPACITY: usize = 65_536;

/// A sequence thinned as it grows: every `stride`-th item, the stride doubled (and
/// every other item kept dropped) whenever `capacity` items are held; the last item
/// pushed is always kept.
#[derive(Debug)]
pub struct Thinned<T> {
    capacity: usize,
    items: Vec<T>,
    stride: usize,
    seen: usize,
    last: Option<T>,
}

impl<T: Clone> Thinned<T> {
    /// An empty sequence holding at most `capacity` items (at least 2) besides the last.
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.max(2),
            items: Vec::new(),
            stride: 1,
            seen: 0,
            last: None,
        }
    }

    /// Adds the next item.
    pub fn push(&mut self, item: T) {
        if self.seen % self.stride == 0 {
            if self.items.len() == self.capacity {
                let mut k = 0;
                self.items.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
            if self.seen % self.stride == 0 {
                self.items.push(item.clone());
            }
        }
        self.last = Some(item);
        self.seen += 1;
    }

    /// Items pushed so far.
    pub fn seen(&self) -> usize {
        self.seen
    }

    /// The items kept, in order, ending with the last one pushed.
    pub fn into_vec(self) -> Vec<T> {
        let mut items = self.items;
        let kept_last = self
            .seen
            .checked_sub(1)
            .is_none_or(|k| k % self.stride == 0);
        if let (Some(last), false) = (self.last, kept_last) {
            items.push(last);
        }
        items
    }
}

/// The sink of a streaming `calibrate`: see the module's documentation.
pub struct StreamSink {
    csv: EstimatesCsv,
    csv_error: Option<std::io::Error>,
    rows: Thinned<EstimateRow>,
    effects: Vec<EffectRow>,
}

impl StreamSink {
    /// A sink writing its rows to `csv`.
    pub fn new(csv: EstimatesCsv) -> Self {
        Self {
            csv,
            csv_error: None,
            rows: Thinned::new(THIN_CAPACITY),
            effects: Vec::new(),
        }
    }

    /// Ends the run: closes `estimates.csv` (the first write error, if any) and gives
    /// the thinned rows and the last estimate of each effect.
    pub fn finish(self) -> std::io::Result<(Vec<EstimateRow>, Vec<EffectRow>)> {
        if let Some(e) = self.csv_error {
            return Err(e);
        }
        self.csv.finish()?;
        Ok((self.rows.into_vec(), self.effects))
    }
}

impl RunSink for StreamSink {
    fn innovation(&mut self, _: &Innovation) {}

    fn row(&mut self, r: &EstimateRow) {
        if self.csv_error.is_none() {
            self.csv_error = self.csv.row(r).err();
        }
        self.rows.push(*r);
    }

    fn effect(&mut self, e: EffectRow) {
        match self.effects.iter_mut().find(|o| o.effect == e.effect) {
            Some(slot) => *slot = e,
            None => self.effects.push(e),
        }
    }
}

/// `truth.csv` read to the end: thinned to [`THIN_CAPACITY`] rows for the plots, and
/// the single row nearest `t_end` for the score.
pub fn read_truth(reader: TruthReader, t_end: f64) -> Result<(Truth, Truth), RecordingError> {
    let names = reader.names().to_vec();
    let mut thinned = Thinned::new(THIN_CAPACITY);
    let mut nearest: Option<(f64, Vec<f64>)> = None;
    for row in reader {
        let row = row?;
        if nearest
            .as_ref()
            .is_none_or(|(t, _)| (row.t - t_end).abs() < (t - t_end).abs())
        {
            nearest = Some((row.t, row.values.clone()));
        }
        thinned.push((row.t, row.values));
    }
    let table = |rows: Vec<(f64, Vec<f64>)>| {
        let mut columns = vec![Vec::with_capacity(rows.len()); names.len()];
        let mut t = Vec::with_capacity(rows.len());
        for (time, values) in rows {
            t.push(time);
            for (c, v) in columns.iter_mut().zip(values) {
                c.push(v);
            }
        }
        Truth {
            names: names.clone(),
            t,
            columns,
        }
    };
    Ok((
        table(thinned.into_vec()),
        table(nearest.into_iter().collect()),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_a_regular_subsequence_and_the_last() {
        let mut t = Thinned::new(4);
        for k in 0..10 {
            t.push(k);
        }
        // 0..10 with capacity 4: stride 4 after two halvings, then the last.
        assert_eq!(t.seen(), 10);
        assert_eq!(t.into_vec(), vec![0, 4, 8, 9]);
        let mut short = Thinned::new(8);
        for k in 0..5 {
            short.push(k);
        }
        assert_eq!(short.into_vec(), vec![0, 1, 2, 3, 4]);
        let mut exact = Thinned::new(4);
        for k in 0..9 {
            exact.push(k);
        }
        assert_eq!(exact.into_vec(), vec![0, 4, 8]);
    }
}
