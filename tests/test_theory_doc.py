"""``docs/theory.md`` is the project's own theory page (issue 11, point 15): it is in the
repository, has the sections the code cites, states the rules the code applies, and its
measured costs of the paper's errata are the ones the code measures."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from slidingarm.control.controllers import guard_for_period
from slidingarm.study import load_shipped
from slidingarm.study.analysis import errata_table

ROOT = Path(__file__).resolve().parents[1]
THEORY = ROOT / "docs" / "theory.md"
SRC = ROOT / "src" / "slidingarm"
CITE = re.compile(r"docs/theory\.md §(\d+)")


def _sections() -> dict[int, str]:
    text = THEORY.read_text(encoding="utf-8")
    return {int(m.group(1)): m.group(2) for m in re.finditer(r"^## §(\d+)\. (.+)$", text, re.M)}


def _sources() -> list[Path]:
    return [p for p in SRC.rglob("*") if p.suffix in (".py", ".toml") and p.is_file()]


def test_the_theory_page_is_in_the_repository_with_its_sections() -> None:
    assert THEORY.is_file()
    titles = _sections()
    assert sorted(titles) == list(range(1, 9))
    text = THEORY.read_text(encoding="utf-8").lower()
    for topic in ("conventions", "the control law", "the guard rule", "convergence times",
                  "metrics", "errata"):  # fmt: skip
        assert topic in text, topic


def test_the_sources_cite_the_theory_page_not_the_shared_spec() -> None:
    spec = [f"{p.relative_to(ROOT)}:{i}" for p in _sources()
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
            if re.search(r"SPEC ?§|SPEC\.md|\.\./shared", line)]  # fmt: skip
    assert not spec, spec
    cited = {int(n) for p in _sources() for n in CITE.findall(p.read_text(encoding="utf-8"))}
    assert cited and cited <= set(_sections())
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "docs/theory.md" in readme and "SPEC" not in readme


def test_the_guard_rule_as_written_is_the_one_applied() -> None:
    text = THEORY.read_text(encoding="utf-8")
    assert "ε_e = (2 β γ Ts)^(1/(1−γ))" in text and "`ε_e = 4.99e-8` rad" in text
    assert f"{guard_for_period(2.0, 0.6, 5e-4):.3g}" == "4.99e-08"


def test_the_errata_costs_written_are_the_ones_measured() -> None:
    table = errata_table(load_shipped("sign")).set_index("variant")
    text = THEORY.read_text(encoding="utf-8")
    correct, law, exponent = (table.loc[v] for v in ("correct", "paper law", "paper exponent"))
    both = table.loc["paper law and exponent"]
    assert "MSE 4.73 rad² against 0.0125" in text
    assert (round(law.mse_mean, 2), round(correct.mse_mean, 4)) == (4.73, 0.0125)
    assert f"steady-state error {law.steady_state_error:.1f} rad" in text
    assert f"MSE {both.mse_mean:.2f} rad²" in text
    assert f"MSE {exponent.mse_mean:.4f} against {correct.mse_mean:.4f} rad²" in text
    assert (
        f"steady-state error {exponent.steady_state_error:.1e} rad against "
        f"{correct.steady_state_error:.1e} rad" in text
    )
    ratio = exponent.steady_state_error / correct.steady_state_error
    assert f"({ratio:.0f}×)" in text
    assert law.mse_mean / correct.mse_mean == pytest.approx(380, rel=0.02)
