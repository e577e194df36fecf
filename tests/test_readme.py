"""The README's Python blocks run as written, and the forces they show balance power.

Reference (plain numpy): along the crank's uniform motion the power of the
drive and of gravity equals the rate of change of the kinetic energy,
d/dt T = omega dT/dtheta, by central differences over the 1-degree steps of
the README (truncation O(h^2): 1e-3 of the largest power term).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

README = Path(__file__).parent.parent / "README.md"


def test_readme_python_runs_and_balances_power() -> None:
    code = re.findall(r"^```python\n(.*?)^```$", README.read_text(), flags=re.S | re.M)
    assert len(code) == 3
    ns: dict = {"__name__": "readme"}
    for block in code:
        exec(compile(block, str(README), "exec"), ns)  # the README itself
    f = ns["f"]
    th = np.radians(np.arange(361))
    dT = np.gradient(f.kinetic, th) * 2 * np.pi
    balance = (f.power["drive"] + f.power["gravity"] - dT)[1:-1]
    assert np.abs(balance).max() < 1e-3 * np.abs(f.power["drive"]).max()
    # the planar linkage of spatial revolutes: out-of-plane components indeterminate
    assert np.array_equal(f.determinate("B")[0], [True, True, False, False, False, True])
    # the equilibrium block: balanced, and the crank's virtual power of gravity and the
    # spring vanishes there (a check by finite differences of the potential energy)
    eq = ns["eq"]
    assert eq.converged and eq.unbalance <= eq.force_tol.max()
    sy = eq.system
    a = eq.value("A")
    V = []
    for h in (-1e-5, 1e-5):
        tr = ns["openimp"].sweep(sy, {"A": [a + h]}, q=eq.q)
        V.append(ns["openimp"].forces_of(tr).potential[0])
    assert abs(V[1] - V[0]) / 2e-5 < 1e-6 * max(1.0, abs(eq.potential))
