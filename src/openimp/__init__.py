"""openimp: mechanism and multibody analysis by the 4x4 transformation-matrix method.

Build a :class:`Model` (or read an IMP deck with :func:`load`), compile it to a
:class:`~openimp.system.System` and run analyses on it::

    import numpy as np, openimp
    m = openimp.Model("four-bar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    ...
    system = openimp.compile(m)
    res = openimp.sweep(system, {"A": np.radians(np.arange(361))})

(``docs/python.md`` goes on to a plot and an animation.)
"""

from typing import Any

from openimp.errors import AnalysisError, InputError, OpenIMPError
from openimp.model import Model

__version__ = "0.1.0"


def compile(model: Model) -> Any:
    """Check ``model`` and build its immutable :class:`~openimp.system.System`."""
    return model.compile()


def sweep(system: Any, *args: Any, **kw: Any) -> Any:
    """Move ``system`` through driver values: a :class:`~openimp.kinematics.SweepResult`.

    ``sweep(system, {"A": angles}, rates={"A": 2 * np.pi})``; the arguments are
    those of :meth:`openimp.system.System.sweep`.
    """
    return system.sweep(*args, **kw)


def load(path: str) -> Any:
    """Read an IMP deck: the model it builds plus its requests (see openimp.imp.interp.load)."""
    from openimp.imp.interp import load as _load

    return _load(path)


__all__ = ["AnalysisError", "InputError", "Model", "OpenIMPError", "__version__", "compile",
           "load", "sweep"]
