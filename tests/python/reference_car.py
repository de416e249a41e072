"""An independent reference for the plant: the full car written out by hand, force by force.

Nothing here comes from the Rust code: the equations of motion are written element by element
(suspension, seat and tyre forces, and their moments about the COG), the linear maps A, B are
read off them by evaluating on unit vectors, and the discretisation is SciPy's `expm` of the
augmented (zero- or first-order-hold) matrix.
"""

import json
import pathlib

import numpy as np
from scipy.linalg import expm

PARAMS = {
    k: v["value"]
    for k, v in json.loads(
        (pathlib.Path(__file__).resolve().parents[2] / "vehicle" / "params" / "default.json").read_text()
    )["parameters"].items()
}

CORNERS = ["fl", "fr", "rl", "rr"]


def accelerations(p, q, dq, zr, dzr, u):
    """q = [z_s, phi, theta, z_seat, z_u fl fr rl rr]; returns (q̈, dict of named quantities)."""
    zs, phi, th, zseat = q[:4]
    zu = q[4:]
    dzs, dphi, dth, dzseat = dq[:4]
    dzu = dq[4:]
    # Body points above the wheels: left at +w1, right at -w2, front at +L2, rear at -L1.
    ys = [p["w1"], -p["w2"], p["w1"], -p["w2"]]
    xs = [p["L2"], p["L2"], -p["L1"], -p["L1"]]
    ks = [p["k_s_f"], p["k_s_f"], p["k_s_r"], p["k_s_r"]]
    cs = [p["c_s_f"], p["c_s_f"], p["c_s_r"], p["c_s_r"]]
    zb = [zs + y * phi + x * th for x, y in zip(xs, ys)]
    dzb = [dzs + y * dphi + x * dth for x, y in zip(xs, ys)]
    # Suspension force pushing the body up at each corner (actuator extends it).
    F = [-ks[i] * (zb[i] - zu[i]) - cs[i] * (dzb[i] - dzu[i]) + u[i] for i in range(4)]
    # Seat on the body at x = s2, y = -s1.
    za = zs - p["s1"] * phi + p["s2"] * th
    dza = dzs - p["s1"] * dphi + p["s2"] * dth
    Fseat = -p["k_seat"] * (zseat - za) - p["c_seat"] * (dzseat - dza) + u[4]
    # Tyres pushing the wheels up.
    T = [-p["k_t"] * (zu[i] - zr[i]) - p["c_t"] * (dzu[i] - dzr[i]) for i in range(4)]
    ddq = np.empty(8)
    ddq[0] = (sum(F) - Fseat) / p["m_s"]
    ddq[1] = (sum(ys[i] * F[i] for i in range(4)) + p["s1"] * Fseat) / p["I_x"]
    ddq[2] = (sum(xs[i] * F[i] for i in range(4)) - p["s2"] * Fseat) / p["I_y"]
    ddq[3] = Fseat / p["m_seat"]
    # The wheel carries the reaction of the suspension force (actuator included) and the tyre.
    ddq[4:] = [(T[i] - F[i]) / p["m_u"] for i in range(4)]
    named = {
        "a_body": ddq[0], "alpha_roll": ddq[1], "alpha_pitch": ddq[2], "a_seat": ddq[3],
        "stroke_seat": zseat - za,
    }
    for i, c in enumerate(CORNERS):
        named[f"stroke_{c}"] = zb[i] - zu[i]
        named[f"tire_defl_{c}"] = zu[i] - zr[i]
        named[f"tire_load_{c}"] = T[i]
    return ddq, named


OUTPUTS = ["a_seat", "a_body", "alpha_roll", "alpha_pitch", "stroke_seat"] + [
    f"{n}_{c}" for n in ("stroke", "tire_defl", "tire_load") for c in CORNERS
]


def linear_maps(p=PARAMS):
    """A (16x16), B (16x13) with inputs w = [z_r(4), dz_r(4), u(5)]; C, D for OUTPUTS."""

    def f(x, w):
        ddq, named = accelerations(p, x[:8], x[8:], w[:4], w[4:8], w[8:])
        return np.concatenate([x[8:], ddq]), np.array([named[n] for n in OUTPUTS])

    x0, w0 = np.zeros(16), np.zeros(13)
    A = np.column_stack([f(e, w0)[0] for e in np.eye(16)])
    B = np.column_stack([f(x0, e)[0] for e in np.eye(13)])
    C = np.column_stack([f(e, w0)[1] for e in np.eye(16)])
    D = np.column_stack([f(x0, e)[1] for e in np.eye(13)])
    return A, B, C, D


def discretise(A, B, h):
    """x+ = Phi x + G0 w0 + G1 (w1 - w0) for w linear over the step (G1 unused for a hold)."""
    n, m = B.shape
    M = np.zeros((n + 2 * m, n + 2 * m))
    M[:n, :n] = A * h
    M[:n, n:n + m] = B * h
    M[n:n + m, n + m:] = np.eye(m)
    E = expm(M)
    return E[:n, :n], E[:n, n:n + m], E[:n, n + m:]


def simulate(W, h, first_order_hold):
    """Exact response to inputs sampled at t_k = k h (rows of W): held or linearly interpolated.

    Returns states and outputs at every t_k (outputs use the inputs at t_k)."""
    A, B, C, D = linear_maps()
    Phi, G0, G1 = discretise(A, B, h)
    X = np.zeros((len(W), 16))
    for k in range(len(W) - 1):
        dw = W[k + 1] - W[k] if first_order_hold else np.zeros_like(W[k])
        X[k + 1] = Phi @ X[k] + G0 @ W[k] + G1 @ dw
    Y = X @ C.T + W @ D.T
    return X, Y
