"""The thesis hinf_of's optimal gamma against an independent Riccati solution (Doyle, Glover, Khargonekar &
Francis 1989, with the general D12/D21 cross terms of Glover & Doyle 1988): bisection on gamma
with SciPy's solve_continuous_are, on the same regularised generalised plant the certificate
stores. Nothing here comes from the LMI."""

import json
import pathlib
import subprocess

import numpy as np
import pytest
from scipy.linalg import LinAlgError, solve_continuous_are

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def certificate(tmp_path_factory):
    """hinf_of synthesised with the tyre-load rows of z switched off: they feed the road through
    (D11 != 0), outside the DGKF formulas below; everything else is the thesis design (`make thesis`)."""
    out = tmp_path_factory.mktemp("riccati")
    design = json.loads((ROOT / "synth" / "designs" / "thesis.json").read_text())
    design["weight_tyre_load"] = 0.0
    (out / "design.json").write_text(json.dumps(design))
    subprocess.run([str(ROOT / "target" / "release" / "synth"), "--design", str(out / "design.json"), "--out", str(out), "hinf_of"],
                   check=True, stdout=subprocess.DEVNULL)
    return json.loads((out / "hinf_of.certificate.json").read_text())


def plant(cert):
    return {k: np.array(v, dtype=float) for k, v in cert["generalized_plant"].items()}


def stabilising_are(a, b, q, r, s):
    """SciPy's CARE solution, accepted only if it really solves the equation and stabilises:
    below the optimum the Hamiltonian has imaginary-axis eigenvalues and solve_continuous_are
    may return a non-solution without raising."""
    x = solve_continuous_are(a, b, q, r, s=s)
    gain = np.linalg.solve(r, b.T @ x + s.T)
    residual = a.T @ x + x @ a - (x @ b + s) @ gain + q
    if np.max(np.abs(residual)) > 1e-8 * max(1.0, np.max(np.abs(x))):
        raise LinAlgError("not a solution")
    if np.max(np.linalg.eigvals(a - b @ gain).real) > -1e-9:
        raise LinAlgError("not stabilising")
    return x


def riccati_feasible(g, gamma):
    """gamma achievable iff the stabilising X, Y >= 0 exist and rho(X Y) < gamma^2 (D11 = 0)."""
    A, B1, B2, C1, D12, C2, D21 = (g[k] for k in ("A", "B_w", "B_u", "C_z", "D_zu", "C_y", "D_yw"))
    nw, nz = B1.shape[1], C1.shape[0]
    try:
        # Full information: A'X + XA + C1'C1 - (XB + S) R^-1 (B'X + S') = 0, B = [B1 B2].
        X = stabilising_are(A, np.hstack([B1, B2]), C1.T @ C1,
                                 np.block([[-gamma**2 * np.eye(nw), np.zeros((nw, B2.shape[1]))],
                                           [np.zeros((B2.shape[1], nw)), D12.T @ D12]]),
                                 np.hstack([np.zeros((A.shape[0], nw)), C1.T @ D12]))
        # Filtering (dual).
        Y = stabilising_are(A.T, np.hstack([C1.T, C2.T]), B1 @ B1.T,
                                 np.block([[-gamma**2 * np.eye(nz), np.zeros((nz, C2.shape[0]))],
                                           [np.zeros((C2.shape[0], nz)), D21 @ D21.T]]),
                                 np.hstack([np.zeros((A.shape[0], nz)), B1 @ D21.T]))
    except (LinAlgError, ValueError):
        return False
    psd = lambda M: np.min(np.linalg.eigvalsh((M + M.T) / 2)) > -1e-9 * max(1.0, np.max(np.abs(M)))
    if not (psd(X) and psd(Y)):
        return False
    return np.max(np.abs(np.linalg.eigvals(X @ Y))) < gamma**2


def test_output_feedback_gamma_matches_the_riccati_optimum(certificate):
    cert, g = certificate, plant(certificate)
    assert np.max(np.abs(g["D_zw"])) == 0.0, "the DGKF formulas used here assume D11 = 0"
    lo, hi = 1e-3, 1e3
    assert riccati_feasible(g, hi) and not riccati_feasible(g, lo)
    while hi / lo > 1 + 1e-7:
        mid = np.sqrt(lo * hi)
        lo, hi = (lo, mid) if riccati_feasible(g, mid) else (mid, hi)
    gamma_lmi = cert["details"]["gamma_opt"]
    print(f"Riccati optimum {hi:.7f}, LMI optimum {gamma_lmi:.7f}, relative difference {abs(gamma_lmi - hi) / hi:.2e}")
    assert abs(gamma_lmi - hi) / hi < 1e-3
    # The shipped controller is built a little above the optimum, and certified below its gamma.
    assert cert["norm_upper"] <= cert["gamma"] * (1 + 1e-6)
