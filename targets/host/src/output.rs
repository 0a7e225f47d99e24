//! Writing a [`Trace`] as CSV (header row `t, q0.., qd0.., x0.., u0.., f0.., xp0.., xh0.., tr`)
//! with the `csv` crate and a sidecar `NAME.columns.md` saying what each column holds, in which
//! unit, and the one place negative zeros become `0.0` in what the tools print
//! ([`unsigned_zero`], and [`to_json`] through it).

use std::path::Path;

use crate::closed_loop::Trace;

/// What a trace column holds, with its unit, by its name (`t`, `q0`, `xp2`, `tr`…); `None` for a
/// name no trace writes.
pub fn column_meaning(name: &str) -> Option<String> {
    if name == "t" {
        return Some("time since the start, s".into());
    }
    if name == "tr" {
        return Some(
            "when the proxy (`xp*`) was last rendered, s (moving solids were where their motion had taken them then)"
                .into(),
        );
    }
    let split = name.find(|c: char| c.is_ascii_digit())?;
    let (prefix, index) = name.split_at(split);
    let k: usize = index.parse().ok()?;
    let meaning = match prefix {
        "q" => format!("joint {k}'s coordinate, rad (revolute) or m (prismatic)"),
        "qd" => format!("joint {k}'s velocity, rad/s (revolute) or m/s (prismatic)"),
        "x" => format!("task coordinate {k} of the device, m (rad for an angular task coordinate)"),
        "u" => format!("joint {k}'s commanded torque, N·m (revolute) or force, N (prismatic), after limiting"),
        "f" => format!(
            "the operator's force on task coordinate {k} (f_op), N (N·m for an angular task coordinate)"
        ),
        "xp" => format!(
            "task coordinate {k} of the proxy (the rendered reference), m (rad for an angular task coordinate)"
        ),
        "xh" => format!(
            "task coordinate {k} of the HIP the proxy was rendered for (the device as the controller measured it), m (rad for an angular task coordinate)"
        ),
        _ => return None,
    };
    Some(meaning)
}

/// The sidecar of a trace written to `path`: `trace.csv` → `trace.columns.md`.
pub fn columns_path(path: &Path) -> std::path::PathBuf {
    let stem = path.file_stem().map_or_else(|| "trace".into(), |s| s.to_string_lossy().into_owned());
    path.with_file_name(format!("{stem}.columns.md"))
}

/// The sidecar's text: one row per column of `trace`, its name, meaning and unit.
pub fn columns_text(trace: &Trace) -> String {
    let mut text = String::from(
        "# Columns of the trace\n\nOne row per sample; numbers in SI units. Written by hapticgen next to the CSV.\n\n| column | meaning, unit |\n| --- | --- |\n",
    );
    for name in &trace.columns {
        let meaning = column_meaning(name).unwrap_or_else(|| "(not documented)".into());
        text.push_str(&format!("| `{name}` | {meaning} |\n"));
    }
    text
}

/// Writes `trace` to `path` as CSV, and its columns' meanings and units next to it
/// ([`columns_path`], [`columns_text`]).
pub fn write_csv(trace: &Trace, path: &Path) -> Result<(), String> {
    let fail = |e: &dyn std::fmt::Display| format!("error: cannot write {}: {e}", path.display());
    let sidecar = columns_path(path);
    std::fs::write(&sidecar, columns_text(trace))
        .map_err(|e| format!("error: cannot write {}: {e}", sidecar.display()))?;
    let mut writer = csv::Writer::from_path(path).map_err(|e| fail(&e))?;
    writer.write_record(&trace.columns).map_err(|e| fail(&e))?;
    for row in &trace.rows {
        writer
            .write_record(row.iter().map(|v| format!("{:.9e}", unsigned_zero(*v))))
            .map_err(|e| fail(&e))?;
    }
    writer.flush().map_err(|e| fail(&e))
}

/// `x`, with a negative zero made positive: printed numbers never read `-0.0` (every other value,
/// NaN included, unchanged).
/// Generic over `f32` and `f64` (a float's `Default` is its positive zero).
pub fn unsigned_zero<F: Copy + PartialEq + Default>(x: F) -> F {
    if x == F::default() {
        F::default()
    } else {
        x
    }
}

/// A number for a model file: rounded to `significant` digits, the shortest text that reads
/// back as that, always with a decimal point or an exponent (YAML reads it as a float), plain
/// between 1e-3 and 1e6.
pub fn yaml_number(x: f64, significant: usize) -> String {
    let rounded: f64 = format!("{x:.*e}", significant.max(1) - 1).parse().unwrap_or(x);
    if rounded == 0.0 {
        "0.0".into()
    } else if (1e-3..1e6).contains(&rounded.abs()) {
        let text = format!("{rounded}");
        if text.contains('.') {
            text
        } else {
            format!("{text}.0")
        }
    } else {
        format!("{rounded:e}")
    }
}

/// `value` as JSON (indented if `pretty`), every number through [`unsigned_zero`] and the keys in
/// their declared order (`eval`, `summary.json`).
pub fn to_json(value: &impl serde::Serialize, pretty: bool) -> Result<String, String> {
    let mut out = Vec::new();
    let result = if pretty {
        value.serialize(&mut serde_json::Serializer::with_formatter(
            &mut out,
            UnsignedZeros(serde_json::ser::PrettyFormatter::new()),
        ))
    } else {
        value.serialize(&mut serde_json::Serializer::with_formatter(
            &mut out,
            UnsignedZeros(serde_json::ser::CompactFormatter),
        ))
    };
    result.map_err(|e| e.to_string())?;
    String::from_utf8(out).map_err(|e| e.to_string())
}

/// A JSON formatter that writes floats through [`unsigned_zero`] and leaves everything else to
/// the one it wraps.
struct UnsignedZeros<F>(F);

impl<F: serde_json::ser::Formatter> serde_json::ser::Formatter for UnsignedZeros<F> {
    fn write_f32<W: ?Sized + std::io::Write>(&mut self, writer: &mut W, value: f32) -> std::io::Result<()> {
        self.0.write_f32(writer, unsigned_zero(value))
    }
    fn write_f64<W: ?Sized + std::io::Write>(&mut self, writer: &mut W, value: f64) -> std::io::Result<()> {
        self.0.write_f64(writer, unsigned_zero(value))
    }
    fn begin_array<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.0.begin_array(writer)
    }
    fn end_array<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.0.end_array(writer)
    }
    fn begin_array_value<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
        first: bool,
    ) -> std::io::Result<()> {
        self.0.begin_array_value(writer, first)
    }
    fn end_array_value<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.0.end_array_value(writer)
    }
    fn begin_object<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.0.begin_object(writer)
    }
    fn end_object<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.0.end_object(writer)
    }
    fn begin_object_key<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
        first: bool,
    ) -> std::io::Result<()> {
        self.0.begin_object_key(writer, first)
    }
    fn end_object_key<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.0.end_object_key(writer)
    }
    fn begin_object_value<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.0.begin_object_value(writer)
    }
    fn end_object_value<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.0.end_object_value(writer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every column the simulator writes is documented with a unit.
    #[test]
    fn every_trace_column_is_documented() {
        let mut columns = vec!["t".to_string()];
        for prefix in ["q", "qd", "x", "u", "f", "xp", "xh"] {
            columns.extend((0..6).map(|k| format!("{prefix}{k}")));
        }
        columns.push("tr".into());
        let trace = Trace { columns, ..Trace::default() };
        let text = columns_text(&trace);
        for name in &trace.columns {
            let meaning = column_meaning(name).unwrap_or_else(|| panic!("`{name}` undocumented"));
            assert!(
                [", s", " m", "rad", " N"].iter().any(|unit| meaning.contains(unit)),
                "{name}: {meaning}"
            );
            assert!(text.contains(&format!("| `{name}` | {meaning} |")), "{text}");
        }
        assert!(!text.contains("not documented"));
        assert_eq!(column_meaning("z0"), None);
        assert_eq!(columns_path(Path::new("out/trace.csv")), Path::new("out/trace.columns.md"));
    }

    #[test]
    fn negative_zeros_print_as_zero() {
        assert_eq!(format!("{}", unsigned_zero(-0.0_f64)), "0");
        assert_eq!(format!("{}", unsigned_zero(-0.0_f32)), "0");
        assert_eq!(format!("{:.1}", unsigned_zero(-1.5_f64)), "-1.5");
        assert!(unsigned_zero(f64::NAN).is_nan());
        let value = serde_json::json!({"b": [-0.0, 1.0], "a": {"x": -0.0}});
        assert_eq!(to_json(&value, false).as_deref(), Ok(r#"{"a":{"x":0.0},"b":[0.0,1.0]}"#));
        assert!(!to_json(&value, true).unwrap_or_default().contains("-0"));
    }
}
