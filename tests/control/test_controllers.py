"""The sliding-mode controllers: validation, the compiled law against SPEC §3, the singularity
guard and the super-twisting state (issue 3, point 1).

The compiled torque is compared with an independent numpy implementation of SPEC §3,

.. math:: \\tau = M(q)\\,[\\ddot q_d - \\nu(e, \\dot e) - K\\varphi(s)] + h(q, \\dot q),

built from :meth:`PlanarArm.mass_matrix`, :meth:`PlanarArm.bias` and the surfaces' numpy
``value``/``nu``, which are themselves checked against the formulas of the SPEC table written out
here. ``law="paper"`` is compared with the paper's eqs. 19-22,
:math:`u_i = (-f_i - \\nu_i)/g_i - k_i\\varphi(s_i)`, :math:`f = -M^{-1}h`,
:math:`g_i = [M^{-1}]_{ii}`.

Tolerances are rounding bounds: ``RTOL_*`` times a scale of the terms that are summed (so
cancellation cannot make the comparison fail or pass by luck).
"""

from __future__ import annotations

import copy
import math
import pickle
import re
import sys
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from slidingarm import (
    FTSMC,
    NTSMC,
    PAPER_Q0,
    PDSMC,
    TSMC,
    PaperReference,
    PlanarArm,
    SerialArm,
    SlidingModeController,
    robots,
    simulate,
)
from slidingarm.control import _kernels as CK
from slidingarm.control.surfaces import DEFAULT_EPS_E, FastTerminalSurface

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _arms import massless_tip_ur5

ARM = PlanarArm.paper()
N = ARM.n
EPS = float(np.finfo(np.float64).eps)

#: Study gains (alpha = lam = 2, beta = 2, gamma = q/p = 3/5, k = 20, width 0.05).
GAINS: dict[str, dict[str, Any]] = {
    "pdsmc": {"lam": 2.0, "k": 20.0},
    "tsmc": {"beta": 2.0, "p": 5, "q": 3, "k": 20.0},
    "ftsmc": {"alpha": 2.0, "beta": 2.0, "p": 5, "q": 3, "k": 20.0},
    # NTSMC: gamma = p/q = 5/3 in (1, 2)
    "ntsmc": {"beta": 2.0, "p": 5, "q": 3, "k": 20.0},
}
CLASSES: dict[str, type[SlidingModeController]] = {
    "pdsmc": PDSMC,
    "tsmc": TSMC,
    "ftsmc": FTSMC,
    "ntsmc": NTSMC,
}
SWITCHINGS = ("sign", "tanh", "sat")
WIDTH = 0.05

#: Relative rounding tolerance of the model law (a 3x3 product and sums of O(1) terms).
RTOL_MODEL = 1e3 * EPS
#: The paper's law divides by [M^-1]_ii (it and f from the ABA): allow for cond(M) (< 1e3 here).
RTOL_PAPER = 1e6 * EPS


def make(
    name: str, switching: str = "sign", *, model: PlanarArm = ARM, **overrides: Any
) -> SlidingModeController:
    kwargs: dict[str, Any] = {**GAINS[name], "switching": switching, **overrides}
    if switching != "sign" and "width" not in kwargs:
        kwargs["width"] = WIDTH
    return CLASSES[name](model, **kwargs)


# ---------------------------------------------------------------------------- validation
def test_defaults_are_built_with_the_study_gains() -> None:
    c = make("ftsmc")
    d = c.to_dict()
    assert d["controller"] == "ftsmc"
    assert d["alpha"] == 2.0 and d["beta"] == 2.0 and d["gamma"] == pytest.approx(3 / 5)
    assert d["k"] == 20.0 and d["switching"] == "sign" and d["law"] == "model"
    assert "width" not in d and "k2" not in d
    assert d["model"] == ARM.to_dict()
    np.testing.assert_array_equal(c.k, np.full(N, 20.0))
    assert make("tsmc", "tanh").to_dict()["width"] == WIDTH
    assert make("ntsmc").to_dict()["gamma"] == pytest.approx(5 / 3)


#: The entries of each controller's to_dict besides "controller" and "model": its own
#: constructor's names, nothing of the internal packing (PDSMC runs as a fast-terminal surface
#: with beta = 0, and TSMC as one with alpha = 0, in the compiled kernel).
OWN_PARAMS: dict[str, dict[str, Any]] = {
    "pdsmc": {"lam": 2.0},
    "tsmc": {"beta": 2.0, "gamma": 3 / 5, "eps_e": None},  # None: chosen from dt by simulate
    "ftsmc": {"alpha": 2.0, "beta": 2.0, "gamma": 3 / 5, "eps_e": None},
    "ntsmc": {"beta": 2.0, "gamma": 5 / 3},
}
COMMON = {"k": 20.0, "switching": "sign", "law": "model", "reaching": "classic"}


@pytest.mark.parametrize("name", list(CLASSES))
def test_to_dict_names_exactly_the_controllers_own_parameters(name: str) -> None:
    d = make(name).to_dict()
    assert d == {"controller": name, **OWN_PARAMS[name], **COMMON, "model": ARM.to_dict()}
    assert list(d) == ["controller", *OWN_PARAMS[name], *COMMON, "model"]
    # options appear where they apply, in constructor order
    st = make(name, "tanh", reaching="super-twisting", k2=5.0).to_dict()
    assert list(st)[-7:] == ["k", "switching", "width", "law", "reaching", "k2", "model"]
    assert (st["width"], st["k2"]) == (WIDTH, 5.0)


def test_repr_names_the_controllers_own_parameters() -> None:
    assert repr(PDSMC(ARM, lam=1, k=1)) == (
        "PDSMC(lam=1.0, k=1.0, switching='sign', law='model', reaching='classic')"
    )
    assert repr(PDSMC(ARM, lam=[1, 2, 3], k=4, switching="tanh", width=0.1)) == (
        "PDSMC(lam=[1.0, 2.0, 3.0], k=4.0, switching='tanh', width=0.1, law='model', "
        "reaching='classic')"
    )
    assert repr(TSMC(ARM, beta=2, p=5, q=3, k=1)) == (
        "TSMC(beta=2.0, gamma=0.6, eps_e=None, k=1.0, switching='sign', law='model', "
        "reaching='classic')"
    )
    assert repr(FTSMC(ARM, alpha=1, beta=2, gamma=0.5, k=1, eps_e=1e-6)) == (
        "FTSMC(alpha=1.0, beta=2.0, gamma=0.5, eps_e=1e-06, k=1.0, switching='sign', "
        "law='model', reaching='classic')"
    )
    assert repr(NTSMC(ARM, beta=2, gamma=1.5, k=1)) == (
        "NTSMC(beta=2.0, gamma=1.5, k=1.0, switching='sign', law='model', reaching='classic')"
    )
    # the paper's non-terminal exponent is flagged in the record, and only when admitted
    c = FTSMC(ARM, alpha=1, beta=2, gamma=5 / 3, k=1, allow_nonterminal=True)
    assert c.to_dict()["allow_nonterminal"] is True
    assert "allow_nonterminal=True" in repr(c)
    assert "allow_nonterminal" not in make("ftsmc").to_dict()


def test_a_bare_controller_describes_its_surface() -> None:
    c = SlidingModeController(ARM, FastTerminalSurface(alpha=np.array(2.0)), k=1.0)
    d = c.to_dict()
    assert d["controller"] == "smc" and d["surface"] == "fast_terminal" and d["alpha"] == 2.0


def test_pdsmc_still_runs_as_a_linear_fast_terminal_surface() -> None:
    ci, cf, _, _ = PDSMC(ARM, lam=[1.0, 2.0, 3.0], k=4.0).compiled()
    ft = FTSMC(ARM, alpha=[1.0, 2.0, 3.0], beta=1.0, gamma=0.5, k=4.0).compiled()
    np.testing.assert_array_equal(ci, ft[0])
    np.testing.assert_array_equal(cf[CK.CF_ALPHA], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(cf[CK.CF_BETA], 0.0)


def test_simulation_records_pdsmc_by_its_own_parameters() -> None:
    c = PDSMC(ARM, lam=2.0, k=20.0, switching="tanh")
    r = simulate(ARM, c, PaperReference(), q0=PAPER_Q0, t_final=0.01, dt=5e-4)
    params = r.params["controller"]
    assert params == c.to_dict()
    assert params["lam"] == 2.0
    assert not {"alpha", "beta", "gamma", "eps_e", "surface"} & set(params)


@pytest.mark.parametrize(
    ("name", "param", "value", "match"),
    [
        ("pdsmc", "lam", True, r"^lam must be a number or one number per joint, not a boolean, "
         r"got True$"),
        ("pdsmc", "k", True, r"^k must be a number or one number per joint, not a boolean, "
         r"got True$"),
        ("ftsmc", "alpha", [1.0, True, 1.0], r"^alpha must be a number or one number per joint, "
         r"not a boolean, got \[1\.0, True, 1\.0\]$"),
        ("tsmc", "beta", np.array([True, True, True]), r"^beta must be a number or one number "
         r"per joint, not a boolean, got array\(\[ True,  True,  True\]\)$"),
        ("ntsmc", "beta", np.True_, r"^beta must be a number or one number per joint, not a "
         rf"boolean, got {re.escape(repr(np.True_))}$"),
        ("ftsmc", "width", False, r"^width must be a number or one number per joint, not a "
         r"boolean, got False$"),
        ("ftsmc", "k2", True, r"^k2 must be a number or one number per joint, not a boolean, "
         r"got True$"),
        ("tsmc", "eps_e", True, r"^eps_e must be a number, not a boolean, got True$"),
        ("ftsmc", "eps_e", np.True_, r"^eps_e must be a number, not a boolean, "
         rf"got {re.escape(repr(np.True_))}$"),
        ("pdsmc", "k", [1.0, np.False_, 1.0], r"^k must be a number or one number per joint, "
         rf"not a boolean, got \[1\.0, {re.escape(repr(np.False_))}, 1\.0\]$"),
    ],
)  # fmt: skip
def test_boolean_gains_are_rejected(name: str, param: str, value: Any, match: str) -> None:
    extra: dict[str, Any] = {param: value}
    switching = "sign"
    if param == "width":
        switching = "tanh"
    if param == "k2":
        extra["reaching"] = "super-twisting"
    with pytest.raises(ValueError, match=match):
        make(name, switching, **extra)


@pytest.mark.parametrize("name", ["tsmc", "ftsmc", "ntsmc"])
def test_boolean_exponents_are_rejected(name: str) -> None:
    gains = {k: v for k, v in GAINS[name].items() if k not in ("p", "q")}
    with pytest.raises(ValueError, match=r"^gamma must be a number, not a boolean, got True$"):
        CLASSES[name](ARM, **gains, gamma=True)
    with pytest.raises(
        ValueError, match=r"^p and q must be positive odd integers, got p=True, q=1$"
    ):
        CLASSES[name](ARM, **gains, p=True, q=1)
    with pytest.raises(ValueError, match=r"^gamma must be a number, not a boolean, got np\.True_$"):
        CLASSES[name](ARM, **gains, gamma=np.True_)
    with pytest.raises(
        ValueError, match=r"^p and q must be positive odd integers, got p=5, q=np\.True_$"
    ):
        CLASSES[name](ARM, **gains, p=5, q=np.True_)


@pytest.mark.parametrize("name", ["tsmc", "ftsmc"])
@pytest.mark.parametrize(
    ("exponent", "match"),
    [
        (
            {"gamma": 1.5},
            r"gamma must lie in \(0, 1\) \(terminal: 0 < gamma = q/p < 1\), got 1\.5; "
            r"the paper's p/q > 1 is not terminal",
        ),
        # the paper's exponent p/q with q < p: passing (p, q) = (3, 5) gives q/p = 5/3 > 1
        ({"p": 3, "q": 5}, r"got 1\.666.*the paper's p/q > 1 is not terminal"),
        ({"gamma": 5 / 3}, r"the paper's p/q > 1 is not terminal"),
        ({"gamma": 0.0}, r"gamma must lie in \(0, 1\) .*got 0\.0$"),
        ({"gamma": -0.5}, r"gamma must lie in \(0, 1\) .*got -0\.5$"),
        ({"gamma": 1.0}, r"gamma must lie in \(0, 1\) .*got 1\.0$"),
        ({"gamma": math.nan}, r"gamma must be finite, got nan"),
        ({"gamma": math.inf}, r"gamma must be finite, got inf"),
        ({"gamma": "half"}, r"gamma must be a number, got 'half'"),
        ({"p": 4, "q": 3}, r"p and q must be positive odd integers, got p=4, q=3"),
        ({"p": 5, "q": 2}, r"p and q must be positive odd integers, got p=5, q=2"),
        ({"p": -5, "q": 3}, r"p and q must be positive odd integers, got p=-5, q=3"),
        ({"p": 5.0, "q": 3}, r"p and q must be positive odd integers, got p=5\.0, q=3"),
        ({"gamma": 0.6, "p": 5, "q": 3}, r"give either gamma or \(p, q\), not both"),
        ({"gamma": 0.6, "p": 5}, r"give either gamma or \(p, q\), not both"),
        ({"p": 5}, r"gamma is required \(or both p and q\)"),
        ({}, r"gamma is required \(or both p and q\)"),
    ],
)
def test_terminal_exponent_is_validated(name: str, exponent: dict[str, Any], match: str) -> None:
    gains = {k: v for k, v in GAINS[name].items() if k not in ("p", "q")}
    with pytest.raises(ValueError, match=match):
        CLASSES[name](ARM, **gains, **exponent)


@pytest.mark.parametrize(
    ("exponent", "match"),
    [
        ({"gamma": 2.5}, r"gamma must lie in \(1, 2\) \(nonsingular: 1 < p/q < 2\), got 2\.5$"),
        ({"gamma": 0.6}, r"gamma must lie in \(1, 2\) .*got 0\.6$"),
        ({"gamma": 1.0}, r"gamma must lie in \(1, 2\) .*got 1\.0$"),
        ({"gamma": 2.0}, r"gamma must lie in \(1, 2\) .*got 2\.0$"),
        ({"p": 3, "q": 5}, r"gamma must lie in \(1, 2\) .*got 0\.6$"),
        ({"p": 7, "q": 3}, r"gamma must lie in \(1, 2\) .*got 2\.33"),
        ({"p": 6, "q": 5}, r"p and q must be positive odd integers, got p=6, q=5"),
        ({"gamma": 1.5, "p": 3, "q": 1}, r"give either gamma or \(p, q\), not both"),
    ],
)
def test_nonsingular_exponent_is_validated(exponent: dict[str, Any], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        NTSMC(ARM, beta=2.0, k=20.0, **exponent)


def test_nonsingular_exponent_is_p_over_q() -> None:
    assert NTSMC(ARM, beta=2.0, p=5, q=3, k=1.0).surface.gamma == pytest.approx(5 / 3)
    assert NTSMC(ARM, beta=2.0, gamma=1.5, k=1.0).surface.gamma == 1.5


@pytest.mark.parametrize("name", ["tsmc", "ftsmc"])
def test_allow_nonterminal_admits_gamma_above_one(name: str) -> None:
    gains = {k: v for k, v in GAINS[name].items() if k not in ("p", "q")}
    c = CLASSES[name](ARM, **gains, gamma=5 / 3, allow_nonterminal=True)
    assert c.surface.to_dict()["gamma"] == pytest.approx(5 / 3)
    # the paper's (p, q) order, taken literally
    c = CLASSES[name](ARM, **gains, p=3, q=5, allow_nonterminal=True)
    assert c.surface.to_dict()["gamma"] == pytest.approx(5 / 3)
    # still a positive, finite exponent
    with pytest.raises(ValueError, match=r"gamma must be > 0, got -1\.0"):
        CLASSES[name](ARM, **gains, gamma=-1.0, allow_nonterminal=True)
    with pytest.raises(ValueError, match=r"gamma must be finite"):
        CLASSES[name](ARM, **gains, gamma=math.inf, allow_nonterminal=True)


@pytest.mark.parametrize(
    ("name", "param"),
    [
        ("pdsmc", "lam"),
        ("pdsmc", "k"),
        ("tsmc", "beta"),
        ("tsmc", "k"),
        ("ftsmc", "alpha"),
        ("ftsmc", "beta"),
        ("ftsmc", "k"),
        ("ntsmc", "beta"),
        ("ntsmc", "k"),
    ],
)
def test_gains_are_validated(name: str, param: str) -> None:
    def build(value: Any, switching: str = "sign", **extra: Any) -> SlidingModeController:
        return make(name, switching, **{param: value}, **extra)

    with pytest.raises(ValueError, match=rf"^{param} must be > 0, got 0\.0$"):
        build(0.0)
    with pytest.raises(ValueError, match=rf"^{param} must be > 0, got -2\.0$"):
        build(-2.0)
    with pytest.raises(ValueError, match=rf"^{param} must be > 0, got \[1\.0, 0\.0, 1\.0\]$"):
        build([1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match=rf"^{param} must be finite, got nan$"):
        build(math.nan)
    with pytest.raises(ValueError, match=rf"^{param} must be finite, got \[1\.0, inf, 1\.0\]$"):
        build([1.0, math.inf, 1.0])
    with pytest.raises(
        ValueError,
        match=rf"^{param} has 2 values but the model has 3 joints "
        r"\(give a scalar or one value per joint\)$",
    ):
        build([1.0, 2.0])
    with pytest.raises(ValueError, match=rf"^{param} has 4 values but the model has 3 joints"):
        build([1.0, 2.0, 3.0, 4.0])
    with pytest.raises(ValueError, match=rf"^{param} must be a scalar or a 1-D vector"):
        build([[1.0, 2.0, 3.0]])
    with pytest.raises(ValueError, match=rf"^{param} must not be empty$"):
        build([])
    with pytest.raises(ValueError, match=rf"^{param} must be a number or one number per joint"):
        build("fast")
    # a string is not a number, even one that reads as a number
    with pytest.raises(
        ValueError, match=rf"^{param} must be a number or one number per joint, got '20'$"
    ):
        build("20")
    # one value per joint is accepted and kept per joint
    c = build([1.0, 2.0, 3.0])
    if param == "k":
        np.testing.assert_array_equal(c.k, [1.0, 2.0, 3.0])


def test_width_is_validated() -> None:
    with pytest.raises(
        ValueError,
        match=r"width \(the boundary layer\) applies to 'tanh' and 'sat' only, not 'sign'",
    ):
        make("ftsmc", "sign", width=0.05)
    for switching in ("tanh", "sat"):
        with pytest.raises(ValueError, match=r"^width must be > 0, got -0\.1$"):
            make("ftsmc", switching, width=-0.1)
        with pytest.raises(ValueError, match=r"^width must be > 0, got 0\.0$"):
            make("ftsmc", switching, width=0.0)
        with pytest.raises(ValueError, match=r"^width must be finite"):
            make("ftsmc", switching, width=math.inf)
        with pytest.raises(ValueError, match=r"^width has 2 values but the model has 3 joints"):
            make("ftsmc", switching, width=[0.1, 0.2])
    # the default layer
    assert PDSMC(ARM, lam=2.0, k=20.0, switching="tanh").to_dict()["width"] == WIDTH


def test_names_are_validated() -> None:
    with pytest.raises(
        ValueError, match=r"switching must be one of \['sat', 'sign', 'tanh'\], got 'sgn'"
    ):
        make("pdsmc", "sgn")
    with pytest.raises(ValueError, match=r"law must be 'model' or 'paper', got 'exact'"):
        make("pdsmc", law="exact")
    with pytest.raises(
        ValueError, match=r"reaching must be 'classic' or 'super-twisting', got 'twisting'"
    ):
        make("pdsmc", reaching="twisting")


def test_super_twisting_gains_are_validated() -> None:
    with pytest.raises(
        ValueError,
        match=r"k2 \(the super-twisting integral gain\) is required with reaching='super-twisting'",
    ):
        make("ftsmc", reaching="super-twisting")
    with pytest.raises(ValueError, match=r"k2 applies to reaching='super-twisting' only"):
        make("ftsmc", k2=5.0)
    with pytest.raises(ValueError, match=r"^k2 must be > 0, got 0\.0$"):
        make("ftsmc", reaching="super-twisting", k2=0.0)
    with pytest.raises(ValueError, match=r"^k2 has 2 values but the model has 3 joints"):
        make("ftsmc", reaching="super-twisting", k2=[1.0, 2.0])


@pytest.mark.parametrize("name", sorted(CLASSES))
def test_model_must_be_an_arm_model(name: str) -> None:
    with pytest.raises(
        TypeError, match=r"model must be an arm model \(an ArmModel such as PlanarArm: the "
        r"controller's nominal arm\), got str"
    ):
        make(name, model="paper")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"model must be an arm model .*got NoneType"):
        make(name, model=None)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ["tsmc", "ftsmc"])
def test_singularity_guard_is_validated(name: str) -> None:
    for bad in (0.0, -1e-9, math.nan, math.inf):
        with pytest.raises(
            ValueError, match=r"eps_e must be a finite value > 0 \(the singularity guard\)"
        ):
            make(name, eps_e=bad)


def test_gains_follow_the_model_size() -> None:
    arm2 = PlanarArm((1.0, 2.0), (0.5, 0.7))
    c = FTSMC(arm2, alpha=[1.0, 2.0], beta=2.0, gamma=0.5, k=[3.0, 4.0])
    assert c.n == 2
    np.testing.assert_array_equal(c.k, [3.0, 4.0])
    with pytest.raises(ValueError, match=r"k has 3 values but the model has 2 joints"):
        FTSMC(arm2, alpha=1.0, beta=2.0, gamma=0.5, k=[3.0, 4.0, 5.0])


# ---------------------------------------------------------------------------- surfaces
def _sig(x: np.ndarray, p: float) -> np.ndarray:
    return np.abs(x) ** p * np.sign(x)


def test_surfaces_match_the_spec_table() -> None:
    """``value``/``nu`` equal SPEC §3's table (and the NTSM row of the surfaces module)."""
    rng = np.random.default_rng(7)
    e = rng.uniform(-2.0, 2.0, (500, N)) * 10.0 ** rng.uniform(-8, 0, (500, N))
    ed = rng.uniform(-3.0, 3.0, (500, N))
    lam, alpha, beta, gamma = 2.0, 2.0, 2.0, 0.6
    guarded = np.maximum(np.abs(e), DEFAULT_EPS_E)  # the documented singularity guard
    pd_ = make("pdsmc").surface
    np.testing.assert_allclose(pd_.value(e, ed), ed + lam * e, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(pd_.nu(e, ed), lam * ed, rtol=1e-14, atol=1e-15)
    ts = make("tsmc").surface
    np.testing.assert_allclose(ts.value(e, ed), ed + beta * _sig(e, gamma), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(
        ts.nu(e, ed), beta * gamma * guarded ** (gamma - 1) * ed, rtol=1e-13, atol=1e-15
    )
    ft = make("ftsmc").surface
    np.testing.assert_allclose(
        ft.value(e, ed), ed + alpha * e + beta * _sig(e, gamma), rtol=1e-13, atol=1e-15
    )
    np.testing.assert_allclose(
        ft.nu(e, ed), (alpha + beta * gamma * guarded ** (gamma - 1)) * ed, rtol=1e-13, atol=1e-15
    )
    nt = make("ntsmc").surface
    g = 5 / 3
    np.testing.assert_allclose(nt.value(e, ed), e + _sig(ed, g) / beta, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(nt.nu(e, ed), beta / g * _sig(ed, 2 - g), rtol=1e-13, atol=1e-15)


def test_nu_is_the_time_derivative_of_the_non_edot_part() -> None:
    """ν = d/dt[α e + β sig(e)^γ] along e(t): checked by a central difference of the surface."""
    rng = np.random.default_rng(8)
    for name in ("pdsmc", "tsmc", "ftsmc"):
        surf = make(name).surface
        for _ in range(50):
            e0 = rng.uniform(0.05, 1.0, N) * rng.choice([-1.0, 1.0], N)
            ed = rng.uniform(-2.0, 2.0, N)
            h = 1e-6
            part = surf.value(e0 + h * ed, 0.0 * ed) - surf.value(e0 - h * ed, 0.0 * ed)
            np.testing.assert_allclose(part / (2 * h), surf.nu(e0, ed), rtol=1e-7, atol=1e-9)


def test_singularity_guard_is_the_documented_one() -> None:
    """At |e| < eps_e, |e|^(γ-1) is evaluated at eps_e; the guard bounds ν for every e."""
    surf = make("tsmc").surface
    assert isinstance(surf, FastTerminalSurface)
    assert surf.eps_e == DEFAULT_EPS_E
    ed = np.array([1.0, -3.0, 1e4])
    cap = 2.0 * 0.6 * DEFAULT_EPS_E ** (0.6 - 1.0)
    for e in (np.zeros(N), np.full(N, 1e-300), np.full(N, -1e-12), np.full(N, DEFAULT_EPS_E)):
        np.testing.assert_allclose(surf.nu(e, ed), cap * ed, rtol=1e-14)
    # the compiled law uses the same guard: tau at e = 0 equals the numpy formula
    c = make("tsmc")
    qr = np.array([0.3, -0.2, 0.9])
    tau, s = c.evaluate(qr, ed, qr, np.zeros(N), np.zeros(N))
    np.testing.assert_array_equal(s, ed)
    expected = ARM.mass_matrix(qr) @ (-cap * ed - 20.0 * np.sign(ed)) + ARM.bias(qr, ed)
    np.testing.assert_allclose(tau, expected, rtol=RTOL_MODEL)


# ---------------------------------------------------------------------------- the compiled law
def _phi(switching: str, s: np.ndarray, width: float) -> np.ndarray:
    if switching == "sign":
        return np.sign(s)
    if switching == "tanh":
        return np.tanh(s / width)
    return np.clip(s / width, -1.0, 1.0)


def _numpy_law(
    c: SlidingModeController,
    k: np.ndarray,
    width: float,
    q: np.ndarray,
    qd: np.ndarray,
    qr: np.ndarray,
    qdr: np.ndarray,
    qddr: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SPEC §3 (or the paper's law) in numpy; returns ``(tau, s, scale)``."""
    e, ed = q - qr, qd - qdr
    s = c.surface.value(e, ed)
    nu = c.surface.nu(e, ed)
    r = k * _phi(c.switching, s, width)
    m = c.model.mass_matrix(q)
    h = c.model.bias(q, qd)
    if c.law == "model":
        a = qddr - nu - r
        return m @ a + h, s, np.abs(m) @ np.abs(a) + np.abs(h) + np.abs(qddr)
    minv = np.linalg.inv(m)
    f = -minv @ h
    g = np.diag(minv)
    tau = (-f - nu) / g - r
    return tau, s, (np.abs(f) + np.abs(nu)) / g + np.abs(r)


def _random_states(rng: np.random.Generator, count: int) -> list[tuple[np.ndarray, ...]]:
    states = []
    for _ in range(count):
        qr = rng.uniform(-np.pi, np.pi, N)
        qdr = rng.uniform(-3.0, 3.0, N)
        qddr = rng.uniform(-5.0, 5.0, N)
        # errors from 1e-12 (inside the guard) to order one, either sign
        e = rng.choice([-1.0, 1.0], N) * 10.0 ** rng.uniform(-12.0, 0.3, N)
        ed = rng.uniform(-3.0, 3.0, N)
        states.append((qr + e, qdr + ed, qr, qdr, qddr))
    return states


@pytest.mark.parametrize("law", ["model", "paper"])
@pytest.mark.parametrize("switching", SWITCHINGS)
@pytest.mark.parametrize("name", sorted(CLASSES))
def test_compiled_torque_equals_the_formula(name: str, switching: str, law: str) -> None:
    rng = np.random.default_rng(zlib.crc32(f"{name}-{switching}-{law}".encode()))
    k = np.array([20.0, 15.0, 25.0])
    width = 0.07
    c = make(name, switching, law=law, k=k, **({} if switching == "sign" else {"width": width}))
    rtol = RTOL_MODEL if law == "model" else RTOL_PAPER
    for q, qd, qr, qdr, qddr in _random_states(rng, 150):
        tau, s = c.evaluate(q, qd, qr, qdr, qddr)
        tau_np, s_np, scale = _numpy_law(c, k, width, q, qd, qr, qdr, qddr)
        np.testing.assert_allclose(s, s_np, rtol=1e-13, atol=1e-13)
        assert np.all(np.abs(tau - tau_np) <= rtol * scale), (tau, tau_np)
        # the fast path computes the same torque
        np.testing.assert_array_equal(c(q, qd, qr, qdr, qddr), tau)


def test_exact_model_law_gives_the_reaching_law() -> None:
    """With the plant equal to the model, q̈ = M⁻¹(τ - h) makes ë = -ν - Kφ(s) exactly."""
    rng = np.random.default_rng(3)
    for name in ("pdsmc", "tsmc", "ftsmc"):
        c = make(name, "tanh")
        for q, qd, qr, qdr, qddr in _random_states(rng, 30):
            tau, s = c.evaluate(q, qd, qr, qdr, qddr)
            qdd = ARM.forward_dynamics(q, qd, tau)
            nu = c.surface.nu(q - qr, qd - qdr)
            # rounding: the solve with M (cond < 1e3) and ν up to 1e4 (inside the guard)
            lhs, rhs = qdd - qddr + nu, -20.0 * np.tanh(s / WIDTH)
            assert np.all(np.abs(lhs - rhs) <= 1e-9 * (1.0 + np.abs(nu) + np.abs(qdd))), (lhs, rhs)


def _ur5(massless_tip: bool = False) -> SerialArm:
    """The shipped UR5, or the UR5 with no mass nor inertia in its last link (a URDF the loader
    accepts; its mass matrix is singular at every state)."""
    return massless_tip_ur5() if massless_tip else robots.load("ur5")


def test_paper_law_on_a_serial_model_is_eqs_19_to_22() -> None:
    """The paper's law with a serial nominal model (the UR5): f and the diagonal of M^-1 from
    its articulated-body algorithm, against numpy's inverse of its mass matrix, to within the
    rounding that cond(M) allows."""
    ur5 = _ur5()
    k = np.linspace(15.0, 25.0, 6)
    c = FTSMC(ur5, alpha=2.0, beta=2.0, p=5, q=3, k=k, switching="tanh", width=WIDTH, law="paper")
    rng = np.random.default_rng(1922)
    for _ in range(40):
        q, qr = rng.uniform(-np.pi, np.pi, (2, 6))
        qd, qdr = rng.uniform(-2.0, 2.0, (2, 6))
        qddr = rng.uniform(-5.0, 5.0, 6)
        tau, s = c.evaluate(q, qd, qr, qdr, qddr)
        tau_np, s_np, scale = _numpy_law(c, k, WIDTH, q, qd, qr, qdr, qddr)
        np.testing.assert_allclose(s, s_np, rtol=1e-13, atol=1e-13)
        cond = np.linalg.cond(ur5.mass_matrix(q))
        assert np.all(np.abs(tau - tau_np) <= 100.0 * cond * EPS * scale), (tau, tau_np, cond)
        np.testing.assert_array_equal(c(q, qd, qr, qdr, qddr), tau)


def test_paper_law_refuses_a_model_without_an_inverse_mass_matrix() -> None:
    """A nominal model whose mass matrix is singular at a finite state (a massless tip): the
    paper's law, which needs M^-1, gives NaN for every torque (ending a run as non-finite),
    and ``evaluate`` says why; the model law (no M^-1) is unaffected."""
    arm = _ur5(massless_tip=True)
    gains: dict[str, Any] = {"alpha": 2.0, "beta": 2.0, "p": 5, "q": 3, "k": 20.0}
    state = (np.full(6, 0.3), np.full(6, 0.1), np.zeros(6), np.zeros(6), np.zeros(6))
    paper = FTSMC(arm, switching="tanh", width=WIDTH, law="paper", **gains)
    assert np.all(np.isnan(paper(*state)))
    with pytest.raises(ValueError, match="mass matrix, which is not positive definite"):
        paper.evaluate(*state)
    tau, _ = FTSMC(arm, switching="tanh", width=WIDTH, **gains).evaluate(*state)
    assert np.all(np.isfinite(tau))


def test_paper_law_differs_from_the_model_law() -> None:
    """The paper's law is a different law (no q̈_d, a row of M⁻¹ as a scalar)."""
    q = np.array([0.7, 1.5, 0.5])
    args = (q, np.zeros(N), np.zeros(N), np.zeros(N), np.array([0.0, -0.5, 0.5]))
    t_model, _ = make("ftsmc").evaluate(*args)
    t_paper, _ = make("ftsmc", law="paper").evaluate(*args)
    assert np.max(np.abs(t_model - t_paper)) > 1.0


def test_evaluate_validates_its_inputs() -> None:
    c = make("ftsmc")
    good = [np.zeros(N)] * 5
    for i, name in enumerate(("q", "qd", "q_ref", "qd_ref", "qdd_ref")):
        args = list(good)
        args[i] = np.zeros(N + 1)
        with pytest.raises(ValueError, match=rf"^{name} must have shape \(3,\), got \(4,\)$"):
            c.evaluate(*args)
        args[i] = np.array([0.0, math.nan, 0.0])
        with pytest.raises(ValueError, match=rf"^{name} must be finite \(no NaN or inf\)$"):
            c.evaluate(*args)


def test_evaluate_fast_path_refuses_what_the_general_path_refuses() -> None:
    """float64 C-contiguous inputs take the compiled checks (shape, finiteness inside the
    call); every other kind of input takes the general path. Both give the same torques, bit
    for bit, and the same messages."""
    c = make("ftsmc", "tanh", reaching="super-twisting", k=4.0, k2=30.0)
    ref = make("ftsmc", "tanh", reaching="super-twisting", k=4.0, k2=30.0)
    q = np.array([0.7, 1.5, 0.5])
    qd = np.array([0.1, -0.2, 0.3])
    good = [q, qd, np.zeros(N), np.zeros(N), np.array([0.0, -0.5, 0.5])]
    names = ("q", "qd", "q_ref", "qd_ref", "qdd_ref")
    for i, name in enumerate(names):
        for bad in (math.nan, math.inf, -math.inf):
            args = list(good)
            args[i] = np.array([0.0, bad, 0.0])
            with pytest.raises(ValueError, match=rf"^{name} must be finite \(no NaN or inf\)$"):
                c.evaluate(*args, dt=5e-4)
        for wrong in (np.zeros(N + 1), np.zeros(N - 1), np.zeros((1, N)), np.zeros((N, 1))):
            args = list(good)
            args[i] = wrong
            shape = re.escape(str(wrong.shape))
            with pytest.raises(ValueError, match=rf"^{name} must have shape \(3,\), got {shape}$"):
                c.evaluate(*args, dt=5e-4)
        # other dtypes and layouts: the general path, which still refuses a NaN by name
        for kind in (np.float32, np.int64):
            args = list(good)
            args[i] = np.array([0, 1, 0], dtype=kind)
            args[(i + 1) % 5] = np.array([0.0, math.nan, 0.0])
            with pytest.raises(ValueError, match="must be finite"):
                c.evaluate(*args, dt=5e-4)
    # the refusals above left the integral alone: c and ref agree, whatever the input's kind
    strided = np.repeat(q, 2)[::2]
    readonly = q.copy()
    readonly.setflags(write=False)
    for first in (q, list(q), tuple(q), strided, readonly, q.astype(">f8")):
        got = c.evaluate(first, *good[1:], dt=5e-4)
        want = ref.evaluate(*good, dt=5e-4)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
    with pytest.raises(ValueError, match=r"^dt > 0 \(the sample time\) is required"):
        c.evaluate(*good)
    with pytest.raises(ValueError, match=r"^qd must be finite"):  # the inputs first
        c.evaluate(q, np.array([0.0, math.nan, 0.0]), *good[2:])
    ints = [np.array([0, 1, 0]), *good[1:]]
    np.testing.assert_array_equal(
        make("ftsmc").evaluate(*ints)[0], make("ftsmc").evaluate(*[a.astype(float) for a in ints])[0]
    )


def _strided(a: np.ndarray) -> np.ndarray:
    b = np.repeat(a, 2)[::2]
    assert not b.flags.c_contiguous
    return b


def _reversed(a: np.ndarray) -> np.ndarray:
    b = a[::-1].copy()[::-1]  # the same values, read through a negative stride
    assert b.strides[0] < 0
    return b


def _readonly(a: np.ndarray) -> np.ndarray:
    b = a.copy()
    b.setflags(write=False)
    return b


def _unaligned(a: np.ndarray) -> np.ndarray:
    buf = np.zeros(a.size * 8 + 1, dtype=np.uint8)
    b = np.frombuffer(buf.data, dtype=np.float64, count=a.size, offset=1)
    b[:] = a
    assert not b.flags.aligned
    return b


def test_evaluate_takes_every_float64_vector_and_refuses_the_rest_by_name() -> None:
    """Every one-dimensional float64 input (strided, reversed, read-only, unaligned) takes the
    compiled checks, which copy it before the law reads it: the torques and ``s`` are those of
    contiguous inputs bit for bit, a NaN or a wrong length is refused by name, and a refused
    call leaves the super-twisting integral alone. An array of another number of dimensions
    (0-d included) gets the general path's shape message. A copied or unpickled controller
    (which looks its compiled function up again) evaluates as the original does."""
    kw: dict[str, Any] = {"reaching": "super-twisting", "k": 4.0, "k2": 30.0}
    c, ref = make("ftsmc", "tanh", **kw), make("ftsmc", "tanh", **kw)
    good = [
        np.array([0.7, 1.5, 0.5]),
        np.array([0.1, -0.2, 0.3]),
        np.array([0.2, 1.0, 0.4]),
        np.zeros(N),
        np.array([0.0, -0.5, 0.5]),
    ]
    names = ("q", "qd", "q_ref", "qd_ref", "qdd_ref")
    for kind in (_strided, _reversed, _readonly, _unaligned):
        for i, name in enumerate(names):
            args = list(good)
            args[i] = kind(good[i])
            got, want = c.evaluate(*args, dt=5e-4), ref.evaluate(*good, dt=5e-4)
            np.testing.assert_array_equal(got[0], want[0])
            np.testing.assert_array_equal(got[1], want[1])
            args[i] = kind(np.array([0.0, math.nan, 0.0]))
            with pytest.raises(ValueError, match=rf"^{name} must be finite \(no NaN or inf\)$"):
                c.evaluate(*args, dt=5e-4)
            args[i] = kind(np.zeros(N + 1))
            with pytest.raises(ValueError, match=rf"^{name} must have shape \(3,\), got \(4,\)$"):
                c.evaluate(*args, dt=5e-4)
    for i, name in enumerate(names):
        for wrong in (np.array(0.5), np.zeros((1, N)), np.zeros((N, 1)), np.zeros((1, 1, N))):
            args = list(good)
            args[i] = wrong
            # (the general path reports a 0-d array as the (1,) numpy makes of it)
            shape = re.escape(str(wrong.shape if wrong.ndim else (1,)))
            with pytest.raises(ValueError, match=rf"^{name} must have shape \(3,\), got {shape}$"):
                c.evaluate(*args, dt=5e-4)
    # the refusals left the integral alone, and copies carry it with the rest
    for twin in (copy.deepcopy(c), pickle.loads(pickle.dumps(c)), copy.copy(c)):
        twin_ref = copy.deepcopy(ref)
        got, want = twin.evaluate(*good, dt=5e-4), twin_ref.evaluate(*good, dt=5e-4)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


# ---------------------------------------------------------------------------- singularity
CONTROLLERS: list[SlidingModeController] = [
    make(name, switching, law=law)
    for name in sorted(CLASSES)
    for switching in SWITCHINGS
    for law in ("model", "paper")
] + [make(name, "sign", reaching="super-twisting", k2=30.0) for name in sorted(CLASSES)]

SPECIAL_E = [0.0, -0.0, 1e-300, -1e-300, 5e-324, -5e-324, DEFAULT_EPS_E, -DEFAULT_EPS_E, 1e6, -1e6]
errors = st.one_of(
    st.sampled_from(SPECIAL_E),
    st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=True),
    st.floats(-1e-6, 1e-6, allow_nan=False, allow_subnormal=True),
)
rates = st.one_of(
    st.sampled_from([0.0, 1e-300, -1e-300, 1e4, -1e4]), st.floats(-1e4, 1e4, allow_nan=False)
)
vec: Callable[[st.SearchStrategy[float]], st.SearchStrategy[list[float]]] = lambda s: st.lists(  # noqa: E731
    s, min_size=N, max_size=N
)


@settings(max_examples=150, deadline=None)
@given(
    e=vec(errors),
    ed=vec(rates),
    qr=st.one_of(st.just([0.0] * N), vec(st.floats(-np.pi, np.pi))),
    qdr=vec(st.floats(-3.0, 3.0)),
    qddr=vec(st.floats(-10.0, 10.0)),
)
@example(e=[0.0] * N, ed=[1.0, -2.0, 3.0], qr=[0.0] * N, qdr=[0.0] * N, qddr=[0.0] * N)
@example(
    e=[1e-300, -1e-300, 0.0], ed=[1e4, -1e4, 1e-3], qr=[0.0] * N, qdr=[0.0] * N, qddr=[0.0] * N
)
@example(e=[1e6, -1e6, 1e6], ed=[1e4, -1e4, 0.0], qr=[0.0] * N, qdr=[0.0] * N, qddr=[0.0] * N)
def test_torque_is_always_finite(
    e: list[float], ed: list[float], qr: list[float], qdr: list[float], qddr: list[float]
) -> None:
    qr_a = np.array(qr)
    q = qr_a + np.array(e)
    qd = np.array(qdr) + np.array(ed)
    for c in CONTROLLERS:
        tau, s = c.evaluate(q, qd, qr_a, np.array(qdr), np.array(qddr), dt=5e-4)
        assert np.all(np.isfinite(tau)), (c, tau)
        assert np.all(np.isfinite(s)), (c, s)


def test_a_state_beyond_float64_is_an_error_not_nan() -> None:
    """|qd| = 1e200 overflows the model's velocity-squared terms: a named error, not NaN."""
    z = np.zeros(N)
    qd = np.array([1e200, 0.0, 0.0])
    for c in CONTROLLERS:
        with pytest.raises(
            ValueError,
            match=r"^the torque of joint \d overflows float64 at this "
            r"state \(\|qd\| up to 1e\+200 rad/s\): the state is out of range$",
        ):
            c.evaluate(z, qd, z, z, z, dt=5e-4)


def test_a_rejected_call_leaves_the_super_twisting_integral_alone() -> None:
    z = np.zeros(N)
    a, b = (make("ftsmc", "tanh", reaching="super-twisting", k=4.0, k2=30.0) for _ in range(2))
    for c in (a, b):
        c.evaluate(z + 0.1, z, z, z, z, dt=5e-4)
    with pytest.raises(ValueError, match="overflows float64"):
        a.evaluate(z, np.array([1e200, 0.0, 0.0]), z, z, z, dt=5e-4)
    np.testing.assert_array_equal(
        a.evaluate(z + 0.2, z, z, z, z, dt=5e-4)[0], b.evaluate(z + 0.2, z, z, z, z, dt=5e-4)[0]
    )


# ---------------------------------------------------------------------------- super-twisting
def _sequence(rng: np.random.Generator, count: int) -> list[tuple[np.ndarray, ...]]:
    return _random_states(rng, count)


@pytest.mark.parametrize("switching", SWITCHINGS)
def test_super_twisting_is_deterministic_and_resets(switching: str) -> None:
    def st_ctrl() -> SlidingModeController:
        return make("ftsmc", switching, reaching="super-twisting", k=4.0, k2=30.0)

    seq = _sequence(np.random.default_rng(11), 20)
    dt = 5e-4
    a, b = st_ctrl(), st_ctrl()
    assert a.stateful and a.reaching == "super-twisting"
    out_a = [a.evaluate(*x, dt=dt)[0] for x in seq]
    out_b = [b.evaluate(*x, dt=dt)[0] for x in seq]
    np.testing.assert_array_equal(out_a, out_b)
    # the integral makes the law depend on the history: the same state twice differs
    assert not np.array_equal(out_a[0], a.evaluate(*seq[0], dt=dt)[0])
    a.reset()
    np.testing.assert_array_equal([a.evaluate(*x, dt=dt)[0] for x in seq], out_a)

    # the law itself: r = k1 sig(s)^(1/2) + w, w advanced by dt k2 phi(s) after use
    c = st_ctrl()
    w = np.zeros(N)
    for q, qd, qr, qdr, qddr in seq[:5]:
        tau, s = c.evaluate(q, qd, qr, qdr, qddr, dt=dt)
        e, ed = q - qr, qd - qdr
        nu = c.surface.nu(e, ed)
        r = 4.0 * np.sqrt(np.abs(s)) * np.sign(s) + w
        expected = ARM.mass_matrix(q) @ (qddr - nu - r) + ARM.bias(q, qd)
        np.testing.assert_allclose(tau, expected, rtol=1e-10, atol=1e-9)
        w = w + dt * 30.0 * _phi(switching, s, WIDTH)


def test_super_twisting_evaluate_requires_dt() -> None:
    c = make("ftsmc", reaching="super-twisting", k2=30.0)
    x = _sequence(np.random.default_rng(12), 1)[0]
    msg = r"dt > 0 \(the sample time\) is required by the super-twisting law"
    for dt in (None, 0.0, -1e-3, math.nan, math.inf):
        with pytest.raises(ValueError, match=msg):
            c.evaluate(*x, dt=dt)
    # the classic law is stateless: dt is optional and does not change anything
    classic = make("ftsmc")
    assert not classic.stateful
    np.testing.assert_array_equal(classic.evaluate(*x)[0], classic.evaluate(*x, dt=1e-3)[0])
