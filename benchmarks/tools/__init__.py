"""One module per tool; :data:`TOOLS` lists the benchmarked tool variants.

Each entry: key -> (module, extra environment for its worker process,
ctx.extra options, number of batch variants it runs).  Tools whose per-posture
work is driven from a Python loop run a subset of the 1000 batch variants
(postures per second is a rate, so the subset changes the wall time, not the
figure); the subset is reported in the table.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class Tool:
    key: str
    label: str
    module: str
    env: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    nvariants: int = 1000
    pip: str = ""  # the PyPI distribution that provides it


TOOLS: dict[str, Tool] = {
    t.key: t
    for t in [
        Tool("openimp", "openimp", "benchmarks.tools.openimp_tool", pip="openimp"),
        Tool("pylinkage-py", "pylinkage (pure Python)", "benchmarks.tools.pylinkage_tool",
             env={"NUMBA_DISABLE_JIT": "1"}, extra={"mode": "python"}, nvariants=100,
             pip="pylinkage"),
        Tool("pylinkage-numba", "pylinkage (numba)", "benchmarks.tools.pylinkage_tool",
             extra={"mode": "numba"}, pip="pylinkage"),
        Tool("exudyn", "Exudyn (static load steps)", "benchmarks.tools.exudyn_tool",
             nvariants=100, pip="exudyn"),
        Tool("mujoco", "MuJoCo + Python Newton", "benchmarks.tools.mujoco_tool", nvariants=50,
             pip="mujoco"),
        Tool("pinocchio", "Pinocchio + Python Newton", "benchmarks.tools.pinocchio_tool",
             nvariants=50, pip="pin"),
    ]
}
