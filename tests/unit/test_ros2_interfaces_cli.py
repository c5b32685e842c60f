"""``uhrisim ros2-interfaces --into VENV`` without building (the build itself:
tests/integration/test_ros2_interfaces_into.py): what it installs into another venv is
the ros2 extra of pyproject.toml — rclpy, the message wheels and the build-only wheels a
plain rclpy lacks — with the extra's own marker dropped; a folder that is no venv is
refused with one line."""

from __future__ import annotations

from packaging.requirements import Requirement
from typer.testing import CliRunner

from tests.support.cli import one_line_error
from uhrisim.bridges.ros2.interfaces.__main__ import ros2_requirements
from uhrisim.cli import app


def test_the_ros2_extra_goes_into_the_other_venv() -> None:
    requirements = [Requirement(text) for text in ros2_requirements()]
    names = {req.name for req in requirements}
    assert {"ros-kilted-rclpy", "ros-kilted-std-msgs", "ros-ament-package",
            "ros-ament-cmake-include-directories", "ros-ament-cmake-ros-core",
            "ros-rosidl-core-generators", "catkin_pkg", "cmake"} <= names
    assert all("extra" not in str(req.marker) for req in requirements)
    assert all(req.marker is None or req.marker.evaluate() for req in requirements)


def test_a_folder_without_python_is_refused(tmp_path) -> None:
    result = CliRunner().invoke(app, ["ros2-interfaces", "--into", str(tmp_path / "none")])
    one_line_error(result, "no bin/python there")
