"""The thesis hinf_sf's (dist/thesis/, `make thesis`) second claim re-checked outside Rust: the shipped gain is the mixed H2/H-infinity
point, and its certificate states an H2 bound on the rows of z without road feed-through. Here
the closed loop is rebuilt from the certificate's generalised plant and gain, and its H2 norm
computed from SciPy's Lyapunov solver (Bartels-Stewart, not the Kronecker solve of the Rust
certificate)."""

import json
import pathlib

import numpy as np
from scipy.linalg import solve_continuous_lyapunov

THESIS = pathlib.Path(__file__).resolve().parents[2] / "dist" / "thesis"
FORCE_UNIT = 1000.0  # N per unit of the generalised plant's u (certificate "scaling")


def test_hinf_sf_h2_norm_is_the_certified_one_and_below_its_bound():
    cert = json.loads((THESIS / "hinf_sf.certificate.json").read_text())
    g = {k: np.array(v, dtype=float) for k, v in cert["generalized_plant"].items()}
    k = np.array(cert["controller"]["D"], dtype=float) / FORCE_UNIT  # u = K x, state feedback
    a = g["A"] + g["B_u"] @ k
    assert np.max(np.linalg.eigvals(a).real) < 0
    rows = [i for i in range(g["C_z"].shape[0]) if not np.any(g["D_zw"][i])]
    assert rows == cert["details"]["h2_rows"]
    c = (g["C_z"] + g["D_zu"] @ k)[rows]
    gramian = solve_continuous_lyapunov(a, -g["B_w"] @ g["B_w"].T)
    h2 = np.sqrt(np.trace(c @ gramian @ c.T))
    d = cert["details"]
    print(f"hinf_sf H2 norm {h2:.6f} (certificate {d['h2_norm']:.6f}, bound {d['h2_bound']:.6f}, "
          f"bound at the gamma-optimal point {d['h2_bound_at_gamma_opt']:.6f})")
    assert abs(h2 - d["h2_norm"]) <= 1e-6 * h2
    assert h2 <= d["h2_bound"] * (1 + 1e-6)
