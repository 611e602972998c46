//! Reading one column of a plain CSV file as the series to identify.
//!
//! Format: a header line naming the columns, then one row per sample, comma separated;
//! blank lines and lines whose first non-blank character is `#` are ignored anywhere;
//! surrounding spaces and a trailing `\r` are ignored. Every cell of the chosen column must be
//! a finite number. Any departure is an error naming the file, the line and the column.

use std::path::Path;

/// A column read from a series file.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesColumn {
    /// The column's name as in the header.
    pub name: String,
    /// Its values, in file order.
    pub values: Vec<f64>,
}

/// Reads column `column` of the CSV file at `path`; with `column = None` the file must have
/// exactly one column.
pub fn read_series_csv(path: &Path, column: Option<&str>) -> Result<SeriesColumn, String> {
    let text = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let text =
        String::from_utf8(text).map_err(|e| format!("{}: not UTF-8 text ({e})", path.display()))?;
    parse_series_csv(&path.display().to_string(), &text, column)
}

/// Parses CSV `text` (named `origin` in errors); see [`read_series_csv`].
pub fn parse_series_csv(
    origin: &str,
    text: &str,
    column: Option<&str>,
) -> Result<SeriesColumn, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| {
            let t = l.trim();
            !t.is_empty() && !t.starts_with('#')
        });
    let (header_line, header) = lines
        .next()
        .ok_or_else(|| format!("{origin}: empty file (no header line)"))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    for (i, n) in names.iter().enumerate() {
        if n.is_empty() {
            return Err(format!(
                "{origin}, line {header_line}, column {}: empty column name in the header",
                i + 1
            ));
        }
        if names.iter().take(i).any(|m| m == n) {
            return Err(format!(
                "{origin}, line {header_line}, column {} ({n}): duplicate column name",
                i + 1
            ));
        }
    }
    let idx = match column {
        Some(c) => names.iter().position(|n| *n == c).ok_or_else(|| {
            format!(
                "{origin}, line {header_line}: no column `{c}` in the header (columns: {})",
                names.join(", ")
            )
        })?,
        None if names.len() == 1 => 0,
        None => {
            return Err(format!(
                "{origin}: {} columns ({}): choose one with --column",
                names.len(),
                names.join(", ")
            ))
        }
    };
    let name = names.get(idx).copied().unwrap_or_default().to_string();
    let mut values = Vec::new();
    for (line, row) in lines {
        let cells: Vec<&str> = row.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(format!(
                "{origin}, line {line}: {} fields, the header has {}",
                cells.len(),
                names.len()
            ));
        }
        let cell = cells.get(idx).copied().unwrap_or_default();
        let v: f64 = cell.parse().map_err(|_| {
            format!(
                "{origin}, line {line}, column {} ({name}): `{cell}` is not a number",
                idx + 1
            )
        })?;
        if !v.is_finite() {
            return Err(format!(
                "{origin}, line {line}, column {} ({name}): `{cell}` is not a finite number",
                idx + 1
            ));
        }
        values.push(v);
    }
    if values.is_empty() {
        return Err(format!("{origin}: no data rows after the header"));
    }
    Ok(SeriesColumn { name, values })
}
