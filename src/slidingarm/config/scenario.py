"""The scenario (:class:`Scenario`, one comparison of controllers) and what it builds
(:class:`Setup`, library objects ready for :func:`slidingarm.simulate`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, get_args

import numpy as np
from pydantic import Field, PrivateAttr

from slidingarm import robots
from slidingarm._io import MAX_TABLE_BYTES, file_problem
from slidingarm._validate import MAX_POSITION
from slidingarm.config.errors import ConfigError, literal_values, tags
from slidingarm.config.specs import (
    _CONTROLLER_CLASSES,
    _SURFACE_GAINS,
    PLANAR_KEYS,
    ControllerSpec,
    DisturbanceSpec,
    FaultSpec,
    GainsSpec,
    MismatchSpec,
    PlantSpec,
    QuinticReferenceSpec,
    ReferenceSpec,
    SensorSpec,
    SimulationSpec,
    SineReferenceSpec,
    SinusoidalDisturbanceSpec,
    SweepSpec,
    TableReferenceSpec,
    VelocitySpec,
    _build_disturbance,
    _ControllerHead,
    _gain_names,
    _tuple,
)
from slidingarm.config.values import _NAME_PATTERN, Switching, _Strict
from slidingarm.control.controllers import SlidingModeController
from slidingarm.disturbances import Disturbance
from slidingarm.models.planar import PlanarArm
from slidingarm.models.serial import SerialArm
from slidingarm.references import Reference, reference_from_dict
from slidingarm.sensors import Sensor
from slidingarm.simulate import (
    MEMORY_SHARE,
    _grid_steps,
    available_memory,
    byte_size,
    memory_estimate,
)

#: The arms a scenario builds.
Arm = PlanarArm | SerialArm

__all__ = ["Scenario", "Setup", "choices"]

#: Samples of the reference evaluated at once when it is checked: validation stays within a
#: few MB however long the run (it never allocates the traces).
_CHECK_CHUNK = 2**15

# --------------------------------------------------------------------------------------------
# the scenario


@dataclass(frozen=True)
class Setup:
    """A built scenario: library objects ready for :func:`slidingarm.simulate`.

    ``controllers`` maps each controller's label to the controller, in the file's order.
    """

    name: str
    description: str
    nominal: Arm
    plant: Arm
    reference: Reference
    controllers: dict[str, SlidingModeController]
    q0: tuple[float, ...]
    qd0: tuple[float, ...] | None
    t_final: float
    dt: float
    substeps: int
    sensor: Sensor
    disturbances: tuple[Disturbance, ...]
    torque_limit: float | tuple[float, ...] | None
    seed: int

    def options(self) -> dict[str, Any]:
        """Keyword arguments of :func:`slidingarm.simulate` other than the plant, controller and
        reference."""
        return {
            "q0": self.q0,
            "qd0": self.qd0,
            "t_final": self.t_final,
            "dt": self.dt,
            "substeps": self.substeps,
            "sensor": self.sensor,
            "disturbances": self.disturbances,
            "torque_limit": self.torque_limit,
            "seed": self.seed,
        }


class Scenario(_Strict):
    """One comparison of controllers on one arm, reference, sensor and disturbance set."""

    extends: str | None = Field(
        default=None,
        description="Base scenario file (relative to this one) or the name of a shipped "
        "scenario ('tanh'), merged under this file: tables merge key by key, values and arrays "
        "of tables replace; name and description are not inherited.",
    )
    name: str | None = Field(
        default=None, pattern=_NAME_PATTERN, description="Scenario name (default: the file's stem)."
    )
    description: str = ""
    switching: Switching = Field(description="Switching function shared by the controllers.")
    plant: PlantSpec
    mismatch: MismatchSpec = MismatchSpec()
    reference: ReferenceSpec
    simulation: SimulationSpec
    sensor: SensorSpec = SensorSpec()
    disturbances: list[DisturbanceSpec] = Field(default_factory=list)
    gains: GainsSpec = GainsSpec()
    controllers: list[ControllerSpec] = Field(min_length=1)
    sweep: SweepSpec | None = Field(
        default=None,
        description="A Monte Carlo sweep of this scenario (slidingarm sweep only): runs, seed, "
        'chunk and distributions keyed by dotted paths ("gains.k" = { uniform = [10, 40] }).',
    )

    _source: Path | None = PrivateAttr(default=None)
    _base_dir: Path | None = PrivateAttr(default=None)
    _origin: dict[tuple[Any, ...], str] = PrivateAttr(default_factory=dict)

    @property
    def source(self) -> Path | None:
        """The file this scenario was read from (``None`` when built from a mapping)."""
        return self._source

    @property
    def key(self) -> str:
        """The scenario's name (``name``, or the file's stem, or ``"scenario"``)."""
        if self.name:
            return self.name
        return self._source.stem if self._source is not None else "scenario"

    # ---------------------------------------------------------------- checks and build
    def _fail(self, path: str, reason: str) -> ConfigError:
        return ConfigError(reason, file=self._source, path=path)

    def controller_gains(self, index: int) -> dict[str, Any]:
        """Keyword arguments of controller ``index``'s class (without the model).

        Shared gains fill what the controller does not override; a gain the controller does
        not use is not passed (``width`` with sign switching, ``k2`` with classic reaching).
        """
        spec = self.controllers[index]
        here = f"controllers[{index}]"
        shared = self.gains
        switching = spec.switching or self.switching
        uses = _SURFACE_GAINS[spec.name]
        # overrides of gains this controller does not have
        meaning = {
            "alpha": "linear",
            "lam": "linear",
            "beta": "beta",
            "gamma": "exponent",
            "p": "exponent",
            "q": "exponent",
        }
        for key, what in meaning.items():
            if getattr(spec, key) is not None and what not in uses:
                raise self._fail(
                    f"{here}.{key}",
                    f"{spec.name} has no gain {key}; its gains are {_gain_names(spec.name)}",
                )
        klass = _CONTROLLER_CLASSES[spec.name]
        if spec.allow_nonterminal and not klass.TERMINAL:
            terminal = " and ".join(n for n, c in _CONTROLLER_CLASSES.items() if c.TERMINAL)
            raise self._fail(f"{here}.allow_nonterminal", f"applies to {terminal} only")
        if spec.width is not None and switching == "sign":
            raise self._fail(
                f"{here}.width",
                "the boundary layer applies to tanh and sat only, not sign switching",
            )
        if spec.k2 is not None and spec.reaching != "super-twisting":
            raise self._fail(f"{here}.k2", "applies to reaching = 'super-twisting' only")

        def pick(key: str, required: bool) -> Any:
            value = getattr(spec, key)
            if value is None:
                value = getattr(shared, key)
            if value is None and required:
                raise self._fail(
                    f"gains.{key}",
                    f"missing: {spec.name} ({here}) needs {key}; set "
                    "it in [gains] (shared) or on the controller",
                )
            return value

        kwargs: dict[str, Any] = {
            "switching": switching,
            "law": spec.law,
            "reaching": spec.reaching,
        }
        kwargs["k"] = pick("k", True)
        if switching != "sign":
            width = pick("width", False)
            if width is not None:
                kwargs["width"] = width
        if spec.reaching == "super-twisting":
            kwargs["k2"] = pick("k2", True)
        if "linear" in uses:
            linear = spec.linear if spec.linear is not None else shared.linear
            if linear is None:
                raise self._fail(
                    "gains.alpha",
                    f"missing: {spec.name} ({here}) needs alpha (= lam), "
                    "the linear surface gain; set it in [gains] or on the controller",
                )
            assert klass.LINEAR_NAME is not None
            kwargs[klass.LINEAR_NAME] = linear
        if "beta" in uses:
            kwargs["beta"] = pick("beta", True)
        if "exponent" in uses:
            exp = spec.exponent() or shared.exponent()
            if not exp:
                raise self._fail(
                    "gains.gamma",
                    f"missing: {spec.name} ({here}) needs gamma (or p "
                    "and q); set it in [gains] or on the controller",
                )
            if klass.EXPONENT_RANGE[0] >= 1.0 and not spec.exponent() and "gamma" in exp:
                # shared gamma = q/p; the nonsingular surface's exponent is p/q = 1/gamma
                exp = {"gamma": 1.0 / exp["gamma"]}
            kwargs.update(exp)
            if klass.TERMINAL:
                kwargs["allow_nonterminal"] = spec.allow_nonterminal
                eps = pick("eps_e", False)
                if eps is not None:
                    kwargs["eps_e"] = eps
        elif spec.eps_e is not None:
            raise self._fail(f"{here}.eps_e", f"{spec.name} has no singular term to guard")
        return {k: _tuple(v) if isinstance(v, list) else v for k, v in kwargs.items()}

    def _check_lengths(self, n: int) -> None:
        """Every per-joint value has 1 or ``n`` entries; joint numbers exist."""
        items: list[tuple[str, Any]] = [
            ("simulation.q0", self.simulation.q0),
            ("simulation.qd0", self.simulation.qd0),
            ("simulation.torque_limit", self.simulation.torque_limit),
            ("mismatch.mass_error", self.mismatch.mass_error),
            ("mismatch.length_error", self.mismatch.length_error),
        ]
        if self.sensor.noise is not None:
            items.append(("sensor.noise.sigma", self.sensor.noise.sigma))
        for i, d in enumerate(self.disturbances):
            for key in ("value", "amplitude", "sigma"):
                if hasattr(d, key):
                    items.append((f"disturbances[{i}].{key}", getattr(d, key)))
        gain_keys = ("alpha", "lam", "beta", "k", "width", "k2")
        items += [(f"gains.{key}", getattr(self.gains, key)) for key in gain_keys]
        for i, c in enumerate(self.controllers):
            items += [(f"controllers[{i}].{key}", getattr(c, key)) for key in gain_keys]
        exact = {"simulation.q0", "simulation.qd0"}
        for path, value in items:
            if isinstance(value, list):
                if len(value) != n and (path in exact or len(value) != 1):
                    allowed = f"{n} values" if path in exact else f"a scalar or {n} values"
                    raise self._fail(
                        path, f"has {len(value)} values but the arm has {n} joints (give {allowed})"
                    )
        for i, f in enumerate(self.sensor.faults):
            if f.joint > n:
                raise self._fail(
                    f"sensor.faults[{i}].joint",
                    f"joint {f.joint} does not exist on a {n}-joint arm (1..{n})",
                )

    def check(self) -> None:
        """Cross-field checks pydantic cannot do alone (joint counts, time grid, gains).

        Raises
        ------
        ConfigError
        """
        self.build()

    def build(self) -> Setup:
        """Build the library objects.

        Raises
        ------
        ConfigError
            For anything the file's keys do not fit together on (joint counts, time grid,
            missing gains, table files), with the key path.
        """
        labels = [c.key for c in self.controllers]
        for i, label in enumerate(labels):
            if label in labels[:i]:
                raise self._fail(
                    f"controllers[{i}].label",
                    f"duplicate controller {label!r}; "
                    "give each controller of the same type a distinct label",
                )
        nominal = self._build_plant()
        n = nominal.n
        self._check_lengths(n)
        plant = self._build_mismatch(nominal)
        base = self._base_dir
        sim = self.simulation
        steps = self._guard("simulation.t_final", lambda: _grid_steps(sim.t_final, sim.dt)[0])
        self._check_memory(steps + 1, n)
        self._check_rates(sim.dt)
        ref_path = getattr(self.reference, "path", None)
        if ref_path is not None:
            full = Path(ref_path) if base is None else Path(base) / ref_path
            problem = file_problem(full, "reference table", MAX_TABLE_BYTES)
            if problem == "no such file":
                raise self._fail("reference.path", f"table file not found: {full}")
            if problem is not None:
                raise self._fail("reference.path", f"{full}: {problem}")
        self._check_reference_lengths(n)
        reference = self._guard(
            "reference",
            lambda: reference_from_dict(
                self.reference.model_dump(exclude_none=True), base_dir=base
            ),
        )
        if reference.n != n:
            key = "reference.path" if ref_path is not None else "reference"
            raise self._fail(key, f"describes {reference.n} joints but the arm has {n}")
        self._check_reference(nominal, reference, steps, sim.dt)
        sensor = self._guard("sensor", self.sensor.build)
        disturbances = tuple(
            self._guard(f"disturbances[{i}]", partial(_build_disturbance, d))
            for i, d in enumerate(self.disturbances)
        )
        controllers: dict[str, SlidingModeController] = {}
        for i, spec in enumerate(self.controllers):
            kwargs = self.controller_gains(i)
            cls = _CONTROLLER_CLASSES[spec.name]
            controllers[spec.key] = self._guard(
                f"controllers[{i}]", partial(cls, nominal, **kwargs)
            )
        return Setup(
            name=self.key,
            description=self.description,
            nominal=nominal,
            plant=plant,
            reference=reference,
            controllers=controllers,
            q0=tuple(sim.q0),
            qd0=None if sim.qd0 is None else tuple(sim.qd0),
            t_final=sim.t_final,
            dt=sim.dt,
            substeps=sim.substeps,
            sensor=sensor,
            disturbances=disturbances,
            torque_limit=_tuple(sim.torque_limit) if sim.torque_limit is not None else None,
            seed=sim.seed,
        )

    # ---------------------------------------------------------------- sizes and rates
    def _check_memory(self, samples: int, n: int) -> None:
        """The run's :func:`~slidingarm.simulate.memory_estimate` (every controller in one batch,
        every sample kept) within :data:`~slidingarm.simulate.MEMORY_SHARE` of the memory
        available, checked before anything is allocated."""
        runs = len(self.controllers)
        need = memory_estimate(samples, n, runs)
        avail = available_memory()
        if avail is None or need <= MEMORY_SHARE * avail:
            return
        raise self._fail(
            "simulation.t_final",
            f"simulation.t_final / simulation.dt = {samples - 1:.4g} steps x {n} joints x "
            f"{runs} run{'s' if runs != 1 else ''} (one per controller) would need "
            f"{byte_size(need)} of traces and workspaces, more than {MEMORY_SHARE:.0%} of "
            f"the {byte_size(avail)} of memory available: shorten simulation.t_final or "
            'lengthen simulation.dt (a sweep of many runs should record = "metrics")',
        )

    def _check_rates(self, dt: float) -> None:
        """Frequencies below the grid's Nyquist rate :math:`1/(2\\Delta t)` (a faster sine
        aliases to a slower one on the samples) and a quintic move of at least one sample
        (a shorter one falls between two samples and its acceleration, of order
        :math:`\\Delta q / D^2`, overflows)."""
        nyquist = 0.5 / dt
        ref = self.reference
        checks: list[tuple[str, Any]] = []
        if isinstance(ref, SineReferenceSpec):
            checks.append(("reference.frequency", ref.frequency))
        for i, d in enumerate(self.disturbances):
            if isinstance(d, SinusoidalDisturbanceSpec):
                checks.append((f"disturbances[{i}].frequency", d.frequency))
        for key, value in checks:
            worst = max(value) if isinstance(value, list) else value
            if worst >= nyquist:
                raise self._fail(
                    key,
                    f"must be below the Nyquist rate 1/(2 dt) = {nyquist:g} Hz of the grid "
                    f"(simulation.dt = {dt:g} s), got {worst:g} Hz",
                )
        if isinstance(ref, QuinticReferenceSpec) and ref.duration < dt:
            raise self._fail(
                "reference.duration",
                f"must be at least one sample, simulation.dt = {dt:g} s (a shorter move falls "
                f"between two samples), got {ref.duration:g} s",
            )

    def _check_reference(self, arm: Arm, reference: Reference, steps: int, dt: float) -> None:
        """The reference at every sample of the run, a chunk of samples at a time: finite
        (:math:`q_d, \\dot q_d, \\ddot q_d`), within ±MAX_POSITION, and (a serial arm)
        within the arm's finite URDF limits (:meth:`_check_limits`)."""
        serial = isinstance(arm, SerialArm)
        if serial:
            assert isinstance(arm, SerialArm)
            self._check_points(arm)
        key = self._reference_key()
        for lo in range(0, steps + 1, _CHECK_CHUNK):
            t = np.arange(lo, min(lo + _CHECK_CHUNK, steps + 1), dtype=np.float64) * dt
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                values = self._guard(key, partial(reference.evaluate, t))
            for what, a in zip(("position", "velocity", "acceleration"), values, strict=True):
                bad = ~np.isfinite(a)
                if np.any(bad):
                    k, j = (int(i) for i in np.argwhere(bad)[0])
                    raise self._fail(
                        key,
                        f"the reference's {what} is not finite at t = {float(t[k]):.6g} s "
                        f"(joint {j + 1}); check its scale against the sample time",
                    )
            q = values[0]
            far = np.abs(q) > MAX_POSITION
            if np.any(far):
                k, j = (int(i) for i in np.argwhere(far)[0])
                raise self._fail(
                    key,
                    f"joint {j + 1} reaches {q[k, j]:.6g} at t = {float(t[k]):.6g} s, beyond "
                    f"±{MAX_POSITION:g} (rad, or m)",
                )
            if serial:
                assert isinstance(arm, SerialArm)
                self._check_limits(arm, q, t)

    # ---------------------------------------------------------------- arm-dependent checks
    def _set_in(self, *key: str) -> Path | None:
        """The folder of the file that set ``key`` (``extends``), else of this scenario."""
        for n in range(len(key), 0, -1):
            if key[:n] in self._origin:
                return Path(self._origin[key[:n]]).parent
        return self._base_dir

    def _build_plant(self) -> Arm:
        """The nominal arm, with ``plant.robot``, ``plant.urdf`` or ``plant.tool`` named when a
        serial arm cannot be built."""
        try:
            return self._guard("plant", lambda: self.plant.build(self._set_in("plant", "urdf")))
        except ConfigError as exc:
            if exc.file is not None:
                raise
            raise self._fail(exc.path or "plant", exc.reason) from None

    def _build_mismatch(self, nominal: Arm) -> Arm:
        """The simulated plant: the nominal arm with ``[mismatch]``."""
        m = self.mismatch
        if m.payload_link is None:
            return self._guard("mismatch", lambda: m.build().apply(nominal))
        if not isinstance(nominal, SerialArm):
            raise self._fail(
                "mismatch.payload_link",
                "names a link of a robot or URDF arm; a planar arm's payload sits at its tip "
                "(remove payload_link)",
            )
        if m.payload == 0.0:
            raise self._fail(
                "mismatch.payload_link",
                "says where the payload sits, but mismatch.payload is 0 kg; set the payload's "
                "mass or remove payload_link",
            )
        return self._guard("mismatch.payload_link", lambda: m.build().apply(nominal))

    def _check_reference_lengths(self, n: int) -> None:
        """Each per-joint vector of the reference has the arm's ``n`` values."""
        ref = self.reference
        vectors: list[tuple[str, Any, bool]] = []  # (key, value, scalar allowed)
        if isinstance(ref, QuinticReferenceSpec):
            vectors = [("q_start", ref.q_start, False), ("q_end", ref.q_end, False)]
        elif isinstance(ref, SineReferenceSpec):
            vectors = [("offset", ref.offset, False)]
            vectors += [(k, getattr(ref, k), True) for k in ("amplitude", "frequency", "phase")]
        elif isinstance(ref, TableReferenceSpec) and ref.q is not None:
            vectors = [(f"q[{i}]", row, False) for i, row in enumerate(ref.q)]
        elif ref.kind == "paper" and n != 3:
            raise self._fail(
                "reference.kind",
                f"the paper's reference describes 3 joints but the arm has {n}; give a "
                "quintic, sine or table reference with one value per joint",
            )
        for key, value, scalar in vectors:
            if isinstance(value, list) and len(value) != n:
                allowed = f"a scalar or {n} values" if scalar else f"{n} values"
                raise self._fail(
                    f"reference.{key}",
                    f"has {len(value)} values but the arm has {n} joints (give {allowed})",
                )

    def _limit_check(self, arm: SerialArm) -> Any:
        """``outside(q)``: the first sample and joint of ``q`` (T, n) outside the arm's finite
        URDF position limits, as ``(k, j, side, limit)``, or ``None``."""
        lower, upper = arm.limits["lower"], arm.limits["upper"]
        # rounding of a trajectory that touches a limit is not leaving it
        scale = np.maximum(np.abs(np.where(np.isfinite(lower), lower, 0.0)), 1.0)
        scale = np.maximum(scale, np.abs(np.where(np.isfinite(upper), upper, 0.0)))
        tol = 1e-9 * scale

        def outside(q: np.ndarray) -> tuple[int, int, str, float] | None:
            below = q < lower - tol
            above = q > upper + tol
            bad = below | above
            if not np.any(bad):
                return None
            k, j = (int(i) for i in np.argwhere(bad)[0])
            side = "lower" if below[k, j] else "upper"
            return k, j, side, float(lower[j] if side == "lower" else upper[j])

        return outside

    @staticmethod
    def _joint(arm: SerialArm, j: int) -> tuple[str, str]:
        """``("joint 2 (shoulder)", "rad")``: a joint as messages name it, and its unit."""
        unit = "m" if arm.joint_types[j] == "prismatic" else "rad"
        return f"joint {j + 1} ({arm.joint_names[j]})", unit

    def _check_points(self, arm: SerialArm) -> None:
        """``q0`` and the reference's own points (end points, waypoints, offset) within the
        arm's finite URDF position limits; the error names the key, the joint and the limit."""
        lower, upper = arm.limits["lower"], arm.limits["upper"]
        if not (np.any(np.isfinite(lower)) or np.any(np.isfinite(upper))):
            return
        outside = self._limit_check(arm)
        q0 = np.asarray(self.simulation.q0, dtype=float)[None, :]
        hit = outside(q0)
        if hit is not None:
            _, j, side, limit = hit
            joint, unit = self._joint(arm, j)
            raise self._fail(
                "simulation.q0",
                f"{joint} starts at {q0[0, j]:.6g} {unit}, "
                f"{'below' if side == 'lower' else 'above'} its URDF {side} limit "
                f"{limit:.6g} {unit}",
            )
        # the reference's own points (end points, waypoints, a sine's offset), wherever they
        # fall in time; every sample of the run follows (a spline's overshoot, a sine's
        # amplitude) in _check_limits
        for key, value in self._reference_points():
            point = np.asarray(value, dtype=float)[None, :]
            hit = outside(point)
            if hit is not None:
                _, j, side, limit = hit
                joint, unit = self._joint(arm, j)
                raise self._fail(
                    f"reference.{key}",
                    f"{joint} is at {point[0, j]:.6g} {unit} there, "
                    f"{'below' if side == 'lower' else 'above'} its URDF {side} limit "
                    f"{limit:.6g} {unit} (the reference must stay within the joint limits)",
                )

    def _check_limits(self, arm: SerialArm, q_ref: np.ndarray, t: np.ndarray) -> None:
        """The reference ``q_ref`` at the samples ``t`` within the arm's finite URDF position
        limits; the error names the key, the joint, the time and the limit."""
        lower, upper = arm.limits["lower"], arm.limits["upper"]
        if not (np.any(np.isfinite(lower)) or np.any(np.isfinite(upper))):
            return
        hit = self._limit_check(arm)(q_ref)
        if hit is None:
            return
        k, j, side, limit = hit
        joint, unit = self._joint(arm, j)
        raise self._fail(
            self._reference_key(),
            f"{joint} reaches {q_ref[k, j]:.6g} {unit} at t = {float(t[k]):.6g} s, "
            f"{'below' if side == 'lower' else 'above'} its URDF {side} limit {limit:.6g} "
            f"{unit} (the reference must stay within the joint limits)",
        )

    def _reference_points(self) -> list[tuple[str, Any]]:
        """The reference's own points (key, joint vector): end points, waypoints, offset."""
        ref = self.reference
        if isinstance(ref, QuinticReferenceSpec):
            return [("q_start", ref.q_start), ("q_end", ref.q_end)]
        if isinstance(ref, SineReferenceSpec):
            return [("offset", ref.offset)]
        if isinstance(ref, TableReferenceSpec) and ref.q is not None:
            return [(f"q[{i}]", row) for i, row in enumerate(ref.q)]
        return []

    def _reference_key(self) -> str:
        """The key that moves the reference between its points."""
        ref = self.reference
        if isinstance(ref, SineReferenceSpec):
            return "reference.amplitude"
        if isinstance(ref, QuinticReferenceSpec):
            return "reference.duration"
        if isinstance(ref, TableReferenceSpec):
            return "reference.q" if ref.q is not None else "reference.path"
        return "reference"

    def _guard(self, path: str, make: Callable[[], Any]) -> Any:
        try:
            return make()
        except ConfigError:
            raise
        except (ValueError, OSError) as exc:
            raise self._fail(path, str(exc)) from exc

    # ---------------------------------------------------------------- export
    def to_dict(self) -> dict[str, Any]:
        """The scenario as plain data (no ``extends``; a table ``path`` made absolute), such that
        ``scenario_from_dict(s.to_dict())`` is the same scenario."""
        d = self.model_dump(mode="json", exclude_none=True, exclude={"extends"})
        d["name"] = self.key
        ref = d.get("reference", {})
        if ref.get("kind") == "table" and "path" in ref and self._base_dir is not None:
            ref["path"] = str((self._base_dir / ref["path"]).resolve())
        if self.plant.serial:
            # the planar keys' defaults (mass_model) do not apply to a serial arm
            d["plant"] = {k: v for k, v in d["plant"].items() if k not in PLANAR_KEYS}
        urdf = self.plant.urdf_path(self._set_in("plant", "urdf"))
        if urdf is not None:
            d["plant"]["urdf"] = str(urdf.resolve())
        return d

    def to_toml(self) -> str:
        """The resolved scenario as TOML text, self-contained (see :meth:`to_dict`)."""
        import tomli_w

        return tomli_w.dumps(self.to_dict(), multiline_strings=True)


# --------------------------------------------------------------------------------------------
# what a scenario can name


def choices() -> dict[str, list[str]]:
    """What each choice of a scenario file may be, by section (for ``slidingarm list``)."""
    head = _ControllerHead.model_fields
    return {
        "switching laws (switching)": list(get_args(Switching)),
        "reaching laws (controllers[].reaching)": literal_values(head["reaching"].annotation),
        "control laws (controllers[].law)": literal_values(head["law"].annotation),
        "references (reference.kind)": tags(ReferenceSpec),
        "velocity estimators (sensor.velocity.kind)": tags(VelocitySpec),
        "sensor faults (sensor.faults[].kind)": tags(FaultSpec),
        "disturbances (disturbances[].kind)": tags(DisturbanceSpec),
        "model mismatch ([mismatch])": list(MismatchSpec.model_fields),
        "plant presets (plant.preset)": literal_values(PlantSpec.model_fields["preset"].annotation),
        "robots (plant.robot)": list(robots.names()),
        "mass models (plant.mass_model)": literal_values(
            PlantSpec.model_fields["mass_model"].annotation
        ),
    }
