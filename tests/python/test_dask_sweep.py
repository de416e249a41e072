"""The Dask sweep (python/suspension_sweep) equals `master sweep` on one machine run by run:
the same rows, every column but the loop time, to the last bit; with the FMUs and the master
shipped to the workers and with shared paths."""

import subprocess
import sys

import pyarrow.parquet as pq

from conftest import ROOT


def _sweep(tmp_path):
    (tmp_path / "bump.json").write_text(
        '{"name": "b", "duration": 1.0, "step": 0.001, "road": {"profile": 1, '
        '"bump_height": 0.05, "bump_length": 5.0, "side": 0, "speed": 15.0, "start_distance": 1.5}}'
    )
    spec = tmp_path / "sweep.json"
    spec.write_text(
        '{"name": "d", "base": "bump.json", "controllers": ["passive", "hinf_sf", "delay_sf"], '
        '"seed": 9, "samples": 3, "latin_hypercube": true, '
        '"parameters": {"plant.m_s": {"grid": [1250, -1.0]}, "plant.tau": {"uniform": [0, 0.02]}}}'
    )
    return spec


def _without_time(path):
    t = pq.read_table(path)
    return t.drop_columns(["loop_seconds"]).to_pylist()


def test_the_distributed_sweep_is_the_local_one(tmp_path):
    spec = _sweep(tmp_path)
    master = ROOT / "target" / "release" / "master"
    local = tmp_path / "local"
    subprocess.run([master, "--dist", ROOT / "dist", "sweep", spec, "--out", local],
                   check=True, capture_output=True)
    want = _without_time(local / "runs.parquet")
    assert len(want) == 18 and sum(r["status"] == "failed" for r in want) == 9
    for mode in (["--local", "2"], ["--local", "2", "--shared"]):
        out = tmp_path / ("dask" + "".join(mode))
        done = subprocess.run(
            [sys.executable, "-m", "suspension_sweep.sweep", spec, *mode, "--chunk", "5",
             "--out", out],
            capture_output=True, text=True,
        )
        assert done.returncode == 0, (mode, done.returncode, done.stderr[-4000:])
        assert "18 runs (9 failed) in 4 chunks" in done.stdout, done.stdout
        assert _without_time(out / "runs.parquet") == want, mode
        csv_rows = (out / "runs.csv").read_text().splitlines()
        local_rows = (local / "runs.csv").read_text().splitlines()
        assert [r.rsplit(",", 1)[0] for r in csv_rows] == [r.rsplit(",", 1)[0] for r in local_rows]


def test_chunks_cover_the_table_once():
    from suspension_sweep.sweep import chunks

    assert chunks(10, 4) == [(0, 4), (4, 8), (8, 10)]
    assert chunks(8, 4) == [(0, 4), (4, 8)]
    assert chunks(0, 4) == []
