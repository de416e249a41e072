"""The plant FMU's Model Exchange interface as an importer runs it: FMPy integrates it with
CVode (events located by its root finder) and must land on the plant's own Co-Simulation,
whose steps are exact; a linearisation through the FMU gives the car's modes the README
states."""

import ctypes
import pathlib
import re

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model

ROOT = pathlib.Path(__file__).resolve().parents[2]

# Constant inputs from t = 0 (FMPy sets them as start values), so both interfaces see the same
# inputs exactly. The second drives the FL wheel into its bump stop, the seat into its rebound
# stop and the FR suspension into its rebound stop: contact events, located by CVode.
SCENARIOS = {
    "linear": {"road_z_fl": 0.05, "u_seat": 300.0},
    "stops": {"road_z_fl": 0.15, "u_seat": 1000.0, "u_fr": 2500.0},
    # 10 Hz actuators, the seat's losing half its force at 0.5 s: the lag's states and the
    # fault's time event.
    "lag and fault": {"road_z_rr": 0.03, "u_seat": 400.0, "u_rl": -800.0,
                      "actuator_bandwidth": 10.0, "fault_time": 0.5, "fault_loss_seat": 0.5},
}
OUTPUTS = ["x[1]", "x[4]", "x[13]", "stroke_fl", "stroke_fr", "stroke_seat", "tire_force_fl",
           "tire_force_fr", "stop_force_fl", "stop_force_fr", "stop_force_seat", "a_seat",
           "a_seat_wk", "f_seat"]
RTOL = 1e-13
DWELL = ["stop_time_fl", "stop_time_fr", "stop_time_seat"]


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_cvode_on_model_exchange_matches_the_exact_co_simulation(plant_fmu, scenario):
    """Each output within 1e-8 of its range over 2 s at CVode's relative tolerance 1e-13
    (measured: at most 7e-10, the seat's W_k acceleration on the stops). The times at a stop
    integrate the switching instants, which the indicators' 0.1 nm hysteresis moves by about
    1e-9 s each: within 1e-8 s."""
    common = dict(stop_time=2.0, output_interval=1e-3, start_values=SCENARIOS[scenario],
                  output=OUTPUTS + DWELL)
    me = simulate_fmu(plant_fmu, fmi_type="ModelExchange", solver="CVode",
                      relative_tolerance=RTOL, record_events=False, **common)
    cs = simulate_fmu(plant_fmu, fmi_type="CoSimulation", **common)
    assert len(me) == len(cs) == 2001
    worst = {}
    for name in OUTPUTS:
        span = np.ptp(cs[name])
        if span == 0.0:
            assert np.all(me[name] == cs[name]), name
            continue
        worst[name] = np.max(np.abs(me[name] - cs[name])) / span
    print(scenario, {k: f"{v:.1e}" for k, v in worst.items()})
    assert max(worst.values()) <= 1e-8, worst
    for name in DWELL:
        assert np.max(np.abs(me[name] - cs[name])) <= 1e-8, name
    if scenario == "stops":
        # The run switches contacts: the comparison covers the events.
        for name in ["stop_force_fl", "stop_force_fr", "stop_force_seat"]:
            assert np.ptp(cs[name]) > 100.0, name
    if scenario == "lag and fault":
        # The seat's force rises behind its lag, then halves at the fault.
        t = cs["time"]
        assert 390.0 < cs["f_seat"][t == 0.5 - 1e-3][0] < 400.0
        assert abs(cs["f_seat"][-1] - 200.0) < 1.0 and abs(me["f_seat"][-1] - 200.0) < 1.0


def readme_modes():
    """The car's undamped modal frequencies as the README states them [Hz]: heave, pitch,
    roll, seat, and the wheel-hop range."""
    text = (ROOT / "README.md").read_text()
    block = text.split("<!-- modes:begin -->")[1].split("<!-- modes:end -->")[0]
    heave, pitch, roll, seat = (float(re.search(rf"{w} ([0-9.]+) Hz", block).group(1))
                                for w in ["body heave", "pitch", "roll", "seat"])
    low, high = map(float, re.search(r"wheel hop ([0-9.]+)–([0-9.]+) Hz", block).groups())
    return [heave, pitch, roll, seat], (low, high)


def test_a_linearisation_through_the_fmu_gives_the_readme_modes(plant_fmu):
    """Central differences of the derivatives through the Model Exchange interface at the
    equilibrium give the car's A (exactly, up to round-off: it is linear there); its
    position-to-acceleration block is -M^-1 K, whose eigenvalues are the undamped modes the
    README lists, to the two decimals it prints."""
    md = read_model_description(plant_fmu)
    assert md.modelExchange is not None and md.numberOfContinuousStates == 41
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(plant_fmu), modelIdentifier="plant",
                    instanceName="linearise")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    assert not fmu.newDiscreteStates()[0]
    fmu.enterContinuousTimeMode()
    nx = md.numberOfContinuousStates
    x0 = np.zeros(nx)
    fmu.getContinuousStates(x0.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), nx)

    def derivatives(x):
        dx = np.zeros(nx)
        fmu.setContinuousStates(x.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), nx)
        fmu.getDerivatives(dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), nx)
        return dx

    a = np.zeros((16, 16))
    for j in range(16):
        e = np.zeros(nx)
        e[j] = 1e-4
        a[:, j] = ((derivatives(x0 + e) - derivatives(x0 - e)) / 2e-4)[:16]
    fmu.terminate()
    fmu.freeInstance()
    stiffness = -a[8:, :8]
    hz = np.sort(np.sqrt(np.linalg.eigvals(stiffness).real)) / (2 * np.pi)
    (heave, pitch, roll, seat), (hop_low, hop_high) = readme_modes()
    body = sorted([heave, pitch, roll, seat])
    print("linearised modes [Hz]:", np.round(hz, 3))
    assert np.allclose(hz[:4], body, atol=0.005 + 1e-9), (hz[:4], body)
    assert abs(hz[4] - hop_low) <= 0.005 + 1e-9 and abs(hz[7] - hop_high) <= 0.005 + 1e-9, hz[4:]


def test_fmpys_directional_derivatives_are_the_finite_differences(plant_fmu):
    """FMPy's `getDirectionalDerivative` on the Model Exchange plant (the Jacobian an
    importer's linearisation asks for) against central differences of the derivatives through
    the same FMU: the car's A and its B along the seat command, to 1e-9 of their largest
    entry."""
    md = read_model_description(plant_fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(plant_fmu), modelIdentifier="plant",
                    instanceName="jacobian")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["u_seat"]], [100.0])
    fmu.exitInitializationMode()
    fmu.newDiscreteStates()
    fmu.enterContinuousTimeMode()
    nx = md.numberOfContinuousStates
    x0 = np.zeros(nx)
    p = ctypes.POINTER(ctypes.c_double)
    fmu.getContinuousStates(x0.ctypes.data_as(p), nx)
    ders = [vr[f"der(x[{k}])"] for k in range(1, 17)]
    knowns = [f"x[{k}]" for k in range(1, 17)] + ["u_seat"]

    def derivatives(x):
        dx = np.zeros(nx)
        fmu.setContinuousStates(x.ctypes.data_as(p), nx)
        fmu.getDerivatives(dx.ctypes.data_as(p), nx)
        return dx[:16]

    for j, known in enumerate(knowns):
        column = np.array(fmu.getDirectionalDerivative(ders, [vr[known]], [1.0]))
        if j < 16:
            e = np.zeros(nx)
            e[j] = 1e-4
            reference = (derivatives(x0 + e) - derivatives(x0 - e)) / 2e-4
        else:
            fmu.setContinuousStates(x0.ctypes.data_as(p), nx)
            fmu.setReal([vr["u_seat"]], [110.0])
            up = derivatives(x0)
            fmu.setReal([vr["u_seat"]], [90.0])
            reference = (up - derivatives(x0)) / 20.0
            fmu.setReal([vr["u_seat"]], [100.0])
        assert np.max(np.abs(column - reference)) <= 1e-9 * np.max(np.abs(reference)), known
    fmu.terminate()
    fmu.freeInstance()


def test_the_road_as_model_exchange_announces_its_kinks():
    """The road FMU is Model Exchange too (no state: its outputs are functions of time), so an
    importer that takes Model Exchange only can drive the Model Exchange plant with it. Where a
    height or a velocity kinks (a terrain ramp's ends, a pothole's ramps), under the front and
    then the rear wheels, it asks for a time event; its outputs equal the Co-Simulation's."""
    road = str(ROOT / "dist" / "road.fmu")
    speed, wheelbase = 10.0, 2.4
    values = {"profile": 4, "pothole_depth": -0.05, "pothole_length": 3.0, "pothole_ramp": 0.5,
              "speed": speed, "ramp_rise": 0.5, "ramp_length": 30.0}
    outputs = ["road_z_fl", "road_z_rr", "road_v_fl", "road_v_rr"]
    common = dict(stop_time=5.0, output_interval=1e-3, start_values=values, output=outputs)
    me = simulate_fmu(road, fmi_type="ModelExchange", record_events=True, **common)
    t = me["time"]
    events = sorted({t[i] for i in range(1, len(t)) if t[i] == t[i - 1]})
    start = read_model_description(road)
    start_distance = next(float(v.start) for v in start.modelVariables if v.name == "start_distance")
    # The pothole's ramps (0, 0.5, 2.5, 3 m past start_distance) and the terrain ramp's ends
    # (0 and 30 m), under the front wheels and a wheelbase later under the rear ones; the one
    # at t = 0 is the start's.
    expected = sorted({round((d + w) / speed, 12)
                       for d in [start_distance + s for s in (0.0, 0.5, 2.5, 3.0)] + [0.0, 30.0]
                       for w in (0.0, wheelbase)} - {0.0})
    expected = [e for e in expected if e < 5.0]
    assert np.allclose(events, expected, atol=1e-9), (events, expected)
    me = simulate_fmu(road, fmi_type="ModelExchange", record_events=False, **common)
    cs = simulate_fmu(road, fmi_type="CoSimulation", **common)
    for name in outputs:
        assert np.array_equal(me[name], cs[name]), name
