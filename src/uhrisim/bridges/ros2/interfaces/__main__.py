"""Build the interface packages of :mod:`uhrisim.bridges.ros2.interfaces` that a Python
environment lacks (``--force``: all of them) and install them into its prefix.

Without ``--into`` the environment is this one (``sys.prefix``); with ``--into VENV``
it is another virtual environment (or any Python prefix with ``bin/python``): a node's
own venv, which needs no uhrisim. There the ``ros2`` extra's wheels (rclpy, the message
wheels and the build tools: rosidl generators, ament, catkin_pkg, CMake, Ninja) are
first installed with that environment's pip (``--no-deps``: skip this), the packages
built with its CMake and Python, and checked by importing them in a process of that
environment.

Each package gets a generated ``package.xml`` and ``CMakeLists.txt`` (the usual
``rosidl_generate_interfaces`` of an interface package) and is configured, built and
installed with CMake against the ROS 2 wheels of the environment. Exit status 0 when
every package imports afterwards; 2 with one ``error:`` line otherwise.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from packaging.requirements import Requirement

from . import PACKAGES, msg_text

_PACKAGE_XML = """<?xml version="1.0"?>
<package format="3">
  <name>{name}</name>
  <version>0.0.0</version>
  <description>{name}, built by uhrisim from the public definitions</description>
  <maintainer email="uhrisim@example.com">uhrisim</maintainer>
  <license>BSD-3-Clause</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
{depends}
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
"""

# The wheels' exported CMake targets name the include folder of the machine that built
# them (/opt/python/...): such folders are dropped before generation.
_CMAKELISTS = """cmake_minimum_required(VERSION 3.16)
project({name})
find_package(ament_cmake REQUIRED)
{find_deps}
find_package(rosidl_default_generators REQUIRED)
rosidl_generate_interfaces(${{PROJECT_NAME}} {msgs} DEPENDENCIES {deps})
ament_export_dependencies(rosidl_default_runtime)
get_property(_targets DIRECTORY PROPERTY IMPORTED_TARGETS)
foreach(_t ${{_targets}})
  get_target_property(_dirs ${{_t}} INTERFACE_INCLUDE_DIRECTORIES)
  if(_dirs)
    set(_kept "")
    foreach(_d ${{_dirs}})
      if(EXISTS "${{_d}}" OR _d MATCHES "^\\\\$<")
        list(APPEND _kept "${{_d}}")
      endif()
    endforeach()
    set_target_properties(${{_t}} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${{_kept}}")
  endif()
endforeach()
ament_package()
"""


@dataclass(frozen=True)
class Target:
    """The Python environment the packages are built for and installed into."""

    python: Path   # its interpreter
    prefix: Path   # its sys.prefix: where share/, lib/ and site-packages are

    @property
    def bindir(self) -> Path:
        return self.python.parent

    def which(self, tool: str) -> str | None:
        """``tool`` from the environment's bin folder first, then from PATH."""
        return shutil.which(tool, path=str(self.bindir) + os.pathsep
                            + os.environ.get("PATH", ""))

    def missing(self) -> list[str]:
        """The packages of :data:`PACKAGES` the environment cannot import."""
        probe = ("import importlib.util, sys; print(' '.join(p for p in sys.argv[1:] "
                 "if importlib.util.find_spec(p) is None))")
        out = subprocess.run([str(self.python), "-c", probe, *PACKAGES], check=True,
                             capture_output=True, text=True).stdout
        return out.split()


def this_environment() -> Target:
    return Target(Path(sys.executable), Path(sys.prefix))


def environment_at(venv: Path) -> Target:
    """The environment whose interpreter is ``venv/bin/python`` (ValueError with the
    reason when there is none)."""
    python = venv / "bin" / "python"
    if not python.exists():
        raise ValueError(f"{venv}: no bin/python there (create it with python -m venv {venv})")
    prefix = subprocess.run([str(python), "-c", "import sys; print(sys.prefix)"],
                            check=True, capture_output=True, text=True).stdout.strip()
    return Target(python, Path(prefix))


def ros2_requirements() -> list[str]:
    """The ``ros2`` extra's requirements (pyproject.toml), for another environment's pip:
    the extra's own marker dropped, the Python-version marker kept (that pip judges it)."""
    out = []
    for text in importlib.metadata.requires("uhrisim") or []:
        req = Requirement(text)
        marker = str(req.marker or "")
        if 'extra == "ros2"' not in marker:
            continue
        kept = marker.replace(' and extra == "ros2"', "").replace('extra == "ros2"', "")
        req.marker = None
        out.append(f"{req}; {kept}" if kept else str(req))
    return out


def _source_tree(name: str, root: Path) -> Path:
    """Write package ``name``'s source folder under ``root``; return it."""
    msgs, deps = PACKAGES[name]
    src = root / name
    (src / "msg").mkdir(parents=True)
    for msg in msgs:
        (src / "msg" / f"{msg}.msg").write_text(msg_text(name, msg))
    (src / "package.xml").write_text(_PACKAGE_XML.format(
        name=name, depends="\n".join(f"  <depend>{d}</depend>" for d in deps)))
    (src / "CMakeLists.txt").write_text(_CMAKELISTS.format(
        name=name, find_deps="\n".join(f"find_package({d} REQUIRED)" for d in deps),
        msgs=" ".join(f'"msg/{m}.msg"' for m in msgs), deps=" ".join(deps)))
    return src


def _run(cmd: list[str], env: dict[str, str], log: Path) -> None:
    with log.open("ab") as out:
        subprocess.run(cmd, env=env, stdout=out, stderr=subprocess.STDOUT, check=True)


def build(name: str, target: Target, work: Path) -> None:
    """Configure, build and install package ``name`` into ``target`` (CalledProcessError
    on failure; the tool's output is in ``work/<name>.log``)."""
    src = _source_tree(name, work)
    env = {**os.environ, "AMENT_PREFIX_PATH": str(target.prefix),
           "PATH": str(target.bindir) + os.pathsep + os.environ.get("PATH", "")}
    cmake = target.which("cmake") or "cmake"
    generator = ["-G", "Ninja"] if target.which("ninja") else []
    log = work / f"{name}.log"
    _run([cmake, "-S", str(src), "-B", str(src / "build"), *generator,
          "-DCMAKE_BUILD_TYPE=Release", f"-DCMAKE_PREFIX_PATH={target.prefix}",
          f"-DCMAKE_INSTALL_PREFIX={target.prefix}", f"-DPython3_EXECUTABLE={target.python}",
          "-DBUILD_TESTING=OFF"], env, log)
    _run([cmake, "--build", str(src / "build"), "--parallel", "2"], env, log)
    _run([cmake, "--install", str(src / "build")], env, log)


def install_requirements(target: Target) -> None:
    """Install the ``ros2`` extra's wheels into ``target`` with its own pip (its index
    settings; CalledProcessError on failure, pip's own message on stderr)."""
    subprocess.run([str(target.python), "-m", "pip", "install", "-q",
                    *ros2_requirements()], check=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="uhrisim ros2-interfaces",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="rebuild every package")
    parser.add_argument("--into", type=Path, metavar="VENV",
                        help="another virtual environment (default: this one)")
    parser.add_argument("--no-deps", action="store_true",
                        help="with --into: do not install the ros2 extra's wheels there")
    args = parser.parse_args(argv)
    try:
        target = this_environment() if args.into is None else environment_at(args.into)
        if args.into is not None and not args.no_deps:
            install_requirements(target)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except subprocess.CalledProcessError:
        print(f"error: installing the ros2 extra's wheels into {args.into} failed "
              "(pip's message above)", file=sys.stderr)
        return 2
    if target.which("cmake") is None:
        print("error: building ROS 2 interfaces needs CMake (pip install cmake)",
              file=sys.stderr)
        return 2
    for name in list(PACKAGES) if args.force else target.missing():
        work = Path(tempfile.mkdtemp(prefix=f"uhrisim-{name}-"))
        try:
            build(name, target, work)
        except (subprocess.CalledProcessError, OSError) as exc:
            print(f"error: building {name} failed ({exc}); see {work / (name + '.log')}",
                  file=sys.stderr)
            return 2
        shutil.rmtree(work, ignore_errors=True)
        print(f"built {name} into {target.prefix}")
    left = target.missing()
    if left:
        print(f"error: {', '.join(left)} built but not importable in {target.python}",
              file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
