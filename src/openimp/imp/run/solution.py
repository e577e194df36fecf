"""What one run solved: a :class:`~openimp.results.Trajectory` and how the run ended.

The runner of any mode hands its motion to the tables, listings and pictures
as a :class:`Solution`: the trajectory of the solved steps (joint variables,
rates, quality index, free coordinates; body postures and point motions on
demand), the output times of those steps, and the run's ending (a failure
message, Ctrl-C, RETURN or END in a VALUE).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from openimp.results import Trajectory


@dataclass
class Solution:
    """The solved steps of a run (model units) and how the run ended.

    ``traj``: the trajectory; ``times``: the output time (or step number) of
    every solved step; ``message``: why the run stopped early ("" when it did
    not); ``interrupted``: the user pressed Ctrl-C; ``stop``: what IMP says
    when a VALUE evaluated RETURN or END; ``end``: END was evaluated, no
    further EXECUTE runs; ``forces``: the loads, once computed; ``response``:
    the time response of a dynamic run.
    """

    traj: Trajectory
    times: np.ndarray
    message: str = ""
    interrupted: bool = False
    stop: str = ""
    end: bool = False
    #: the force analysis of the run (:class:`~openimp.imp.run.forces.ForceResults`),
    #: when a request needs it
    forces: Any = None
    #: static mode: IMP's search line of every step ("Equilibrium found after N search
    #: steps.") and the :class:`~openimp.results.EquilibriumPath`
    search: list[str] | None = None
    equilibria: Any = None
    #: dynamic mode: the time response (:func:`openimp.simulate`'s trajectory, with its
    #: energy audit, integration statistics, coordinate switches and events); its arrays
    #: run over the output times from the first step of the run
    response: Any = None
    #: kinematic mode: the output times of the positions that could not be reached and
    #: were skipped (IMP's way through a limit of travel); not among :attr:`times`
    missing: list[float] | None = None
    #: every output time of the run when some are missing (singular postures are then
    #: numbered by output step); None: :attr:`times`
    grid: np.ndarray | None = None

    @classmethod
    def of(cls, parts: Sequence[Trajectory], empty: Trajectory, times: np.ndarray,
           message: str = "", steps: Sequence[int] | None = None) -> Solution:
        """The solution of the trajectories ``parts`` in order (``empty`` when none);
        ``steps``: the indices into ``times`` of their steps (default: the first ones)."""
        parts = [p for p in parts if p.nsteps]
        traj = Trajectory.concatenate(parts) if parts else empty
        t = times[:traj.nsteps] if steps is None else times[np.asarray(steps, int)]
        return cls(traj, np.asarray(t, dtype=float), message)

    @property
    def n(self) -> int:
        """Number of solved steps."""
        return self.traj.nsteps

    # joint variables and the run's indicators (steps x nq, model units)
    @property
    def q(self) -> np.ndarray:
        return self.traj.q

    @property
    def qd(self) -> np.ndarray:
        return self.traj.qd

    @property
    def qdd(self) -> np.ndarray:
        return self.traj.qdd

    @property
    def quality(self) -> np.ndarray:
        return self.traj.quality

    @property
    def iterations(self) -> np.ndarray:
        return self.traj.iterations

    @property
    def mobility(self) -> np.ndarray:
        return self.traj.mobility

    @property
    def fgc(self) -> list[list[str]]:
        return self.traj.fgc

    def rows(self, k: int, stop: int | None = None) -> Solution:
        """The steps ``k`` to ``stop`` (default: step ``k`` alone), same ending."""
        stop = k + 1 if stop is None else stop
        return Solution(self.traj.steps(k, stop), self.times[k:stop])
