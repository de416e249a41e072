"""`master sweep` read as a data scientist reads it: runs.parquet with pyarrow (an independent
Parquet reader) holds exactly the rows of runs.csv, typed, with nulls where a run failed."""

import csv
import math
import subprocess

import pyarrow.parquet as pq

from conftest import ROOT


def test_the_parquet_table_is_the_csv_table(tmp_path):
    master = ROOT / "target" / "release" / "master"
    (tmp_path / "bump.json").write_text(
        '{"name": "b", "duration": 1.0, "step": 0.001, "road": {"profile": 1, '
        '"bump_height": 0.05, "bump_length": 5.0, "side": 0, "speed": 15.0, "start_distance": 1.5}}'
    )
    (tmp_path / "sweep.json").write_text(
        '{"name": "p", "base": "bump.json", "controllers": ["passive", "hinf_of"], '
        '"seed": 2, "samples": 2, "parameters": {"plant.m_s": {"grid": [1300, -5]}, '
        '"road.speed": {"normal": {"mean": 15.0, "std": 1.0}}}}'
    )
    out = tmp_path / "out"
    subprocess.run(
        [master, "--dist", ROOT / "dist", "sweep", tmp_path / "sweep.json", "--out", out],
        check=True,
        capture_output=True,
    )
    table = pq.read_table(out / "runs.parquet")
    with open(out / "runs.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert table.num_rows == len(rows) == 8
    assert table.column_names == list(rows[0].keys())
    types = {f.name: str(f.type) for f in table.schema}
    assert types["run"] == "int64" and types["controller"] == "string"
    assert types["wk_rms_seat_m_s2"] == "double" and types["tyre_lift_off"] == "bool"
    data = table.to_pylist()
    for got, want in zip(data, rows):
        for name, value in got.items():
            text = want[name]
            if value is None:
                assert text == "", name
            elif isinstance(value, bool):
                assert str(value).lower() == text, name
            elif isinstance(value, float) and name != "loop_seconds":
                assert value == float(text), name
            elif isinstance(value, int):
                assert value == int(text), name
            elif isinstance(value, str):
                assert value == text, name
    failed = [r for r in data if r["status"] == "failed"]
    assert len(failed) == 4 and all(r["wk_rms_seat_m_s2"] is None for r in failed)
    ok = [r for r in data if r["status"] == "ok"]
    assert all(math.isfinite(r["wk_rms_seat_m_s2"]) for r in ok)
    # Each controller sees the same two speeds drawn.
    speeds = {(r["controller"], r["road.speed"]) for r in data}
    assert len({s for _, s in speeds}) == 2 and len(speeds) == 4
