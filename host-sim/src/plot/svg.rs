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
        d.push(if d.is_empty() { 'M' } else { 'L' });
        push_tenths(&mut d, x);
        d.push(' ');
        push_tenths(&mut d, y);
        d.push(' ');
    }
    d.truncate(d.trim_end().len());
    d
}

/// Below this magnitude `10 v` is within 2⁻¹³ of its exact value (half an ulp of 2⁴⁰).
const TENTHS_FAST_BELOW: f64 = 1e11;
/// How far from a half tenth `10 |v|` must be for its rounding to be that of the exact
/// value (far above the 2⁻¹³ the product may be off by).
const TENTHS_TIE_MARGIN: f64 = 1e-3;

/// Pushes `v` onto `out` as `{:.1}` writes it (the plots' pixel coordinates, thousands of
/// them per figure). `{:.1}` rounds the exact binary value to the nearest tenth; `10 |v|`
/// rounded to the nearest integer is that tenth unless `10 |v|` is within a rounding error
/// of a half: those, large and non-finite values are left to `write!`. The sign is
/// written for every negative value, zero included, as `{:.1}` writes it.
fn push_tenths(out: &mut String, v: f64) {
    let a = 10.0 * v.abs();
    // `a` is NaN for a NaN `v`: not fast.
    let fast = a < TENTHS_FAST_BELOW && (a - a.floor() - 0.5).abs() > TENTHS_TIE_MARGIN;
    if !fast {
        // Writing into a String cannot fail.
        let _ = write!(out, "{v:.1}");
        return;
    }
    let tenths = a.round() as u64;
    if v.is_sign_negative() {
        out.push('-');
    }
    let mut digits = [0u8; 20];
    let mut n = tenths / 10;
    let mut len = 0;
    loop {
        if let Some(d) = digits.get_mut(len) {
            *d = b'0' + (n % 10) as u8;
        }
        len += 1;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    for d in digits.iter().take(len).rev() {
        out.push(char::from(*d));
    }
    out.push('.');
    out.push(char::from(b'0' + (tenths % 10) as u8));
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

    /// `push_tenths` writes what `{:.1}` writes: ties and near-ties at every magnitude,
    /// signed zeros, the fast range's edge, non-finite values, 200 000 random values over
    /// 10⁻⁶..10¹⁴ (the fast range and beyond) and 200 000 random bit patterns below 2 in
    /// magnitude (tiny and subnormal values among them; larger ones print hundreds of
    /// digits through `format!`, too slow to test by the hundred thousand).
    #[test]
    fn tenths_are_written_as_the_standard_formatting_writes_them() {
        use rand::{Rng, SeedableRng};
        let check = |v: f64| {
            let mut got = String::new();
            push_tenths(&mut got, v);
            assert_eq!(got, format!("{v:.1}"), "{v:e} ({:#x})", v.to_bits());
        };
        for v in [
            0.0, -0.0, 0.04, -0.04, 0.05, -0.05, 0.25, 0.35, 0.45, 2.25, 1e11, -1e11,
        ] {
            check(v);
        }
        for v in [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN_POSITIVE,
        ] {
            check(v);
        }
        for k in -50_000i64..50_000 {
            let half = (k as f64 + 0.5) / 10.0;
            for v in [
                half,
                f64::from_bits(half.to_bits() + 1),
                f64::from_bits(half.to_bits() - 1),
            ] {
                check(v);
            }
            check(k as f64 / 20.0);
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        for _ in 0..200_000 {
            let v = rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-6..14));
            check(v);
            check(f64::from_bits(rng.gen::<u64>() & !(0x400 << 52)));
        }
    }

    #[test]
    fn shortens_long_text() {
        assert_eq!(shorten("abcdef", 4), "abc…");
        assert_eq!(shorten("abcd", 4), "abcd");
    }
}
