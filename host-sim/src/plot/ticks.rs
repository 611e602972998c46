//! Axis ranges with "nice" tick values (1, 2 or 5 times a power of ten) and
//! tick labels printed with just the digits the step needs.

/// Most ticks an axis may get; beyond this the range is degenerate for
/// floating point and the axis falls back to its two ends.
const MAX_TICKS: usize = 50;

/// A plotted range and its ticks.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Axis {
    /// Lower end of the plotted range (a tick).
    pub lo: f64,
    /// Upper end of the plotted range (a tick), always above `lo`.
    pub hi: f64,
    /// Distance between ticks.
    pub step: f64,
    /// Tick values from `lo` to `hi`.
    pub ticks: Vec<f64>,
}

impl Axis {
    /// The axis for data spanning `range` (`None`: no finite data), widened to
    /// whole ticks, with roughly `intervals` tick intervals (the step is the
    /// smallest nice one not below span/`intervals`). A zero range is widened
    /// around its value.
    pub(super) fn nice(range: Option<(f64, f64)>, intervals: f64) -> Self {
        let (min, max) = widen(range.unwrap_or((0.0, 1.0)));
        nice_ticks(min, max, intervals).unwrap_or_else(|| Self {
            lo: min,
            hi: max,
            step: max / 2.0 - min / 2.0,
            ticks: vec![min, max],
        })
    }

    /// Where `v` falls between `lo` (0) and `hi` (1). A span too wide for
    /// `f64` is computed on halves instead.
    pub(super) fn fraction(&self, v: f64) -> f64 {
        let span = self.hi - self.lo;
        if span.is_finite() {
            (v - self.lo) / span
        } else {
            (v / 2.0 - self.lo / 2.0) / (self.hi / 2.0 - self.lo / 2.0)
        }
    }

    /// The label of tick `v`.
    pub(super) fn label(&self, v: f64) -> String {
        label(v, self.step, self.lo.abs().max(self.hi.abs()))
    }
}

/// A range with `min < max`: equal ends are moved apart around their value.
fn widen((min, max): (f64, f64)) -> (f64, f64) {
    if min < max {
        return (min, max);
    }
    let d = if min == 0.0 { 1.0 } else { min.abs() / 10.0 };
    ((min - d).max(f64::MIN), (max + d).min(f64::MAX))
}

/// 1, 2, 5 or 10 times a power of ten, the smallest not below `raw`.
fn nice_step(raw: f64) -> Option<f64> {
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * magnitude)
        .find(|&s| s >= raw * (1.0 - 1e-9))?;
    (step.is_finite() && step > 0.0).then_some(step)
}

/// Ticks at whole multiples of a nice step, from below `min` to above `max`.
fn nice_ticks(min: f64, max: f64, intervals: f64) -> Option<Axis> {
    let step = nice_step((max - min) / intervals)?;
    let first = (min / step).floor();
    let last = (max / step).ceil();
    let count = last - first;
    if !(count >= 1.0 && count <= MAX_TICKS as f64) {
        return None;
    }
    let ticks: Vec<f64> = (0..=count as usize)
        .map(|i| (first + i as f64) * step)
        .collect();
    let (&lo, &hi) = (ticks.first()?, ticks.last()?);
    (lo.is_finite() && hi.is_finite() && lo < hi).then_some(Axis {
        lo,
        hi,
        step,
        ticks,
    })
}

/// `v` printed with as many decimals as `step` needs; scientific notation when
/// the axis reaches `extent` of 1e6 or more, or stays below 1e-3.
fn label(v: f64, step: f64, extent: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    // Rounding residue of a zero tick, and negative zero, print as "0".
    if v == 0.0 || v.abs() < step.abs() * 1e-6 {
        return "0".to_owned();
    }
    let step_exp = step.abs().log10().floor();
    if !step_exp.is_finite() || !(1e-3..1e6).contains(&extent) {
        let digits = (extent.log10().floor() - step_exp).clamp(0.0, 15.0);
        let digits = if digits.is_finite() {
            digits as usize
        } else {
            6
        };
        return format!("{v:.digits$e}");
    }
    let decimals = (-(step.abs().log10() + 1e-9).floor()).clamp(0.0, 15.0) as usize;
    format!("{v:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Is `x` one of 1, 2, 5 times a power of ten?
    fn is_nice(x: f64) -> bool {
        let mantissa = x / 10f64.powf(x.log10().floor());
        [1.0, 2.0, 5.0, 10.0]
            .iter()
            .any(|m| (mantissa - m).abs() < 1e-9)
    }

    #[test]
    fn ticks_are_nice_and_cover_the_range() {
        let ranges = [
            (0.0, 1.0),
            (-3.7, 12.2),
            (1e-7, 3.3e-7),
            (-5e9, 2e9),
            (100.0, 100.3),
            (0.013, 0.0131),
            (-1.0, -0.999),
            (37.0001, 37.0009),
        ];
        for (min, max) in ranges {
            let axis = Axis::nice(Some((min, max)), 5.0);
            assert!(is_nice(axis.step), "{min}..{max}: step {}", axis.step);
            assert!(axis.lo <= min && axis.hi >= max, "{min}..{max}: {axis:?}");
            let n = axis.ticks.len();
            assert!((4..=12).contains(&n), "{min}..{max}: {n} ticks");
            for t in &axis.ticks {
                let k = t / axis.step;
                assert!(
                    (k - k.round()).abs() < 1e-6,
                    "{t} not a multiple of {}",
                    axis.step
                );
            }
        }
    }

    #[test]
    fn degenerate_ranges_still_give_an_axis() {
        for range in [
            None,
            Some((0.0, 0.0)),
            Some((5.0, 5.0)),
            Some((-2e-300, -2e-300)),
            Some((f64::MAX, f64::MAX)),
            Some((f64::MIN, f64::MAX)),
            Some((1e16, 1e16 + 4.0)),
            Some((0.0, 5e-324)),
        ] {
            let axis = Axis::nice(range, 5.0);
            assert!(
                axis.lo.is_finite() && axis.hi.is_finite() && axis.lo < axis.hi,
                "{range:?}"
            );
            assert!(axis.ticks.len() >= 2 && axis.ticks.len() <= MAX_TICKS + 1);
            if let Some((min, max)) = range {
                assert!(axis.lo <= min && axis.hi >= max, "{range:?}: {axis:?}");
                assert!(axis.fraction(min).is_finite() && axis.fraction(max).is_finite());
            }
            for t in &axis.ticks {
                assert!(!axis.label(*t).contains("NaN"));
            }
        }
    }

    #[test]
    fn labels_use_the_digits_the_step_needs() {
        let axis = Axis::nice(Some((0.0, 1.0)), 5.0);
        let labels: Vec<String> = axis.ticks.iter().map(|t| axis.label(*t)).collect();
        assert_eq!(labels, ["0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        let axis = Axis::nice(Some((-40.0, 110.0)), 5.0);
        assert_eq!(axis.label(-50.0), "-50");
        let axis = Axis::nice(Some((0.0, 3e-6)), 5.0);
        assert_eq!(axis.label(1e-6), "1e-6");
        let axis = Axis::nice(Some((0.0, 1.2e-6)), 5.0);
        assert_eq!(axis.label(5e-7), "5.0e-7");
        let axis = Axis::nice(Some((0.0, 3e7)), 5.0);
        assert_eq!(axis.label(1e7), "1e7");
        assert_eq!(axis.label(-1e-20), "0");
    }
}
