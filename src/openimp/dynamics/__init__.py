"""Dynamic mode (book ch 9-14, 17): what a mechanism carries.

The stages, compiled functions over (System, Data, DynData, State) that the
force analysis of this package and the later analyses (equilibrium,
linearisation, time response) call:

* :mod:`~openimp.dynamics.inertia`: global pseudo-inertias (9.7), inertia
  wrenches (10.8), the mass matrix (10.15), the kinetic energy;
* :mod:`~openimp.dynamics.loads`: gravity, joint and point springs and
  dampers, applied forces and torques (9.5-9.11, 10.12, 10.13);
* :mod:`~openimp.dynamics.inverse`: driving forces (11.14) and joint
  reactions by fictitious displacements (ch 17) along a motion;
* :mod:`~openimp.dynamics.eom`: the equations of motion at one state,
  M(psi) psi'' + c(psi, psi') = Q(psi, psi', t), with the FGC/SGC partition;
* :mod:`~openimp.dynamics.laws`: load laws (callables) evaluated per step;
* :mod:`~openimp.dynamics.linear`: the linearized equations about a set point
  (ch 11), compiled;
* :mod:`~openimp.dynamics.analysis`: :func:`forces` (a motion solved there) and
  :func:`forces_of` (a solved one), the Python entries;
* :mod:`~openimp.dynamics.statics`, :mod:`~openimp.dynamics.equilibrium`: the
  static residual and stiffness (compiled) and :func:`equilibrium`,
  :func:`equilibria` (ch 12);
* :mod:`~openimp.dynamics.vibration`: :func:`linearize`, :func:`modes`,
  :func:`transfer_function`, :func:`frequency_response`, :func:`state_space`
  (ch 11, 13);
* :mod:`~openimp.dynamics.stepping`, :mod:`~openimp.dynamics.response`: the
  compiled time stepping (Dormand-Prince and the book's exponential step) and
  :func:`simulate`, the time response (ch 14).
"""

from openimp.dynamics.analysis import forces, forces_of
from openimp.dynamics.equilibrium import equilibria, equilibrium
from openimp.dynamics.laws import BumpStop, LiftOff, LoadState, OneWayDamper
from openimp.dynamics.response import simulate
from openimp.dynamics.vibration import (
    frequency_response,
    linearize,
    mode_motion,
    modes,
    modes_along,
    state_space,
    transfer_function,
)

__all__ = ["BumpStop", "LiftOff", "LoadState", "OneWayDamper",
           "equilibria", "equilibrium", "forces", "forces_of", "frequency_response",
           "linearize", "mode_motion", "modes", "modes_along", "simulate",
           "state_space", "transfer_function"]
