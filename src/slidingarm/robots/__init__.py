"""Robot arms shipped with slidingarm: the Universal Robots UR5 and the Franka Emika Panda.

Each robot is a URDF file vendored from the example-robot-data package (version 6.0.0), in
``slidingarm/robots/NAME/NAME.urdf`` with the licence of its description beside it
(``LICENSE``). The files keep the original kinematics and inertial data; they carry no visual
or collision geometry, and the Panda's two gripper fingers are welded to its hand (fixed
joints), so that it is a 7-joint serial chain. A comment at the top of each file says where it
comes from, under which licence, and what was changed.

=========  ===========================================  ==========
name       robot                                        joints
=========  ===========================================  ==========
``panda``  Franka Emika Panda arm with its hand         7 revolute
``ur5``    Universal Robots UR5 arm, no tool            6 revolute
=========  ===========================================  ==========

Examples
--------
>>> from slidingarm import robots
>>> robots.names()
('panda', 'ur5')
>>> robots.path("ur5").name
'ur5.urdf'
>>> arm = robots.load("ur5")  # doctest: +SKIP
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from slidingarm._validate import ParameterTypeError

if TYPE_CHECKING:
    from slidingarm.models.serial import SerialArm

__all__ = ["describe", "load", "names", "path"]

#: The shipped robots, sorted; each is the folder and the file stem of its URDF.
_NAMES: tuple[str, ...] = ("panda", "ur5")


def names() -> tuple[str, ...]:
    """The names of the shipped robots, sorted.

    Returns
    -------
    tuple of str
        ``("panda", "ur5")``.
    """
    return _NAMES


def _checked(name: object) -> str:
    """``name`` if it is a shipped robot; otherwise the error that names it and the known ones."""
    known = ", ".join(_NAMES)
    if not isinstance(name, str):
        raise ParameterTypeError(
            f"robot name must be a string, one of {known}; got {type(name).__name__} {name!r}"
        )
    if name not in _NAMES:
        raise ValueError(f"unknown robot {name!r}; the shipped robots are {known}")
    return name


def path(name: str) -> Path:
    """The vendored URDF file of a shipped robot.

    Parameters
    ----------
    name : str
        One of :func:`names`.

    Returns
    -------
    pathlib.Path
        ``slidingarm/robots/NAME/NAME.urdf`` inside the installed package; its licence is
        ``LICENSE`` in the same folder.

    Raises
    ------
    ValueError
        ``name`` is not a shipped robot (the message lists the shipped ones).
    slidingarm._validate.ParameterTypeError
        ``name`` is not a string (a :class:`TypeError` and a :class:`ValueError`).
    """
    name = _checked(name)
    return Path(str(resources.files(__name__).joinpath(name, f"{name}.urdf")))


#: Each robot's default tool frame: the link a user means by "the tool".
_TOOLS = {"panda": "panda_hand_tcp", "ur5": "tool0"}


def load(name: str, *, gravity: float = 9.81, tool: str | None = None) -> SerialArm:
    """Build the :class:`~slidingarm.models.serial.SerialArm` of a shipped robot.

    Equivalent to ``SerialArm.from_urdf(path(name), gravity=gravity, tool=tool)``.

    Parameters
    ----------
    name : str
        One of :func:`names`.
    gravity : float, default 9.81
        Gravitational acceleration (m/s²), along ``-z`` of the robot's root link.
    tool : str or None, default None
        The tool frame's link; by default the robot's flange or tool centre point
        (``tool0`` of the UR5, ``panda_hand_tcp`` of the Panda).

    Returns
    -------
    SerialArm
        A serial arm with ``n == 6`` (``"ur5"``) or ``n == 7`` (``"panda"``).

    Raises
    ------
    ValueError
        ``name`` is not a shipped robot, or :meth:`SerialArm.from_urdf` refuses an argument.
    slidingarm._validate.ParameterTypeError
        ``name`` is not a string.
    """
    urdf = path(name)
    from slidingarm.models.serial import SerialArm

    return SerialArm.from_urdf(urdf, gravity=gravity, tool=_TOOLS[name] if tool is None else tool)


@dataclass(frozen=True)
class _Facts:
    """What :func:`describe` reports, read from a URDF file."""

    joints: tuple[tuple[str, int], ...]  # moving joints: (type, count), sorted by type
    mass: float  # kg, every link with an <inertial>
    moving_mass: float  # kg, the links moved by at least one joint
    source: str
    licence: str


@functools.cache
def _facts(name: str) -> _Facts:
    file = path(name)
    source = licence = ""
    parser: ET.XMLPullParser[ET.Element] = ET.XMLPullParser(events=("comment",))
    parser.feed(file.read_bytes())
    parser.close()
    for event in parser.read_events():
        comment = event[-1]  # (event name, element)
        if not isinstance(comment, ET.Element):
            continue
        for line in (comment.text or "").splitlines():
            key, _, value = line.strip().partition(": ")
            if key == "Source" and not source:
                source = value
            elif key == "Licence" and not licence:
                licence = value.split(" (")[0]
    root = ET.parse(file).getroot()
    parent: dict[str, tuple[str, str]] = {}  # child link -> (parent link, joint type)
    joints = root.findall("joint")  # not the <joint> references inside <transmission>
    for joint in joints:
        child, up = joint.find("child"), joint.find("parent")
        if child is not None and up is not None:
            parent[child.get("link", "")] = (up.get("link", ""), joint.get("type", ""))

    def moved(link: str) -> bool:
        seen = set()
        while link in parent and link not in seen:
            seen.add(link)
            link, kind = parent[link]
            if kind != "fixed":
                return True
        return False

    mass = moving_mass = 0.0
    for link in root.iter("link"):
        element = link.find("inertial/mass")
        if element is not None:
            m = float(element.get("value", "0"))
            mass += m
            if moved(link.get("name", "")):
                moving_mass += m
    kinds = Counter(j.get("type", "") for j in joints if j.get("type") != "fixed")
    return _Facts(tuple(sorted(kinds.items())), mass, moving_mass, source, licence)


def describe(name: str) -> str:
    """One line about a shipped robot: its joints, its mass and where its URDF comes from.

    Everything is read from the vendored file: the moving joints by type, the sum of the links'
    masses (and the part of it moved by the joints, i.e. without the links fixed to the base),
    and the source and licence stated in the file's attribution comment.

    Parameters
    ----------
    name : str
        One of :func:`names`.

    Returns
    -------
    str
        For example ``"6 joints (revolute), 20.994 kg (16.994 kg moving); from example-robot-data
        6.0.0 (PyPI), robots/ur_description/urdf/ur5_robot.urdf; licence BSD"`` (one line).

    Raises
    ------
    ValueError
        ``name`` is not a shipped robot.
    slidingarm._validate.ParameterTypeError
        ``name`` is not a string.
    """
    facts = _facts(_checked(name))
    n = sum(count for _, count in facts.joints)
    if len(facts.joints) == 1:
        kinds = facts.joints[0][0]
    else:
        kinds = ", ".join(f"{count} {kind}" for kind, count in facts.joints)
    return (
        f"{n} joints ({kinds}), {facts.mass:.3f} kg ({facts.moving_mass:.3f} kg moving); "
        f"from {facts.source}; licence {facts.licence}"
    )
