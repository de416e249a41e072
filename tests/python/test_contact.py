"""The physical car (issue 51) against an independent hybrid reference.

The reference is the hand-written car of `reference_car.py`, made unilateral here force by
force: each tyre pushes on its wheel only while it is compressed and pressing, each corner's bump
and rebound stop and each of the seat's end stops pushes only while it is compressed past its
free travel and pressing. Each element is engaged exactly while `min(p, F) > 0` (penetration,
force). Between switches SciPy integrates the car (DOP853, rtol 1e-12); each switch is an event
SciPy locates on the solution, after which the integration restarts in the new mode. Nothing
comes from the Rust code: the static loads are the reference's own equilibrium under gravity.

The plant FMU steps the same car exactly (matrix exponentials per mode, bisection on the exact
trajectory); both are driven by the same held inputs and must agree to 1e-9 of each output's
range through landings, lift-offs and stop contacts.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import reference_car as ref
from test_plant import INPUT_NAMES, STATE_NAMES, Slave

P = ref.PARAMS
G = P["g"]
# The plant's default stops (vehicle::contact::ContactParams), set explicitly on the FMU below.
STOPS = dict(bump_travel=0.08, rebound_travel=0.08, stop_stiffness=250e3, stop_damping=500.0,
             seat_travel=0.05, seat_stop_stiffness=100e3, seat_stop_damping=200.0)
XS = [P["L2"], P["L2"], -P["L1"], -P["L1"]]
YS = [P["w1"], -P["w2"], P["w1"], -P["w2"]]


def static_tyre_loads():
    """The reference's own equilibrium under gravity: springs unloaded at q = 0, gravity on."""
    def acc(q):
        return ref.accelerations(P, q, np.zeros(8), np.zeros(4), np.zeros(4), np.zeros(5))[0]

    K = np.column_stack([acc(e) for e in np.eye(8)])  # q̈ per unit of q (linear)
    gravity = np.array([-G, 0, 0, -G, -G, -G, -G, -G])
    q_static = np.linalg.solve(K, -gravity)
    _, named = ref.accelerations(P, q_static, np.zeros(8), np.zeros(4), np.zeros(4), np.zeros(5))
    return np.array([named[f"tire_load_{c}"] for c in ref.CORNERS])


T0 = static_tyre_loads()

# Elements in the plant's order: tyres, bump stops, rebound stops, seat bump, seat rebound.
N_ELEMENTS = 14


def elements(q, dq, zr, dzr):
    """(penetration, rate, stiffness, damping) of every unilateral element."""
    zb = [q[0] + y * q[1] + x * q[2] for x, y in zip(XS, YS)]
    dzb = [dq[0] + y * dq[1] + x * dq[2] for x, y in zip(XS, YS)]
    stroke = [zb[i] - q[4 + i] for i in range(4)]
    dstroke = [dzb[i] - dq[4 + i] for i in range(4)]
    za = q[0] - P["s1"] * q[1] + P["s2"] * q[2]
    dza = dq[0] - P["s1"] * dq[1] + P["s2"] * dq[2]
    seat, dseat = q[3] - za, dq[3] - dza
    out = []
    for i in range(4):  # tyres: compression beyond the unloaded tyre
        out.append((T0[i] / P["k_t"] - (q[4 + i] - zr[i]), -(dq[4 + i] - dzr[i]), P["k_t"], P["c_t"]))
    k, c = STOPS["stop_stiffness"], STOPS["stop_damping"]
    for i in range(4):
        out.append((-stroke[i] - STOPS["bump_travel"], -dstroke[i], k, c))
    for i in range(4):
        out.append((stroke[i] - STOPS["rebound_travel"], dstroke[i], k, c))
    k, c = STOPS["seat_stop_stiffness"], STOPS["seat_stop_damping"]
    out.append((-seat - STOPS["seat_travel"], -dseat, k, c))
    out.append((seat - STOPS["seat_travel"], dseat, k, c))
    return out


def guards(x, w):
    return [min(p, k * p + c * dp) for p, dp, k, c in elements(x[:8], x[8:], w[:4], w[4:8])]


def dynamics(x, w, mode):
    """ẋ and named outputs of the car in `mode` (engaged flags) under held inputs w."""
    q, dq, zr, dzr = x[:8], x[8:], w[:4], w[4:8]
    u = np.array(w[8:], dtype=float)
    els = elements(q, dq, zr, dzr)
    forces = [k * p + c * dp if on else 0.0 for (p, dp, k, c), on in zip(els, mode)]
    # The stops act along the suspensions and the seat, as the actuators do.
    for i in range(4):
        u[i] += forces[4 + i] - forces[8 + i]
    u[4] += forces[12] - forces[13]
    ddq, named = ref.accelerations(P, q, dq, zr, dzr, u)
    for i in range(4):
        if not mode[i]:
            # A free tyre: its whole force (static load included) leaves the wheel.
            ddq[4 + i] -= (T0[i] + named[f"tire_load_{ref.CORNERS[i]}"]) / P["m_u"]
            named[f"tire_load_{ref.CORNERS[i]}"] = -T0[i]
        named[f"tire_force_{ref.CORNERS[i]}"] = forces[i]
    named["a_seat"] = ddq[3]
    return np.concatenate([dq, ddq]), named


def reconcile(mode, x, w):
    return [g > 0 if (on and g < 0) or (not on and g > 0) else on for on, g in zip(mode, guards(x, w))]


def reference(inputs, h, steps, names):
    """States and `names` at every t_k; the inputs at t_k are held over [t_k, t_k+1)."""
    x = np.zeros(16)
    mode = [True] * 4 + [False] * 10
    airborne = np.zeros(4)
    rows = []

    def record(x, w, mode):
        _, named = dynamics(x, w, mode)
        named.update({n: x[k] for k, n in enumerate(STATE_NAMES)})
        named.update({f"airborne_time_{c}": airborne[i] for i, c in enumerate(ref.CORNERS)})
        return [named[n] for n in names]

    mode = reconcile(mode, x, inputs(0.0))
    rows.append(record(x, inputs(0.0), mode))
    for k in range(steps):
        t, w = k * h, inputs(k * h)
        mode = reconcile(mode, x, w)
        end = t + h
        while t < end:
            events = []
            for j in range(N_ELEMENTS):
                def event(s, y, j=j):
                    return guards(y, w)[j]
                event.terminal = True
                event.direction = -1 if mode[j] else 1
                events.append(event)
            sol = solve_ivp(lambda s, y: dynamics(y, w, mode)[0], (t, end), x, method="DOP853",
                            rtol=1e-12, atol=1e-15, events=events)
            assert sol.success, sol.message
            for i in range(4):
                if not mode[i]:
                    airborne[i] += sol.t[-1] - t
            t, x = sol.t[-1], sol.y[:, -1]
            if sol.status == 1:  # an event: switch the element(s) that fired
                for j, te in enumerate(sol.t_events):
                    if len(te):
                        mode[j] = not mode[j]
        mode = reconcile(mode, x, inputs(end))
        rows.append(record(x, inputs(end), mode))
    return np.array(rows)


def run_plant(path, inputs, h, steps, names):
    s = Slave(path)
    f = s.fmu
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.setReal(s.refs(list(STOPS)), list(STOPS.values()))
    f.exitInitializationMode()
    in_refs, out_refs = s.refs(INPUT_NAMES), s.refs(names)
    rows = []
    f.setReal(in_refs, list(inputs(0.0)))
    rows.append(f.getReal(out_refs))
    stop_time = 0.0
    for k in range(steps):
        t = k * h
        f.setReal(in_refs, list(inputs(t)))
        f.doStep(t, h)
        f.setReal(in_refs, list(inputs(t + h)))
        rows.append(f.getReal(out_refs))
    stop_time = sum(f.getReal(s.refs([f"stop_time_{c}" for c in ref.CORNERS + ["seat"]])))
    f.terminate()
    s.close()
    return np.array(rows), stop_time


def drop(t):
    """The road 10 cm below the wheels from the start: the car falls onto it."""
    return np.array([-0.1] * 4 + [0.0] * 4 + [0.0] * 5)


def pothole(t):
    """A 6 cm deep, 50 cm long pothole with square edges under the left wheels at 20 m/s."""
    z = [0.0] * 4
    for wheel, delay in ((0, 0.0), (2, (P["L1"] + P["L2"]) / 20.0)):
        if 0.2 <= t - delay < 0.225:
            z[wheel] = -0.06
    return np.array(z + [0.0] * 4 + [0.0] * 5)


def big_bump(t):
    """A 15 cm, 3 m long 1 - cos bump under the left wheels at 15 m/s (heights and velocities)."""
    z, v = [0.0] * 4, [0.0] * 4
    for wheel, delay in ((0, 0.0), (2, (P["L1"] + P["L2"]) / 15.0)):
        x = 15.0 * (t - 0.1 - delay)
        if 0.0 <= x <= 3.0:
            k = 2 * math.pi / 3.0
            z[wheel] = 0.075 * (1 - math.cos(k * x))
            v[wheel] = 0.075 * k * 15.0 * math.sin(k * x)
    return np.array(z + v + [0.0] * 5)


NAMES = STATE_NAMES + [f"stroke_{c}" for c in ref.CORNERS] + ["stroke_seat", "a_seat"] + [
    f"tire_load_{c}" for c in ref.CORNERS] + [f"tire_force_{c}" for c in ref.CORNERS] + [
    f"airborne_time_{c}" for c in ref.CORNERS]


@pytest.mark.parametrize("case, h, duration, lifted, stopped", [
    (drop, 5e-3, 1.5, True, True),
    (pothole, 1e-3, 0.8, True, False),
    (big_bump, 1e-3, 1.2, True, True),
], ids=["drop", "pothole", "big_bump"])
def test_the_plant_is_the_hybrid_reference_through_every_contact(plant_fmu, case, h, duration,
                                                                 lifted, stopped):
    steps = int(round(duration / h))
    expected = reference(case, h, steps, NAMES)
    got, stop_time = run_plant(plant_fmu, case, h, steps, NAMES)
    airborne = expected[-1, NAMES.index("airborne_time_fl")]
    assert (airborne > 0) == lifted, f"FL airborne {airborne} s"
    assert (stop_time > 0) == stopped, f"at a stop {stop_time} s"
    worst = 0.0
    for j, name in enumerate(NAMES):
        scale = np.max(np.abs(expected[:, j]))
        if scale == 0:
            assert np.all(got[:, j] == 0), name
            continue
        err = np.max(np.abs(got[:, j] - expected[:, j])) / scale
        worst = max(worst, err)
        assert err < 1e-9, f"{name}: {err:.2e} of its range"
    print(f"{case.__name__}: worst {worst:.1e} of an output's range; FL airborne {airborne:.4f} s")


def test_the_linear_car_is_still_the_linear_reference(plant_fmu):
    """`contact_model = false`: the car of the thesis, whose tyres pull the wheels onto a road that
    drops away (the pothole): its states are the linear reference's exactly."""
    h, steps = 1e-3, 600
    W = np.array([pothole(k * h) for k in range(steps + 1)])
    X_ref, _ = ref.simulate(W, h, first_order_hold=False)
    s = Slave(plant_fmu)
    f = s.fmu
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.setBoolean(s.refs(["contact_model"]), [False])
    f.exitInitializationMode()
    in_refs, out_refs = s.refs(INPUT_NAMES), s.refs(STATE_NAMES + ["tire_force_fl"])
    X, least = [], math.inf
    for k in range(steps + 1):
        f.setReal(in_refs, list(W[k]))
        values = f.getReal(out_refs)
        X.append(values[:16])
        least = min(least, values[16])
        if k < steps:
            f.doStep(k * h, h)
    f.terminate()
    s.close()
    X = np.array(X)
    assert least < 0, "the linear tyre pulls on the road"
    for j in range(16):
        scale = np.max(np.abs(X_ref[:, j]))
        assert np.max(np.abs(X[:, j] - X_ref[:, j])) < 1e-9 * scale, STATE_NAMES[j]


def test_a_state_saved_in_flight_restores_in_a_fresh_instance_bit_for_bit(plant_fmu):
    """Saved through FMI while a wheel is in the air (the pothole), serialised, restored into a
    fresh instance: both go on through the landing bit for bit, the contact mode and the clocks
    included."""
    h = 1e-3
    names = STATE_NAMES + [f"airborne_time_{c}" for c in ref.CORNERS] + ["tire_force_fl"]

    def started(s):
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        s.fmu.exitInitializationMode()

    a = Slave(plant_fmu)
    started(a)
    in_refs, out_refs = a.refs(INPUT_NAMES), a.refs(names)
    on_road = a.refs(["on_road_fl"])
    k = 0
    while not (k > 200 and not a.fmu.getBoolean(on_road)[0]):
        a.fmu.setReal(in_refs, list(pothole(k * h)))
        a.fmu.doStep(k * h, h)
        k += 1
        assert k < 400, "the FL wheel leaves the road in the pothole"
    state = a.fmu.serializeFMUState(a.fmu.getFMUState())
    b = Slave(plant_fmu)
    started(b)
    b.fmu.setFMUState(b.fmu.deserializeFMUState(state))
    assert not b.fmu.getBoolean(on_road)[0], "restored in the air"
    for j in range(k, k + 300):
        for s in (a, b):
            s.fmu.setReal(in_refs, list(pothole(j * h)))
            s.fmu.doStep(j * h, h)
        assert a.fmu.getReal(out_refs) == b.fmu.getReal(out_refs)
    assert a.fmu.getBoolean(on_road)[0], "landed again"
    for s in (a, b):
        s.fmu.terminate()
        s.close()
