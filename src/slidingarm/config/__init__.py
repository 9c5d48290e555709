"""Scenario files: a TOML description of one comparison, validated, then built into library objects.

A scenario states the arm, the model mismatch, the reference, the simulation, the sensor, the
disturbances, the controllers to compare and the gains they share. It is validated by pydantic
models that forbid unknown keys everywhere; every error is one line naming the file, the key
path (``controllers[1].gamma``, ``sensor.noise.sigma``) and what is allowed::

    sign.toml: controllers[1].gamma: must lie in (0, 1) (terminal: gamma = q/p with odd q < p), got 1.6667

Layout of a file (every table is optional except ``plant``, ``reference``, ``simulation`` and
``controllers``; ``slidingarm schema`` prints the full JSON schema)::

    extends = "paper.toml"      # optional base file (relative path), merged under this one:
                                # tables merge key by key, except a table that names its kind
                                # (kind; for [plant] preset, masses, robot or urdf), which
                                # replaces the base's; values and arrays replace
    name = "sign"               # default: the file's stem
    description = "..."
    switching = "sign"          # shared switching function: sign | tanh | sat

    [plant]                     # the controller's nominal arm: a planar arm ...
    preset = "paper"            # or masses, lengths (and com, inertia)
    mass_model = "point"        # point | rod
    # ... or a serial arm (these exclude the planar keys above):
    # robot = "ur5"             # a shipped robot (slidingarm.robots.names()), or
    # urdf = "arm.urdf"         # a URDF file, relative to the file that names it
    # tool = "tool0"            # the tool link (default: the robot's flange, the URDF's tip)
    gravity = 9.81              # m/s², along -y (planar) or -z of the root link (serial)

    [mismatch]                  # the simulated plant = nominal arm with these errors
    payload = 0.0               # kg at the tool
    mass_error = 0.0            # relative, scalar or per joint
    length_error = 0.0
    # payload_link = "link"     # serial arms: the payload at this link's origin instead

    [reference]                 # slidingarm.references.reference_from_dict; one value per joint
    kind = "paper"              # paper | quintic | sine | table (path relative to the file;
                                # ends = "rest" starts and ends a spline at rest); on a serial
                                # arm the reference and q0 must keep within the URDF's limits

    [simulation]
    t_final = 4.5               # s
    dt = 5e-4                   # s, sample time
    substeps = 1                # RK4 steps per sample
    q0 = [0.7, 1.5, 0.5]        # rad
    qd0 = [0.0, 0.0, 0.0]       # rad/s
    seed = 1
    torque_limit = 100.0        # optional, N m, scalar or per joint

    [sensor]
    noise = { sigma = 1e-4 }                           # rad
    velocity = { kind = "filtered", time_constant = 0.005 }
    faults = [{ kind = "bias", joint = 1, t_start = 2.0, value = 0.01 }]
    reasons = "markdown"

    [[disturbances]]
    kind = "constant"           # constant | sinusoidal | random
    value = 0.5

    [gains]                     # stated once, shared wherever a gain means the same thing
    alpha = 2.0                 # = lam: PDSMC's lambda and FTSMC's alpha (the linear term)
    beta = 2.0                  # the terminal term of TSMC and FTSMC
    p = 5                       # gamma = q/p (or give gamma)
    q = 3
    k = 20.0                    # reaching gain
    width = 0.05                # boundary layer of tanh/sat (ignored with sign)
    reasons = "markdown"

    [[controllers]]
    name = "ftsmc"              # pdsmc | tsmc | ftsmc | ntsmc
    label = "ftsmc"             # unique; names the results (default: name)
    law = "model"               # model | paper
    reaching = "classic"        # classic | super-twisting
    # any gain above (and switching, allow_nonterminal) overrides the shared value here

Load with :func:`load_scenario` (or :func:`scenario_from_dict`) and build with
:meth:`Scenario.build`, which returns a :class:`Setup` of library objects.

The package, by concept: :mod:`~slidingarm.config.values` (number, per-joint and vector types
and their JSON schema), :mod:`~slidingarm.config.specs` (the component specs: plant, mismatch,
references, simulation, sensor, disturbances, gains and controllers),
:mod:`~slidingarm.config.scenario` (:class:`Scenario` and :class:`Setup`),
:mod:`~slidingarm.config.loader` (TOML, ``extends``) and :mod:`~slidingarm.config.errors`
(:class:`ConfigError`, pydantic errors as one line).
"""

from __future__ import annotations

from slidingarm.config.errors import ConfigError
from slidingarm.config.loader import load_scenario, scenario_from_dict
from slidingarm.config.scenario import Scenario, Setup, choices
from slidingarm.config.specs import CONTROLLERS, ControllerSpec, GainsSpec

__all__ = [
    "CONTROLLERS",
    "ConfigError",
    "ControllerSpec",
    "GainsSpec",
    "Scenario",
    "Setup",
    "choices",
    "load_scenario",
    "scenario_from_dict",
]
