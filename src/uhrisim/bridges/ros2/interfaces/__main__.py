"""Build the interface packages of :mod:`uhrisim.bridges.ros2.interfaces` that this
environment lacks (``--force``: all of them) and install them into ``sys.prefix``.

Each package gets a generated ``package.xml`` and ``CMakeLists.txt`` (the usual
``rosidl_generate_interfaces`` of an interface package) and is configured, built and
installed with CMake against the ROS 2 wheels of the environment. Exit status 0 when
every package imports afterwards; 2 with one ``error:`` line otherwise.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from . import PACKAGES, missing, msg_text

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


def build(name: str, prefix: Path, work: Path) -> None:
    """Configure, build and install package ``name`` into ``prefix`` (CalledProcessError
    on failure; the tool's output is in ``work/<name>.log``)."""
    src = _source_tree(name, work)
    bindir = str(Path(sys.executable).parent)
    env = {**os.environ, "AMENT_PREFIX_PATH": str(prefix),
           "PATH": bindir + os.pathsep + os.environ.get("PATH", "")}
    cmake = shutil.which("cmake", path=env["PATH"]) or "cmake"
    generator = ["-G", "Ninja"] if shutil.which("ninja", path=env["PATH"]) else []
    log = work / f"{name}.log"
    _run([cmake, "-S", str(src), "-B", str(src / "build"), *generator,
          "-DCMAKE_BUILD_TYPE=Release", f"-DCMAKE_PREFIX_PATH={prefix}",
          f"-DCMAKE_INSTALL_PREFIX={prefix}", f"-DPython3_EXECUTABLE={sys.executable}",
          "-DBUILD_TESTING=OFF"], env, log)
    _run([cmake, "--build", str(src / "build"), "--parallel", "2"], env, log)
    _run([cmake, "--install", str(src / "build")], env, log)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m uhrisim.bridges.ros2.interfaces",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="rebuild every package")
    args = parser.parse_args(argv)
    if shutil.which("cmake", path=str(Path(sys.executable).parent) + os.pathsep
                    + os.environ.get("PATH", "")) is None:
        print("error: building ROS 2 interfaces needs CMake (pip install cmake)",
              file=sys.stderr)
        return 2
    todo = list(PACKAGES) if args.force else missing()
    prefix = Path(sys.prefix)
    for name in todo:
        work = Path(tempfile.mkdtemp(prefix=f"uhrisim-{name}-"))
        try:
            build(name, prefix, work)
        except (subprocess.CalledProcessError, OSError) as exc:
            print(f"error: building {name} failed ({exc}); see {work / (name + '.log')}",
                  file=sys.stderr)
            return 2
        shutil.rmtree(work, ignore_errors=True)
        print(f"built {name} into {prefix}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
