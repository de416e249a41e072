"""The JSON Schemas of scenario and sweep files (schemas/, generated from the master's types by
`make schemas`; a Rust test keeps them current) accept every file the project ships and refuse
what the master refuses. jsonschema 3.2 (the version cffconvert pins) knows draft 7, which covers
every keyword these schemas use."""
import json
import subprocess
from pathlib import Path

import pytest
from jsonschema import Draft7Validator

ROOT = Path(__file__).resolve().parents[2]
MASTER = ROOT / "target" / "release" / "master"


def validator(kind):
    return Draft7Validator(json.loads((ROOT / "schemas" / f"{kind}.schema.json").read_text()))


@pytest.mark.parametrize("kind,folder", [("scenario", "scenarios"), ("sweep", "sweeps")])
def test_every_shipped_file_follows_its_schema(kind, folder):
    files = sorted((ROOT / folder).glob("*.json"))
    assert files
    for f in files:
        errors = [e.message for e in validator(kind).iter_errors(json.loads(f.read_text()))]
        assert not errors, f"{f.name}: {errors}"


BUMP = json.loads((ROOT / "scenarios" / "bump.json").read_text())


@pytest.mark.parametrize("change,why", [
    (lambda s: s.pop("step"), "'step' is a required property"),
    (lambda s: s.update(durration=1.0), "Additional properties are not allowed"),
    (lambda s: s.update(duration="8 s"), "is not of type 'number'"),
    (lambda s: s["plant"].update(m_s="heavy"), "is not of type 'number'"),
], ids=["missing step", "misspelt key", "duration as text", "plant value as text"])
def test_the_schema_and_the_master_refuse_the_same_mistakes(tmp_path, change, why):
    scenario = json.loads(json.dumps(BUMP))
    scenario.setdefault("plant", {})
    change(scenario)
    messages = [e.message for e in validator("scenario").iter_errors(scenario)]
    assert any(why in m for m in messages), messages
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(scenario))
    run = subprocess.run([str(MASTER), "--dist", str(ROOT / "dist"), "run", "--scenario", str(path), "--out", str(tmp_path / "x.csv")],
                         capture_output=True, text=True)
    assert run.returncode != 0 and "bad.json" in run.stderr, run.stderr
