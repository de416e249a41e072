"""`make bench`: a 10 s closed loop at 1 kHz (road.fmu -> plant.fmu -> hinf_of.fmu, the 5 cm
bump) in the Rust master against the same loop in FMPy (the Python master of
tests/python/test_closed_loop.py), same FMUs, same order; then the Rust loop on the ISO class C
road. Loop time only (FMUs loaded and initialised), best of three, as a ratio and against real
time."""

import json
import pathlib
import re
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))
import test_closed_loop as py  # noqa: E402

SECONDS, STEP = 10.0, 1e-3


def rust(scenario, dist=ROOT / "dist"):
    best = float("inf")
    for _ in range(3):
        out = subprocess.run([str(ROOT / "target" / "release" / "master"), "--dist", str(dist), "run", "--scenario", scenario,
                              "--controller", "hinf_of", "--out", str(pathlib.Path(tempfile.gettempdir()) / "bench_master.csv")],
                             check=True, capture_output=True, text=True).stdout
        best = min(best, float(re.search(r"loop ([0-9.]+) s", out).group(1)))
    return best


def python(road_params):
    best = float("inf")
    for _ in range(3):
        ints = {k: v for k, v in road_params.items() if k in ("profile", "side", "iso_class", "seed")}
        road = py.RoadFmu(ints, {k: v for k, v in road_params.items() if k not in ints})
        plant, ctrl = py.Fmu("plant"), py.Fmu("hinf_of")
        road_refs, force_refs = plant.refs(py.ROAD), plant.refs(py.FORCES)
        y_from, y_to, u_from, rec = plant.refs(ctrl.inputs), ctrl.refs(ctrl.inputs), ctrl.refs(py.FORCES), plant.refs(py.RECORD)
        t0 = time.perf_counter()
        for k in range(int(round(SECONDS / STEP))):
            t = k * STEP
            plant.fmu.setReal(road_refs, road(t))
            ctrl.fmu.setReal(y_to, plant.fmu.getReal(y_from))
            plant.fmu.setReal(force_refs, ctrl.fmu.getReal(u_from))
            ctrl.fmu.doStep(t, STEP)
            plant.fmu.doStep(t, STEP)
            plant.fmu.setReal(road_refs, road(t + STEP))
            plant.fmu.getReal(rec)
        best = min(best, time.perf_counter() - t0)
        for f in (plant, ctrl, road.f):
            f.close()
    return best


# A real car's plant (issue 49's second loop target): the sensor model on and 10 Hz actuators.
REAL_CAR = {"sensor_model": 1, "actuator_bandwidth": 10.0}


def scenario_file(name, seconds=SECONDS, plant=None):
    """scenarios/<name>.json cut to `seconds` at 1 kHz (with the plant overrides `plant`), in
    the temporary directory."""
    scenario = json.loads((ROOT / "scenarios" / f"{name}.json").read_text())
    tag = "_real_car" if plant else ""
    scenario.update(name=f"bench_{name}{tag}_{seconds:g}s", duration=seconds, step=STEP)
    scenario.setdefault("plant", {}).update(plant or {})
    path = pathlib.Path(tempfile.gettempdir()) / f"bench_{name}{tag}_{seconds:g}s.json"
    path.write_text(json.dumps(scenario))
    return scenario, str(path)


def main():
    scenario, path = scenario_file("bump")
    r, p = rust(path), python(scenario["road"])
    print(f"10 s closed loop at 1 kHz (road -> plant -> hinf_of): Rust master {r * 1e3:.1f} ms ({SECONDS / r:.0f}x real time), "
          f"FMPy master {p * 1e3:.0f} ms ({SECONDS / p:.1f}x real time): Rust {p / r:.0f}x faster")
    r = rust(scenario_file("iso_c")[1])
    print(f"The same on the ISO class C road at 20 m/s: Rust master {r * 1e3:.1f} ms ({SECONDS / r:.0f}x real time)")
    real = rust(scenario_file("iso_c", plant=REAL_CAR)[1])
    print(f"The same with the plant's sensor model on and 10 Hz actuators: {real * 1e3:.1f} ms "
          f"({real / r:.2f}x the ideal plant's loop; target at most 1.2x)")


if __name__ == "__main__":
    main()
