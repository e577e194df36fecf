"""The IMP manual's chapter 9 example 4 (SAE left front suspension, ``saetst.dat``),
run unchanged with the manual's session: every element acts (the ball joints'
springs on their Cardan angles, the tyre and bumpers written as VALUE springs that
read the posture, the shock absorber whose rate reads its own velocity).

Independent check: the static equilibrium is where the potential energy along the
suspension's travel is stationary, computed here in numpy from a kinematic sweep
of the same deck (gravity at the mass centres, every spring's energy from its
length or joint angle, the tyre's one-sided spring), not from openimp's loads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from helpers.decks import MANUAL_DECKS, manual_session, run_deck, write

DECK = MANUAL_DECKS / "saetst.dat"
SESSION = "RECALL INPUT = saetst.dat\nEXECUTE HOLD\nRECALL INPUT\nEXECUTE\nEND\n"

#: weights (lbf: UNIT (MASS) = 1/386.088 with g = 386.088 in/s^2) and mass centres of the
#: deck's DATA MASS statements, as points in the same joint frames
CENTRES = {"LCA": ("LBAL", "0,0,8.64", 15.85), "UCA": ("UBAL", "0,0,3.79", 7.00),
           "TROD": ("TBAL", "0,0,9.15", 3.43), "SPND": ("AXLE", "1.31,1.38,-3.29", 29.90),
           "WHEL": ("AXLE", "0,0,0.32", 67.45)}
DEG = np.pi / 180.0


@pytest.fixture(scope="module")
def example4(tmp_path_factory):
    return manual_session(tmp_path_factory.mktemp("ex4"), "saetst.dat", SESSION)


def _energy_stationary(tmp_path: Path) -> tuple[float, float]:
    """(LPIN deg, RIDE) where dE/dLPIN = 0 along a kinematic sweep of LPIN at BUMP = 0."""
    text = DECK.read_text().split(" REMARK: OPERATING CONDITIONS")[0]
    for i, (link, (joint, xyz, _w)) in enumerate(CENTRES.items()):  # IMP names: 4 letters
        text += f" POINT({link})=G{i}\n DATA POINT(G{i},{joint})={xyz}\n"
    text += (" DATA POSITION(BUMP)=0\n DATA POSITION(LPIN)=0.30,0.002,25\n"
             " LIST POSITION(ALL)\n LIST FORCE(JNCS,RBNS)\n EXECUTE\n END\n")
    r = run_deck(write(tmp_path, text, "sweep.imp"))[0][0]
    assert r.ok, r.failure

    def rows(item: str) -> np.ndarray:
        return r.table("LIST POSITION", item).rows

    lpin = rows("joint LPIN")[:, 1]
    ride = rows("joint RIDE")[:, 1]
    E = sum(w * rows(f"point G{i}")[:, 3] for i, (_j, _x, w) in enumerate(CENTRES.values()))
    E = E + 0.5 * 365.0 * (rows("spring SPNG")[:, 1] - 16.25) ** 2
    E = E + 0.5 * 100.0 * (rows("spring STIF")[:, 1] - 11.0) ** 2
    E = E + 0.5 * 28.0 / DEG * (lpin * DEG) ** 2 + 0.5 * 38.4 / DEG * (
        rows("joint UPIN")[:, 1] * DEG) ** 2
    for ball, free in (("LBAL", (0.0, 90.0, 180.0)), ("UBAL", (-180.0, 90.0, 0.0))):
        ang = rows(f"joint {ball}")[:, 1:4]
        d = (ang - np.array(free) + 180.0) % 360.0 - 180.0  # the free angle modulo a turn
        E = E + np.sum(0.5 * 20.0 / DEG * (d * DEG) ** 2, axis=1)
    E = E + np.where(ride < 0.83, 0.5 * 1450.0 * (0.83 - ride) ** 2, 0.0)
    for bumper in ("JNCS", "RBNS"):  # out of contact over the sweep: no energy
        assert np.all(r.table("LIST FORCE", f"spring {bumper}").rows[:, 1] == 0.0)
    dE = np.gradient(E, lpin)
    j = int(np.flatnonzero(np.sign(dE[:-1]) != np.sign(dE[1:]))[0])
    x = lpin[j] - dE[j] * (lpin[j + 1] - lpin[j]) / (dE[j + 1] - dE[j])
    return float(x), float(np.interp(x, lpin, ride))


def test_static_run_is_the_energy_minimum_with_every_element(example4, tmp_path) -> None:
    """LPIN 0.3469 deg, RIDE 0.0975, tyre 1062.1 lbf (the reference of
    shared/reference/imp-manual-decks), the stationary point of the energy to 2e-4 deg
    (the sweep's step is 0.002 deg), and no load left out or undefined."""
    runs, _echo = example4
    st = runs[0]
    assert st.ok and st.mode == "static", st.failure
    for word in ("undefined", "left out", "dropped", "cannot carry"):
        assert not any(word in m for m in st.messages), st.messages
    lpin = st.table("PRINT POSITION", "joint LPIN").rows[0, 1]
    ride = st.table("PRINT POSITION", "joint RIDE").rows[0, 1]
    tyre = st.table("PRINT FORCE", "joint PACH").rows[0, 3]
    assert lpin == pytest.approx(0.3469, abs=5e-5)
    assert ride == pytest.approx(0.0975, abs=5e-5)
    # the tyre alone loads the massless TIRE: its spring force, to the residual the
    # deck's ZERO EQUILIBRIUM 0.0001 leaves (1.4e-4 lbf measured)
    assert -tyre == pytest.approx(1450.0 * (0.83 - ride), abs=1e-3)
    assert -tyre == pytest.approx(1062.1, abs=0.05)
    x, r = _energy_stationary(tmp_path)
    assert lpin == pytest.approx(x, abs=2e-4) and ride == pytest.approx(r, abs=1e-4)


def test_dynamic_run_keeps_the_shock_absorber_and_the_tyre_lift_off(example4) -> None:
    """Over the 2.95 in hole the tyre leaves the road and lands again within the 0.25 s
    run (its load is 0 in between, located switches of RIDE's IF), the shock
    absorber's IF switches as its velocity changes sign, and the tyre load settles
    back to the static 1062 lbf."""
    runs, echo = example4
    dyn = runs[1]
    assert dyn.ok and dyn.mode == "dynamic", dyn.failure
    rows = dyn.table("LIST FORCE", "joint PACH").rows
    t, fz = rows[:, 0], rows[:, 3]
    assert t[-1] == pytest.approx(0.25) and fz[0] == pytest.approx(-1062.118, abs=1e-3)
    off = t[fz == 0.0]
    assert off.size and 0.010 < off[0] < 0.020 and 0.05 < off[-1] < 0.06
    assert np.all(fz[t > 0.06] < -700.0)
    assert fz[-1] == pytest.approx(-1062.1, abs=2.0)
    ride = [ln for ln in echo if "RIDE switches" in ln]
    shock = [ln for ln in echo if "SHCK switches" in ln]
    assert len(ride) == 2 and len(shock) >= 3, echo
