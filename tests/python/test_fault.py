"""The fault-tolerant designs' claims (thesis ch. 8) re-checked outside Rust.

* the thesis ft_of's (dist/thesis/) gamma at every vertex of the effectiveness box, from the certificate's matrices with each
  actuator's column of B_u and D_zu scaled by its effectiveness, by a frequency sweep refined with
  SciPy (a different algorithm from the certificate's Hamiltonian bisection);
* the thesis ft_of's fault detector (dist/thesis/ft_of/controller.json) on the independent
  reference car (tests/python/reference_car.py, not the Rust model it was derived from): blind
  to the road, and reporting the low-passed force deficit of a faulty actuator;
* the shipped ft_of's detector (dist/ft_of/controller.json) on its load cells: it reads nothing
  else, so no road reaches it, and it reports each actuator's deficit against the runtime's
  actuator model, low-passed.
"""

import json
import pathlib

import numpy as np
import pytest

from reference_car import PARAMS, OUTPUTS, linear_maps
from test_robust import arrays, certificate, closed_loop, sweep_norm

DIST = pathlib.Path(__file__).resolve().parents[2] / "dist"


def vertices(rho_min):
    """The 32 effectiveness vertices in the certificate's order (bit i set: actuator i at rho_min)."""
    return [np.array([rho_min if bits >> i & 1 else 1.0 for i in range(5)]) for bits in range(32)]


def test_ft_of_gamma_holds_at_every_fault_vertex_and_hinf_of_is_compared_fairly():
    cert = certificate("ft_of")
    d = cert["details"]
    gamma, rho_min = cert["gamma"], d["fault_rho_min"]
    claimed = d["fault_box"]["vertex_norms"]
    g0 = arrays(cert["generalized_plant"])
    worst = 0.0
    for rho, norm_claimed in zip(vertices(rho_min), claimed):
        g = dict(g0, B_u=g0["B_u"] * rho, D_zu=g0["D_zu"] * rho)
        A, B, C, D = closed_loop(g, cert["controller"])
        assert np.max(np.linalg.eigvals(A).real) < 0, f"unstable at effectiveness {rho}"
        norm = sweep_norm(A, B, C, D)
        assert norm_claimed * (1 - 1e-4) <= norm <= norm_claimed * (1 + 1e-6), f"{rho}: sweep {norm}, certificate {norm_claimed}"
        assert norm <= gamma * (1 + 1e-6)
        worst = max(worst, norm)
    assert abs(worst - d["worst_norm_over_faults"]) <= 1e-4 * worst
    print(f"ft_of: worst over 32 vertices {worst:.6f} (gamma {gamma:.6f})")


def reference_measurements(spec, p=PARAMS):
    """C_y of the measurements the detector of `spec` (a controller.json) reads, from the
    reference car, and the detector's B restricted to them. The shipped ft_of also reads the
    applied forces (its estimator uses them); its detector must not."""
    A, B, C, D = linear_maps(p)
    rows = {n: C[i] for i, n in enumerate(OUTPUTS)}
    det = arrays(spec["fault_detection"])
    names = [n["name"] for n in spec["inputs"]]
    read = [i for i, n in enumerate(names) if np.abs(det["B"][:, i]).max() > 0]
    assert all(names[i].startswith("f_") for i in range(len(names)) if i not in read), names
    velocity = {"v_body": 8, "omega_roll": 9, "omega_pitch": 10}
    c_y = np.array([rows[names[i]] if names[i] in rows else np.eye(16)[velocity[names[i]]] for i in read])
    # The strokes have no feed-through from the road or the forces.
    assert all(np.abs(D[OUTPUTS.index(names[i])]).max() == 0 for i in read if names[i] in rows)
    return A, B, c_y, dict(det, B=det["B"][:, read], D=det["D"][:, read])


def test_the_shipped_detector_reads_the_load_cells_alone_and_reports_each_deficit():
    spec = json.loads((DIST / "ft_of" / "controller.json").read_text())
    det = {k: np.array(v, dtype=float) for k, v in spec["fault_detection"].items() if isinstance(v, list)}
    names = [n["name"] for n in spec["inputs"]]
    assert spec["fault_detection"]["input"] == "modelled_force"
    cells = spec["accommodation"]["forces"]
    read = [names[i] for i in range(len(names)) if np.abs(det["B"][:, i]).max() > 0 or np.abs(det["D"][:, i]).max() > 0]
    assert sorted(read) == sorted(cells), read
    m = det["A"].shape[0]
    b_f = det["B"][:, [names.index(c) for c in cells]]
    for w in [0.0, 0.5, 3.0, 12.0, 70.0, 500.0]:
        filt = np.linalg.inv(1j * w * np.eye(m) - det["A"])
        # Per actuator, from the modelled force m and the load cell f to the residual.
        from_model, from_cell = det["C"] @ filt @ det["B_u"], det["C"] @ filt @ b_f
        # Healthy (f = m): nothing, at every frequency.
        assert np.abs(from_model + from_cell).max() < 1e-12
        # FL at half force (f = m / 2): its deficit m / 2, low-passed, on its own residual.
        T = -1.0 / det["A"][0, 0]
        faulty = from_model[:, 0] + 0.5 * from_cell[:, 0]
        np.testing.assert_allclose(abs(faulty[0]), 0.5 / abs(1 + 1j * w * T), rtol=1e-12)
        assert np.abs(faulty[1:]).max() < 1e-12


def test_detector_is_blind_to_the_road_and_sees_a_faulty_actuator_on_the_reference_car():
    A, B, c_y, det = reference_measurements(json.loads((DIST / "thesis" / "ft_of" / "controller.json").read_text()))
    b_road, b_u = B[:, :8], B[:, 8:]
    n, m = A.shape[0], det["A"].shape[0]
    T = -1.0 / det["A"][0, 0]
    deficit_dc = None
    for w in [0.05, 0.5, 3.0, 12.0, 70.0, 500.0]:
        s = 1j * w
        plant = np.linalg.inv(s * np.eye(n) - A)
        filt = np.linalg.inv(s * np.eye(m) - det["A"])
        from_y = det["C"] @ filt @ det["B"] + det["D"]
        road = from_y @ c_y @ plant @ b_road  # N per m and per m/s of road
        healthy = from_y @ c_y @ plant @ b_u + det["C"] @ filt @ det["B_u"]  # applied = sent
        # FL at half force: applied = 0.5 u_fl, the detector still integrates the command sent.
        faulty = from_y @ c_y @ plant @ (b_u * [0.5, 1, 1, 1, 1]) + det["C"] @ filt @ det["B_u"]
        assert np.abs(road).max() < 1e-5, f"w = {w}: road reaches the residual ({np.abs(road).max():.2e} N per unit)"
        assert np.abs(healthy).max() < 1e-9, f"w = {w}: healthy commands reach the residual"
        # A first-order low-pass of the deficit -0.5 u_fl: |r| / |u_fl| = 0.5 |G+G e_1| / |1 + jwT|.
        gain = np.linalg.norm(faulty[:, 0])
        if deficit_dc is None:
            deficit_dc = gain * abs(1 + s * T)
        np.testing.assert_allclose(gain * abs(1 + s * T), deficit_dc, rtol=1e-6)
        assert np.abs(faulty[:, 1:]).max() < 1e-9
    # At DC it is the min-norm deficit estimate of 0.5 N per N on FL: between 0.25 and 0.5.
    assert 0.25 < deficit_dc <= 0.5 + 1e-9, deficit_dc
