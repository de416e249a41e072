//! A sweep's results: the run table as CSV and Parquet, the report (statistics per controller,
//! limit shares, worst-case map) and the plot of each controller's empirical CDF.

use crate::cosim::{err, MasterError};
use crate::report::significant;
use crate::sweep::{metric_values, Outcome, Row, Sweep, METRICS};
use parquet::basic::{LogicalType, Repetition, Type as Physical};
const OPTIONAL: Repetition = Repetition::OPTIONAL;
const REQUIRED: Repetition = Repetition::REQUIRED;
use parquet::data_type::{BoolType, ByteArray, ByteArrayType, DoubleType, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;

/// A swept value as a number (Booleans as 0/1).
fn number(v: &Value) -> f64 {
    v.as_f64()
        .or_else(|| v.as_bool().map(|b| b as u8 as f64))
        .unwrap_or(f64::NAN)
}

/// A column of the run table; [`columns`] gives their order, the one place it is written.
#[derive(Debug, Clone, Copy)]
enum Column {
    Run,
    Point,
    Controller,
    /// The `i`-th swept parameter.
    Swept(usize),
    Status,
    Message,
    /// What the FMUs warned of, `; `-separated.
    Warnings,
    /// The `m`-th of [`METRICS`].
    Metric(usize),
    StrokeExceeded,
    TyreLiftOff,
    /// The largest share of the time a wheel is off the road.
    AirborneShare,
    /// The largest share of the time a corner or the seat is on a stop.
    StopShare,
    SaturatedShare,
    LoopSeconds,
}

/// One cell: what CSV prints and Parquet stores. `None` is a failed run's missing figure.
enum Cell<'a> {
    Int(i64),
    Text(String),
    /// A swept value: its JSON text in CSV, a number in Parquet.
    Swept(&'a Value),
    Real(Option<f64>),
    Bool(Option<bool>),
}

fn columns(parameters: usize) -> Vec<Column> {
    use Column::*;
    let mut c = vec![Run, Point, Controller];
    c.extend((0..parameters).map(Swept));
    c.extend([Status, Message, Warnings]);
    c.extend((0..METRICS.len()).map(Metric));
    c.extend([
        StrokeExceeded,
        TyreLiftOff,
        AirborneShare,
        StopShare,
        SaturatedShare,
        LoopSeconds,
    ]);
    c
}

impl Column {
    fn name(self, names: &[String]) -> String {
        match self {
            Column::Run => "run".into(),
            Column::Point => "point".into(),
            Column::Controller => "controller".into(),
            Column::Swept(i) => names[i].clone(),
            Column::Status => "status".into(),
            Column::Message => "message".into(),
            Column::Warnings => "warnings".into(),
            Column::Metric(m) => METRICS[m].into(),
            Column::StrokeExceeded => "stroke_exceeded".into(),
            Column::TyreLiftOff => "tyre_lift_off".into(),
            Column::AirborneShare => "airborne_share".into(),
            Column::StopShare => "stop_share".into(),
            Column::SaturatedShare => "saturated_share".into(),
            Column::LoopSeconds => "loop_seconds".into(),
        }
    }

    fn cell(self, r: &Row) -> Cell<'_> {
        let done = r.outcome.finished();
        match self {
            Column::Run => Cell::Int(r.job.run as i64),
            Column::Point => Cell::Int(r.job.point as i64),
            Column::Controller => Cell::Text(r.job.controller_name().into()),
            Column::Swept(i) => Cell::Swept(&r.job.values[i]),
            Column::Status => Cell::Text(if done.is_some() { "ok" } else { "failed" }.into()),
            Column::Message => Cell::Text(match &r.outcome {
                Outcome::Ok(..) => String::new(),
                Outcome::Failed(m) => m.clone(),
            }),
            Column::Warnings => Cell::Text(r.warnings.join("; ")),
            Column::Metric(m) => Cell::Real(done.map(|f| metric_values(f)[m])),
            Column::StrokeExceeded => Cell::Bool(done.map(|f| f.flags.stroke_exceeded)),
            Column::TyreLiftOff => Cell::Bool(done.map(|f| f.flags.tyre_lift_off)),
            Column::AirborneShare => Cell::Real(done.map(|f| largest(&f.flags.airborne))),
            Column::StopShare => Cell::Real(done.map(|f| largest(&f.flags.at_stop))),
            Column::SaturatedShare => Cell::Real(done.map(|f| f.flags.saturated_share)),
            Column::LoopSeconds => Cell::Real(Some(r.loop_seconds)),
        }
    }

    /// The Parquet type: metrics and flags are null for a failed run.
    fn parquet(self) -> (Physical, Repetition) {
        match self {
            Column::Run | Column::Point => (Physical::INT64, REQUIRED),
            Column::Controller | Column::Status | Column::Message | Column::Warnings => {
                (Physical::BYTE_ARRAY, REQUIRED)
            }
            Column::Swept(_) | Column::LoopSeconds => (Physical::DOUBLE, REQUIRED),
            Column::Metric(_)
            | Column::SaturatedShare
            | Column::AirborneShare
            | Column::StopShare => (Physical::DOUBLE, OPTIONAL),
            Column::StrokeExceeded | Column::TyreLiftOff => (Physical::BOOLEAN, OPTIONAL),
        }
    }
}

fn largest(shares: &[f64]) -> f64 {
    shares.iter().copied().fold(0.0, f64::max)
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

impl Cell<'_> {
    fn csv(&self) -> String {
        match self {
            Cell::Int(i) => i.to_string(),
            Cell::Text(t) => csv_field(t),
            Cell::Swept(v) => csv_field(&v.to_string()),
            Cell::Real(Some(x)) => format!("{x:e}"),
            Cell::Bool(Some(b)) => b.to_string(),
            Cell::Real(None) | Cell::Bool(None) => String::new(),
        }
    }
}

/// The rows as CSV: one line per run; a failed run's metrics are empty.
pub fn csv(names: &[String], rows: &[Row]) -> String {
    let cols = columns(names.len());
    let line = |cells: Vec<String>| cells.join(",") + "\n";
    let mut s = line(cols.iter().map(|c| c.name(names)).collect());
    for r in rows {
        s += &line(cols.iter().map(|c| c.cell(r).csv()).collect());
    }
    s
}

/// The rows as one Parquet row group, the columns of `columns` typed by `Column::parquet`:
/// `run`, `point` INT64; `controller`, `status`, `message`, `warnings` UTF-8; the swept values and
/// `loop_seconds` DOUBLE; the metrics and `saturated_share` optional DOUBLE and the two flags
/// optional BOOLEAN (null for a failed run).
pub fn write_parquet(path: &Path, names: &[String], rows: &[Row]) -> Result<(), MasterError> {
    let e = |x: parquet::errors::ParquetError| err(format!("{}: {x}", path.display()));
    let cols = columns(names.len());
    let fields = cols
        .iter()
        .map(|c| {
            let (physical, repetition) = c.parquet();
            let name = c.name(names);
            let mut b = Type::primitive_type_builder(&name, physical).with_repetition(repetition);
            if physical == Physical::BYTE_ARRAY {
                b = b.with_logical_type(Some(LogicalType::String));
            }
            b.build().map(Arc::new)
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(e)?;
    let schema = Arc::new(
        Type::group_type_builder("sweep")
            .with_fields(fields)
            .build()
            .map_err(e)?,
    );
    let file = std::fs::File::create(path)
        .map_err(|x| err(format!("cannot write {}: {x}", path.display())))?;
    let mut writer =
        SerializedFileWriter::new(file, schema, Arc::new(WriterProperties::builder().build()))
            .map_err(e)?;
    let mut group = writer.next_row_group().map_err(e)?;
    for c in &cols {
        let mut col = group
            .next_column()
            .map_err(e)?
            .expect("one column writer per field of the schema");
        let cells: Vec<Cell> = rows.iter().map(|r| c.cell(r)).collect();
        let optional = c.parquet().1 == OPTIONAL;
        let definition: Vec<i16> = cells
            .iter()
            .map(|x| !matches!(x, Cell::Real(None) | Cell::Bool(None)) as i16)
            .collect();
        let levels = optional.then_some(definition.as_slice());
        match c.parquet().0 {
            Physical::INT64 => {
                let v: Vec<i64> = cells
                    .iter()
                    .filter_map(|x| match x {
                        Cell::Int(i) => Some(*i),
                        _ => None,
                    })
                    .collect();
                col.typed::<Int64Type>().write_batch(&v, levels, None)
            }
            Physical::BYTE_ARRAY => {
                let v: Vec<ByteArray> = cells
                    .iter()
                    .filter_map(|x| match x {
                        Cell::Text(t) => Some(ByteArray::from(t.as_str())),
                        _ => None,
                    })
                    .collect();
                col.typed::<ByteArrayType>().write_batch(&v, levels, None)
            }
            Physical::BOOLEAN => {
                let v: Vec<bool> = cells
                    .iter()
                    .filter_map(|x| match x {
                        Cell::Bool(b) => *b,
                        _ => None,
                    })
                    .collect();
                col.typed::<BoolType>().write_batch(&v, levels, None)
            }
            _ => {
                let v: Vec<f64> = cells
                    .iter()
                    .filter_map(|x| match x {
                        Cell::Swept(v) => Some(number(v)),
                        Cell::Real(r) => *r,
                        _ => None,
                    })
                    .collect();
                col.typed::<DoubleType>().write_batch(&v, levels, None)
            }
        }
        .map_err(e)?;
        col.close().map_err(e)?;
    }
    group.close().map_err(e)?;
    writer.close().map_err(e)?;
    Ok(())
}

/// `(mean, median, p95, worst)` of values (p95 by nearest rank).
pub fn statistics(values: &[f64]) -> Option<[f64; 4]> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let median = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    let p95 = v[((0.95 * n as f64).ceil() as usize).clamp(1, n) - 1];
    Some([v.iter().sum::<f64>() / n as f64, median, p95, v[n - 1]])
}

/// The cells of one map axis: each distinct value when there are at most 8, else 6 equal bins
/// of the range. `(labels, cell of each value)`.
fn axis(values: &[f64]) -> (Vec<String>, Vec<usize>) {
    let mut distinct: Vec<f64> = values.to_vec();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    if distinct.len() <= 8 {
        let cell = values
            .iter()
            .map(|v| distinct.iter().position(|d| d == v).unwrap_or(0))
            .collect();
        return (distinct.iter().map(|d| format!("{d}")).collect(), cell);
    }
    let (lo, hi) = (distinct[0], distinct[distinct.len() - 1]);
    let bins = 6;
    let width = (hi - lo) / bins as f64;
    let cell = values
        .iter()
        .map(|v| (((v - lo) / width) as usize).min(bins - 1))
        .collect();
    let labels = (0..bins)
        .map(|b| {
            format!(
                "{:.4}–{:.4}",
                lo + width * b as f64,
                lo + width * (b + 1) as f64
            )
        })
        .collect();
    (labels, cell)
}

/// The report: the sweep, then per controller the share of failed and limit-breaking runs and
/// each metric's mean, median, p95 and worst; the worst W_k seat over a map of two parameters
/// (`map`, [`WorstMap::new`] of the same rows, which `map.svg` draws too).
pub fn report(sweep: &Sweep, rows: &[Row], map: Option<&WorstMap>, wall_seconds: f64) -> String {
    let s = &sweep.spec;
    let mut t = format!(
        "# Sweep `{}`\n\n{}\n\nBase scenario `{}` ({}), {} runs: {} parameter points × {} controllers, in {:.1} s wall time (`master sweep`). Every point is run with every controller. Rows in `runs.csv` and `runs.parquet`.\n\n",
        s.name,
        s.description,
        sweep.base.name,
        sweep.base.description,
        rows.len(),
        rows.len() / s.controllers.len().max(1),
        s.controllers.len(),
        wall_seconds,
    );
    let draws = match (s.samples, s.latin_hypercube) {
        (Some(n), true) => format!("{n} Latin-hypercube draws (seed {})", s.seed),
        (Some(n), false) => format!("{n} random draws (seed {})", s.seed),
        (None, _) => "grids only".into(),
    };
    writeln!(
        t,
        "Parameters ({draws}; the same draws at every grid point):\n"
    )
    .unwrap();
    t += "| parameter | swept as |\n|---|---|\n";
    for (n, d) in &s.parameters {
        writeln!(t, "| `{n}` | {d} |").unwrap();
    }
    t += "\n## Limits and failures (share of runs)\n\n";
    writeln!(
        t,
        "| controller | runs | failed | stroke > {} m | tyre lift-off | saturated at any time | mean time saturated | an FMU warned |\n|---|---|---|---|---|---|---|---|",
        sweep.base.stroke_max
    )
    .unwrap();
    let share = |k: usize, n: usize| format!("{:.1} %", 100.0 * k as f64 / n.max(1) as f64);
    for c in &s.controllers {
        let mine: Vec<&Row> = rows
            .iter()
            .filter(|r| r.job.controller_name() == c)
            .collect();
        let n = mine.len();
        let flags: Vec<_> = mine
            .iter()
            .filter_map(|r| r.outcome.finished().map(|f| f.flags))
            .collect();
        let count =
            |p: &dyn Fn(&crate::report::Flags) -> bool| flags.iter().filter(|f| p(f)).count();
        let mean_sat =
            flags.iter().fold(0.0, |a, f| a + f.saturated_share) / flags.len().max(1) as f64;
        writeln!(
            t,
            "| `{c}` | {n} | {} | {} | {} | {} | {:.2} % | {} |",
            share(n - flags.len(), n),
            share(count(&|f| f.stroke_exceeded), n),
            share(count(&|f| f.tyre_lift_off), n),
            share(count(&|f| f.saturated_share > 0.0), n),
            100.0 * mean_sat,
            share(mine.iter().filter(|r| !r.warnings.is_empty()).count(), n)
        )
        .unwrap();
    }
    // Each distinct warning once, with how many runs gave it.
    let mut warned: Vec<(&str, usize)> = Vec::new();
    for w in rows.iter().flat_map(|r| &r.warnings) {
        match warned.iter_mut().find(|(m, _)| *m == w.as_str()) {
            Some((_, k)) => *k += 1,
            None => warned.push((w, 1)),
        }
    }
    if !warned.is_empty() {
        t +=
            "\nWarnings of the FMUs (each distinct message, first 10, with its count of runs):\n\n";
        for (m, k) in warned.iter().take(10) {
            writeln!(t, "- {k} × {m}").unwrap();
        }
    }
    let failures: Vec<&Row> = rows
        .iter()
        .filter(|r| r.outcome.finished().is_none())
        .collect();
    if !failures.is_empty() {
        t += "\nFailed runs (first 10):\n\n";
        for r in failures.iter().take(10) {
            if let Outcome::Failed(m) = &r.outcome {
                writeln!(
                    t,
                    "- run {} (`{}`): {m}",
                    r.job.run,
                    r.job.controller_name()
                )
                .unwrap();
            }
        }
    }
    t += "\n## Metrics over the runs that finished: mean / median / p95 / worst\n\n";
    t += "| controller |";
    for m in METRICS {
        write!(t, " {m} |").unwrap();
    }
    t += "\n|---|";
    t += &"---|".repeat(METRICS.len());
    t.push('\n');
    for c in &s.controllers {
        write!(t, "| `{c}` |").unwrap();
        let figs: Vec<[f64; 10]> = rows
            .iter()
            .filter(|r| r.job.controller_name() == c)
            .filter_map(|r| r.outcome.finished().map(metric_values))
            .collect();
        for m in 0..METRICS.len() {
            let v: Vec<f64> = figs.iter().map(|f| f[m]).collect();
            match statistics(&v) {
                Some([mean, med, p95, worst]) => {
                    write!(t, " {mean:.4} / {med:.4} / {p95:.4} / {worst:.4} |").unwrap()
                }
                None => t += " - |",
            }
        }
        t.push('\n');
    }
    t += "\n![W_k RMS seat acceleration: empirical CDF per controller](cdf.svg)\n";
    if let Some(map) = map {
        writeln!(
            t,
            "\n## Worst W_k RMS seat acceleration [m/s²] over `{}` (rows) × `{}` (columns)\n\n`failed` where a run of the cell failed (instability or FMU error).\n\n![Worst W_k RMS seat acceleration per cell, one panel per controller](map.svg)\n",
            map.rows_name, map.columns_name
        )
        .unwrap();
        for (c, cells) in &map.panels {
            writeln!(t, "\n**`{c}`**\n").unwrap();
            t += &format!("| {} \\ {} |", map.rows_name, map.columns_name);
            for l in &map.columns {
                write!(t, " {l} |").unwrap();
            }
            t += "\n|---|";
            t += &"---|".repeat(map.columns.len());
            t.push('\n');
            for (l, row) in map.rows.iter().zip(cells) {
                write!(t, "| {l} |").unwrap();
                for cell in row {
                    t += &match cell {
                        MapCell::Empty => " |".to_string(),
                        MapCell::Failed => " failed |".to_string(),
                        MapCell::Worst(w) => format!(" {w:.4} |"),
                    };
                }
                t.push('\n');
            }
        }
    }
    t
}

/// A cell of the worst-case map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MapCell {
    /// No run of the sweep falls in it.
    Empty,
    /// A run of it failed (instability or FMU error).
    Failed,
    /// The worst W_k seat RMS of its runs [m/s²].
    Worst(f64),
}

/// The worst W_k seat RMS over two swept parameters (the spec's `map`, else the first two),
/// per controller: the axes as `axis` cuts them.
#[derive(Debug, Clone, PartialEq)]
pub struct WorstMap {
    pub rows_name: String,
    pub columns_name: String,
    pub rows: Vec<String>,
    pub columns: Vec<String>,
    /// Per controller, in the spec's order: `cells[row][column]`.
    pub panels: Vec<(String, Vec<Vec<MapCell>>)>,
}

impl WorstMap {
    /// `None` with fewer than two swept parameters.
    pub fn new(sweep: &Sweep, rows: &[Row]) -> Option<WorstMap> {
        let names = sweep.parameter_names();
        let [a, b] = sweep.spec.map.clone().or_else(|| match names.as_slice() {
            [a, b, ..] => Some([a.clone(), b.clone()]),
            _ => None,
        })?;
        let index = |n: &str| names.iter().position(|m| m == n).unwrap_or(0);
        let values =
            |i: usize| -> Vec<f64> { rows.iter().map(|r| number(&r.job.values[i])).collect() };
        let ((la, ca), (lb, cb)) = (axis(&values(index(&a))), axis(&values(index(&b))));
        let panels = sweep
            .spec
            .controllers
            .iter()
            .map(|c| {
                let mut cells = vec![vec![MapCell::Empty; lb.len()]; la.len()];
                for (k, r) in rows.iter().enumerate() {
                    if r.job.controller_name() != c {
                        continue;
                    }
                    let cell = &mut cells[ca[k]][cb[k]];
                    *cell = match (*cell, r.outcome.finished()) {
                        (MapCell::Failed, _) | (_, None) => MapCell::Failed,
                        (MapCell::Empty, Some(f)) => MapCell::Worst(f.wk_rms_seat),
                        (MapCell::Worst(w), Some(f)) => MapCell::Worst(w.max(f.wk_rms_seat)),
                    };
                }
                (c.clone(), cells)
            })
            .collect();
        Some(WorstMap {
            rows_name: a,
            columns_name: b,
            rows: la,
            columns: lb,
            panels,
        })
    }
}

/// The worst-case map as a heat map: one panel per controller, every panel on one logarithmic
/// colour scale (viridis, shown on the right), each cell's worst figure written in it, failed
/// cells red.
pub fn plot_map(path: &Path, sweep: &Sweep, map: &WorstMap) -> Result<(), MasterError> {
    use plotters::style::colors::colormaps::ViridisRGB;
    let e = |x: String| err(format!("plot {}: {x}", path.display()));
    let worst = map.panels.iter().flat_map(|p| p.1.iter().flatten());
    let (lo, hi) = worst.fold((f64::INFINITY, 0.0f64), |(lo, hi), c| match c {
        MapCell::Worst(w) if *w > 0.0 => (lo.min(w.log10()), hi.max(w.log10())),
        _ => (lo, hi),
    });
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo, hi)
    } else if lo.is_finite() {
        (lo - 0.5, lo + 0.5)
    } else {
        (-3.0, 0.0)
    };
    // The colour of a figure's log10.
    let colour = |l: f64| ViridisRGB::get_color_normalized(l.clamp(lo, hi), lo, hi);
    let n = map.panels.len().max(1);
    let across = n.min(3);
    let down = n.div_ceil(across);
    let (width, height) = (380 * across as u32 + 130, 330 * down as u32 + 50);
    let root = SVGBackend::new(path, (width, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
    let root = root
        .titled(
            &format!(
                "Sweep {}: worst W_k RMS seat acceleration [m/s²] per cell",
                sweep.spec.name
            ),
            ("sans-serif", 20),
        )
        .map_err(|x| e(x.to_string()))?;
    let (panels, bar) = root.split_horizontally(width - 130);
    let (nr, nc) = (map.rows.len(), map.columns.len());
    let text = |size: u32| ("sans-serif", size).into_font();
    for ((name, cells), area) in map.panels.iter().zip(panels.split_evenly((down, across))) {
        let mut chart = ChartBuilder::on(&area)
            .caption(name.as_str(), text(16))
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..nc as f64, 0.0..nr as f64)
            .map_err(|x| e(x.to_string()))?;
        let label = |labels: &[String], v: f64| {
            let i = v.floor() as usize;
            if (v - i as f64 - 0.5).abs() < 1e-9 {
                labels.get(i).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(map.columns_name.as_str())
            .y_desc(map.rows_name.as_str())
            .x_labels(2 * nc + 1)
            .y_labels(2 * nr + 1)
            .x_label_formatter(&|v| label(&map.columns, *v))
            .y_label_formatter(&|v| label(&map.rows, *v))
            .label_style(text(10))
            .draw()
            .map_err(|x| e(x.to_string()))?;
        let at = |i: usize, j: usize| (j as f64, i as f64);
        chart
            .draw_series(cells.iter().enumerate().flat_map(|(i, row)| {
                row.iter().enumerate().filter_map(move |(j, c)| {
                    let fill = match c {
                        MapCell::Empty => return None,
                        MapCell::Failed => RED.filled(),
                        MapCell::Worst(w) => colour(w.log10()).filled(),
                    };
                    let (x, y) = at(i, j);
                    Some(Rectangle::new([(x, y), (x + 1.0, y + 1.0)], fill))
                })
            }))
            .map_err(|x| e(x.to_string()))?;
        if nr * nc <= 64 {
            chart
                .draw_series(cells.iter().enumerate().flat_map(|(i, row)| {
                    row.iter().enumerate().filter_map(move |(j, c)| {
                        let (s, dark) = match c {
                            MapCell::Empty => return None,
                            MapCell::Failed => ("failed".to_string(), true),
                            MapCell::Worst(w) => (significant(*w), w.log10() < 0.5 * (lo + hi)),
                        };
                        let (x, y) = at(i, j);
                        let style = text(11)
                            .color(if dark { &WHITE } else { &BLACK })
                            .pos(Pos::new(HPos::Center, VPos::Center));
                        Some(Text::new(s, (x + 0.5, y + 0.5), style))
                    })
                }))
                .map_err(|x| e(x.to_string()))?;
        }
    }
    // The colour bar: the scale's decades of W_k seat RMS.
    let mut chart = ChartBuilder::on(&bar)
        .margin(20)
        .margin_left(30)
        .margin_right(5)
        .right_y_label_area_size(55)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(|x| e(x.to_string()))?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_formatter(&|v| significant(10f64.powf(*v)))
        .label_style(text(10))
        .draw()
        .map_err(|x| e(x.to_string()))?;
    let strips = 64;
    chart
        .draw_series((0..strips).map(|k| {
            let (a, b) = (
                lo + (hi - lo) * k as f64 / strips as f64,
                lo + (hi - lo) * (k + 1) as f64 / strips as f64,
            );
            Rectangle::new([(0.0, a), (1.0, b)], colour(0.5 * (a + b)).filled())
        }))
        .map_err(|x| e(x.to_string()))?;
    root.present().map_err(|x| e(x.to_string()))?;
    Ok(())
}

/// The empirical CDF of W_k RMS seat acceleration of each controller (log axis), failed runs
/// left out (the report counts them).
pub fn plot_cdf(path: &Path, sweep: &Sweep, rows: &[Row]) -> Result<(), MasterError> {
    let e = |x: String| err(format!("plot {}: {x}", path.display()));
    let curves: Vec<(String, Vec<f64>)> = sweep
        .spec
        .controllers
        .iter()
        .map(|c| {
            let mut v: Vec<f64> = rows
                .iter()
                .filter(|r| r.job.controller_name() == c)
                .filter_map(|r| r.outcome.finished().map(|f| f.wk_rms_seat))
                .filter(|v| *v > 0.0)
                .collect();
            v.sort_by(f64::total_cmp);
            (c.clone(), v)
        })
        .collect();
    let all = curves.iter().flat_map(|c| c.1.iter().copied());
    let (lo, hi) = all.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo / 1.2, hi * 1.2)
    } else {
        (1e-3, 1.0)
    };
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "Sweep {}: W_k-weighted RMS seat acceleration, empirical CDF",
                sweep.spec.name
            ),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(lo.log10()..hi.log10(), 0.0..1.0)
        .map_err(|x| e(x.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("W_k RMS seat acceleration [m/s²] (log)")
        .y_desc("share of runs ≤ x")
        .x_labels(10)
        .x_label_formatter(&|v| significant(10f64.powf(*v)))
        .draw()
        .map_err(|x| e(x.to_string()))?;
    for (k, (name, v)) in curves.iter().enumerate() {
        let color = crate::report::color(k);
        let n = v.len().max(1) as f64;
        let steps: Vec<(f64, f64)> = v
            .iter()
            .enumerate()
            .flat_map(|(i, x)| [(x.log10(), i as f64 / n), (x.log10(), (i + 1) as f64 / n)])
            .collect();
        chart
            .draw_series(LineSeries::new(steps, color.stroke_width(2)))
            .map_err(|x| e(x.to_string()))?
            // A controller whose runs all equal an earlier one's is drawn over it, and says so.
            .label(match curves[..k].iter().find(|c| c.1 == *v) {
                Some(same) => format!("{name} = {}", same.0),
                None => name.clone(),
            })
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|x| e(x.to_string()))?;
    root.present().map_err(|x| e(x.to_string()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_known_samples() {
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        assert_eq!(statistics(&v), Some([10.5, 10.5, 19.0, 20.0]));
        assert_eq!(statistics(&[3.0, 1.0, 2.0]), Some([2.0, 2.0, 3.0, 3.0]));
        assert_eq!(statistics(&[]), None);
    }

    #[test]
    fn a_map_axis_keeps_few_values_and_bins_many() {
        let (labels, cells) = axis(&[1800.0, 1200.0, 1500.0, 1200.0]);
        assert_eq!(labels, ["1200", "1500", "1800"]);
        assert_eq!(cells, [2, 0, 1, 0]);
        let v: Vec<f64> = (0..=60).map(|k| k as f64 / 60.0).collect();
        let (labels, cells) = axis(&v);
        assert_eq!(labels.len(), 6);
        assert_eq!((cells[0], cells[30], cells[60]), (0, 3, 5));
    }
}
