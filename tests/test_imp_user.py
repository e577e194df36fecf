"""USER(name) in IMP decks (issue 25 item 6): a Python function f(t, nderiv), registered
with ``openimp.imp.register_user`` or given to ``openimp run --user FILE.py``, as
IMP's C function ``real user(Word name, real t, int nderiv)`` was.

Checks: a crank driven by USER(ROAD) = sin 2t turns by it, its rate is the given
derivative (not a difference); a slider pushed by a USER force moves as the
force's double integral (closed form); a failing function and a bad file are
messages, never tracebacks.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from helpers.decks import cpu_limit, run_deck, write
from openimp.errors import InputError
from openimp.imp import register_user
from openimp.imp.expr import USER_FUNCTIONS

CRANK = """ZPIN (BASE, CRNK) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
POINT (CRNK) = P
DATA POINT (P, ABS) = 1, 0, 0
VALUE (V) = USER(ROAD)
DATA MOTION (A) = V
DATA TIME = 1, 0, 0.125
LIST POSITION (A)
LIST VELOCITY (A)
LIST ACCEL (A)
EXECUTE
END
"""


def road(t: float, n: int) -> float:
    return (math.sin(2 * t), 2 * math.cos(2 * t), -4 * math.sin(2 * t))[n]


@pytest.fixture
def registry():
    saved = dict(USER_FUNCTIONS)
    yield
    USER_FUNCTIONS.clear()
    USER_FUNCTIONS.update(saved)


def _check_crank(r) -> None:
    t = np.arange(9) * 0.125
    rows = [r.table(f"LIST {q}", "joint A").rows for q in ("POSITION", "VELOCITY", "ACCEL")]
    np.testing.assert_allclose(rows[0][:, 0], t, atol=1e-12)
    np.testing.assert_allclose(rows[0][:, 1], np.degrees(np.sin(2 * t)), atol=1e-9)
    np.testing.assert_allclose(rows[1][:, 1], 2 * np.cos(2 * t), atol=1e-9)
    np.testing.assert_allclose(rows[2][:, 1], -4 * np.sin(2 * t), atol=1e-9)


def test_user_function_drives_a_crank(tmp_path, registry) -> None:
    register_user("ROADWAY", road)  # IMP reads the first four characters
    runs, _ = run_deck(write(tmp_path, CRANK))
    assert runs[0].ok, runs[0].failure
    _check_crank(runs[0])


def test_user_file_from_the_command_line(tmp_path) -> None:
    (tmp_path / "funcs.py").write_text(
        "import math\n\ndef road(t, n):\n"
        "    return (math.sin(2 * t), 2 * math.cos(2 * t), -4 * math.sin(2 * t))[n]\n\n"
        "USER = {'ROAD': road}\n")
    p = write(tmp_path, CRANK)
    r = subprocess.run([sys.executable, "-m", "openimp.cli", "run", "--user",
                        str(tmp_path / "funcs.py"), str(p), "--json", str(tmp_path / "o.json")],
                       capture_output=True, text=True, preexec_fn=cpu_limit)
    assert r.returncode == 0, r.stderr
    tables = json.loads((tmp_path / "o.json").read_text())["runs"][0]["tables"]

    class Json:  # the run's tables as _check_crank reads them
        def table(self, request: str, item: str) -> SimpleNamespace:
            t = next(t for t in tables if t["request"] == request and t["item"] == item)
            return SimpleNamespace(rows=np.array(t["rows"], float))

    _check_crank(Json())


@pytest.mark.parametrize(("text", "words"), [
    ("raise SystemError('boom')\n", "the file does not run (SystemError: boom)"),
    ("USER = 3\n", "define a dict USER"),
    ("USER = {'ROAD': 3}\n", "give a function f(t, nderiv), got int"),
])
def test_bad_user_file_is_a_message(tmp_path, text, words) -> None:
    (tmp_path / "funcs.py").write_text(text)
    p = write(tmp_path, CRANK)
    r = subprocess.run([sys.executable, "-m", "openimp.cli", "run", "--user",
                        str(tmp_path / "funcs.py"), str(p)],
                       capture_output=True, text=True, preexec_fn=cpu_limit)
    assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_failing_or_missing_user_function_is_said(tmp_path, registry) -> None:
    """Missing: the message says how to supply it; raising or returning NaN: the message
    names the function, the time and the error; IMP's 0 is used."""
    p = write(tmp_path, CRANK)
    _runs, echo = run_deck(p)
    assert any("USER(ROAD) is not supplied: register it with openimp.imp.register_user"
               in ln for ln in echo), echo
    register_user("ROAD", lambda t, n: 1.0 / (t - 0.25) if t > 0.2 else 0.0)
    _runs, echo = run_deck(p)
    assert any("USER(ROAD) failed at t = 0.25 with nderiv 0 (ZeroDivisionError" in ln
               for ln in echo), echo
    register_user("ROAD", lambda t, n: math.nan)
    _runs, echo = run_deck(p)
    assert any("USER(ROAD) returned nan at t = 0 with nderiv 0" in ln for ln in echo), echo
    with pytest.raises(InputError, match="not an IMP name"):
        register_user("", road)


SLIDER = """UNIT (MASS) = 1
XSLIDE (BASE, CAR) = S
DATA XSLIDE (S) = 0, 0, 0
DATA MASS (CAR, LINK) = 2; 0, 0, 0
VALUE (F) = USER(PUSH)
DATA FORCE (S) = F
REMARK OPENIMP INTEGRATOR = RK, 1E-11
FIND DYNAMICS
DATA TIME = 1, 0, 0.1
LIST POSITION (S)
EXECUTE
END
"""


def test_user_force_in_the_time_response(tmp_path, registry) -> None:
    """F = 3 cos t on 2 mass units from rest: x = 1.5 (1 - cos t), to 1e-9."""
    register_user("PUSH", lambda t, n: (3 * math.cos(t), -3 * math.sin(t),
                                        -3 * math.cos(t))[n])
    runs, _ = run_deck(write(tmp_path, SLIDER))
    r = runs[0]
    assert r.ok and r.mode == "dynamic", r.failure
    rows = r.table("LIST POSITION", "joint S").rows
    np.testing.assert_allclose(rows[:, 1], 1.5 * (1 - np.cos(rows[:, 0])), atol=1e-9)
