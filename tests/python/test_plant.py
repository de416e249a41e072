"""The plant FMU from Python (FMPy), checked against the independent hand-written reference."""

import ctypes
import math
import shutil

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy
from fmpy.validation import validate_fmu
from fmpy import extract

import reference_car as ref

SPEED, HEIGHT, LENGTH, START = 15.0, 0.05, 5.0, 0.1
WHEELBASE = ref.PARAMS["L1"] + ref.PARAMS["L2"]


def bump(t, delay):
    """5 cm high, 5 m long 1 - cos bump at 15 m/s: height and vertical velocity."""
    x = SPEED * (t - START - delay)
    if 0.0 <= x <= LENGTH:
        w = 2 * math.pi / LENGTH
        return 0.5 * HEIGHT * (1 - math.cos(w * x)), 0.5 * HEIGHT * w * SPEED * math.sin(w * x)
    return 0.0, 0.0


def inputs_at(t):
    """w = [z_r fl fr rl rr, v_r fl fr rl rr, u fl fr rl rr seat]: bump on the left wheels, the
    rear one delayed by the wheelbase, plus actuator forces that exercise every column of B."""
    zf, vf = bump(t, 0.0)
    zr, vr = bump(t, WHEELBASE / SPEED)
    u = [400 * math.sin(9 * t), -300 * math.sin(5 * t), 250 * math.cos(7 * t), 0.0, 150 * math.sin(13 * t)]
    return np.array([zf, 0.0, zr, 0.0, vf, 0.0, vr, 0.0] + u)


INPUT_NAMES = [f"road_z_{c}" for c in ref.CORNERS] + [f"road_v_{c}" for c in ref.CORNERS] + [
    f"u_{a}" for a in ref.CORNERS + ["seat"]
]
STATE_NAMES = [f"x[{k}]" for k in range(1, 17)]


# FMPy's addLoggerProxy keeps the Python logger in a process-wide variable of its C helper, so
# the logger must outlive every instance created afterwards: one logger for the whole session,
# writing into a list the tests read and clear.
LOG = []


def _record(env, name, status, category, message):
    LOG.append((name.decode(), status, category.decode(), message.decode()))


_C_LOGGER = fmi2CallbackLoggerTYPE(_record)


class Slave:
    def __init__(self, path, capture_log=False, logging_on=False):
        self.md = read_model_description(path)
        self.dir = extract(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmu = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=self.dir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName="plant",
        )
        callbacks = None
        if capture_log:
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = _C_LOGGER
            addLoggerProxy(ctypes.byref(callbacks))
            self._keep = callbacks
        self.fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)

    def refs(self, names):
        return [self.vr[n] for n in names]

    def close(self):
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def run_fmu(path, h, steps, first_order_hold):
    s = Slave(path)
    f = s.fmu
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    in_refs = s.refs(INPUT_NAMES)
    out_names = STATE_NAMES + ref.OUTPUTS
    out_refs = s.refs(out_names)
    X = np.zeros((steps + 1, len(out_names)))
    f.setReal(in_refs, list(inputs_at(0.0)))
    X[0] = f.getReal(out_refs)
    for k in range(steps):
        t = k * h
        w0, w1 = inputs_at(t), inputs_at(t + h)
        f.setReal(in_refs, list(w0))
        if first_order_hold:
            f.setRealInputDerivatives(in_refs, [1] * len(in_refs), list((w1 - w0) / h))
        f.doStep(t, h)
        f.setReal(in_refs, list(w1))
        X[k + 1] = f.getReal(out_refs)
    f.terminate()
    s.close()
    return X, out_names


def test_fmpy_validate_reports_no_problems(plant_fmu):
    assert validate_fmu(plant_fmu) == []


@pytest.mark.parametrize("h", [1e-3, 1e-2])
@pytest.mark.parametrize("first_order_hold", [False, True], ids=["held", "interpolated"])
def test_bump_matches_independent_exact_solution(plant_fmu, h, first_order_hold):
    duration = 2.0
    steps = int(round(duration / h))
    W = np.array([inputs_at(k * h) for k in range(steps + 1)])
    X_ref, Y_ref = ref.simulate(W, h, first_order_hold)
    got, names = run_fmu(plant_fmu, h, steps, first_order_hold)
    expected = np.hstack([X_ref, Y_ref])
    worst = 0.0
    for j, name in enumerate(names):
        scale = np.max(np.abs(expected[:, j]))
        assert scale > 0, name
        err = np.max(np.abs(got[:, j] - expected[:, j])) / scale
        worst = max(worst, err)
        assert err < 1e-9, f"{name}: relative error {err:.2e}"
    print(f"h = {h}, {'FOH' if first_order_hold else 'ZOH'}: worst relative error {worst:.2e}")


def test_held_and_interpolated_inputs_differ_so_the_check_has_teeth(plant_fmu):
    h = 1e-2
    held, _ = run_fmu(plant_fmu, h, 50, False)
    ramp, _ = run_fmu(plant_fmu, h, 50, True)
    assert np.max(np.abs(held[:, 0] - ramp[:, 0])) > 1e-4 * np.max(np.abs(held[:, 0]))


def test_errors_reach_the_importer_logger_formatted(plant_fmu):
    LOG.clear()
    messages = LOG
    s = Slave(plant_fmu, capture_log=True)
    with pytest.raises(Exception):
        s.fmu.doStep(0.0, 1e-3)
    assert ("plant", 3, "logStatusError", "fmi2DoStep: illegal call in state Instantiated") in messages
    s.fmu.reset()
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.fmu.exitInitializationMode()
    with pytest.raises(Exception):
        s.fmu.setReal(s.refs(["road_z_fl"]), [float("nan")])
    assert any("value of 'road_z_fl' must be finite, got NaN" in m[3] for m in messages)
    assert s.fmu.getReal(s.refs(["road_z_fl"])) == [0.0]
    s.close()


def test_wrong_guid_is_refused(plant_fmu):
    md = read_model_description(plant_fmu)
    d = extract(plant_fmu)
    fmu = FMU2Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=d,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
    with pytest.raises(Exception):
        fmu.instantiate()
    fmu.freeLibrary()
    shutil.rmtree(d, ignore_errors=True)


def test_negative_mass_is_refused_before_initialisation(plant_fmu):
    s = Slave(plant_fmu)
    with pytest.raises(Exception):
        s.fmu.setReal(s.refs(["m_s"]), [-1500.0])
    s.close()


def test_fmu_state_serialises_across_instances(plant_fmu):
    a, b = Slave(plant_fmu), Slave(plant_fmu)
    for s in (a, b):
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        s.fmu.exitInitializationMode()
    refs = a.refs(INPUT_NAMES)
    h = 1e-3
    for k in range(200):
        a.fmu.setReal(refs, list(inputs_at(k * h)))
        a.fmu.doStep(k * h, h)
    state = a.fmu.getFMUstate()
    blob = a.fmu.serializeFMUstate(state)
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    out = a.refs(STATE_NAMES)
    for k in range(200, 400):
        for s in (a, b):
            s.fmu.setReal(refs, list(inputs_at(k * h)))
            s.fmu.doStep(k * h, h)
        assert a.fmu.getReal(out) == b.fmu.getReal(out)
    corrupt = bytearray(blob)
    corrupt[len(corrupt) // 2] ^= 0xFF
    with pytest.raises(Exception):
        b.fmu.deSerializeFMUstate(bytes(corrupt))
    a.close()
    b.close()
