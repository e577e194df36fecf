"""openimp: mechanism and multibody analysis by the 4x4 transformation-matrix method.

Build a :class:`Model` (or read an IMP deck with :func:`load`), compile it to a
:class:`~openimp.system.System` and run analyses on it::

    import numpy as np, openimp
    m = openimp.Model("four-bar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    ...
    res = m.compile().sweep({"A": np.radians(np.arange(361))})
"""

from typing import Any

from openimp.errors import AnalysisError, InputError, OpenIMPError
from openimp.model import Model

__version__ = "0.1.0"


def load(path: str, **options: Any) -> Any:
    """Read an IMP deck: the model it builds plus its requests (see openimp.imp.interp.load;
    ``options``: ``check``, ``allow_read``)."""
    from openimp.imp.interp import load as _load

    return _load(path, **options)


__all__ = ["AnalysisError", "InputError", "Model", "OpenIMPError", "__version__", "load"]
