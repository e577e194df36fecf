"""What the tests share, importable from any test as ``helpers.<module>``.

``tests/`` is on ``sys.path`` for every test run (``pythonpath`` in pyproject.toml's
pytest section, and pytest's rootdir insertion of the conftest directory), so a test
module imports ``from helpers.models import Spec`` and never another test module.

* ``geometry``: plain-numpy frames and the closed-form geometry of book mechanisms
  (4x4 transforms, circle intersection, book example 5.1's shape matrices, the RSSR);
* ``models``: builders of Models that record what they gave the model (``Rig``: every
  joint frame; ``Spec``: masses, gravity and elements for the force references), the
  shared mechanisms (the four-bar, the five-bar, the slider-crank's joints);
* ``mechanics``: ``Ref``, the plain-numpy mechanics of a ``Spec`` along a trajectory
  (Newton-Euler balance, energies);
* ``response_models``, ``statics_models``: the models and references of the time
  response and static tests;
* ``decks``: writing and running IMP decks;
* ``docs``: the code blocks and phrases of the documentation pages.
"""
