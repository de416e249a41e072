"""The SSP 1.0 archives `master ssp` writes (dist/car.ssp from `make`: road, plant and hinf_of on
the bump): valid against the SSP 1.0 schema (FMPy's copy of the XSDs), parameters as in the
scenario, and simulated by a second SSP engine (FMPy's `simulate_ssp`) like the Rust master.

`simulate_ssp` exchanges values after all components have stepped (Jacobi) and starts its
connectors at 0, the master steps road -> plant -> controller (Gauss-Seidel): the two differ by
the one-step lag of the loop, so they are compared to 3 % in RMS and peak, and by correlation,
as libcosim is (test_libcosim.py)."""

import json
import pathlib
import subprocess

import numpy as np
import pytest
from fmpy.ssp.simulation import simulate_ssp
from fmpy.ssp.ssd import ParameterSet, read_ssd

import master_csv

ROOT = pathlib.Path(__file__).resolve().parents[2]
MASTER = ROOT / "target" / "release" / "master"


def parameters(ssd):
    """{component: {name: value}} from the inline parameter sets."""
    out = {}
    for c in ssd.system.elements:
        out[c.name] = {p.name: float(p.value) for b in c.parameterBindings for s in b.parameterValues for p in s.parameters}
    return out


def test_make_writes_a_valid_ssp_of_the_bump_loop():
    path = ROOT / "dist" / "car.ssp"
    assert path.exists(), "run `make` (it writes dist/car.ssp)"
    ssd = read_ssd(str(path), validate=True)  # raises on a schema violation
    assert [c.name for c in ssd.system.elements] == ["road", "plant", "hinf_of"]
    assert [c.source for c in ssd.system.elements] == ["resources/road.fmu", "resources/plant.fmu", "resources/hinf_of.fmu"]
    scenario = json.loads((ROOT / "scenarios" / "bump.json").read_text())
    assert parameters(ssd)["road"] == pytest.approx({k: float(v) for k, v in scenario["road"].items()})
    wired = {(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in ssd.system.connections}
    for n in ("road_z_fl", "road_v_rr"):
        assert ("road", n, "plant", n) in wired
    for n in ("u_fl", "u_seat"):
        assert ("hinf_of", n, "plant", n) in wired
    assert ("plant", "sensor_stroke_fl", "hinf_of", "sensor_stroke_fl") in wired


def test_unknown_controller_is_refused(tmp_path):
    r = subprocess.run([str(MASTER), "--dist", str(ROOT / "dist"), "ssp", "--scenario", str(ROOT / "scenarios" / "bump.json"),
                        "--controller", "no_such_controller", "--out", str(tmp_path / "x.ssp")], capture_output=True, text=True)
    assert r.returncode != 0 and "no_such_controller.fmu not found" in r.stderr
    assert not (tmp_path / "x.ssp").exists()


@pytest.mark.parametrize("scenario,controller", [("bump", "hinf_of"), ("saturation", "hinf_of_aw")])
def test_fmpy_simulates_the_ssp_like_the_rust_master(tmp_path, scenario, controller):
    """Road, plant and controller parameters from the SSD (the saturation scenario sets the
    force limits of the plant and of the anti-windup controller, and an ISO class D road)."""
    spec = ROOT / "scenarios" / f"{scenario}.json"
    ssp = tmp_path / f"{scenario}.ssp"
    subprocess.run([str(MASTER), "--dist", str(ROOT / "dist"), "ssp", "--scenario", str(spec), "--controller", controller, "--out", str(ssp)], check=True)
    ssd = read_ssd(str(ssp), validate=True)
    values = parameters(ssd)
    s = json.loads(spec.read_text())
    assert values["plant"] == pytest.approx({k: float(v) for k, v in s.get("plant", {}).items()})
    # simulate_ssp takes one parameter set with "component.variable" names.
    merged = ParameterSet(name=scenario)
    for c in ssd.system.elements:
        for b in c.parameterBindings:
            for ps in b.parameterValues:
                for p in ps.parameters:
                    p.name = f"{c.name}.{p.name}"
                    merged.parameters.append(p)
    result = simulate_ssp(str(ssp), stop_time=s["duration"], step_size=s["step"], parameter_set=merged)

    out = tmp_path / "master.csv"
    subprocess.run([str(MASTER), "--dist", str(ROOT / "dist"), "run", "--scenario", str(spec), "--controller", controller, "--out", str(out)], check=True)
    rust = master_csv.read(out)
    for name in ("a_seat", "stroke_fl", "f_fl"):
        # Row k of each is the state at t_{k+1} (FMPy labels it t_k); FMPy may add a last row
        # where its accumulated time falls just short of the stop time.
        n = min(len(result), len(rust))
        a, b = result[f"plant.{name}"][:n], rust[name][:n]
        rms_a, rms_b = np.sqrt(np.mean(a ** 2)), np.sqrt(np.mean(b ** 2))
        print(scenario, name, "FMPy SSP RMS", rms_a, "master RMS", rms_b, "corr", np.corrcoef(a, b)[0, 1])
        assert n == round(s["duration"] / s["step"])
        assert abs(rms_a / rms_b - 1) < 0.03 and abs(np.abs(a).max() / np.abs(b).max() - 1) < 0.03
        assert np.corrcoef(a, b)[0, 1] > 0.99
    if scenario == "saturation":
        # The limits reached the plant: its applied force never exceeds them, and does reach them.
        assert np.abs(result["plant.f_fl"]).max() == pytest.approx(s["plant"]["u_max"], rel=1e-9)
