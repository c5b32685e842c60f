"""ROS 2 interface packages that have no wheels, built at install time (see PROVENANCE.md).

``uhrisim ros2-interfaces`` (``python -m uhrisim.bridges.ros2.interfaces``) builds
``tf2_msgs`` (TFMessage) and ``marine_acoustic_msgs`` (PingInfo, SonarImageData,
ProjectedSonarImage) from the ``.msg`` files next to this module, and uhrisim's own
``uhrisim_msgs`` (HelmDecision, BehaviorContribution, Variable, Event) from the
definitions every recording embeds (:mod:`uhrisim.ros.msgdefs`), with the rosidl
generator wheels of the ``ros2`` extra (CMake, a C/C++ compiler), and installs them into
the Python environment's prefix exactly where a wheel puts its files: the types are the
real ones a ROS 2 installation has (same names, same type hashes), usable from rclpy in
any process of that environment (``--into VENV``: another environment's). ``make
venv-test`` runs it.
"""

from __future__ import annotations

from pathlib import Path

#: The interface packages built here: package -> (its .msg files, packages it depends on).
PACKAGES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "tf2_msgs": (("TFMessage",), ("geometry_msgs",)),
    "marine_acoustic_msgs": (("PingInfo", "SonarImageData", "ProjectedSonarImage"),
                             ("geometry_msgs", "std_msgs")),
    "uhrisim_msgs": (("BehaviorContribution", "HelmDecision", "Variable", "Event"),
                     ("std_msgs",)),
}

#: Folder holding ``<package>/msg/<Type>.msg``.
SOURCE_DIR = Path(__file__).resolve().parent


def msg_text(package: str, name: str) -> str:
    """The ``.msg`` text of ``package/name``: the file next to this module, or for
    uhrisim_msgs the definition the recordings embed."""
    path = SOURCE_DIR / package / "msg" / f"{name}.msg"
    if path.is_file():
        return path.read_text()
    from uhrisim.ros.msgdefs import own_definition

    return own_definition(f"{package}/msg/{name}")


def build_hint() -> str:
    """What to run to build the missing packages (one line, for error messages)."""
    return "uhrisim ros2-interfaces (needs CMake and a C/C++ compiler)"
