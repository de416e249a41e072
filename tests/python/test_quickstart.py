"""The README's quick start is code that works: its block (between the quickstart markers) runs
as written from the repository root, and its seat acceleration is the Rust master's on the same
road (scenarios/iso_c.json cut to 5 s) -- the same loop order, so to 1e-9."""

import json
import os
import pathlib
import re
import subprocess

import numpy as np

import master_csv

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_the_readme_quick_start_moves_the_car_like_the_master(tmp_path):
    readme = (ROOT / "README.md").read_text()
    block = re.search(r"<!-- quickstart:begin -->\n```python\n(.*?)```\n<!-- quickstart:end -->", readme, re.S)
    assert block, "README.md has no quickstart block"
    namespace = {}
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        exec(compile(block.group(1), "README.md quickstart", "exec"), namespace)
    finally:
        os.chdir(cwd)
    a_seat = np.array(namespace["a_seat"])
    assert len(a_seat) == 5000

    scenario = json.loads((ROOT / "scenarios" / "iso_c.json").read_text())
    assert scenario["road"] == {"profile": 2, "iso_class": 3, "seed": 7, "speed": 20.0, "start_distance": -2.4}, \
        "the quick start's road is iso_c's: change both"
    scenario["duration"] = 5.0
    spec, out = tmp_path / "iso_c_5s.json", tmp_path / "run.csv"
    spec.write_text(json.dumps(scenario))
    subprocess.run([str(ROOT / "target" / "release" / "master"), "--dist", str(ROOT / "dist"), "run", "--scenario", str(spec),
                    "--controller", "hinf_of", "--out", str(out)], check=True, capture_output=True)
    master = master_csv.read(out)["a_seat"]
    assert len(master) == len(a_seat)
    assert np.sqrt(np.mean(a_seat**2)) > 0.005, "the car moved"
    assert np.max(np.abs(a_seat - master)) <= 1e-9 * np.max(np.abs(master))
