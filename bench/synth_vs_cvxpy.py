"""`make bench`: wall time of each synthesis in Rust (release `synth`, Clarabel) beside the same
LMI built with CVXPY and solved by Clarabel in Python, in the same run, as a ratio. The CVXPY
problems are built from the generalised plant the Rust certificate stores, so both sides solve
the same LMI; the γ each side finds is printed too (a cross-check of the LMI layer)."""

import json
import pathlib
import subprocess
import sys
import tempfile
import time

import cvxpy as cp
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
SYNTH = ROOT / "target" / "release" / "synth"


def rust(variant, out):
    t = time.perf_counter()
    subprocess.run([str(SYNTH), "--out", out, variant], check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    cert = json.loads((pathlib.Path(out) / f"{variant}.certificate.json").read_text())
    return wall, cert


def mats(cert):
    return {k: np.array(v, dtype=float) for k, v in cert["generalized_plant"].items()}


def cvxpy_sf(g, eps=1e-7):
    A, Bw, Bu, Cz, Dzw, Dzu = (g[k] for k in ("A", "B_w", "B_u", "C_z", "D_zw", "D_zu"))
    n, nw, nz, nu = A.shape[0], Bw.shape[1], Cz.shape[0], Bu.shape[1]
    Q = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((nu, n))
    gamma = cp.Variable()
    L = A @ Q + Bu @ Y
    M = cp.bmat([[L + L.T, Bw, (Cz @ Q + Dzu @ Y).T],
                 [Bw.T, -gamma * np.eye(nw), Dzw.T],
                 [Cz @ Q + Dzu @ Y, Dzw, -gamma * np.eye(nz)]])
    prob = cp.Problem(cp.Minimize(gamma), [(M + M.T) / 2 << -eps * np.eye(M.shape[0]), Q >> eps * np.eye(n)])
    prob.solve(solver=cp.CLARABEL)
    return gamma.value


def cvxpy_of(g, eps=1e-7, backoff=0.02, beta=1e3):
    """Both stages, as synth does them: minimise γ; then at 1.02 γ* with X, Y ⪯ βI maximise t."""
    gamma_opt = cvxpy_of_stage(g, eps)
    cvxpy_of_stage(g, eps, fixed_gamma=(1 + backoff) * gamma_opt, beta=beta)
    return gamma_opt


def cvxpy_of_stage(g, eps=1e-7, fixed_gamma=None, beta=None):
    A, B1, B2, C1, D11, D12, C2, D21 = (g[k] for k in ("A", "B_w", "B_u", "C_z", "D_zw", "D_zu", "C_y", "D_yw"))
    n, nw, nz, nu, ny = A.shape[0], B1.shape[1], C1.shape[0], B2.shape[1], C2.shape[0]
    X = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((n, n), symmetric=True)
    Ah, Bh, Ch, Dh = cp.Variable((n, n)), cp.Variable((n, ny)), cp.Variable((nu, n)), cp.Variable((nu, ny))
    gamma = cp.Variable() if fixed_gamma is None else fixed_gamma
    m11 = A @ X + B2 @ Ch
    m22 = Y @ A + Bh @ C2
    M = cp.bmat([
        [m11 + m11.T, Ah.T + A + B2 @ Dh @ C2, B1 + B2 @ Dh @ D21, (C1 @ X + D12 @ Ch).T],
        [(Ah.T + A + B2 @ Dh @ C2).T, m22 + m22.T, Y @ B1 + Bh @ D21, (C1 + D12 @ Dh @ C2).T],
        [(B1 + B2 @ Dh @ D21).T, (Y @ B1 + Bh @ D21).T, -gamma * np.eye(nw), (D11 + D12 @ Dh @ D21).T],
        [C1 @ X + D12 @ Ch, C1 + D12 @ Dh @ C2, D11 + D12 @ Dh @ D21, -gamma * np.eye(nz)],
    ])
    C = cp.bmat([[X, np.eye(n)], [np.eye(n), Y]])
    lmi = (M + M.T) / 2 << -eps * np.eye(M.shape[0])
    if fixed_gamma is None:
        prob = cp.Problem(cp.Minimize(gamma), [lmi, (C + C.T) / 2 >> eps * np.eye(2 * n)])
        prob.solve(solver=cp.CLARABEL)
        return gamma.value
    t = cp.Variable()
    cons = [lmi, (C + C.T) / 2 >> t * np.eye(2 * n), t >= 0, X << beta * np.eye(n), Y << beta * np.eye(n)]
    cp.Problem(cp.Maximize(t), cons).solve(solver=cp.CLARABEL)
    return t.value


def main():
    if not SYNTH.exists():
        sys.exit(f"{SYNTH} not found: run `make` first")
    rows = []
    with tempfile.TemporaryDirectory() as out:
        for variant, py, what in [("hinf_sf", cvxpy_sf, "whole design"), ("hinf_of", cvxpy_of, "both stages")]:
            wall, cert = rust(variant, out)
            g = mats(cert)
            t = time.perf_counter()
            gamma_py = py(g)
            t_py = time.perf_counter() - t
            gamma_rust = cert["details"]["gamma_opt"] if variant == "hinf_of" else cert["gamma"]
            rows.append((variant, cert["synthesis_seconds"], wall, t_py, what, gamma_rust, gamma_py))
    print(f"{'variant':<9} {'Rust synth [s]':>15} {'(process) [s]':>14} {'CVXPY+Clarabel [s]':>19} {'ratio':>6}  {'γ Rust':>10} {'γ CVXPY':>10}  CVXPY part")
    for v, t_rust, wall, t_py, what, gr, gp in rows:
        print(f"{v:<9} {t_rust:>15.2f} {wall:>14.2f} {t_py:>19.2f} {t_py / t_rust:>5.1f}×  {gr:>10.6f} {gp:>10.6f}  {what}")
    print("Rust synth time = LMI assembly and solve of every stage, controller reconstruction and the certificate;")
    print("CVXPY time = problem construction (canonicalisation) and Clarabel solve of the same stages. ratio = CVXPY / Rust.")


if __name__ == "__main__":
    main()
