"""The paper's study (docs/theory.md §7): shipped scenarios, running them, and regenerating everything.

- :data:`SCENARIOS` — ``sign``, ``tanh``, ``noise``, shipped as TOML files in
  ``slidingarm/study/scenarios/`` (with their common base ``paper.toml``, where the shared gains
  and their reasons live); :data:`SHIPPED` adds the UR5's ``ur5`` and ``ur5_sign``;
- :func:`run_scenario` — simulate every controller of a scenario;
- :func:`run` — one scenario's results folder (CSVs, metrics, figures, config, manifest);
- :func:`reproduce` — the whole study with its analyses and report.
"""

from slidingarm.study.output import OutputError
from slidingarm.study.paper import PAPER_MSE
from slidingarm.study.reproduce import Progress, StudyOutput, reproduce, run, run_scenario
from slidingarm.study.shipped import (
    BASE,
    SCENARIOS,
    SHIPPED,
    load_shipped,
    resolve_scenario,
    scenario_path,
    scenarios_dir,
)

__all__ = [
    "BASE",
    "PAPER_MSE",
    "SCENARIOS",
    "SHIPPED",
    "OutputError",
    "Progress",
    "StudyOutput",
    "load_shipped",
    "reproduce",
    "resolve_scenario",
    "run",
    "run_scenario",
    "scenario_path",
    "scenarios_dir",
]
