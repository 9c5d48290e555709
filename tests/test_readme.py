"""The README's Python snippets run as written and print what the README shows (issue 11,
point 11).

Every ```python block of the README must be followed by a ```text block: what it prints. The
snippets run in order in one fresh interpreter (a script in a temporary folder, so that numba
can cache the custom law the README compiles), after the tour's shell steps it depends on: the
README's ```toml block is written to ``my.toml`` and run with ``slidingarm run my.toml --out
my_run`` (without figures, which the metrics do not depend on). The comparison is exact, line
by line (trailing spaces aside): the snippets round what they print, so only formatting they
control is compared.
"""

from __future__ import annotations

import difflib
import itertools
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

import slidingarm
from slidingarm.cli import app

README = Path(__file__).resolve().parents[1] / "README.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```\s*$", re.S | re.M)
MARK = "<<<readme-snippet-end>>>"


def blocks(text: str) -> list[tuple[str, str]]:
    """The README's fenced blocks in order, as ``(language, body)``."""
    return [(m.group(1), m.group(2)) for m in FENCE.finditer(text)]


def snippets(text: str) -> list[tuple[str, str]]:
    """Each ```python block with the ```text block that follows it (its output)."""
    found = blocks(text)
    pairs = []
    for i, (lang, body) in enumerate(found):
        if lang != "python":
            continue
        nxt = found[i + 1] if i + 1 < len(found) else ("", "")
        assert nxt[0] == "text", (
            f"README python snippet {len(pairs) + 1} is not followed by a ```text block "
            f"with its output:\n{body}"
        )
        pairs.append((body, nxt[1]))
    return pairs


def shell_outputs(text: str) -> dict[str, str]:
    """The output the README shows for the tour's ``slidingarm validate my.toml`` and
    ``slidingarm run my.toml`` (the ```text block after each one-command ```bash block)."""
    found = blocks(text)
    shown = {}
    for (lang, body), (nxt, out) in itertools.pairwise(found):
        words = body.split()
        if lang == "bash" and nxt == "text" and words[:2] in (["slidingarm", "validate"],
                                                              ["slidingarm", "run"]):  # fmt: skip
            if "my.toml" in words:
                shown[words[1]] = out
    assert set(shown) == {"validate", "run"}, "the tour shows what validate and run print"
    return shown


def _lines(text: str) -> list[str]:
    return [line.rstrip() for line in text.strip("\n").splitlines()]


def test_the_readme_has_its_snippets_with_their_output() -> None:
    pairs = snippets(README.read_text(encoding="utf-8"))
    assert len(pairs) >= 7  # pandas, library, composition, UR5, MuJoCo, batch, custom law
    assert all(out.strip() for _code, out in pairs)


def test_readme_snippets_print_what_the_readme_shows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    text = README.read_text(encoding="utf-8")
    # the tour's scenario file (the other toml blocks are excerpts, such as a [sweep] table)
    tomls = [body for lang, body in blocks(text) if lang == "toml" and "extends" in body]
    assert len(tomls) == 1 and 'extends = "tanh"' in tomls[0]
    (tmp_path / "my.toml").write_text(tomls[0], encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    shown = shell_outputs(text)
    checked = CliRunner().invoke(app, ["validate", "my.toml"])
    assert checked.exit_code == 0 and _lines(checked.stdout) == _lines(shown["validate"])
    ran = CliRunner().invoke(app, ["run", "my.toml", "--out", "my_run", "--no-figures"])
    assert ran.exit_code == 0, ran.stderr
    # the run's line "wrote my_run (N files) in T s" varies (time; no figures here), its table not
    head, *table = _lines(shown["run"])
    assert re.fullmatch(r"wrote my_run \(\d+ files\) in [\d.]+ s", head)
    assert _lines(ran.stdout)[1:] == table

    pairs = snippets(text)
    script = "".join(f"{code}\nprint({MARK!r}, flush=True)\n" for code, _out in pairs)
    (tmp_path / "readme_snippets.py").write_text(script, encoding="utf-8")
    env = dict(os.environ, MPLBACKEND="Agg")
    src = str(Path(slidingarm.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([src, *filter(None, [env.get("PYTHONPATH")])])
    proc = subprocess.run(
        [sys.executable, "readme_snippets.py"], cwd=tmp_path, env=env, capture_output=True,
        text=True, timeout=900,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    printed = proc.stdout.split(MARK + "\n")
    assert len(printed) == len(pairs) + 1 and printed[-1] == ""
    for i, ((code, expected), got) in enumerate(zip(pairs, printed, strict=False), start=1):
        want, have = _lines(expected), _lines(got)
        diff = "\n".join(difflib.unified_diff(want, have, "README", "printed", lineterm=""))
        assert have == want, f"README snippet {i} prints otherwise:\n{diff}\n--- snippet:\n{code}"
