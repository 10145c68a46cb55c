//! Placeholders in figure titles and series labels: titles and series labels quote the data instead of hard-coding what a
//! run happens to contain ([`fill`]): `{range:COLUMN}` becomes the range of
//! the column's numbers ("1–4", or "4" when all are equal), `{COLUMN}` its
//! distinct values ("1, 2, 4"), and `{COLUMN#N}` the distinct values of
//! field N of each cell split at `:` (`{sampler#1}` of `adaptive:0.2:2` is
//! `0.2`). A title reads the figure's rows, a series label that series'
//! rows, so a quick run's figure says what the quick run measured.

use super::number;
use crate::experiment::data::Table;
use crate::Error;

/// `text` with its placeholders (see the module docs) filled from `rows`
/// of `table`. An error names a placeholder whose column `table` lacks, or
/// a range over a column without numbers.
pub fn fill(text: &str, table: &Table, rows: &[&Vec<String>]) -> Result<String, Error> {
    let mut out = String::new();
    let mut rest = text;
    while let Some(open) = rest.find('{') {
        let Some(len) = rest[open..].find('}') else {
            break;
        };
        out.push_str(&rest[..open]);
        let inner = &rest[open + 1..open + len];
        rest = &rest[open + len + 1..];
        let problem = |message: String| Error::Placeholder {
            placeholder: inner.to_string(),
            message,
        };
        let (range, name) = match inner.strip_prefix("range:") {
            Some(n) => (true, n),
            None => (false, inner),
        };
        let (name, field) = match name.split_once('#') {
            Some((n, f)) => (
                n,
                Some(
                    f.parse::<usize>()
                        .map_err(|_| problem(format!("`{f}` is not a field number")))?,
                ),
            ),
            None => (name, None),
        };
        let col = table
            .column(name)
            .ok_or_else(|| problem(format!("data.csv has no column `{name}`")))?;
        let cells: Vec<&str> = rows
            .iter()
            .map(|r| match field {
                Some(f) => r[col].split(':').nth(f).unwrap_or(""),
                None => r[col].as_str(),
            })
            .filter(|c| !c.trim().is_empty())
            .collect();
        if range {
            let nums: Vec<f64> = cells
                .iter()
                .map(|c| number(c))
                .filter(|v| v.is_finite())
                .collect();
            let lo = nums.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = nums.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if nums.is_empty() {
                return Err(problem(format!(
                    "column `{name}` has no numbers in these rows"
                )));
            }
            if lo == hi {
                out.push_str(&format!("{lo}"));
            } else {
                out.push_str(&format!("{lo}–{hi}"));
            }
        } else {
            let mut distinct: Vec<&str> = Vec::new();
            for c in cells {
                if !distinct.contains(&c) {
                    distinct.push(c);
                }
            }
            if distinct.iter().all(|c| number(c).is_finite()) {
                distinct.sort_by(|a, b| number(a).total_cmp(&number(b)));
            }
            out.push_str(&distinct.join(", "));
        }
    }
    out.push_str(rest);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::{fill, Table};

    #[test]
    fn titles_and_labels_quote_the_data() {
        let table = Table {
            columns: vec!["spp".to_string(), "sampler".to_string()],
            rows: [
                ["4", "adaptive:0.2:2"],
                ["1", "adaptive:0.05:2"],
                ["2", "adaptive:0.05:2"],
            ]
            .iter()
            .map(|r| r.iter().map(|c| c.to_string()).collect())
            .collect(),
        };
        let rows: Vec<&Vec<String>> = table.rows.iter().collect();
        let f = |t: &str| fill(t, &table, &rows);
        assert_eq!(f("MSE ({range:spp} spp)").unwrap(), "MSE (1–4 spp)");
        assert_eq!(f("at {spp} spp").unwrap(), "at 1, 2, 4 spp");
        assert_eq!(f("thresholds {sampler#1}").unwrap(), "thresholds 0.05, 0.2");
        assert_eq!(f("no placeholder").unwrap(), "no placeholder");
        assert_eq!(f("{range:spp}").unwrap(), "1–4");
        let one = vec![&table.rows[0]];
        assert_eq!(fill("{range:spp} spp", &table, &one).unwrap(), "4 spp");
        assert!(f("{nope}")
            .unwrap_err()
            .to_string()
            .contains("no column `nope`"));
        assert!(f("{range:sampler}").is_err());
    }
}
