"""Tests for :mod:`slidingarm.robots`: the vendored UR5 and Panda URDFs and their helpers."""

from __future__ import annotations

import hashlib
import importlib.util
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pinocchio as pin
import pytest
from typer.testing import CliRunner

from slidingarm import robots
from slidingarm._validate import ParameterTypeError
from slidingarm.cli import app


@dataclass(frozen=True)
class Original:
    """Facts of the original file in example-robot-data 6.0.0, recorded once (see below)."""

    dof: int
    links: int  # <link> elements
    inertials: int  # <link> elements with an <inertial>
    mass: float  # kg, sum of <mass value> over all links
    moving_mass: float  # kg, the links moved by a joint (the base's links excluded)
    inertial_sha256: str  # of the raw <inertial>…</inertial> texts, in file order, "\n"-joined


# Recorded from the ORIGINAL files of the PyPI wheel example_robot_data-6.0.0-0-py3-none-any.whl
# (unzipped; cmeel.prefix/share/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf and
# .../robots/panda_description/urdf/panda.urdf): links and masses counted with
# xml.etree.ElementTree, the hash with _inertial_sha256 below applied to the original text. The
# hash ties the vendored inertial data byte for byte to the original without needing the wheel.
# Moving mass: UR5 without base_link (4 kg, fixed to world); Panda without panda_link0 (0.629769).
ORIGINAL = {
    "panda": Original(
        dof=7,
        links=13,
        inertials=13,
        mass=17.451901,
        moving_mass=16.822132,
        inertial_sha256="c971d8dfcad78273828fc368f7d2bd0f888e62cae9f7f67d5b1b6667e4911fb4",
    ),
    "ur5": Original(
        dof=6,
        links=11,
        inertials=10,
        mass=20.9939,
        moving_mass=16.9939,
        inertial_sha256="db53e9f66ae582295a396498868dc81b2e784b7de1f43f08baa6d985c51305c6",
    ),
}

#: Pinocchio's revolute joint models (bounded: the URDFs use "revolute", not "continuous").
REVOLUTE = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned"}

NAMES = ("panda", "ur5")


def _inertial_sha256(text: str) -> str:
    blocks = re.findall(r"<inertial>.*?</inertial>", text, re.S)
    return hashlib.sha256("\n".join(blocks).encode("utf-8")).hexdigest()


def _root(name: str) -> ET.Element:
    return ET.parse(robots.path(name)).getroot()


# ---------------------------------------------------------------------------- names and errors


def test_names_are_sorted_and_complete() -> None:
    assert robots.names() == ("panda", "ur5")
    assert tuple(ORIGINAL) == robots.names()


@pytest.mark.parametrize("name", NAMES)
def test_path_is_the_vendored_file(name: str) -> None:
    file = robots.path(name)
    assert isinstance(file, Path)
    assert file.name == f"{name}.urdf" and file.parent.name == name and file.is_file()


@pytest.mark.parametrize("function", [robots.path, robots.describe, robots.load])
@pytest.mark.parametrize("name", ["ur10", "UR5", "", "panda.urdf"])
def test_unknown_name_names_it_and_the_known_ones(
    function: Callable[[object], object], name: str
) -> None:
    with pytest.raises(ValueError, match="unknown robot") as info:
        function(name)
    assert repr(name) in str(info.value)
    assert "panda, ur5" in str(info.value)
    assert not isinstance(info.value, TypeError)


@pytest.mark.parametrize("function", [robots.path, robots.describe, robots.load])
@pytest.mark.parametrize("name", [None, 5, b"ur5", Path("ur5"), ("ur5",)])
def test_a_name_that_is_no_string_is_a_type_error(
    function: Callable[[object], object], name: object
) -> None:
    with pytest.raises(ParameterTypeError, match="robot name must be a string") as info:
        function(name)
    assert isinstance(info.value, TypeError) and isinstance(info.value, ValueError)
    assert "panda, ur5" in str(info.value)


# ---------------------------------------------------------------------------- the vendored files


@pytest.mark.parametrize("name", NAMES)
def test_pinocchio_reads_a_revolute_chain_with_massive_bodies(name: str) -> None:
    model = pin.buildModelFromUrdf(str(robots.path(name)))
    dof = ORIGINAL[name].dof
    assert model.nq == model.nv == dof
    assert model.njoints == dof + 1  # the universe and one joint per coordinate
    for i in range(1, model.njoints):
        assert model.joints[i].shortname() in REVOLUTE, model.names[i]
        assert model.parents[i] == i - 1, "a chain"
        assert model.inertias[i].mass > 0, f"body of {model.names[i]} has no mass"
    moving = sum(model.inertias[i].mass for i in range(1, model.njoints))
    assert moving == pytest.approx(ORIGINAL[name].moving_mass, rel=1e-12)
    total = sum(model.inertias[i].mass for i in range(model.njoints))
    assert total == pytest.approx(ORIGINAL[name].mass, rel=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_inertial_data_is_the_original(name: str) -> None:
    original = ORIGINAL[name]
    root = _root(name)
    links = root.findall("link")
    assert len(links) == original.links
    assert sum(link.find("inertial") is not None for link in links) == original.inertials
    mass = sum(float(m.get("value", "nan")) for m in root.iter("mass"))
    assert mass == pytest.approx(original.mass, rel=1e-12)
    assert _inertial_sha256(robots.path(name).read_text(encoding="utf-8")) == (
        original.inertial_sha256
    )


@pytest.mark.parametrize("name", NAMES)
def test_no_geometry_and_no_package_references(name: str) -> None:
    text = robots.path(name).read_text(encoding="utf-8")
    for word in ("<visual", "<collision", "<geometry", "mesh", "package://", ".stl", ".dae"):
        assert word not in text.lower(), word
    root = _root(name)
    assert root.find(".//visual") is None and root.find(".//collision") is None


@pytest.mark.parametrize("name", NAMES)
def test_every_moving_joint_is_revolute_and_nothing_mimics(name: str) -> None:
    joints = _root(name).findall("joint")
    moving = [j for j in joints if j.get("type") != "fixed"]
    assert len(moving) == ORIGINAL[name].dof
    assert {j.get("type") for j in moving} == {"revolute"}
    assert all(j.find("mimic") is None for j in joints)


def test_the_panda_fingers_are_welded_to_the_hand() -> None:
    joints = {j.get("name"): j for j in _root("panda").findall("joint")}
    for name, child in (
        ("panda_finger_joint1", "panda_leftfinger"),
        ("panda_finger_joint2", "panda_rightfinger"),
    ):
        joint = joints[name]
        assert joint.get("type") == "fixed"
        assert [e.tag for e in joint] == ["parent", "child", "origin"]
        parent, link, origin = joint
        assert parent.get("link") == "panda_hand" and link.get("link") == child
        assert origin.attrib == {"rpy": "0 0 0", "xyz": "0 0 0.0584"}


@pytest.mark.parametrize("name", NAMES)
def test_licence_and_attribution_beside_and_in_each_file(name: str) -> None:
    licence = robots.path(name).with_name("LICENSE")
    text = licence.read_text(encoding="utf-8")
    assert text.strip()
    assert ("Apache License" if name == "panda" else "BSD 2-Clause License") in text
    urdf = robots.path(name).read_text(encoding="utf-8")
    declaration, comment = urdf.split("\n", 2)[:2]
    assert declaration.startswith("<?xml") and comment == "<!--"
    header = urdf.split("-->", 1)[0]
    assert "Vendored by slidingarm" in header
    assert "Source: example-robot-data 6.0.0 (PyPI), robots/" in header
    assert f"Licence: {'Apache-2.0' if name == 'panda' else 'BSD'} (" in header
    assert "Changed:" in header and "LICENSE" in header


# ---------------------------------------------------------------------------- describe, load, CLI


@pytest.mark.parametrize("name", NAMES)
def test_describe_is_one_line_read_from_the_file(name: str) -> None:
    line = robots.describe(name)
    original = ORIGINAL[name]
    assert "\n" not in line
    assert line.startswith(f"{original.dof} joints (revolute), {original.mass:.3f} kg ")
    assert f"({original.moving_mass:.3f} kg moving)" in line
    assert "from example-robot-data 6.0.0 (PyPI)" in line
    assert line.endswith("licence Apache-2.0" if name == "panda" else "licence BSD")


_NO_SERIAL = importlib.util.find_spec("slidingarm.models.serial") is None


@pytest.mark.skipif(_NO_SERIAL, reason="slidingarm.models.serial (SerialArm) not there yet")
@pytest.mark.parametrize("name", NAMES)
def test_load_builds_the_serial_arm(name: str) -> None:
    from slidingarm.models.serial import SerialArm

    arm = robots.load(name)
    assert isinstance(arm, SerialArm)
    assert arm.n == ORIGINAL[name].dof


def test_cli_list_shows_the_robots() -> None:
    result = CliRunner().invoke(app, ["list"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    heading = next(i for i, line in enumerate(lines) if line.startswith("robots"))
    for name in NAMES:
        assert f"  {name:<8} {robots.describe(name)}" in lines[heading + 1 :]
