"""Running the EXECUTEs of a deck, split by concern:

* :mod:`~openimp.imp.run.prepare`: the model built and checked, request items,
  what will not be produced, output times (every mode);
* :mod:`~openimp.imp.run.kinematic`: the kinematic runner (input motions,
  postures and rates);
* :mod:`~openimp.imp.run.static`: the static runner (equilibrium postures);
* :mod:`~openimp.imp.run.dynamic`: the dynamic runner (the time response);
* :mod:`~openimp.imp.run.solution`: what a run solved (a trajectory and how
  the run ended);
* :mod:`~openimp.imp.run.forces`: the force analysis of a solved run in IMP's
  convention of its mode (FORCE requests, FORCE(...) in VALUEs);
* :mod:`~openimp.imp.run.vibration`: linearized vibration of a solved
  kinematic run (PRINT FREQUENCY at every position; PRINT, LIST, STORE and
  PLOT DYNAMICS at the last one);
* :mod:`~openimp.imp.run.quantities`: tables and PRINT text from a solution;
* :mod:`~openimp.imp.run.output`: the deck's events in order, each EXECUTE
  through the runner of its mode (:data:`~openimp.imp.run.output.SOLVERS`),
  listings, pictures and files.
"""

from openimp.imp.run.output import SOLVERS, Context, execute_run, run_deck
from openimp.imp.run.prepare import Prepared, not_produced, trailing_requests, validate
from openimp.imp.run.solution import Solution

__all__ = ["SOLVERS", "Context", "Prepared", "Solution", "execute_run", "not_produced",
           "run_deck", "trailing_requests", "validate"]
