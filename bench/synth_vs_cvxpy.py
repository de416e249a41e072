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
from scipy.linalg import null_space

ROOT = pathlib.Path(__file__).resolve().parents[1]
SYNTH = ROOT / "target" / "release" / "synth"


def rust(variant, out):
    t = time.perf_counter()
    # The thesis's H∞ LMIs (their certificate stores the generalised plant); synth's default
    # design file is the comfort one, whose designs solve no such LMI.
    subprocess.run([str(SYNTH), "--design", str(ROOT / "synth" / "designs" / "thesis.json"), "--out", out, variant],
                   check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    cert = json.loads((pathlib.Path(out) / f"{variant}.certificate.json").read_text())
    return wall, cert


def mats(cert):
    return {k: np.array(v, dtype=float) for k, v in cert["generalized_plant"].items()}


def cvxpy_sf(g, eps=1e-7, backoff=0.02):
    """Both stages of synth's hinf_sf: γ* (Th. 5.1), then at (1 + backoff) γ* the (Q, Y) minimising
    the H2 bound of the z rows without feed-through (w's −γI block Schur-eliminated, as in Rust)."""
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
    gamma_opt = gamma.value
    rows = [i for i in range(nz) if not np.any(Dzw[i])]
    C2, D2 = Cz[rows], Dzu[rows]
    g_fix = (1 + backoff) * gamma_opt
    m = C2 @ Q.value + D2 @ Y.value
    reference = g_fix * np.trace(m @ np.linalg.solve(Q.value, m.T))
    Q2 = cp.Variable((n, n), symmetric=True)
    Y2 = cp.Variable((nu, n))
    W = cp.Variable((len(rows), len(rows)), symmetric=True)
    L2 = A @ Q2 + Bu @ Y2
    czq = Cz @ Q2 + Dzu @ Y2
    brl = cp.bmat([[L2 + L2.T + Bw @ Bw.T / g_fix, czq.T + Bw @ Dzw.T / g_fix],
                   [czq + Dzw @ Bw.T / g_fix, Dzw @ Dzw.T / g_fix - g_fix * np.eye(nz)]])
    h2 = cp.bmat([[W, C2 @ Q2 + D2 @ Y2], [(C2 @ Q2 + D2 @ Y2).T, Q2 / g_fix]])
    cons = [sym(brl) << -eps * np.eye(n + nz), Q2 >> eps * np.eye(n), sym(h2) >> 0]
    cp.Problem(cp.Minimize(cp.trace(W) / reference), cons).solve(solver=cp.CLARABEL)
    return gamma_opt


def balance(A):
    """Osborne's diagonal balancing with powers of two, as synth's `Balanced::new`."""
    A = A.copy()
    d = np.ones(A.shape[0])
    for _ in range(100):
        changed = False
        for i in range(A.shape[0]):
            c = np.abs(A[:, i]).sum() - abs(A[i, i])
            r = np.abs(A[i, :]).sum() - abs(A[i, i])
            if c == 0 or r == 0:
                continue
            f = 2.0 ** round(np.log2(r / c) / 2)
            if f != 1 and c * f + r / f < 0.95 * (c + r):
                A[:, i] *= f
                A[i, :] /= f
                d[i] *= f
                changed = True
        if not changed:
            break
    return d


def sym(M):
    return (M + M.T) / 2


def cvxpy_of(g, eps=1e-7, backoff=0.02, beta=1e3):
    """Both stages, as synth does them: the reduced projected LMIs of the balanced plant;
    minimise γ (scaled variables); then at 1.02 γ* with X, Y ⪯ βI maximise t."""
    A, B1, B2, C1, D11, D12, C2, D21 = (g[k] for k in ("A", "B_w", "B_u", "C_z", "D_zw", "D_zu", "C_y", "D_yw"))
    d = balance(A)
    A, B1, B2, C1, C2 = A * d[None, :] / d[:, None], B1 / d[:, None], B2 / d[:, None], C1 * d[None, :], C2 * d[None, :]
    n, nw, nz = A.shape[0], B1.shape[1], C1.shape[0]
    W = null_space(np.hstack([B2.T, D12.T]))
    V = null_space(np.hstack([C2, D21]))
    b, c = np.vstack([B1, D11]), np.vstack([C1.T, D11.T])
    gram_x, gram_y = W.T @ b @ b.T @ W, V.T @ c @ c.T @ V

    def lmis(X, Y, a, s):
        lx = W.T @ cp.bmat([[A @ X + X @ A.T, X @ C1.T], [C1 @ X, -a * np.eye(nz)]]) @ W + s * gram_x
        ly = V.T @ cp.bmat([[Y @ A + A.T @ Y, Y @ B1], [B1.T @ Y, -a * np.eye(nw)]]) @ V + s * gram_y
        return [sym(lx) << -eps * np.eye(lx.shape[0]), sym(ly) << -eps * np.eye(ly.shape[0])]

    X, Y = cp.Variable((n, n), symmetric=True), cp.Variable((n, n), symmetric=True)
    eta, zeta = cp.Variable(), cp.Variable()
    cons = lmis(X, Y, 1.0, zeta) + [
        sym(cp.bmat([[X, eta * np.eye(n)], [eta * np.eye(n), Y]])) >> eps * np.eye(2 * n),
        sym(cp.bmat([[cp.reshape(zeta, (1, 1)), cp.reshape(eta, (1, 1))], [cp.reshape(eta, (1, 1)), np.ones((1, 1))]])) >> 0,
    ]
    cp.Problem(cp.Maximize(eta), cons).solve(solver=cp.CLARABEL)
    gamma_opt = 1.0 / eta.value

    gamma = (1 + backoff) * gamma_opt
    X, Y, t = cp.Variable((n, n), symmetric=True), cp.Variable((n, n), symmetric=True), cp.Variable()
    cons = lmis(X, Y, gamma, 1.0 / gamma) + [
        sym(cp.bmat([[X, np.eye(n)], [np.eye(n), Y]])) >> t * np.eye(2 * n), t >= 0,
        X << beta * np.eye(n), Y << beta * np.eye(n)]
    cp.Problem(cp.Maximize(t), cons).solve(solver=cp.CLARABEL)
    return gamma_opt


def main():
    if not SYNTH.exists():
        sys.exit(f"{SYNTH} not found: run `make` first")
    rows = []
    with tempfile.TemporaryDirectory() as out:
        for variant, py, what in [("hinf_sf", cvxpy_sf, "both stages"), ("hinf_of", cvxpy_of, "both stages")]:
            wall, cert = rust(variant, out)
            g = mats(cert)
            t = time.perf_counter()
            gamma_py = py(g)
            t_py = time.perf_counter() - t
            gamma_rust = cert["details"]["gamma_opt"]
            rows.append((variant, cert["synthesis_seconds"], wall, t_py, what, gamma_rust, gamma_py))
    print(f"{'variant':<9} {'Rust synth [s]':>15} {'(process) [s]':>14} {'CVXPY+Clarabel [s]':>19} {'ratio':>6}  {'γ Rust':>10} {'γ CVXPY':>10}  CVXPY part")
    for v, t_rust, wall, t_py, what, gr, gp in rows:
        print(f"{v:<9} {t_rust:>15.2f} {wall:>14.2f} {t_py:>19.2f} {t_py / t_rust:>5.1f}×  {gr:>10.6f} {gp:>10.6f}  {what}")
    print("Rust synth time = LMI assembly and solve of every stage, controller reconstruction and the certificate;")
    print("CVXPY time = problem construction (canonicalisation) and Clarabel solve of the same stages. ratio = CVXPY / Rust.")


if __name__ == "__main__":
    main()
