"""FMI 3.0 (`dist/fmi3/`): every FMU validates in FMPy and carries the FMI 2.0 FMU's variables
with the same value references; the closed loop over FMI 3.0 (road FMU, plant, controller in a
Gauss-Seidel master written here) is the FMI 2.0 loop bit for bit; the plant's Model Exchange
through FMI 3.0 in FMPy's CVode lands on its FMI 2.0 twin and on its own Co-Simulation; the
FMI 3.0 calling rules hold, and what the FMUs do not have is refused with a message. A controller
ticked by its sample clock (Event Mode) is the certified Gauss-Seidel loop in every master order."""

import ctypes
import json
import pathlib
import re
import shutil
import zipfile
from xml.etree import ElementTree

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Model, FMU2Slave
from fmpy.fmi3 import FMU3Model, FMU3Slave, fmi3ValueReference
from fmpy.validation import validate_fmu

ROOT = pathlib.Path(__file__).resolve().parents[2]
CONTROLLERS = ["hinf_sf", "hinf_of", "hinf_of_aw", "robust_sf", "robust_of", "delay_sf", "ft_of", "skyhook", "lqg"]
FMUS = ["road", "plant"] + CONTROLLERS
ROAD = [f"road_{q}_{c}" for q in "zv" for c in ("fl", "fr", "rl", "rr")]
FORCES = ["u_fl", "u_fr", "u_rl", "u_rr", "u_seat"]
TIME_VR = 1_000_000_000
SAMPLE_CLOCK_VR = 8000


def path(name, fmi):
    p = ROOT / "dist" / ("fmi3" if fmi == 3 else "") / f"{name}.fmu"
    if not p.exists():
        pytest.fail(f"{p} not found: run `make` first")
    return str(p)


@pytest.mark.parametrize("name", FMUS)
def test_every_fmi3_fmu_validates_and_carries_the_fmi2_variables(name):
    fmu3 = path(name, 3)
    assert validate_fmu(fmu3) == []
    md2, md3 = read_model_description(path(name, 2)), read_model_description(fmu3)
    assert md3.fmiVersion == "3.0" and md3.instantiationToken == md2.guid
    # A controller has Event Mode: its sample clock ticks it, and clocks its outputs, which are
    # discrete and no initial unknowns; a plant or road has neither.
    clocked = name in CONTROLLERS
    assert md3.coSimulation is not None and md3.coSimulation.hasEventMode is clocked
    clocks = [v for v in md3.modelVariables if v.type == "Clock"]
    if clocked:
        [clock] = clocks
        assert (clock.name, clock.valueReference, clock.causality) == ("sample", SAMPLE_CLOCK_VR, "input")
        # FMPy reads no interval: the XML says it.
        with zipfile.ZipFile(fmu3) as z:
            xml = ElementTree.fromstring(z.read("modelDescription.xml"))
        element = xml.find("ModelVariables/Clock")
        assert element.get("intervalVariability") == "constant"
        assert float(element.get("intervalDecimal")) == 1e-3
        outputs = [v for v in md3.modelVariables if v.causality == "output"]
        assert outputs and all(v.clocks == [clock] and v.variability == "discrete" for v in outputs)
        assert not {u.variable.name for u in md3.initialUnknowns} & {v.name for v in outputs}
    else:
        assert clocks == []

    def table(md):
        # FMI 2.0's Real outputs are continuous; FMI 3.0's clocked ones discrete.
        return {v.name: (v.valueReference, v.causality,
                         "discrete" if clocked and v.causality == "output" else v.variability)
                for v in md.modelVariables if v.type != "Clock"}
    two, three = table(md2), table(md3)
    # Every FMI 2.0 variable, and FMI 3.0's own: the independent time and (Model Exchange) the
    # event indicators, above every model variable's reference.
    extra = {k: v for k, v in three.items() if k not in two}
    assert {k: three[k] for k in two} == two
    assert extra.pop("time") == (TIME_VR, "independent", "continuous")
    # A controller's matrices, FMI 3.0 arrays (held to its resource file below).
    for name in ("A_c", "B_c", "C_c", "D_c"):
        if name in extra:
            assert clocked and extra.pop(name)[1:] == ("calculatedParameter", "fixed")
    n = len(md3.eventIndicators)
    assert sorted(extra) == sorted(f"event_indicator[{i + 1}]" for i in range(n))
    assert all(vr > TIME_VR for vr, _, _ in extra.values())
    assert (md3.modelExchange is not None) == (md2.modelExchange is not None)
    if md2.modelExchange is not None:
        assert n == md2.numberOfEventIndicators and len(md3.derivatives) == len(md2.derivatives)
    # Typed: a Real is a Float64, an Integer an Int32.
    types = {v.name: v.type for v in md3.modelVariables}
    for v in md2.modelVariables:
        assert types[v.name] == {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}[v.type]


@pytest.mark.parametrize("name", FMUS)
def test_fmpy_simulates_every_fmi3_fmu_as_it_comes(name):
    """`fmpy simulate` with its defaults (Co-Simulation; for a controller without Event Mode,
    which FMPy's simulate_fmu does not drive clocks in): it runs, and every output is finite."""
    res = simulate_fmu(path(name, 3), stop_time=0.1, output_interval=1e-3)
    assert len(res) == 101
    outputs = [n for n in res.dtype.names if n != "time"]
    assert outputs and all(np.isfinite(res[n]).all() for n in outputs)


class Slave:
    """One FMU of either version, instantiated and initialised with `parameters`."""

    def __init__(self, name, fmi, parameters=None, integers=None, log=None, clocked=False):
        p = path(name, fmi)
        self.md = read_model_description(p)
        self.dir = extract(p)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmi = fmi
        identifier = self.md.coSimulation.modelIdentifier
        if fmi == 3:
            self.fmu = FMU3Slave(guid=self.md.guid, unzipDirectory=self.dir, modelIdentifier=identifier,
                                 instanceName=name)
            self.fmu.instantiate(logMessage=log, eventModeUsed=clocked)
        else:
            self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir, modelIdentifier=identifier,
                                 instanceName=name)
            self.fmu.instantiate()
        for k, v in (parameters or {}).items():
            if k in self.vr:
                self.set([k], [v])
        for k, v in (integers or {}).items():
            vr = [self.vr[k]]
            self.fmu.setInt32(vr, [v]) if fmi == 3 else self.fmu.setInteger(vr, [v])
        if fmi == 3:
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def get(self, names):
        vr = [self.vr[n] for n in names]
        return self.fmu.getFloat64(vr) if self.fmi == 3 else self.fmu.getReal(vr)

    def set(self, names, values):
        vr = [self.vr[n] for n in names]
        return self.fmu.setFloat64(vr, values) if self.fmi == 3 else self.fmu.setReal(vr, values)

    def step(self, t, h, tick=False):
        if self.fmi == 3:
            event, terminate, early, last = self.fmu.doStep(t, h)
            # A clocked instance asks for Event Mode where a step ends at its tick.
            assert event == tick and not (terminate or early)
            assert last == pytest.approx(t + h, abs=1e-12)
        else:
            self.fmu.doStep(t, h)

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def inputs(md):
    """The inputs a master exchanges values of (a controller's clock is no value)."""
    return [v.name for v in md.modelVariables if v.causality == "input" and v.type != "Clock"]


BUMP = {"bump_height": 0.08, "bump_length": 3.0, "speed": 15.0, "start_distance": 1.5}


def ordered_loop(fmi, controller, order, clocked=False, seconds=2.0, h=1e-3):
    """The bump loop in a master order: "gauss-seidel" (the plant's outputs set on the controller,
    its command read and set on the plant, then every FMU steps) or "controller first" (the
    controller stepped first, its command read after its step driving the plant over the step
    it took; legitimate, and the order `delay_sf` loses its comfort in over FMI 2.0). With
    `clocked` the FMI 3.0 controller runs in Event Mode and its sample clock ticks it at every
    communication point: the command is computed at the tick and held."""
    road = Slave("road", fmi, BUMP, {"profile": 1})
    plant = Slave("plant", fmi)
    ctrl = Slave(controller, fmi, clocked=clocked)
    reads = inputs(ctrl.md)
    record = ["a_seat", "stroke_fl", "stroke_seat", "f_fl", "f_seat", "tire_load_rl"]
    log = []
    t = 0.0
    for k in range(int(round(seconds / h))):
        if order == "jacobi":
            # Every output read before any input is set; the command given is the one at hand
            # then, or with a clock the one its tick gives (the event's outputs read again).
            r, y, u = road.get(ROAD), plant.get(reads), ctrl.get(FORCES)
            plant.set(ROAD, r)
            ctrl.set(reads, y)
        else:
            plant.set(ROAD, road.get(ROAD))
            ctrl.set(reads, plant.get(reads))
        if clocked:  # in Event Mode at the tick (after initialisation, then after each step)
            ctrl.fmu.setClock([SAMPLE_CLOCK_VR], [True])
            need, terminate, _, _, defined, following = ctrl.fmu.updateDiscreteStates()
            assert not (need or terminate) and defined and following == pytest.approx(t + h, abs=1e-12)
            ctrl.fmu.enterStepMode()
        if order == "controller first":
            ctrl.step(t, h, tick=clocked)
        plant.set(FORCES, u if order == "jacobi" and not clocked else ctrl.get(FORCES))
        log.append(plant.get(record) + ctrl.get(FORCES))
        for s in (road, plant) + ((ctrl,) if order != "controller first" else ()):
            s.step(t, h, tick=clocked and s is ctrl)
        t = (k + 1) * h
        if clocked:
            ctrl.fmu.enterEventMode()
    for s in (road, plant, ctrl):
        s.close()
    return np.array(log)


@pytest.mark.parametrize("controller", ["hinf_of", "delay_sf", "ft_of", "skyhook"])
def test_the_fmi3_closed_loop_is_the_fmi2_loop_bit_for_bit(controller):
    for order in ("gauss-seidel", "controller first"):
        two, three = ordered_loop(2, controller, order), ordered_loop(3, controller, order)
        assert np.abs(two).max() > 0.1  # the bump moves the car and the actuators
        assert np.array_equal(two, three), (order, np.abs(two - three).max())


@pytest.mark.parametrize("controller", ["delay_sf", "hinf_sf", "hinf_of", "ft_of", "lqg"])
def test_a_clocked_controller_is_the_gauss_seidel_loop_in_every_master_order(controller):
    """Ticked by its clock, the command a master reads is the one computed at the last tick
    whatever it steps first: Gauss-Seidel and controller first are FMI 2.0's Gauss-Seidel loop
    (the one the certificates predict) bit for bit. In the Jacobi order the tick samples the
    plant's outputs before the road's new values reach them (the plant's feedthrough from the
    road): within 0.5 % of it in RMS seat acceleration. Over FMI 2.0 the controller-first and
    Jacobi orders read another command: `delay_sf` and `hinf_sf`, which feed measurements
    through, lose 9-12 % on this bump."""
    rms = lambda log: np.sqrt(np.mean(log[:, 0] ** 2))
    reference = ordered_loop(2, controller, "gauss-seidel")
    assert np.abs(reference).max() > 0.1
    for order in ("gauss-seidel", "controller first"):
        clocked = ordered_loop(3, controller, order, clocked=True)
        assert np.array_equal(clocked, reference), (order, np.abs(clocked - reference).max())
    jacobi = rms(ordered_loop(3, controller, "jacobi", clocked=True)) / rms(reference) - 1
    unclocked = {o: rms(ordered_loop(2, controller, o)) / rms(reference) - 1
                 for o in ("jacobi", "controller first")}
    print(f"{controller}: RMS a_seat against Gauss-Seidel: clocked Jacobi {jacobi:+.2%}; over FMI 2.0 "
          + ", ".join(f"{o} {d:+.2%}" for o, d in unclocked.items()))
    assert abs(jacobi) < 5e-3
    if controller in ("delay_sf", "hinf_sf"):
        assert min(unclocked.values()) > 0.05, unclocked


@pytest.mark.parametrize("start", [
    # The FL wheel into its bump stop, the seat and the FR suspension into their rebound stops.
    {"road_z_fl": 0.15, "u_seat": 1000.0, "u_fr": 2500.0},
    # 10 Hz actuators and the seat losing half its force at 0.5 s (a time event).
    {"road_z_rr": 0.03, "u_seat": 400.0, "u_rl": -800.0, "actuator_bandwidth": 10.0, "fault_time": 0.5,
     "fault_loss_seat": 0.5},
], ids=["stops", "lag and fault"])
def test_the_plant_through_fmi3_model_exchange_matches_fmi2_and_its_co_simulation(start):
    """FMPy's CVode (relative tolerance 1e-13) on the FMI 3.0 Model Exchange plant, its contacts'
    and the fault's events included: against the same integration through FMI 2.0 and against
    the FMI 3.0 Co-Simulation (exact steps), each output within 1e-8 of its range, as
    `test_model_exchange.py` holds FMI 2.0's."""
    outputs = ["x[1]", "x[13]", "stroke_fl", "stroke_fr", "stroke_seat", "stop_force_fl", "a_seat", "f_seat"]
    run = lambda fmi, kind, **kw: simulate_fmu(path("plant", fmi), fmi_type=kind, stop_time=2.0, start_values=start,
                                               output=outputs, output_interval=1e-3, **kw)
    me3 = run(3, "ModelExchange", solver="CVode", relative_tolerance=1e-13, record_events=False)
    me2 = run(2, "ModelExchange", solver="CVode", relative_tolerance=1e-13, record_events=False)
    cs3 = run(3, "CoSimulation")
    cs2 = run(2, "CoSimulation")
    assert len(me3) == len(cs3) == 2001
    for name in outputs:
        assert np.array_equal(cs3[name], cs2[name]), name
        scale = np.ptp(cs3[name])  # 0 for a constant (an ideal actuator's force)
        assert np.abs(me3[name] - me2[name]).max() <= 1e-8 * scale, name
        assert np.abs(me3[name] - cs3[name]).max() <= 1e-8 * scale, name


def test_the_comparison_ran_every_run_over_fmi3_too_and_each_is_its_fmi2_run():
    """`master compare` (`make`) runs every scenario with every controller again through the FMI
    3.0 FMUs and reports how many are identical to their FMI 2.0 run bit for bit: all."""
    report = (ROOT / "results" / "report.md").read_text()
    found = re.search(r"## FMI 3\.0\n\n.*?(\d+) of (\d+) identical to its FMI 2\.0 run bit for bit", report, re.S)
    assert found, "results/report.md has no FMI 3.0 section: run `make compare`"
    same, total = map(int, found.groups())
    assert total >= 100 and same == total, found.group(0)


@pytest.fixture
def messages():
    return []


def plant3(messages, **kw):
    def log(env, status, category, message):
        messages.append((status, category.decode(), message.decode()))
    return Slave("plant", 3, log=log, **kw)


def test_fmi3_state_machine_and_arguments_are_enforced_with_a_message(messages):
    p = path("plant", 3)
    md = read_model_description(p)
    unzipped = extract(p)
    try:
        def log(env, status, category, message):
            messages.append((status, category.decode(), message.decode()))

        # A wrong instantiation token, and Co-Simulation's Event Mode (hasEventMode = false).
        wrong = FMU3Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=unzipped,
                          modelIdentifier="plant", instanceName="wrong")
        with pytest.raises(Exception, match="Failed to instantiate"):
            wrong.instantiate(logMessage=log)
        assert any("instantiation token mismatch" in m for _, _, m in messages), messages
        events = FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier="plant", instanceName="events")
        with pytest.raises(Exception, match="Failed to instantiate"):
            events.instantiate(logMessage=log, eventModeUsed=True)
        assert any("hasEventMode = false" in m for _, _, m in messages), messages

        fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier="plant", instanceName="plant")
        fmu.instantiate(logMessage=log)
        # A step before initialisation.
        with pytest.raises(FMICallException):
            fmu.doStep(0.0, 1e-3)
        assert messages[-1][0] == 3 and "fmi3DoStep: illegal call in state Instantiated" in messages[-1][2]
        fmu.reset()
        # In Initialization Mode: nValues that is not nValueReferences, a type the FMU has none
        # of, and the independent variable, which is readable and not settable.
        vr = (fmi3ValueReference * 1)(md.modelVariables[0].valueReference)
        out = (ctypes.c_double * 2)()
        refusals = [
            (lambda: fmu.fmi3GetFloat64(fmu.component, vr, 1, out, 2), "every variable of this FMU is a scalar"),
            (lambda: fmu.getFloat32([md.modelVariables[0].valueReference]), "this FMU has no Float32 variable"),
            (lambda: fmu.setFloat64([TIME_VR], [1.0]), "'time' is the independent variable"),
        ]
        for call, why in refusals:
            fmu.enterInitializationMode(startTime=0.25)
            assert fmu.getFloat64([TIME_VR]) == [0.25]
            assert fmu.getFloat32([]) == []  # naming no variable changes nothing
            with pytest.raises(FMICallException):
                call()
            assert messages[-1][0] == 3 and why in messages[-1][2], messages[-1]
            fmu.reset()
        for call, why in [(lambda: fmu.enterConfigurationMode(), "no structural parameters"),
                          (lambda: fmu.enterStepMode(), "illegal call in state Instantiated")]:
            with pytest.raises(FMICallException):
                call()
            assert why in messages[-1][2], messages[-1]
            fmu.reset()
        fmu.freeInstance()
    finally:
        shutil.rmtree(unzipped, ignore_errors=True)


def test_an_fmi3_state_serialises_and_restores_by_value(messages):
    plant = plant3(messages)
    plant.set(["road_z_fl", "road_v_fl"], [0.01, 0.2])
    for k in range(200):
        plant.step(k * 1e-3, 1e-3)
    state = plant.fmu.getFMUState()
    data = plant.fmu.serializeFMUState(state)
    plant.fmu.freeFMUState(state)
    before = plant.get(["a_seat", "stroke_fl"]) + plant.fmu.getFloat64([TIME_VR])
    for k in range(200, 400):
        plant.step(k * 1e-3, 1e-3)
    after = plant.get(["a_seat", "stroke_fl"])
    plant.fmu.setFMUState(plant.fmu.deserializeFMUState(data))
    assert plant.get(["a_seat", "stroke_fl"]) + plant.fmu.getFloat64([TIME_VR]) == before
    for k in range(200, 400):
        plant.step(k * 1e-3, 1e-3)
    assert plant.get(["a_seat", "stroke_fl"]) == after
    plant.close()


def test_the_fmi3_model_exchange_jacobians_are_the_fmi2_ones_and_its_indicators_are_variables():
    """The linearisation an FMI 3.0 importer asks for: `fmi3GetDirectionalDerivative` of the
    Model Exchange plant along every state and the seat command equals FMI 2.0's (which
    `test_model_exchange.py` holds to central differences), and each `event_indicator[i]`
    variable reads what `fmi3GetEventIndicators` gives."""
    models = {}
    for fmi, cls in [(2, FMU2Model), (3, FMU3Model)]:
        md = read_model_description(path("plant", fmi))
        fmu = cls(guid=md.guid, unzipDirectory=extract(path("plant", fmi)), modelIdentifier="plant",
                  instanceName=f"jacobian{fmi}")
        fmu.instantiate()
        vr = {v.name: v.valueReference for v in md.modelVariables}
        if fmi == 3:
            fmu.enterInitializationMode(startTime=0.0)
            fmu.setFloat64([vr["u_seat"], vr["road_z_fl"]], [100.0, 0.02])
            fmu.exitInitializationMode()
            fmu.updateDiscreteStates()
        else:
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.setReal([vr["u_seat"], vr["road_z_fl"]], [100.0, 0.02])
            fmu.exitInitializationMode()
            fmu.newDiscreteStates()
        fmu.enterContinuousTimeMode()
        models[fmi] = (md, fmu, vr)
    (md2, fmu2, vr2), (md3, fmu3, vr3) = models[2], models[3]
    ders = [f"der(x[{k}])" for k in range(1, 17)]
    for known in [f"x[{k}]" for k in range(1, 17)] + ["u_seat", "road_v_fl"]:
        two = fmu2.getDirectionalDerivative([vr2[d] for d in ders], [vr2[known]], [1.0])
        three = fmu3.getDirectionalDerivative([vr3[d] for d in ders], [vr3[known]], [1.0])
        assert three == two and any(v != 0.0 for v in two), known
    n = len(md3.eventIndicators)
    assert n == 14
    indicators = (ctypes.c_double * n)()
    fmu3.fmi3GetEventIndicators(fmu3.component, indicators, n)
    named = fmu3.getFloat64([vr3[f"event_indicator[{i + 1}]"] for i in range(n)])
    assert named == list(indicators) and any(v != 0.0 for v in named)
    for fmu in (fmu2, fmu3):
        fmu.terminate()
        fmu.freeInstance()


def test_the_fmi3_road_as_model_exchange_announces_the_same_kinks():
    """The FMI 3.0 road in FMPy's Model Exchange: the same time events as FMI 2.0's (a pothole's
    ramps and a terrain ramp's ends under the front and then the rear wheels) and the same
    outputs, equal to its Co-Simulation."""
    values = {"profile": 4, "pothole_depth": -0.05, "pothole_length": 3.0, "pothole_ramp": 0.5,
              "speed": 10.0, "ramp_rise": 0.5, "ramp_length": 30.0}
    outputs = ["road_z_fl", "road_z_rr", "road_v_fl", "road_v_rr"]
    common = dict(stop_time=5.0, output_interval=1e-3, start_values=values, output=outputs)
    runs = {fmi: simulate_fmu(path("road", fmi), fmi_type="ModelExchange", record_events=True, **common)
            for fmi in (2, 3)}
    events = {fmi: [t for i, t in enumerate(r["time"][1:]) if t == r["time"][i]] for fmi, r in runs.items()}
    assert len(events[3]) >= 8 and events[3] == events[2]
    for name in outputs:
        assert np.array_equal(runs[3][name], runs[2][name]), name
    cs = simulate_fmu(path("road", 3), fmi_type="CoSimulation", **common)
    me = simulate_fmu(path("road", 3), fmi_type="ModelExchange", record_events=False, **common)
    for name in outputs:
        assert np.array_equal(me[name], cs[name]), name


def test_the_sample_clock_is_enforced_with_a_message(messages):
    """Ticked by its clock, a controller steps only between ticks, ticks only at its ticks and
    in Event Mode, says why it refuses anything else, and keeps its clock in its FMU state."""
    def log(env, status, category, message):
        messages.append((status, category.decode(), message.decode()))

    def clocked(name="hinf_of", **kw):
        return Slave(name, 3, log=log, clocked=True, **kw)

    def tick(ctrl, t):
        ctrl.fmu.setClock([SAMPLE_CLOCK_VR], [True])
        assert ctrl.fmu.updateDiscreteStates()[4:] == (True, pytest.approx(t + 1e-3, abs=1e-12))

    def refused(call, why):
        with pytest.raises(FMICallException):
            call()
        assert messages[-1][0] == 3 and why in messages[-1][2], messages[-1]

    ctrl = clocked()  # in Event Mode at t = 0, its first tick due
    refused(lambda: ctrl.fmu.doStep(0.0, 1e-3), "fmi3DoStep: illegal call in state EventMode")
    ctrl = clocked()
    ctrl.fmu.enterStepMode()
    refused(lambda: ctrl.fmu.doStep(0.0, 1e-3), "ticks at t = 0 s and has not ticked")
    ctrl = clocked()
    tick(ctrl, 0.0)
    ctrl.fmu.enterStepMode()
    refused(lambda: ctrl.fmu.doStep(0.0, 1.5e-3), "passes the tick of clock 'sample' at 0.001 s")
    # Between ticks any steps; Event Mode is asked for where one ends at the tick.
    ctrl = clocked()
    tick(ctrl, 0.0)
    ctrl.fmu.enterStepMode()
    assert ctrl.fmu.doStep(0.0, 4e-4)[0] is False and ctrl.fmu.doStep(4e-4, 6e-4)[0] is True
    refused(lambda: ctrl.fmu.setClock([SAMPLE_CLOCK_VR], [True]), "a clock is set in Event Mode")
    ctrl = clocked()
    tick(ctrl, 0.0)
    ctrl.fmu.enterStepMode()
    ctrl.fmu.doStep(0.0, 4e-4)
    ctrl.fmu.enterEventMode()
    refused(lambda: ctrl.fmu.setClock([SAMPLE_CLOCK_VR], [True]), "is not its next tick, 0.001 s")
    # After a reset the clock starts again: Event Mode at the new start time, its first tick due.
    ctrl.fmu.reset()
    ctrl.fmu.enterInitializationMode(startTime=0.5)
    ctrl.fmu.exitInitializationMode()
    tick(ctrl, 0.5)
    ctrl.fmu.enterStepMode()
    assert ctrl.fmu.doStep(0.5, 1e-3)[0] is True
    ctrl = clocked()
    refused(lambda: ctrl.fmu.getClock([SAMPLE_CLOCK_VR]), "is an input clock")
    ctrl = clocked()
    vr = (fmi3ValueReference * 1)(SAMPLE_CLOCK_VR)
    interval, qualifier = (ctypes.c_double * 1)(), (ctypes.c_int * 1)()
    ctrl.fmu.getIntervalDecimal(vr, interval, qualifier)
    assert (interval[0], qualifier[0]) == (1e-3, 1)  # constant: fmi3IntervalUnchanged
    refused(lambda: ctrl.fmu.fmi3SetIntervalDecimal(ctrl.fmu.component, vr, 1, interval), "constant interval")
    # A predictor ticked by its clock has the Gauss-Seidel order's timing whatever the master's.
    with pytest.raises(FMICallException):
        clocked("delay_sf", integers={"master_order": 1})
    assert "master_order = 1: ticked by its clock" in messages[-1][2], messages[-1]
    # Without Event Mode the plant and road have none to enter.
    refused(lambda: Slave("plant", 3, log=log).fmu.enterEventMode(), "needs eventModeUsed = true")

    # FMPy's simulate_fmu activates no input clock: with Event Mode the first step is refused
    # (its tick never taken); without it the controller is sampled at every step, as in FMI 2.0.
    with pytest.raises(Exception, match="fmi3DoStep failed"):
        simulate_fmu(path("hinf_of", 3), stop_time=0.01, output_interval=1e-3, use_event_mode=True,
                     logger=lambda *a: None)
    assert len(simulate_fmu(path("hinf_of", 3), stop_time=0.01, output_interval=1e-3)) == 11

    # FMU state: the clock's ticks and held commands restore by value, into a clocked instance only.
    ctrl = clocked()
    reads = inputs(ctrl.md)
    commands = []
    for k in range(10):
        if k == 5:
            data = ctrl.fmu.serializeFMUState(ctrl.fmu.getFMUState())
        ctrl.set(reads, [0.01 * np.sin(k + i) for i in range(len(reads))])
        tick(ctrl, k * 1e-3)
        ctrl.fmu.enterStepMode()
        ctrl.fmu.doStep(k * 1e-3, 5e-4)
        commands.append(ctrl.get(FORCES))
        ctrl.fmu.doStep(k * 1e-3 + 5e-4, 5e-4)
        ctrl.fmu.enterEventMode()
    again = clocked()
    again.fmu.setFMUState(again.fmu.deserializeFMUState(data))
    for k in range(5, 10):
        again.set(reads, [0.01 * np.sin(k + i) for i in range(len(reads))])
        tick(again, k * 1e-3)
        again.fmu.enterStepMode()
        again.fmu.doStep(k * 1e-3, 5e-4)
        assert again.get(FORCES) == commands[k]
        again.fmu.doStep(k * 1e-3 + 5e-4, 5e-4)
        again.fmu.enterEventMode()
    assert np.abs(commands).max() > 0
    unclocked = Slave("hinf_of", 3, log=log)
    refused(lambda: unclocked.fmu.setFMUState(unclocked.fmu.deserializeFMUState(data)), "eventModeUsed")


@pytest.mark.parametrize("controller", CONTROLLERS)
def test_a_controllers_matrices_are_fmi3_arrays_of_its_resource_file(controller, messages):
    """`A_c`, `B_c`, `C_c`, `D_c` (value references 9000-9003, those with elements) are
    row-major arrays equal to the matrices of the FMU's own `resources/controller.json`; nValues
    counts their elements, and they cannot be set."""
    def log(env, status, category, message):
        messages.append((status, category.decode(), message.decode()))

    ctrl = Slave(controller, 3, log=log)
    with open(pathlib.Path(ctrl.dir) / "resources" / "controller.json") as f:
        spec = json.load(f)
    arrays = {v.name: v for v in ctrl.md.modelVariables if v.dimensions}
    expected = {k: np.array(spec[k[0]], dtype=float) for k in ("A_c", "B_c", "C_c", "D_c")}
    expected = {k: m for k, m in expected.items() if m.size}
    assert sorted(arrays) == sorted(expected)
    for name, m in expected.items():
        v = arrays[name]
        assert v.valueReference == 9000 + "ABCD".index(name[0])
        assert v.causality == "calculatedParameter" and [int(d.start) for d in v.dimensions] == list(m.shape)
        values = ctrl.fmu.getFloat64([v.valueReference], nValues=m.size)
        assert np.array_equal(np.array(values).reshape(m.shape), m), name
    # An array with a scalar: every element, then the scalar.
    d = arrays["D_c"]
    both = ctrl.fmu.getFloat64([d.valueReference, ctrl.vr["u_fl"]], nValues=expected["D_c"].size + 1)
    assert both[:-1] == list(expected["D_c"].ravel()) and both[-1] == ctrl.get(["u_fl"])[0]
    with pytest.raises(FMICallException):
        ctrl.fmu.getFloat64([d.valueReference])
    assert "an array counts its elements" in messages[-1][2], messages[-1]
    ctrl.fmu.reset()
    with pytest.raises(FMICallException):
        ctrl.fmu.setFloat64([d.valueReference], list(expected["D_c"].ravel()))
    assert "'D_c' is a calculated parameter" in messages[-1][2], messages[-1]
    ctrl.fmu.freeInstance()
    shutil.rmtree(ctrl.dir, ignore_errors=True)


def terminals(name):
    """The FMU's FMI 3.0 terminals, validated against the standard's schema (FMPy's copy):
    {(terminal, member): variable}."""
    from lxml import etree
    import fmpy
    schema = etree.XMLSchema(file=str(pathlib.Path(fmpy.__file__).parent / "schema" / "fmi3" /
                                      "fmi3TerminalsAndIcons.xsd"))
    with zipfile.ZipFile(path(name, 3)) as z:
        doc = etree.fromstring(z.read("terminalsAndIcons/terminalsAndIcons.xml"))
    schema.assertValid(doc)
    out = {}
    for t in doc.iter("Terminal"):
        assert t.get("matchingRule") == "bus"
        for m in t.iter("TerminalMemberVariable"):
            assert m.get("variableKind") == "signal"
            out[(t.get("name"), m.get("memberName"))] = m.get("variableName")
    return out


@pytest.mark.parametrize("name", FMUS)
def test_every_fmi3_fmu_has_terminals_holding_each_input_and_output_once(name):
    md = read_model_description(path(name, 3))
    io = sorted(v.name for v in md.modelVariables
                if v.causality in ("input", "output") and v.type != "Clock")
    assert sorted(terminals(name).values()) == io


@pytest.mark.parametrize("other", ["road"] + CONTROLLERS)
def test_terminals_connect_the_plant_as_the_variable_names_do(other):
    """Matching the terminals of the plant and of the road or a controller member by member
    (the `bus` rule) gives exactly the connections a master makes by name: each of the other
    FMU's inputs from the plant's output of its name, each of its outputs to the plant's input."""
    plant, theirs = terminals("plant"), terminals(other)
    by_terminal = {(plant[k], v) for k, v in theirs.items() if k in plant}
    md_plant, md_other = (read_model_description(path(n, 3)) for n in ("plant", other))
    causality = {v.name: v.causality for v in md_plant.modelVariables}
    by_name = {(v.name, v.name) for v in md_other.modelVariables
               if v.causality in ("input", "output") and v.type != "Clock" and v.name in causality}
    assert by_terminal == by_name and by_name
    them = {v.name: v.causality for v in md_other.modelVariables}
    assert all({causality[p], them[o]} == {"input", "output"} for p, o in by_terminal)
