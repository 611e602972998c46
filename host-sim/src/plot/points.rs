//! Turning data into drawable pieces: non-finite points break a line (or a
//! band) into separate pieces, and long data is decimated so files stay small.
//!
//! Decimation keeps the shape: each bucket of consecutive points is replaced
//! by its lowest and highest point (min/max bucketing), so peaks survive.
//! A piece needs two points to be drawn; a lone finite point between
//! non-finite ones draws nothing, as in other plotting tools.

use std::ops::Range;

/// Points per series above which it is decimated (min/max bucketing keeps at
/// most about this many).
pub(super) const MAX_POINTS: usize = 4000;

/// Consecutive indices per bucket for data of length `n`.
fn bucket_size(n: usize) -> usize {
    if n <= MAX_POINTS {
        1
    } else {
        n.div_ceil(MAX_POINTS / 2)
    }
}

/// Maximal runs of indices `0..n` where `ok` holds, of at least two indices.
fn runs(n: usize, ok: impl Fn(usize) -> bool) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut start = None;
    for i in 0..=n {
        match (start, i < n && ok(i)) {
            (None, true) => start = Some(i),
            (Some(s), false) => {
                if i - s >= 2 {
                    out.push(s..i);
                }
                start = None;
            }
            _ => {}
        }
    }
    out
}

/// `range` cut into consecutive buckets of `size` indices.
fn buckets(range: Range<usize>, size: usize) -> impl Iterator<Item = Range<usize>> {
    let end = range.end;
    range.step_by(size).map(move |s| s..(s + size).min(end))
}

/// A value of a slice that the caller knows to be in range.
fn at(v: &[f64], i: usize) -> f64 {
    v.get(i).copied().unwrap_or(f64::NAN)
}

/// Polyline pieces of the points `(x[i], y[i])` (the shorter length wins).
pub(super) fn line_pieces(x: &[f64], y: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let n = x.len().min(y.len());
    let size = bucket_size(n);
    let ok = |i| at(x, i).is_finite() && at(y, i).is_finite();
    runs(n, ok)
        .into_iter()
        .map(|run| {
            let mut piece = Vec::new();
            for bucket in buckets(run, size) {
                let by_y = |a: &usize, b: &usize| at(y, *a).total_cmp(&at(y, *b));
                let lowest = bucket.clone().min_by(by_y);
                let highest = bucket.clone().max_by(by_y);
                if let (Some(a), Some(b)) = (lowest, highest) {
                    let (first, second) = (a.min(b), a.max(b));
                    piece.push((at(x, first), at(y, first)));
                    if second != first {
                        piece.push((at(x, second), at(y, second)));
                    }
                }
            }
            piece
        })
        .collect()
}

/// Band pieces `(x, lo, hi)`; decimated buckets keep their envelope (lowest
/// `lo`, highest `hi`) at their first and last `x`.
pub(super) fn band_pieces(x: &[f64], lo: &[f64], hi: &[f64]) -> Vec<Vec<(f64, f64, f64)>> {
    let n = x.len().min(lo.len()).min(hi.len());
    let size = bucket_size(n);
    let ok = |i| at(x, i).is_finite() && at(lo, i).is_finite() && at(hi, i).is_finite();
    runs(n, ok)
        .into_iter()
        .map(|run| {
            let mut piece = Vec::new();
            for bucket in buckets(run, size) {
                let low = bucket
                    .clone()
                    .map(|i| at(lo, i))
                    .fold(f64::INFINITY, f64::min);
                let high = bucket
                    .clone()
                    .map(|i| at(hi, i))
                    .fold(f64::NEG_INFINITY, f64::max);
                let (first, last) = (bucket.start, bucket.end - 1);
                piece.push((at(x, first), low, high));
                if last != first {
                    piece.push((at(x, last), low, high));
                }
            }
            piece
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_points_break_lines() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let y = [1.0, 2.0, f64::NAN, 3.0, 4.0, f64::INFINITY, 5.0];
        let pieces = line_pieces(&x, &y);
        assert_eq!(
            pieces,
            vec![vec![(0.0, 1.0), (1.0, 2.0)], vec![(3.0, 3.0), (4.0, 4.0)]]
        );
        assert!(line_pieces(&[], &[]).is_empty());
        assert!(line_pieces(&[1.0], &[1.0]).is_empty());
    }

    #[test]
    fn long_series_are_decimated_keeping_extremes() {
        let n = 100_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut y: Vec<f64> = x.iter().map(|t| (t / 1000.0).sin()).collect();
        y[54_321] = 50.0;
        y[77_777] = -50.0;
        let pieces = line_pieces(&x, &y);
        assert_eq!(pieces.len(), 1);
        let points = &pieces[0];
        assert!(points.len() <= MAX_POINTS + 2, "{} points", points.len());
        assert!(points.contains(&(54_321.0, 50.0)));
        assert!(points.contains(&(77_777.0, -50.0)));
        assert!(points.windows(2).all(|w| w[0].0 < w[1].0), "order kept");
    }

    #[test]
    fn bands_keep_their_envelope() {
        let n = 10_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut lo = vec![-1.0; n];
        let hi = vec![1.0; n];
        lo[5000] = -7.0;
        lo[9000] = f64::NAN;
        let pieces = band_pieces(&x, &lo, &hi);
        assert_eq!(pieces.len(), 2);
        let total: usize = pieces.iter().map(Vec::len).sum();
        assert!(total <= MAX_POINTS + 4);
        assert!(pieces[0].iter().any(|p| p.1 == -7.0));
        assert!(pieces.iter().flatten().all(|p| p.2 == 1.0));
    }
}
