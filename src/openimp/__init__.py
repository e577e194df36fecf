"""openimp: mechanism and multibody analysis by the 4x4 transformation-matrix method.

Build a :class:`Model` (or read an IMP deck with :func:`load`), compile it to a
:class:`~openimp.system.System` and run analyses on it, free functions of the
compiled system as in Pinocchio and MuJoCo::

    import numpy as np, openimp
    m = openimp.Model("four-bar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0))
    ...
    system = openimp.compile(m)
    res = openimp.sweep(system, {"A": np.radians(np.arange(361))})
    f = openimp.forces_of(res)       # drive torques, joint reactions (with masses, loads)

(``docs/python.md`` goes on to a plot and an animation.)
"""

import importlib
from typing import TYPE_CHECKING, Any

from openimp.errors import AnalysisError, InputError, OpenIMPError

if TYPE_CHECKING:  # the names below, for type checkers; imported on first use otherwise
    from openimp.dynamics import (
        BumpStop,
        LiftOff,
        LoadState,
        OneWayDamper,
        equations,
        equilibria,
        equilibrium,
        forces,
        forces_of,
        frequency_response,
        linearize,
        mode_motion,
        modes,
        modes_along,
        simulate,
        state_space,
        transfer_function,
    )
    from openimp.kinematics import BatchResult, sweep, sweep_batch
    from openimp.kinematics.ballrates import ball_rates
    from openimp.model import Model
    from openimp.results import (
        CoordinateSwitch,
        EnergyAudit,
        EquationsOfMotion,
        Equilibrium,
        EquilibriumPath,
        Event,
        Forces,
        FrequencyResponse,
        IntegrationStats,
        Linearization,
        ModeMap,
        Modes,
        SearchStatus,
        StateSpace,
        StepKind,
        Trajectory,
        TransferFunction,
    )
    from openimp.system import State, System
    from openimp.system import compile_model as compile

#: where each public name lives: ``import openimp`` stays instant (the command starts,
#: and answers Ctrl-C, at once); numpy, scipy and numba load with the first name used
_WHERE: dict[str, tuple[str, str]] = {
    **{n: ("openimp.dynamics", n) for n in (
        "BumpStop", "LiftOff", "LoadState", "OneWayDamper", "equations", "equilibria",
        "equilibrium", "forces", "forces_of", "frequency_response", "linearize",
        "mode_motion", "modes", "modes_along", "simulate", "state_space",
        "transfer_function")},
    **{n: ("openimp.kinematics", n) for n in ("BatchResult", "sweep", "sweep_batch")},
    "ball_rates": ("openimp.kinematics.ballrates", "ball_rates"),
    "Model": ("openimp.model", "Model"),
    **{n: ("openimp.results", n) for n in (
        "CoordinateSwitch", "EnergyAudit", "EquationsOfMotion", "Equilibrium",
        "EquilibriumPath", "Event", "Forces", "FrequencyResponse", "IntegrationStats",
        "Linearization", "ModeMap", "Modes", "SearchStatus", "StateSpace", "StepKind",
        "Trajectory", "TransferFunction")},
    "State": ("openimp.system", "State"),
    "System": ("openimp.system", "System"),
    "compile": ("openimp.system", "compile_model"),
}


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use (PEP 562)."""
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module 'openimp' has no attribute {name!r}")
    value = getattr(importlib.import_module(where[0]), where[1])
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__version__ = "0.1.0"


def load(path: str, **options: Any) -> Any:
    """Read an IMP deck: the model it builds plus its requests (see openimp.imp.deck.load;
    ``options``: ``check``, ``allow_read``)."""
    from openimp.imp.deck import load as _load

    return _load(path, **options)


__all__ = [
    "AnalysisError",
    "BatchResult",
    "BumpStop",
    "CoordinateSwitch",
    "EnergyAudit",
    "EquationsOfMotion",
    "Equilibrium",
    "EquilibriumPath",
    "Event",
    "Forces",
    "FrequencyResponse",
    "InputError",
    "IntegrationStats",
    "LiftOff",
    "Linearization",
    "LoadState",
    "ModeMap",
    "Model",
    "Modes",
    "OneWayDamper",
    "OpenIMPError",
    "SearchStatus",
    "State",
    "StateSpace",
    "StepKind",
    "System",
    "Trajectory",
    "TransferFunction",
    "__version__",
    "ball_rates",
    "compile",
    "equations",
    "equilibria",
    "equilibrium",
    "forces",
    "forces_of",
    "frequency_response",
    "linearize",
    "load",
    "mode_motion",
    "modes",
    "modes_along",
    "simulate",
    "state_space",
    "sweep",
    "sweep_batch",
    "transfer_function",
]
