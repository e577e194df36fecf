"""Kinematic mode (book ch 5-8): posture, velocity and acceleration analysis.

The stages, compiled functions over (model, data, state) that the sweeps and
every later analysis call instead of re-implementing them:

* :mod:`~openimp.kinematics.position`: postures along the tree, loop
  residuals (5.4, 5.5, 6.40, 6.43, 6.48), the joint operators D_h (6.14, 6.41);
* :mod:`~openimp.kinematics.elimination`: the Jacobian (6.45), its restricted
  pivoting (6.5.3), the replay of its row operations on any right-hand side,
  the first geometric derivatives phi' (7.14);
* :mod:`~openimp.kinematics.rates`: body operators W_{b,j} (7.20), velocities
  (7.22), the velocity-product acceleration (8.40-8.45), body accelerations
  (8.52);
* :mod:`~openimp.kinematics.posture`: Newton-Raphson (6.5) and the checks of
  the drivers of a motion;
* :mod:`~openimp.kinematics.sweep`: sweeps through driver values or motions
  of time; :mod:`~openimp.kinematics.batch`: many variants in parallel;
  :mod:`~openimp.kinematics.track`: postures and rates of bodies and points
  along a result; :mod:`~openimp.kinematics.inputs`: the inputs every analysis
  reads the same way (``q``, ``state=``, ``specified=``, rates).
"""

from openimp.kinematics.batch import BatchResult, sweep_batch
from openimp.kinematics.posture import (
    DIVERGED,
    MAXITER,
    OK,
    check_drivers,
    eliminate_at,
    free_coordinate,
    newton,
    passive_freedoms,
    rank_full,
    redundant_drivers,
)
from openimp.kinematics.sweep import SweepResult, sweep
from openimp.results import Trajectory

__all__ = [
    "DIVERGED", "MAXITER", "OK", "BatchResult", "SweepResult", "Trajectory", "check_drivers",
    "eliminate_at", "free_coordinate", "newton", "passive_freedoms", "rank_full",
    "redundant_drivers", "sweep", "sweep_batch",
]
