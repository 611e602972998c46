//! Small SVG text helpers: escaping, coordinates, colours, path data.

use std::fmt::Write;

/// Line colours, cycled by index (series `i`, dashed `i` and band `i` share one).
const PALETTE: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];

/// The colour of the `i`-th series, dashed series or band of a panel.
pub(super) fn colour(i: usize) -> &'static str {
    PALETTE.get(i % PALETTE.len()).copied().unwrap_or("#000000")
}

/// `text` escaped for SVG text content and attribute values.
pub(super) fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // XML 1.0 allows no other control characters.
            c if c.is_control() && !matches!(c, '\t' | '\n' | '\r') => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// `text` cut to at most `max` characters, marked with an ellipsis if cut.
pub(super) fn shorten(text: &str, max: usize) -> String {
    let mut chars = text.chars();
    let head: String = chars.by_ref().take(max).collect();
    if chars.next().is_some() {
        format!(
            "{}…",
            head.chars().take(max.saturating_sub(1)).collect::<String>()
        )
    } else {
        head
    }
}

/// Path data `M x y L x y ...` of pixel points; non-finite points are left out.
pub(super) fn path_data(points: impl IntoIterator<Item = (f64, f64)>) -> String {
    let mut d = String::new();
    for (x, y) in points
        .into_iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
    {
        let command = if d.is_empty() { 'M' } else { 'L' };
        // Writing into a String cannot fail.
        let _ = write!(d, "{command}{x:.1} {y:.1} ");
    }
    d.truncate(d.trim_end().len());
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup_and_control_characters() {
        assert_eq!(
            escape("a<b & \"c\" 'd'>\u{1}"),
            "a&lt;b &amp; &quot;c&quot; &apos;d&apos;&gt; "
        );
    }

    #[test]
    fn path_skips_non_finite_points() {
        let d = path_data([(0.0, 1.0), (f64::NAN, 2.0), (2.26, 3.0)]);
        assert_eq!(d, "M0.0 1.0 L2.3 3.0");
    }

    #[test]
    fn shortens_long_text() {
        assert_eq!(shorten("abcdef", 4), "abc…");
        assert_eq!(shorten("abcd", 4), "abcd");
    }
}
