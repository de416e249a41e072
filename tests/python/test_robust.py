"""The thesis's robust H-inf designs' claims (thesis ch. 6; `make thesis`, dist/thesis/) re-checked
outside Rust.

The certificate stores the mass-dependent matrices at both vertices of the range. Here they are
compared with the independent reference car (tests/python/reference_car.py) at those masses and
at the nominal mass through the affine-in-1/m interpolation, and the closed-loop H-infinity norm
is recomputed at every mass of the certificate's grid by a frequency sweep refined with SciPy
(a different algorithm from the Hamiltonian bisection of the certificate)."""

import json
import pathlib

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from reference_car import PARAMS, linear_maps

THESIS = pathlib.Path(__file__).resolve().parents[2] / "dist" / "thesis"
FORCE_UNIT = 1000.0  # N per unit of the generalised plant's u (certificate "scaling")


def certificate(variant):
    return json.loads((THESIS / f"{variant}.certificate.json").read_text())


def arrays(d):
    return {k: np.array(v, dtype=float) for k, v in d.items() if isinstance(v, list)}


def plant_at(cert, mass):
    """The generalised plant at `mass`: the vertex matrices combined affinely in 1/m."""
    v0, v1 = cert["details"]["vertices"]
    a = (1 / mass - 1 / v1["mass"]) / (1 / v0["mass"] - 1 / v1["mass"])
    g = arrays(cert["generalized_plant"])
    for k in ("A", "B_u", "C_z", "D_zu"):
        g[k] = a * np.array(v0[k]) + (1 - a) * np.array(v1[k])
    return g


def closed_loop(g, k):
    """Plant with controller k (in N) on y = C_y x + D_yw w, in the certificate's scaled units."""
    dk = np.array(k["D"], dtype=float) / FORCE_UNIT
    (nu, ny), nc = dk.shape, len(k["A"])
    ak = np.array(k["A"], dtype=float).reshape(nc, nc)
    bk = np.array(k["B"], dtype=float).reshape(nc, ny)
    ck = np.array(k["C"], dtype=float).reshape(nu, nc) / FORCE_UNIT
    A = np.block([[g["A"] + g["B_u"] @ dk @ g["C_y"], g["B_u"] @ ck], [bk @ g["C_y"], ak]])
    B = np.vstack([g["B_w"] + g["B_u"] @ dk @ g["D_yw"], bk @ g["D_yw"]])
    C = np.hstack([g["C_z"] + g["D_zu"] @ dk @ g["C_y"], g["D_zu"] @ ck])
    D = g["D_zw"] + g["D_zu"] @ dk @ g["D_yw"]
    return A, B, C, D


def sweep_norm(A, B, C, D):
    """sup over w of sigma_max(C (jwI - A)^-1 B + D): log grid, then a bounded refinement."""
    eye = np.eye(A.shape[0])
    sigma = lambda w: np.linalg.norm(C @ np.linalg.solve(1j * w * eye - A, B) + D, 2)
    grid = np.logspace(-2, 3.5, 400)
    values = [sigma(w) for w in grid]
    i = int(np.argmax(values))
    lo, hi = np.log10(grid[max(i - 1, 0)]), np.log10(grid[min(i + 1, len(grid) - 1)])
    best = minimize_scalar(lambda lw: -sigma(10**lw), bounds=(lo, hi), method="bounded", options={"xatol": 1e-10})
    return max(values[i], -best.fun, sigma(0.0) if np.all(np.linalg.eigvals(A).real < 0) else np.inf)


@pytest.mark.parametrize("variant", ["robust_sf", "robust_of"])
def test_vertex_matrices_are_the_independent_reference_car_at_those_masses(variant):
    cert = certificate(variant)
    for v in cert["details"]["vertices"] + [{"mass": PARAMS["m_s"], **{k: plant_at(cert, PARAMS["m_s"])[k].tolist() for k in ("A", "B_u")}}]:
        A, B, _, _ = linear_maps({**PARAMS, "m_s": v["mass"]})
        np.testing.assert_allclose(np.array(v["A"]), A, rtol=0, atol=1e-9 * np.abs(A).max())
        np.testing.assert_allclose(np.array(v["B_u"]), B[:, 8:] * FORCE_UNIT, rtol=0, atol=1e-9 * np.abs(B[:, 8:]).max() * FORCE_UNIT)
    # The interpolation at the nominal mass is the certificate's own nominal plant.
    nominal = plant_at(cert, PARAMS["m_s"])
    g = arrays(cert["generalized_plant"])
    for k in ("A", "B_u", "C_z", "D_zu"):
        np.testing.assert_allclose(nominal[k], g[k], rtol=0, atol=1e-10 * max(1.0, np.abs(g[k]).max()))


@pytest.mark.parametrize("variant,nominal", [("robust_sf", "hinf_sf"), ("robust_of", "hinf_of")])
def test_robust_gamma_holds_at_every_mass_and_beats_the_nominal_design(variant, nominal):
    cert = certificate(variant)
    grid = cert["details"]["mass_grid"]
    gamma = cert["gamma"]
    assert len(grid["masses"]) >= 61
    assert grid["masses"][0] == cert["details"]["vertices"][0]["mass"] and grid["masses"][-1] == cert["details"]["vertices"][1]["mass"]
    worst = 0.0
    for m, claimed in zip(grid["masses"], grid["norms"]):
        A, B, C, D = closed_loop(plant_at(cert, m), cert["controller"])
        assert np.max(np.linalg.eigvals(A).real) < 0, f"{variant} unstable at {m} kg"
        norm = sweep_norm(A, B, C, D)
        # The sweep is a lower bound that reaches the certificate's value, and never exceeds gamma.
        assert norm <= claimed * (1 + 1e-6), f"{m} kg: sweep {norm} above the certified {claimed}"
        assert norm >= claimed * (1 - 1e-4), f"{m} kg: sweep {norm} well below the certified {claimed}"
        assert norm <= gamma * (1 + 1e-6)
        worst = max(worst, norm)
    # The nominal design over the same range: worse at its worst mass than the robust one.
    nominal_cert = certificate(nominal)
    nominal_worst = max(sweep_norm(*closed_loop(plant_at(cert, m), nominal_cert["controller"])) for m in (grid["masses"][0], grid["masses"][-1]))
    print(f"{variant}: worst norm over {len(grid['masses'])} masses {worst:.6f} (gamma {gamma:.6f}); {nominal}: {nominal_worst:.6f}")
    assert nominal_worst > worst
