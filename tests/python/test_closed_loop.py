"""Plant + controller FMUs in closed loop from FMPy (a small Gauss-Seidel master in Python):
the shipped designs' ride comfort against the passive car on the bump and on an ISO 8608
class-C road."""

import glob
import json
import math
import pathlib
import shutil
import subprocess

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

import master_csv

ROOT = pathlib.Path(__file__).resolve().parents[2]
ROAD = [f"road_{q}_{c}" for q in "zv" for c in ("fl", "fr", "rl", "rr")]
FORCES = ["u_fl", "u_fr", "u_rl", "u_rr", "u_seat"]
RECORD = ["a_seat", "alpha_roll", "alpha_pitch", "a_body", "stroke_fl", "stroke_fr", "stroke_rl", "stroke_rr",
          "f_fl", "f_fr", "f_rl", "f_rr", "f_seat", "tire_load_fl", "tire_load_fr", "tire_load_rl", "tire_load_rr"]


class Fmu:
    def __init__(self, name, parameters=None, integers=None):
        path = str(ROOT / "dist" / f"{name}.fmu")
        self.md = read_model_description(path)
        self.dir = extract(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.boolean = {v.name for v in self.md.modelVariables if v.type == "Boolean"}
        self.inputs = [v.name for v in self.md.modelVariables if v.causality == "input"]
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate()
        for k, v in (parameters or {}).items():
            if k in self.vr:  # the plant has them all; a controller only its force limits
                self.fmu.setReal([self.vr[k]], [v])
        for k, v in (integers or {}).items():
            self.fmu.setInteger([self.vr[k]], [v])
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def refs(self, names):
        return [self.vr[n] for n in names]

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def bump(t):
    def one(t):
        x = 15.0 * (t - 0.1)
        if 0 <= x <= 5.0:
            w = 2 * math.pi / 5.0
            return 0.025 * (1 - math.cos(w * x)), 0.025 * w * 15.0 * math.sin(w * x)
        return 0.0, 0.0
    (zf, vf), (zr, vr) = one(t), one(t - 2.4 / 15.0)
    return [zf, 0.0, zr, 0.0, vf, 0.0, vr, 0.0]


def iso_road(g_d_n0, speed, seed):
    """Sum of cosines with the ISO 8608 PSD G_d(n0)(n/n0)^-2 over 0.011-2.83 cycles/m."""
    rng = np.random.default_rng(seed)
    edges = np.geomspace(0.011, 2.83, 401)
    n = np.sqrt(edges[:-1] * edges[1:])
    amp = np.sqrt(2 * g_d_n0 * (n / 0.1) ** -2 * np.diff(edges))
    phase = rng.uniform(0, 2 * np.pi, (2, n.size))

    def track(side, x):
        arg = 2 * np.pi * n * x + phase[side]
        return float(np.sum(amp * np.cos(arg))), float(-np.sum(amp * 2 * np.pi * n * speed * np.sin(arg)))

    def at(t):
        # Faded in over 1 s (the car starts in equilibrium on a flat road), as in tests/src/lib.rs.
        w, dw = (1.0, 0.0) if t >= 1.0 else (0.5 * (1 - math.cos(math.pi * t)), 0.5 * math.pi * math.sin(math.pi * t))
        tr = [track(0, speed * t + 2.4), track(1, speed * t + 2.4), track(0, speed * t), track(1, speed * t)]
        return [w * z for z, _ in tr] + [w * v + dw * z for z, v in tr]

    return at


def run(controller, road, seconds, h=1e-3, plant_parameters=None, record=RECORD, controller_record=()):
    """The log of `record` (plant outputs) after each step, then of `controller_record`
    (controller variables, Booleans as 0/1, read once the controller has its new inputs)."""
    plant = Fmu("plant", plant_parameters)
    ctrl = Fmu(controller, plant_parameters) if controller else None
    road_refs, force_refs, rec = plant.refs(ROAD), plant.refs(FORCES), plant.refs(record)
    if ctrl:
        missing = [n for n in ctrl.inputs if n not in plant.vr]
        assert not missing, f"controller inputs missing from the plant: {missing}"
        y_from, y_to, u_from = plant.refs(ctrl.inputs), ctrl.refs(ctrl.inputs), ctrl.refs(FORCES)
    log = []
    for k in range(int(round(seconds / h))):
        t = k * h
        plant.fmu.setReal(road_refs, road(t))
        if ctrl:
            ctrl.fmu.setReal(y_to, plant.fmu.getReal(y_from))
            plant.fmu.setReal(force_refs, ctrl.fmu.getReal(u_from))
            ctrl.fmu.doStep(t, h)
        plant.fmu.doStep(t, h)
        plant.fmu.setReal(road_refs, road(t + h))
        row = plant.fmu.getReal(rec)
        if controller_record:
            ctrl.fmu.setReal(y_to, plant.fmu.getReal(y_from))
            for n in controller_record:
                value = ctrl.fmu.getBoolean([ctrl.vr[n]])[0] if n in ctrl.boolean else ctrl.fmu.getReal([ctrl.vr[n]])[0]
                row.append(float(value))
        log.append(row)
    plant.close()
    if ctrl:
        ctrl.close()
    return np.array(log)


def we_polynomials():
    """ISO 2631-1 W_e (rotational acceleration) from its definition: band limits 0.4 and 100 Hz
    (Butterworth, Q = 1/sqrt 2), a-v transition f3 = f4 = 1 Hz, Q4 = 0.63. Written here from the
    standard, independently of the Rust filters."""
    w1, w2, w4 = 2 * np.pi * 0.4, 2 * np.pi * 100.0, 2 * np.pi * 1.0
    q = 1 / np.sqrt(2)
    num = np.polymul([w2**2, 0, 0], [1 / w4, 1])
    den = np.polymul(np.polymul([1, w1 / q, w1**2], [1, w2 / q, w2**2]), [1 / w4**2, 1 / (0.63 * w4), 1])
    return num, den


def test_the_we_weighting_here_is_the_standards():
    """W_e's gain against ISO 2631-1's table (factor x 1000) at some of its frequencies."""
    num, den = we_polynomials()
    for f, factor in [(0.5, 862.0), (1.0, 880.0), (4.0, 253.0), (16.0, 62.5), (80.0, 10.5)]:
        s = 2j * np.pi * f
        assert abs(abs(np.polyval(num, s) / np.polyval(den, s)) * 1000 - factor) < 0.02 * factor, f


def we_rms(x, h=1e-3):
    """RMS of x (sampled every h, linear between samples) weighted by W_e."""
    from scipy.signal import lsim
    _, y, _ = lsim(we_polynomials(), x, np.arange(len(x)) * h)
    return float(np.sqrt(np.mean(y**2)))


def figures(log):
    rms = np.sqrt(np.mean(log ** 2, axis=0))
    peak = np.max(np.abs(log), axis=0)
    return {"seat": rms[0], "roll": rms[1], "we_roll": we_rms(log[:, 1]), "pitch": rms[2], "body": rms[3],
            "stroke": peak[4:8].max(), "corner_force": peak[8:12].max(), "seat_force": peak[12],
            "tyre_load_peak": peak[13:17]}


def test_every_fmu_in_dist_validates():
    fmus = sorted(glob.glob(str(ROOT / "dist" / "*.fmu")))
    assert len(fmus) >= 2
    for f in fmus:
        assert validate_fmu(f) == [], f


def test_fmpy_hears_a_controller_stepped_beyond_its_stable_communication_steps(capfd):
    """robust_of's certificate finds its loop as a master runs it stable at steps up to 7.5 ms with
    each of its masses (`comfort.communication_steps`): FMPy stepping it at 10 ms gets
    fmi2Warning (and goes on) with the message through its default logger, once for that step
    size; 7.5 ms is silent."""
    steps = json.loads((ROOT / "dist" / "robust_of" / "controller.json").read_text())["communication_steps"]
    assert steps["stable_up_to_s"] == 7.5e-3
    ctrl = Fmu("robust_of")
    t = 0.0
    for h in (7.5e-3, 7.5e-3, 1e-2, 1e-2):
        ctrl.fmu.doStep(t, h)
        t += h
    ctrl.close()
    out = capfd.readouterr().out
    assert out.count("communication step 0.01 s: robust_of's loop") == 1, out
    assert "use a step of at most 0.0075 s" in out and "0.0075 s:" not in out, out


# Known gap on class C (see the README): on this road realization the dynamic tyre load exceeds
# the static load (the passive car too): the wheel would lift. The ISO rows guard the measured
# tyre loads; every other target is held in full. Roll is judged as ISO 2631-1 weights it (W_e;
# README "Controllers": the comfort designs trade unweighted roll in the wheel-hop band for
# their delay guarantee). The seat 75 % below the passive car's: every design's road has long
# waves and a seat stroke limit, which cost comfort on these roads (the Rust master measures
# `hinf_of` 84.2 % on the bump, 80.5 % on class C, `hinf_sf` 87.6 % and 82.6 %:
# tests/tests/closed_loop.rs).
@pytest.mark.parametrize("controller,road,seconds,seat_reduction,roll_reduction,tyre_limit", [
    ("hinf_sf", bump, 4.0, 0.75, 0.5, 1.0),
    ("hinf_sf", iso_road(256e-6, 20.0, 7), 10.0, 0.75, 0.5, 1.15),
    ("hinf_of", bump, 4.0, 0.75, 0.5, 1.0),
    ("hinf_of", iso_road(256e-6, 20.0, 7), 10.0, 0.75, 0.5, 1.25),
], ids=["sf-bump", "sf-iso_c_20ms", "of-bump", "of-iso_c_20ms"])
def test_controller_against_passive(controller, road, seconds, seat_reduction, roll_reduction, tyre_limit):
    p = figures(run(None, road, seconds))
    a = figures(run(controller, road, seconds))
    print({k: (np.round(a[k], 4), np.round(p[k], 4)) for k in p})
    assert a["seat"] <= (1 - seat_reduction) * p["seat"]
    assert a["we_roll"] <= (1 - roll_reduction) * p["we_roll"]
    assert a["pitch"] <= p["pitch"] and a["body"] <= p["body"]
    assert a["stroke"] < 0.08 and a["corner_force"] < 2500 and a["seat_force"] < 1000
    plant = Fmu("plant")
    static = np.array(plant.fmu.getReal(plant.refs([f"static_tire_load_{c}" for c in ("fl", "fr", "rl", "rr")])))
    plant.close()
    assert np.all(a["tyre_load_peak"] < tyre_limit * static), f"dynamic tyre load {a['tyre_load_peak'] / static} of static"


# The seat's (unweighted) RMS against the passive car's: 80 % below for the state feedback,
# 75 % for `robust_of`, whose design roads with long waves and a seat stroke limit cost them
# comfort on this one (measured: `robust_sf` 86 and 84 %, `robust_of` 84 and 77 %).
@pytest.mark.parametrize("controller,floor", [("robust_sf", 0.2), ("robust_of", 0.25)])
@pytest.mark.parametrize("mass", [1200.0, 1800.0])
def test_robust_controller_on_the_lightest_and_heaviest_car(controller, floor, mass):
    """Thesis ch. 6: comfort and limits at both ends of the mass range, in FMPy."""
    road = iso_road(256e-6, 20.0, 7)
    p = figures(run(None, road, 10.0, plant_parameters={"m_s": mass}))
    a = figures(run(controller, road, 10.0, plant_parameters={"m_s": mass}))
    print(controller, mass, {k: (np.round(a[k], 4), np.round(p[k], 4)) for k in p})
    assert a["seat"] <= floor * p["seat"]
    assert a["pitch"] <= p["pitch"] and a["body"] <= p["body"]
    assert a["stroke"] < 0.08 and a["corner_force"] < 2500 and a["seat_force"] < 1000


def test_anti_windup_keeps_the_commands_within_the_limits_and_its_designed_gain_buys_comfort():
    """Thesis Th. 5.3 in FMPy: 300 N / 100 N limits on the plant and the controller, ISO class D.
    `hinf_of` carries the plain model recovery (no gain), `hinf_of_aw` the designed gain."""
    road, limits = iso_road(1024e-6, 20.0, 7), {"u_max": 300.0, "u_max_seat": 100.0}
    record = RECORD + FORCES  # the plant's inputs u_* read back: the commands it received
    p = figures(run(None, road, 20.0, plant_parameters=limits))
    # Its nominal design hinf_of: the same linear controller with the compensator's gain zero.
    plain_log = run("hinf_of", road, 20.0, plant_parameters=limits, record=record)
    aw_log = run("hinf_of_aw", road, 20.0, plant_parameters=limits, record=record)
    plain, aw = figures(plain_log), figures(aw_log)
    plain_cmd, aw_cmd = np.abs(plain_log[:, 17:]).max(), np.abs(aw_log[:, 17:]).max()
    print("seat RMS passive", p["seat"], "hinf_of", plain["seat"], "hinf_of_aw", aw["seat"], "peak command", plain_cmd, aw_cmd)
    # Both command within the limits; the designed gain buys comfort (measured 1.127 against
    # 1.166, passive 1.758 m/s²; 0.736 against 0.811 on the Rust test's road).
    assert plain_cmd <= 300.0 + 1e-9 and aw_cmd <= 300.0 + 1e-9
    assert aw["seat"] < plain["seat"] and plain["seat"] < 0.7 * p["seat"]


@pytest.mark.parametrize("tau", [0.02, 0.05])
def test_delay_sf_settles_with_the_plant_delay(tau):
    """delay_sf in FMPy with the plant's transport delay, told to its predictor through its
    parameter `tau` (the plant's name), at 20 ms and at the end of its design interval, 50 ms.
    Its slowest mode decays with a time constant of about 3 s (|a_seat| 1.5e-5 m/s² at 10 s,
    7e-7 at 20 s after a 0.025 m/s² peak at 20 ms), so the tail is judged over the 12th second."""
    log = run("delay_sf", bump, 12.0, plant_parameters={"tau": tau})
    p = figures(run(None, bump, 12.0))
    a = figures(log)
    tail = np.abs(log[-1000:, 0]).max()
    print(tau, a["seat"], p["seat"], tail)
    assert a["seat"] < 0.5 * p["seat"] and tail < 1e-3 * np.abs(log[:, 0]).max()
    assert a["stroke"] < 0.08 and a["corner_force"] < 2500 and a["seat_force"] < 1000


def test_ft_of_detects_the_fault_of_fig_8_2_and_keeps_the_seat_quiet():
    """Thesis ch. 8 in FMPy: FL loses half its force at t = 2 s on an ISO class-C road."""
    fault = {"fault_time": 2.0, "fault_loss_fl": 0.5}
    road = iso_road(256e-6, 20.0, 11)
    log = run("ft_of", road, 5.0, plant_parameters=fault, record=["a_seat"], controller_record=["residual_norm", "fault_detected"])
    # Its nominal design: the same law without accommodation or detector.
    of = run("hinf_of", road, 5.0, plant_parameters=fault, record=["a_seat"])
    passive = run(None, road, 5.0, plant_parameters=fault, record=["a_seat"])
    detected = int(np.argmax(log[:, 2] > 0.5))
    rms = lambda a, lo, hi: float(np.sqrt(np.mean(a[lo:hi, 0] ** 2)))
    print("healthy residual peak", log[:1999, 1].max(), "detected at step", detected,
          "seat after:", rms(log, 2000, 5000), rms(of, 2000, 5000), rms(passive, 2000, 5000))
    # Healthy, the load cells read what the runtime's actuator model says: the residual is
    # rounding.
    assert log[:1999, 1].max() < 1e-6 and log[:2000, 2].max() == 0.0
    assert 2000 <= detected < 2300 and log[detected:, 2].min() == 1.0
    # On the car's sensors and design road (as hinf_of) the unweighted seat RMS is about a
    # fifth of the passive car's; a corner at half force barely touches hinf_of's loop, and
    # ft_of's accommodation transient costs at most 5 % against it.
    assert rms(log, 2000, 5000) < 0.25 * rms(passive, 2000, 5000)
    assert rms(log, 2000, 5000) < 1.05 * rms(of, 2000, 5000)


def test_road_fmu_alone_in_fmpy_is_the_closed_form_bump():
    """simulate_fmu on road.fmu alone: the bump of this file's master, to rounding."""
    res = simulate_fmu(str(ROOT / "dist" / "road.fmu"), stop_time=1.0, output_interval=1e-3,
                       start_values={"profile": 1, "speed": 15.0, "start_distance": 1.5, "bump_height": 0.05},
                       output=ROAD)
    worst = max(np.abs(np.array([res[n][k] for n in ROAD]) - np.array(bump(res["time"][k]))).max() for k in range(len(res)))
    assert worst < 1e-12, worst
    assert np.abs(np.array([res[n] for n in ROAD])).max() > 0.04  # the bump is in there


class RoadFmu:
    """road.fmu as a road function of time for `run` (stepped forward to each time asked for)."""

    def __init__(self, integers, reals):
        self.f = Fmu("road", reals, integers)
        self.time, self.refs = 0.0, self.f.refs(ROAD)

    def __call__(self, t):
        if t > self.time + 1e-9:
            self.f.fmu.doStep(self.time, t - self.time)
            self.time = t
        return self.f.fmu.getReal(self.refs)


def test_road_fmu_drives_the_python_master_like_the_closed_form_bump():
    """road -> plant -> controller, all three FMUs in FMPy, against the same loop on this file's bump."""
    road = RoadFmu({"profile": 1}, {"speed": 15.0, "start_distance": 1.5, "bump_height": 0.05})
    with_fmu = run("hinf_of", road, 3.0, record=["a_seat", "stroke_fl"])
    road.f.close()
    closed_form = run("hinf_of", bump, 3.0, record=["a_seat", "stroke_fl"])
    assert np.abs(with_fmu - closed_form).max() <= 1e-9 * np.abs(closed_form).max()


def test_rust_master_and_this_python_master_give_the_same_trajectories(tmp_path):
    """`master run` (Rust, fmi crate) against this file's FMPy master: same FMUs, same step, same
    Gauss-Seidel order road -> plant -> controller."""
    binary = ROOT / "target" / "release" / "master"
    assert binary.exists(), "target/release/master not built: run `make`"
    out = tmp_path / "bump_hinf_of.csv"
    subprocess.run([str(binary), "--dist", str(ROOT / "dist"), "run", "--scenario", str(ROOT / "scenarios" / "bump.json"),
                    "--controller", "hinf_of", "--out", str(out)], check=True)
    rust = master_csv.read(out)
    # The header carries each column's unit, the one the plant declares.
    declared = {v.name: v.unit or "" for v in read_model_description(str(ROOT / "dist" / "plant.fmu")).modelVariables}
    columns = master_csv.header(out)
    assert columns[0] == ("time", "s") and dict(columns)["a_seat"] == "m/s2"
    assert [u for n, u in columns[1:]] == [declared[n] for n, _ in columns[1:]]
    scenario = json.loads((ROOT / "scenarios" / "bump.json").read_text())
    road = scenario["road"]
    ints = {k: v for k, v in road.items() if k in ("profile", "side", "iso_class", "seed")}
    reals = {k: v for k, v in road.items() if k not in ints}
    road_fmu = RoadFmu(ints, reals)
    py = run("hinf_of", road_fmu, scenario["duration"], h=scenario["step"], record=["a_seat", "stroke_fl", "f_fl"])
    road_fmu.f.close()
    assert len(rust) == len(py)
    np.testing.assert_allclose(rust["time"], np.arange(1, len(py) + 1) * scenario["step"], rtol=0, atol=1e-9)
    for k, name in enumerate(["a_seat", "stroke_fl", "f_fl"]):
        scale = np.abs(py[:, k]).max()
        assert np.abs(rust[name] - py[:, k]).max() <= 1e-9 * scale, name


def test_plant_and_controller_alone_in_fmpy_simulate_fmu():
    """fmpy.simulate_fmu on each FMU alone: the plant driven by the bump as an input signal gives
    the passive run of this file's master; hinf_of driven by a held 1 cm FL stroke gives the
    zero-order-hold discretisation (SciPy) of its controller.json."""
    from scipy.signal import cont2discrete

    ts = np.arange(0.0, 2.0 + 1e-9, 1e-3)
    signal = np.array([tuple([x] + bump(x)) for x in ts], dtype=[("time", float)] + [(n, float) for n in ROAD])
    res = simulate_fmu(str(ROOT / "dist" / "plant.fmu"), stop_time=2.0, output_interval=1e-3, step_size=1e-3, input=signal, output=["a_seat", "stroke_fl"])
    loop = run(None, bump, 2.0, record=["a_seat", "stroke_fl"])
    for k, name in enumerate(["a_seat", "stroke_fl"]):
        assert np.abs(res[name][1:] - loop[:, k]).max() <= 1e-9 * np.abs(loop[:, k]).max(), name

    spec = json.loads((ROOT / "dist" / "hinf_of" / "controller.json").read_text())
    A, B, C, D = (np.array(spec[m], dtype=float) for m in "ABCD")
    inputs = [s["name"] for s in spec["inputs"]]
    fl = next(name for name in inputs if name.endswith("stroke_fl"))
    h, n = 1e-3, 200
    stroke = np.array([(0.0,) + tuple(0.01 if name == fl else 0.0 for name in inputs), (1.0,) + tuple(0.01 if name == fl else 0.0 for name in inputs)],
                      dtype=[("time", float)] + [(name, float) for name in inputs])
    res = simulate_fmu(str(ROOT / "dist" / "hinf_of.fmu"), stop_time=n * h, output_interval=h, step_size=h, input=stroke, output=["u_fl", "u_seat"])
    Ad, Bd, _, _, _ = cont2discrete((A, B, C, D), h, method="zoh")
    y = np.zeros(len(inputs))
    y[inputs.index(fl)] = 0.01
    x = np.zeros(A.shape[0])
    expected = []
    for _ in range(n + 1):
        expected.append(C @ x + D @ y)
        x = Ad @ x + Bd @ y
    expected = np.array(expected)
    assert np.abs(expected[:, 0]).max() > 1.0  # the command does respond
    for k, name in enumerate(["u_fl", "u_seat"]):
        assert np.abs(res[name] - expected[:, [0, 4][k]]).max() <= 1e-6 * np.abs(expected[:, [0, 4][k]]).max(), name
