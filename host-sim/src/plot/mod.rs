//! Dependency-free SVG plots for engineering results: panels stacked
//! vertically over a shared x axis, each with solid series, dashed series
//! (e.g. truth) and shaded bands (e.g. ±3σ), nice 1-2-5 ticks and a legend.
//!
//! Robust to any data: non-finite points break lines and are never written,
//! empty or constant data still gives a readable axis, and series longer than
//! [`MAX_POINTS`](points::MAX_POINTS) are decimated by min/max bucketing so
//! files stay small.

mod points;
mod render;
mod svg;
mod ticks;

use std::path::Path;

/// A line drawn through `(x[i], y[i])`; if the lengths differ, the extra
/// values of the longer one are not drawn.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Abscissae (shared axis of the figure).
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
}

/// A shaded region between `lo[i]` and `hi[i]` at `x[i]`, e.g. an estimate ±3σ.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Band {
    /// Legend entry.
    pub name: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Lower edge.
    pub lo: Vec<f64>,
    /// Upper edge.
    pub hi: Vec<f64>,
}

/// One plot of a figure. Series, dashed series and bands with the same index
/// share a colour, so an estimate, its truth and its ±3σ band match.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Panel {
    /// Title above the plot.
    pub title: String,
    /// Label of the y axis, with its unit.
    pub y_label: String,
    /// Solid lines.
    pub series: Vec<Series>,
    /// Shaded bands, drawn under the lines.
    pub bands: Vec<Band>,
    /// Dashed lines, e.g. the truth.
    pub dashed: Vec<Series>,
}

/// A figure: a title, panels stacked vertically, one x axis shared by all.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Figure {
    /// Title at the top.
    pub title: String,
    /// Label of the shared x axis, with its unit.
    pub x_label: String,
    /// Panels, top to bottom.
    pub panels: Vec<Panel>,
}

impl Figure {
    /// The figure as a standalone SVG document.
    pub fn to_svg(&self) -> String {
        render::figure(self)
    }

    /// Writes the figure as an SVG file at `path`.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        std::fs::write(path, self.to_svg())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Checks that tags nest and close, and that `&` only starts an entity.
    fn assert_well_formed(svg: &str) {
        let mut stack: Vec<&str> = Vec::new();
        let mut rest = svg;
        while let Some(open) = rest.find('<') {
            let text = &rest[..open];
            for (i, _) in text.match_indices('&') {
                let entity = &text[i..];
                assert!(
                    ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"]
                        .iter()
                        .any(|e| entity.starts_with(e)),
                    "bare & in {text:?}"
                );
            }
            let close = rest[open..].find('>').expect("unclosed tag") + open;
            let tag = &rest[open + 1..close];
            assert!(!tag.contains('<'), "'<' inside tag {tag:?}");
            if let Some(name) = tag.strip_prefix('/') {
                assert_eq!(stack.pop(), Some(name.trim()), "mismatched </{name}>");
            } else if !tag.starts_with('?') && !tag.ends_with('/') {
                stack.push(tag.split_whitespace().next().unwrap_or(""));
            }
            rest = &rest[close + 1..];
        }
        assert!(stack.is_empty(), "unclosed: {stack:?}");
        assert!(svg.trim_end().ends_with("</svg>"));
    }

    /// Checks that no number in the document is NaN or infinite.
    fn assert_no_non_finite(svg: &str) {
        assert!(!svg.contains("NaN"), "NaN in output");
        assert!(!svg.contains("inf"), "inf in output");
    }

    fn series(name: &str, x: &[f64], y: impl Fn(f64) -> f64) -> Series {
        Series {
            name: name.into(),
            x: x.to_vec(),
            y: x.iter().map(|&t| y(t)).collect(),
        }
    }

    /// An example like a calibration report: estimates, truth and ±3σ bands.
    fn example() -> Figure {
        let t: Vec<f64> = (0..=6000).map(|i| f64::from(i) * 0.1).collect();
        let decay = |t: f64| 3.0 * (0.2 + 2.0 * (-t / 120.0).exp());
        let estimate = |k: f64| {
            move |t: f64| k * (1.0 - (-t / 80.0).exp()) + 0.3 * (t / 7.0).sin() * (-t / 150.0).exp()
        };
        let band = |k: f64| Band {
            name: format!("±3σ {}", ["x", "y", "z"][k as usize]),
            x: t.clone(),
            lo: t.iter().map(|&s| estimate(k)(s) - decay(s)).collect(),
            hi: t.iter().map(|&s| estimate(k)(s) + decay(s)).collect(),
        };
        let mut with_gap = series("θx (gap 200–230 s)", &t, |s| 0.4 * (s / 40.0).sin());
        for (s, y) in with_gap.x.iter().zip(with_gap.y.iter_mut()) {
            if (200.0..230.0).contains(s) {
                *y = f64::NAN;
            }
        }
        Figure {
            title: "Mounting misalignment μ & flexure <demo>".into(),
            x_label: "time (s)".into(),
            panels: vec![
                Panel {
                    title: "Misalignment estimate".into(),
                    y_label: "μ (mrad)".into(),
                    series: (0..3)
                        .map(|k| {
                            series(
                                &format!("μ{} estimate", ["x", "y", "z"][k]),
                                &t,
                                estimate(k as f64),
                            )
                        })
                        .collect(),
                    bands: (0..3).map(|k| band(k as f64)).collect(),
                    dashed: (0..3)
                        .map(|k| {
                            series(&format!("μ{} truth", ["x", "y", "z"][k]), &t, move |_| {
                                k as f64
                            })
                        })
                        .collect(),
                },
                Panel {
                    title: "Flexure angle".into(),
                    y_label: "θ (mrad)".into(),
                    series: vec![with_gap],
                    bands: vec![],
                    dashed: vec![series("constant", &t, |_| 0.25)],
                },
                Panel {
                    title: "Empty panel".into(),
                    y_label: "nothing".into(),
                    ..Panel::default()
                },
            ],
        }
    }

    #[test]
    fn example_renders_well_formed_and_small() {
        let fig = example();
        let svg = fig.to_svg();
        assert_well_formed(&svg);
        assert_no_non_finite(&svg);
        assert!(svg.contains("&lt;demo&gt;") && svg.contains("&amp;"));
        assert!(svg.len() < 600_000, "{} bytes", svg.len());
        let path = std::env::temp_dir().join("flexcal_plot_example.svg");
        fig.write(&path).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), svg);
    }

    #[test]
    fn long_series_are_decimated() {
        let t: Vec<f64> = (0..200_000).map(f64::from).collect();
        let fig = Figure {
            panels: vec![Panel {
                series: vec![series("noise", &t, |s| {
                    (s * 12.9898).sin() * 437.5453 % 1.0
                })],
                ..Panel::default()
            }],
            ..Figure::default()
        };
        let svg = fig.to_svg();
        assert_well_formed(&svg);
        let points = svg.matches(['M', 'L']).count();
        assert!(points <= points::MAX_POINTS + 10, "{points} points");
    }

    #[test]
    fn degenerate_figures_render() {
        let empty = Figure::default().to_svg();
        assert_well_formed(&empty);
        let constant = Figure {
            title: "constant".into(),
            x_label: "x".into(),
            panels: vec![Panel {
                series: vec![
                    series("c", &[1.0, 2.0, 3.0], |_| 5.0),
                    Series::default(),
                    Series {
                        name: "bad".into(),
                        x: vec![f64::NAN, 1.0],
                        y: vec![1.0, f64::INFINITY],
                    },
                ],
                bands: vec![Band {
                    name: "b".into(),
                    x: vec![0.0],
                    lo: vec![],
                    hi: vec![1.0],
                }],
                ..Panel::default()
            }],
        };
        let svg = constant.to_svg();
        assert_well_formed(&svg);
        assert_no_non_finite(&svg);
        let huge = Figure {
            panels: vec![Panel {
                series: vec![Series {
                    name: "h".into(),
                    x: vec![f64::MIN, f64::MAX],
                    y: vec![f64::MAX, f64::MIN],
                }],
                ..Panel::default()
            }],
            ..Figure::default()
        };
        let svg = huge.to_svg();
        assert_well_formed(&svg);
        assert_no_non_finite(&svg);
    }

    fn any_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f64>(),
            -10.0..10.0f64,
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(0.0)
        ]
    }

    fn any_series() -> impl Strategy<Value = Series> {
        (
            "[A-HJ-MO-Z<>&\" ]{0,12}",
            proptest::collection::vec((any_f64(), any_f64()), 0..40),
        )
            .prop_map(|(name, xy)| {
                let (x, y) = xy.into_iter().unzip();
                Series { name, x, y }
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn any_data_gives_well_formed_finite_svg(
            series in proptest::collection::vec(any_series(), 0..4),
            dashed in proptest::collection::vec(any_series(), 0..3),
            band in proptest::collection::vec((any_f64(), any_f64(), any_f64()), 0..30),
            title in "[A-HJ-MO-Z<>&\" ]{0,12}",
        ) {
            let (x, (lo, hi)): (Vec<f64>, (Vec<f64>, Vec<f64>)) =
                band.into_iter().map(|(a, b, c)| (a, (b, c))).unzip();
            let fig = Figure {
                title: title.clone(),
                x_label: title,
                panels: vec![Panel {
                    series,
                    dashed,
                    bands: vec![Band { name: "B".into(), x, lo, hi }],
                    ..Panel::default()
                }],
            };
            let svg = fig.to_svg();
            assert_well_formed(&svg);
            assert_no_non_finite(&svg);
        }
    }
}
