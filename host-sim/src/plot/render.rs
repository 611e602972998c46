//! Layout and drawing of a [`Figure`] as SVG text.

use std::fmt::Write;

use super::points::{band_pieces, line_pieces};
use super::svg::{colour, escape, path_data, shorten};
use super::ticks::Axis;
use super::{Figure, Panel, Series};

/// Width of the whole figure, px.
const WIDTH: f64 = 960.0;
/// Left margin (y tick labels and y label), px.
const LEFT: f64 = 84.0;
/// Right margin, holding the legend, px.
const LEGEND_WIDTH: f64 = 196.0;
/// Height of the figure title strip, px.
const TITLE_HEIGHT: f64 = 40.0;
/// Height of a panel's title strip, px.
const PANEL_TITLE_HEIGHT: f64 = 24.0;
/// Height of a panel's plotting area, px.
const PLOT_HEIGHT: f64 = 200.0;
/// Space between panels, px.
const PANEL_GAP: f64 = 18.0;
/// Bottom margin (x tick labels and x label), px.
const BOTTOM: f64 = 54.0;
/// Height of one legend entry, px.
const LEGEND_LINE: f64 = 16.0;
/// Longest legend entry, characters.
const LEGEND_CHARS: usize = 22;

/// Rough number of tick intervals on the (wide) x axis.
const X_INTERVALS: f64 = 8.0;
/// Rough number of tick intervals on a (short) y axis.
const Y_INTERVALS: f64 = 5.0;
/// Dash pattern of dashed lines.
const DASH: &str = r#" stroke-dasharray="6 4""#;

/// Right end of the plotting areas, px.
const PLOT_RIGHT: f64 = WIDTH - LEGEND_WIDTH;

/// A line ready to draw: colour index, dashed or not, pieces in data units.
struct Line {
    colour: usize,
    dashed: bool,
    pieces: Vec<Vec<(f64, f64)>>,
}

/// A band ready to draw: colour index and pieces `(x, lo, hi)` in data units.
struct Shade {
    colour: usize,
    pieces: Vec<Vec<(f64, f64, f64)>>,
}

/// A panel's drawable content, after breaking at non-finite points and decimating.
struct Prepared {
    lines: Vec<Line>,
    shades: Vec<Shade>,
}

/// The drawable line of `s`.
fn line(colour: usize, dashed: bool, s: &Series) -> Line {
    Line {
        colour,
        dashed,
        pieces: line_pieces(&s.x, &s.y),
    }
}

impl Prepared {
    fn new(panel: &Panel) -> Self {
        let solid = panel
            .series
            .iter()
            .enumerate()
            .map(|(i, s)| line(i, false, s));
        let dashed = panel
            .dashed
            .iter()
            .enumerate()
            .map(|(i, s)| line(i, true, s));
        let shades = panel
            .bands
            .iter()
            .enumerate()
            .map(|(colour, b)| Shade {
                colour,
                pieces: band_pieces(&b.x, &b.lo, &b.hi),
            })
            .collect();
        Self {
            lines: solid.chain(dashed).collect(),
            shades,
        }
    }

    /// Every x drawn.
    fn xs(&self) -> impl Iterator<Item = f64> + '_ {
        let lines = self
            .lines
            .iter()
            .flat_map(|l| l.pieces.iter().flatten().map(|p| p.0));
        let shades = self
            .shades
            .iter()
            .flat_map(|s| s.pieces.iter().flatten().map(|p| p.0));
        lines.chain(shades)
    }

    /// Every y drawn.
    fn ys(&self) -> impl Iterator<Item = f64> + '_ {
        let lines = self
            .lines
            .iter()
            .flat_map(|l| l.pieces.iter().flatten().map(|p| p.1));
        let shades = self
            .shades
            .iter()
            .flat_map(|s| s.pieces.iter().flatten().flat_map(|p| [p.1, p.2]));
        lines.chain(shades)
    }
}

/// Smallest and largest of `values` (all finite), if any.
fn range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// Maps data values to pixels along one direction.
struct Scale<'a> {
    axis: &'a Axis,
    from: f64,
    to: f64,
}

impl Scale<'_> {
    fn px(&self, v: f64) -> f64 {
        self.from + self.axis.fraction(v) * (self.to - self.from)
    }
}

/// The SVG text of `fig`.
pub(super) fn figure(fig: &Figure) -> String {
    let prepared: Vec<Prepared> = fig.panels.iter().map(Prepared::new).collect();
    let x_axis = Axis::nice(range(prepared.iter().flat_map(Prepared::xs)), X_INTERVALS);
    let panel_pitch = PANEL_TITLE_HEIGHT + PLOT_HEIGHT + PANEL_GAP;
    let panels_height = match prepared.len() {
        0 => 0.0,
        n => n as f64 * panel_pitch - PANEL_GAP,
    };
    let height = TITLE_HEIGHT + panels_height + BOTTOM;

    let mut out = String::new();
    let o = &mut out;
    // Writing into a String cannot fail: results of write! are ignored below.
    let _ = writeln!(o, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" viewBox="0 0 {WIDTH} {height}" font-family="DejaVu Sans, Arial, sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        o,
        r#"<rect x="0" y="0" width="{WIDTH}" height="{height}" fill="white"/>"#
    );
    let _ = writeln!(
        o,
        r#"<text x="{:.1}" y="26" text-anchor="middle" font-size="16" font-weight="bold">{}</text>"#,
        (LEFT + PLOT_RIGHT) / 2.0,
        escape(&fig.title)
    );
    let mut bottom = TITLE_HEIGHT;
    for (k, (panel, data)) in fig.panels.iter().zip(&prepared).enumerate() {
        let top = TITLE_HEIGHT + k as f64 * panel_pitch + PANEL_TITLE_HEIGHT;
        draw_panel(o, panel, data, &x_axis, top);
        bottom = top + PLOT_HEIGHT;
    }
    draw_x_axis(o, &fig.x_label, &x_axis, bottom);
    let _ = writeln!(o, "</svg>");
    out
}

/// One panel whose plotting area starts at pixel row `top`.
fn draw_panel(o: &mut String, panel: &Panel, data: &Prepared, x_axis: &Axis, top: f64) {
    let y_axis = Axis::nice(range(data.ys()), Y_INTERVALS);
    let xs = Scale {
        axis: x_axis,
        from: LEFT,
        to: PLOT_RIGHT,
    };
    let ys = Scale {
        axis: &y_axis,
        from: top + PLOT_HEIGHT,
        to: top,
    };
    let _ = writeln!(o, "<g>");
    let _ = writeln!(
        o,
        r#"<text x="{LEFT}" y="{:.1}" font-size="13" font-weight="bold">{}</text>"#,
        top - 7.0,
        escape(&panel.title)
    );
    // Grid and tick labels.
    for &t in &x_axis.ticks {
        let x = xs.px(t);
        if x.is_finite() {
            let _ = writeln!(
                o,
                r##"<line x1="{x:.1}" y1="{top:.1}" x2="{x:.1}" y2="{:.1}" stroke="#e0e0e0"/>"##,
                top + PLOT_HEIGHT
            );
        }
    }
    for &t in &y_axis.ticks {
        let y = ys.px(t);
        if y.is_finite() {
            let _ = writeln!(
                o,
                r##"<line x1="{LEFT}" y1="{y:.1}" x2="{PLOT_RIGHT}" y2="{y:.1}" stroke="#e0e0e0"/>"##
            );
            let _ = writeln!(
                o,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
                LEFT - 6.0,
                y + 4.0,
                escape(&y_axis.label(t))
            );
        }
    }
    let _ = writeln!(
        o,
        r#"<text transform="translate(16 {:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
        top + PLOT_HEIGHT / 2.0,
        escape(&panel.y_label)
    );
    // Data: bands under lines.
    for shade in &data.shades {
        for piece in &shade.pieces {
            let upper = piece.iter().map(|p| (xs.px(p.0), ys.px(p.2)));
            let lower = piece.iter().rev().map(|p| (xs.px(p.0), ys.px(p.1)));
            let d = path_data(upper.chain(lower));
            if !d.is_empty() {
                let _ = writeln!(
                    o,
                    r#"<path d="{d} Z" fill="{}" fill-opacity="0.18" stroke="none"/>"#,
                    colour(shade.colour)
                );
            }
        }
    }
    for line in &data.lines {
        let dash = if line.dashed { DASH } else { "" };
        for piece in &line.pieces {
            let d = path_data(piece.iter().map(|p| (xs.px(p.0), ys.px(p.1))));
            if !d.is_empty() {
                let _ = writeln!(
                    o,
                    r#"<path d="{d}" fill="none" stroke="{}" stroke-width="1.3" stroke-linejoin="round"{dash}/>"#,
                    colour(line.colour)
                );
            }
        }
    }
    let _ = writeln!(
        o,
        r##"<rect x="{LEFT}" y="{top:.1}" width="{:.1}" height="{PLOT_HEIGHT}" fill="none" stroke="#444"/>"##,
        PLOT_RIGHT - LEFT
    );
    draw_legend(o, panel, top);
    let _ = writeln!(o, "</g>");
}

/// How a legend entry shows its item.
#[derive(Clone, Copy, PartialEq)]
enum Swatch {
    Solid,
    Dashed,
    Fill,
}

/// The legend of a panel, right of its plotting area; entries that do not fit
/// are summarised as "… N more".
fn draw_legend(o: &mut String, panel: &Panel, top: f64) {
    let mut entries: Vec<(usize, &str, Swatch)> = Vec::new();
    let solid = panel
        .series
        .iter()
        .map(|s| (s.name.as_str(), Swatch::Solid));
    let dashed = panel
        .dashed
        .iter()
        .map(|s| (s.name.as_str(), Swatch::Dashed));
    let bands = panel.bands.iter().map(|b| (b.name.as_str(), Swatch::Fill));
    for group in [solid.collect::<Vec<_>>(), dashed.collect(), bands.collect()] {
        entries.extend(
            group
                .into_iter()
                .enumerate()
                .map(|(i, (name, swatch))| (i, name, swatch)),
        );
    }
    let fits = (PLOT_HEIGHT / LEGEND_LINE) as usize;
    let shown = if entries.len() > fits {
        fits - 1
    } else {
        entries.len()
    };
    let x0 = PLOT_RIGHT + 14.0;
    for (row, &(i, name, swatch)) in entries.iter().take(shown).enumerate() {
        let y = top + 10.0 + row as f64 * LEGEND_LINE;
        let c = colour(i);
        let _ = match swatch {
            Swatch::Solid | Swatch::Dashed => {
                let dash = if swatch == Swatch::Dashed { DASH } else { "" };
                writeln!(
                    o,
                    r#"<line x1="{x0:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{c}" stroke-width="2"{dash}/>"#,
                    x0 + 22.0
                )
            }
            Swatch::Fill => writeln!(
                o,
                r#"<rect x="{x0:.1}" y="{:.1}" width="22" height="10" fill="{c}" fill-opacity="0.25"/>"#,
                y - 5.0
            ),
        };
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
            x0 + 28.0,
            y + 4.0,
            escape(&shorten(name, LEGEND_CHARS))
        );
    }
    if shown < entries.len() {
        let y = top + 10.0 + shown as f64 * LEGEND_LINE;
        let _ = writeln!(
            o,
            r#"<text x="{x0:.1}" y="{:.1}">… {} more</text>"#,
            y + 4.0,
            entries.len() - shown
        );
    }
}

/// Tick labels and label of the shared x axis, under the last panel (`bottom`).
fn draw_x_axis(o: &mut String, label: &str, axis: &Axis, bottom: f64) {
    let xs = Scale {
        axis,
        from: LEFT,
        to: PLOT_RIGHT,
    };
    for &t in &axis.ticks {
        let x = xs.px(t);
        if x.is_finite() {
            let _ = writeln!(
                o,
                r#"<text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
                bottom + 16.0,
                escape(&axis.label(t))
            );
        }
    }
    let _ = writeln!(
        o,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
        (LEFT + PLOT_RIGHT) / 2.0,
        bottom + 40.0,
        escape(label)
    );
}
