"""Arms shared by tests that are not shipped: variants of the vendored robots."""

from __future__ import annotations

from pathlib import Path

from slidingarm import SerialArm, robots


def massless_tip_ur5() -> SerialArm:
    """The UR5 with no mass nor inertia in its last link: a URDF the loader accepts, whose
    mass matrix is singular at every state (nothing resists the last joint)."""
    text = (Path(robots.__file__).parent / "ur5" / "ur5.urdf").read_text()
    head, tail = text.split('<link name="wrist_3_link">', 1)
    _inertial, rest = tail.split("</inertial>", 1)
    empty = (
        '<inertial><mass value="0"/><origin rpy="0 0 0" xyz="0 0 0"/>'
        '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>'
    )
    return SerialArm.from_urdf(head + '<link name="wrist_3_link">' + empty + "</inertial>" + rest)
