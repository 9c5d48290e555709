"""The smallest complete scenario file, for tests that edit one key of it."""

from __future__ import annotations

from collections.abc import Sequence


def minimal_scenario(
    *,
    switching: str = "sign",
    t_final: float = 0.5,
    controllers: Sequence[str] = ("pdsmc", "tsmc", "ftsmc"),
) -> str:
    """TOML text of the paper's arm and reference with the study's shared gains."""
    blocks = "\n".join(f'[[controllers]]\nname = "{c}"\n' for c in controllers)
    return f"""
switching = "{switching}"

[plant]
preset = "paper"

[reference]
kind = "paper"

[simulation]
t_final = {t_final}
dt = 5e-4
q0 = [0.7, 1.5, 0.5]

[gains]
alpha = 2.0
beta = 2.0
p = 5
q = 3
k = 20.0
width = 0.05

{blocks}"""
