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

from typing import Any

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
from openimp.errors import AnalysisError, InputError, OpenIMPError
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
