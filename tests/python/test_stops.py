"""The certificates' engaged end stops (`engaged_stops`), checked by a second computation.

Each comfort controller of `dist/` is closed around the hand-written car of `reference_car.py`
(not the Rust model) with a stop engaged for good: its stiffness and damping added to the
seat's spring and damper, or to both corners' of an axle, and the plant's `stop_force_*` there
reading it (what `robust_sf`'s stop recovery reads). The loop's eigenvalues must say what the
certificate says: stable, or unstable with the stiffest stable spring where the certificate
puts it.
"""

import json

import numpy as np
import pytest

import reference_car as rc
from conftest import ROOT

# vehicle::contact::ContactParams::default(): the plant FMU's stops.
STOP_STIFFNESS, STOP_DAMPING = 250e3, 500.0
SEAT_STOP_STIFFNESS, SEAT_STOP_DAMPING = 100e3, 200.0

STOPS = {
    "seat": [("k_seat", SEAT_STOP_STIFFNESS), ("c_seat", SEAT_STOP_DAMPING)],
    "front": [("k_s_f", STOP_STIFFNESS), ("c_s_f", STOP_DAMPING)],
    "rear": [("k_s_r", STOP_STIFFNESS), ("c_s_r", STOP_DAMPING)],
}


def comfort_controllers():
    out = []
    for path in sorted((ROOT / "dist").glob("*.certificate.json")):
        cert = json.loads(path.read_text())
        if "engaged_stops" in cert:
            out.append(path.name.removesuffix(".certificate.json"))
    return out


def measured(p, names, stop_forces=None):
    """Rows (over x, then u) of what a controller reads, from the reference car's equations.

    `stop_forces`: the places (`fl` … `seat`) whose stop is engaged for good, each with its
    (stiffness, damping): the plant's `stop_force_<place>` pushes back, `-(k s + c ds/dt)` for
    the stroke `s`; every other stop's force is zero."""
    corners = [(p["L2"], p["w1"]), (p["L2"], -p["w2"]), (-p["L1"], p["w1"]), (-p["L1"], -p["w2"])]
    stop_forces = stop_forces or {}

    def read(x, u):
        ddq, named = rc.accelerations(p, x[:8], x[8:], np.zeros(4), np.zeros(4), u)
        # Strokes are linear in the positions: at the velocities they are the strokes' rates.
        _, rates = rc.accelerations(p, x[8:], np.zeros(8), np.zeros(4), np.zeros(4), np.zeros(5))
        values = dict(named)
        for place in rc.CORNERS + ["seat"]:
            k, c = stop_forces.get(place, (0.0, 0.0))
            values[f"stop_force_{place}"] = -(k * named[f"stroke_{place}"] + c * rates[f"stroke_{place}"])
        for i, c in enumerate(rc.CORNERS):
            xc, yc = corners[i]
            values[f"a_body_{c}"] = ddq[0] + yc * ddq[1] + xc * ddq[2]
            values[f"f_{c}"] = u[i]
        values["f_seat"] = u[4]
        values["omega_roll"], values["omega_pitch"] = x[9], x[10]
        for k in range(16):
            values[f"x[{k + 1}]"] = x[k]
        return np.array([values[n.removeprefix("sensor_")] for n in names])

    x0, u0 = np.zeros(16), np.zeros(5)
    C = np.column_stack([read(e, u0) for e in np.eye(16)])
    D = np.column_stack([read(x0, e) for e in np.eye(5)])
    return C, D


def abscissa(controller, p, stop_forces=None):
    """The largest real part of the closed loop's eigenvalues on a flat road."""
    A, B, _, _ = rc.linear_maps(p)
    Bu = B[:, 8:]
    Ak, Bk, Ck, Dk = (np.array(controller[k], float) for k in "ABCD")
    Cy, Dy = measured(p, [i["name"] for i in controller["inputs"]], stop_forces)
    # u = Ck ξ + Dk (Cy x + Dy u)
    solve = np.linalg.inv(np.eye(5) - Dk @ Dy)
    ux, uxi = solve @ Dk @ Cy, solve @ Ck
    n, nk = 16, Ak.shape[0]
    a = np.zeros((n + nk, n + nk))
    a[:n, :n] = A + Bu @ ux
    a[:n, n:] = Bu @ uxi
    a[n:, :n] = Bk @ (Cy + Dy @ ux)
    a[n:, n:] = Ak + Bk @ Dy @ uxi
    return np.linalg.eigvals(a).real.max()


PLACES = {"seat": ["seat"], "front": ["fl", "fr"], "rear": ["rl", "rr"]}


def engaged(stop, share):
    """The car with a share of `stop` engaged for good, and the stop forces it reads
    (`abscissa`'s last two arguments)."""
    p = dict(rc.PARAMS)
    for name, extra in STOPS[stop]:
        p[name] += share * extra
    (_, k), (_, c) = STOPS[stop]
    return p, {place: (share * k, share * c) for place in PLACES[stop]}


@pytest.mark.parametrize("variant", comfort_controllers())
def test_a_certificates_engaged_stops_are_the_reference_cars(variant):
    cert = json.loads((ROOT / "dist" / f"{variant}.certificate.json").read_text())
    controller = json.loads((ROOT / "dist" / variant / "controller.json").read_text())
    assert abscissa(controller, dict(rc.PARAMS)) < 0, "the nominal loop is stable"
    for e in cert["engaged_stops"]:
        if "predictor" in controller:
            # Not a rational loop: checked at the sampling instants of a master's step, which
            # `master/tests/off_design_certificates.rs` co-simulates.
            assert e["step_s"] > 0 and e["verdict"] in ("stable", "unstable"), e
            continue
        at_stop = abscissa(controller, *engaged(e["stop"], 1.0))
        assert (at_stop < 0) == (e["verdict"] == "stable"), (e, at_stop)
        if e["verdict"] == "unstable":
            # The certificate's bisection is to 1 % of the stop's stiffness.
            (k_name, extra), _ = STOPS[e["stop"]]
            share = (e["stable_up_to_n_m"] - rc.PARAMS[k_name]) / extra
            assert abscissa(controller, *engaged(e["stop"], share)) < 0, e
            assert abscissa(controller, *engaged(e["stop"], share + 0.011)) > 0, e


@pytest.mark.parametrize("variant", comfort_controllers())
def test_every_controller_is_stable_on_its_own_as_its_certificate_says(variant):
    """The controllers issue: each controller stable on its own (an unstable one would need a
    reason in its certificate). numpy's eigenvalues of the shipped `A` against the
    certificate's `controller_spectral_abscissa` (nalgebra's)."""
    cert = json.loads((ROOT / "dist" / f"{variant}.certificate.json").read_text())
    a = np.array(json.loads((ROOT / "dist" / variant / "controller.json").read_text())["A"], float)
    mine = np.linalg.eigvals(a).real.max()
    theirs = cert["controller_spectral_abscissa"]
    assert mine < 0 and theirs < 0, (mine, theirs)
    assert abs(mine - theirs) <= 1e-6 * max(1.0, abs(mine)), (mine, theirs)
