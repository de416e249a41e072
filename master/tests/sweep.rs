//! `master sweep` on the FMUs `make` built into dist/: every row is the run `master run` would
//! make of its scenario (same figures to the last bit), a chunk of the run table gives the same
//! rows as the whole sweep, a run that fails is recorded with its message and the sweep goes on,
//! and the Parquet file holds what the CSV holds (read back with the parquet crate's reader;
//! `tests/python/test_sweep.py` reads it with pyarrow).

use master::cosim::{run, Scenario};
use master::report::figures;
use master::sweep::{metric_values, Sweep, METRICS};
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::Field;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A small sweep beside a short bump scenario, in a fresh directory: masses on a grid (one that
/// makes no car: the plant refuses it when it is set), delays drawn, two controllers.
fn sweep_dir(tag: &str) -> PathBuf {
    let dir = fresh_dir(tag);
    write_bump(&dir, 0.001);
    std::fs::write(
        dir.join("sweep.json"),
        r#"{"name": "t", "base": "bump.json", "controllers": ["passive", "hinf_sf"],
            "seed": 5, "samples": 3, "latin_hypercube": true,
            "parameters": {"plant.m_s": {"grid": [1200, -1.0, 1800]},
                           "plant.tau": {"uniform": [0.0, 0.02]}},
            "map": ["plant.m_s", "plant.tau"]}"#,
    )
    .unwrap();
    dir
}

/// An empty directory of this test process, `master-sweep-{tag}-{pid}` in the temporary one.
fn fresh_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("master-sweep-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `dir/bump.json`: 1.5 s over a 5 cm bump at 15 m/s, at a communication step of `step`.
fn write_bump(dir: &Path, step: f64) {
    let scenario = serde_json::json!({
        "name": "short_bump", "duration": 1.5, "step": step,
        "road": {"profile": 1, "bump_height": 0.05, "bump_length": 5.0, "side": 0,
                 "speed": 15.0, "start_distance": 1.5},
    });
    std::fs::write(dir.join("bump.json"), scenario.to_string()).unwrap();
}

fn master(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_master"))
        .arg("--dist")
        .arg(root().join("dist"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "master {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// `master sweep SPEC --out OUT` with `extra` arguments; its standard output.
fn sweep_into(spec: &Path, out: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "sweep",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    master(&args)
}

fn csv_rows(path: &Path) -> Vec<Vec<String>> {
    // No field of these sweeps is quoted (messages have no commas here: checked below).
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

#[test]
fn a_sweep_is_its_runs_row_by_row_and_a_chunk_is_the_same_rows() {
    let dir = sweep_dir("whole");
    let spec = dir.join("sweep.json");
    let out = dir.join("out");
    let msg = sweep_into(&spec, &out, &[]);
    // 3 masses × 3 draws × 2 controllers; the 6 runs at m_s = −1 fail, are recorded, and the
    // sweep goes on.
    assert!(msg.starts_with("18 runs (6 failed)"), "{msg}");
    let rows = csv_rows(&out.join("runs.csv"));
    let header = &rows[0];
    assert_eq!(
        header[..5],
        ["run", "point", "controller", "plant.m_s", "plant.tau"]
    );
    let col = |n: &str| header.iter().position(|h| h == n).unwrap();
    let rows = &rows[1..];
    assert_eq!(rows.len(), 18);
    let sweep = Sweep::load(&spec).unwrap();
    let jobs = sweep.jobs().unwrap();
    for (r, job) in rows.iter().zip(&jobs) {
        assert_eq!(r[col("run")], job.run.to_string());
        assert_eq!(r[col("controller")], job.controller_name());
        if job.values[0].as_f64() == Some(-1.0) {
            assert_eq!(r[col("status")], "failed");
            assert!(
                r[col("message")].contains("plant: setting 'm_s' = Real(-1.0): Error"),
                "{r:?}"
            );
            assert!(r[col(METRICS[0])].is_empty());
            continue;
        }
        assert_eq!(r[col("status")], "ok", "{r:?}");
        // The row is what `master run` of its scenario gives, to the last bit.
        let scenario: &Scenario = &job.scenario;
        let f = figures(
            &run(&root().join("dist"), scenario, job.controller.as_deref()).unwrap(),
            scenario,
        );
        for (m, v) in METRICS.iter().zip(metric_values(&f)) {
            assert_eq!(
                r[col(m)].parse::<f64>().unwrap(),
                v,
                "{m} of run {}",
                job.run
            );
        }
        assert_eq!(
            r[col("tyre_lift_off")],
            (f.max_tyre_ratio >= 1.0).to_string()
        );
        // The plant's clocks: the largest share of the time off the road and on a stop.
        for (name, shares) in [
            ("airborne_share", &f.flags.airborne[..]),
            ("stop_share", &f.flags.at_stop[..]),
        ] {
            let largest = shares.iter().copied().fold(0.0, f64::max);
            assert_eq!(r[col(name)].parse::<f64>().unwrap(), largest, "{name}");
        }
    }
    // The same draw of τ at every mass; the passive car does not feel τ.
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("| `hinf_sf` | 9 | 33.3 % |"), "{report}");
    assert!(report.contains("over `plant.m_s` (rows) × `plant.tau` (columns)"));
    assert!(std::fs::read_to_string(out.join("cdf.svg"))
        .unwrap()
        .contains("<svg"));
    // The map as a heat map: a panel per controller, the failed cells (m_s = −1 at each of the
    // three τ, for both controllers) marked, the report's map linked.
    let map = std::fs::read_to_string(out.join("map.svg")).unwrap();
    let texts: Vec<&str> = map
        .split("<text")
        .skip(1)
        .filter_map(|t| Some(t.split_once('>')?.1.split_once("</text>")?.0.trim()))
        .collect();
    for c in &sweep.spec.controllers {
        assert!(texts.contains(&c.as_str()), "{c}: {texts:?}");
    }
    assert_eq!(
        texts.iter().filter(|t| **t == "failed").count(),
        6,
        "{texts:?}"
    );
    assert!(report.contains("](map.svg)"));

    // A chunk: runs 7..12 only, the same rows with the same numbers (loop time aside).
    let chunk = dir.join("chunk");
    sweep_into(&spec, &chunk, &["--runs", "7..12"]);
    let part = csv_rows(&chunk.join("runs.csv"));
    assert_eq!(part.len(), 1 + 5);
    let last = header.len() - 1;
    for (p, whole) in part[1..].iter().zip(&rows[7..12]) {
        assert_eq!(p[..last], whole[..last]);
    }

    // The Parquet file holds the CSV's rows: a null metric where the run failed.
    let reader =
        SerializedFileReader::new(std::fs::File::open(out.join("runs.parquet")).unwrap()).unwrap();
    assert_eq!(reader.metadata().file_metadata().num_rows(), 18);
    for (k, record) in reader.get_row_iter(None).unwrap().enumerate() {
        let record = record.unwrap();
        let fields: Vec<(&String, &Field)> = record.get_column_iter().collect();
        assert_eq!(fields.len(), header.len());
        for (((name, field), text), column) in fields.iter().zip(&rows[k]).zip(header) {
            assert_eq!(*name, column);
            match field {
                Field::Null => assert!(text.is_empty(), "{name} of row {k}"),
                Field::Double(v) if *name != "loop_seconds" => {
                    assert_eq!(*v, text.parse::<f64>().unwrap(), "{name} of row {k}")
                }
                Field::Long(v) => assert_eq!(v.to_string(), *text),
                Field::Bool(v) => assert_eq!(v.to_string(), *text),
                Field::Str(v) => assert_eq!(v, text),
                _ => {}
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_sweeps_and_chunks_are_refused_with_the_reason() {
    let dir = sweep_dir("bad");
    let spec = dir.join("sweep.json");
    let e = Command::new(env!("CARGO_BIN_EXE_master"))
        .args([
            "sweep",
            spec.to_str().unwrap(),
            "--runs",
            "10..40",
            "--dry-run",
        ])
        .output()
        .unwrap();
    assert!(!e.status.success());
    assert!(String::from_utf8_lossy(&e.stderr).contains("the run table has 18 runs"));
    let dry = master(&["sweep", spec.to_str().unwrap(), "--dry-run"]);
    assert!(dry.contains("18 runs (9 points x 2 controllers)"), "{dry}");
    std::fs::write(
        dir.join("sweep.json"),
        r#"{"name": "t", "base": "missing.json", "controllers": ["hinf_sf"],
            "parameters": {"plant.m_s": {"grid": [1200]}}}"#,
    )
    .unwrap();
    let e = Sweep::load(&spec).unwrap_err().0;
    assert!(
        e.contains("cannot read scenario") && e.contains("missing.json"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The report sets each certificate's prediction for the loop a master runs beside the runs at
/// that condition: exactly the runs on the design road (class C, 20 m/s, 1 ms) at the nominal
/// car or at a checked condition of the design's uncertainty, every other run left out; the
/// measured mean near the prediction (20 s runs past the fade-in, two seeds).
#[test]
fn the_report_sets_the_certificates_predictions_beside_the_runs_at_their_conditions() {
    let dir = fresh_dir("predicted");
    std::fs::write(
        dir.join("iso.json"),
        r#"{"name": "iso_c_20s", "duration": 20.0, "step": 0.001, "metrics_from": 2.0,
            "road": {"profile": 2, "iso_class": 3, "seed": 7, "speed": 20.0,
                     "start_distance": -2.4}}"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("sweep.json"),
        r#"{"name": "p", "base": "iso.json", "controllers": ["passive", "robust_of", "delay_sf"],
            "seed": 3, "samples": 2,
            "parameters": {"plant.m_s": {"grid": [1200, 1500, 1650.5]},
                           "plant.tau": {"grid": [0.0, 0.01]},
                           "road.seed": {"integers": [1, 100000]}}}"#,
    )
    .unwrap();
    let out = dir.join("out");
    sweep_into(&dir.join("sweep.json"), &out, &[]);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let section = &report[report.find("## Predicted beside measured").unwrap()..];
    let rows: Vec<Vec<&str>> = section
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| l.trim_matches('|').split(" | ").map(str::trim).collect())
        .collect();
    let found: Vec<(&str, &str, &str)> = rows.iter().map(|r| (r[0], r[1], r[3])).collect();
    assert_eq!(
        found,
        [
            ("`robust_of`", "nominal car", "2"),
            ("`robust_of`", "m_s = 1200 kg", "2"),
            ("`delay_sf`", "nominal car", "2"),
            ("`delay_sf`", "delay 10.0 ms", "2"),
        ],
        "{section}"
    );
    // The predictions are the certificates' (read here on their own).
    let certificate = |c: &str| -> serde_json::Value {
        let path = root().join("dist").join(format!("{c}.certificate.json"));
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    };
    let held = |c: &str, k: Option<usize>| -> f64 {
        let json = certificate(c);
        let at = match k {
            None => "/comfort/held/predicted_wk_rms_seat_m_s2".to_string(),
            Some(k) => format!("/comfort/uncertainty/held/{k}/predicted_wk_rms_seat_m_s2"),
        };
        json.pointer(&at).and_then(|v| v.as_f64()).unwrap()
    };
    // The index of the condition that sets `parameter` to `value`.
    let condition = |c: &str, parameter: &str, value: f64| {
        certificate(c)
            .pointer("/comfort/uncertainty/plant_parameters")
            .and_then(|v| v.as_array())
            .unwrap()
            .iter()
            .position(|p| p.get(parameter).and_then(|m| m.as_f64()) == Some(value))
            .expect("the certificate checks that condition")
    };
    let expected = [
        held("robust_of", None),
        held("robust_of", Some(condition("robust_of", "m_s", 1200.0))),
        held("delay_sf", None),
        held("delay_sf", Some(condition("delay_sf", "tau", 0.01))),
    ];
    for (r, p) in rows.iter().zip(expected) {
        assert_eq!(r[2], format!("{p:.4}"), "{r:?}");
        let ratio: f64 = r[6].parse().unwrap();
        assert!((0.85..=1.15).contains(&ratio), "{r:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A controller stepped beyond the communication steps its certificate calls stable
/// (`robust_of` at 10 ms; `skyhook` is stable there) still runs, and its rows carry the FMU's
/// warning: the `warnings` column, the report's share of runs an FMU warned in, and the
/// message once with its count.
#[test]
fn a_controller_stepped_beyond_its_stable_steps_warns_in_its_rows() {
    let dir = fresh_dir("warn");
    write_bump(&dir, 0.01);
    let spec = dir.join("sweep.json");
    std::fs::write(
        &spec,
        r#"{"name": "w", "base": "bump.json", "controllers": ["skyhook", "robust_of"],
            "parameters": {"plant.m_s": {"grid": [1400, 1600]}}}"#,
    )
    .unwrap();
    let out = dir.join("out");
    let msg = sweep_into(&spec, &out, &[]);
    assert!(msg.starts_with("4 runs (0 failed)"), "{msg}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let row = |c: &str| {
        report
            .lines()
            .find(|l| l.starts_with(&format!("| `{c}` | 2 |")))
            .unwrap_or_else(|| panic!("{c}: {report}"))
            .to_string()
    };
    assert!(row("robust_of").ends_with("| 100.0 % |"), "{report}");
    assert!(row("skyhook").ends_with("| 0.0 % |"), "{report}");
    assert!(
        report.contains("- 2 × robust_of: fmi2DoStep: communication step 0.01 s"),
        "{report}"
    );
    let reader =
        SerializedFileReader::new(std::fs::File::open(out.join("runs.parquet")).unwrap()).unwrap();
    let mut seen = 0;
    for record in reader.get_row_iter(None).unwrap() {
        let record = record.unwrap();
        let field = |n: &str| {
            record
                .get_column_iter()
                .find(|(name, _)| *name == n)
                .map(|(_, f)| f.clone())
                .unwrap()
        };
        let (Field::Str(controller), Field::Str(warnings)) =
            (field("controller"), field("warnings"))
        else {
            panic!("controller and warnings are strings: {record:?}");
        };
        assert_eq!(
            warnings.contains("communication step 0.01 s"),
            controller == "robust_of",
            "{controller}: {warnings}"
        );
        seen += 1;
    }
    assert_eq!(seen, 4);
    let _ = std::fs::remove_dir_all(&dir);
}
