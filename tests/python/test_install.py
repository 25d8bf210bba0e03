"""`cmake --install` gives a working installation (issue "Fits the tools its users already use",
must-show 4): into a scratch prefix, the installed pfm-mpm prints its version and runs a shipped
case, the installed Python module imports from the prefix alone and reads a case, and a project
outside the tree finds the package (find_package(pfm_mpm)), builds against pfm::core with the
installed headers and runs."""
import os
import sys

import json
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

CONSUMER_CMAKE = """cmake_minimum_required(VERSION 3.22)
project(consumer LANGUAGES C CXX)
set(CMAKE_CXX_STANDARD 20)
find_package(pfm_mpm 0.1 REQUIRED)
add_executable(consumer main.cpp)
target_link_libraries(consumer PRIVATE pfm::core)
"""

# The plane-strain P-wave modulus of the installed materials library: M = E (1 - nu) /
# ((1 + nu) (1 - 2 nu)) = 1346.15... kPa for E = 1000 kPa, nu = 0.3.
CONSUMER_MAIN = """#include <cstdio>
#include "mpm/core/materials.hpp"
int main() {
  pfm::LinearElastic soil;
  soil.elastic = {1000.0, 0.3};
  const pfm::MaterialConstants c = soil.constants();
  std::printf("%.17g\\n", c.lambda + 2.0 * c.mu);
  return 0;
}
"""


def test_an_installed_prefix_runs_a_case_and_serves_a_cmake_project(
    pfm_binary, tmp_path
):
    build = Path(pfm_binary).resolve().parents[1]
    prefix = tmp_path / "prefix"
    subprocess.run(
        ["cmake", "--install", str(build), "--prefix", str(prefix)],
        check=True,
        capture_output=True,
    )
    installed = prefix / "bin" / "pfm-mpm"
    version = subprocess.run(
        [str(installed), "--version"], check=True, capture_output=True, text=True
    ).stdout
    assert version.startswith("pfm-mpm 0.1.0")
    subprocess.run(
        [
            str(installed),
            "run",
            str(ROOT / "cases" / "column.json"),
            "--out",
            str(tmp_path / "out"),
            "--quiet",
        ],
        check=True,
        capture_output=True,
    )
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert run["status"] == "completed"
    for name in ("LICENSE", "CHANGELOG.md"):
        assert list(prefix.glob(f"share/doc/*/{name}")), name
    # The UL-FEM is built on the step library, not on the MPM solver (issue 46, must-show 2).
    (targets,) = prefix.glob("lib/cmake/pfm_mpm/pfm_mpmTargets.cmake")
    links = re.search(
        r"set_target_properties\(pfm::ulfem .*?INTERFACE_LINK_LIBRARIES \"([^\"]*)\"",
        targets.read_text(),
        re.S,
    )
    assert links and "pfm::step" in links.group(1).split(";")
    assert "pfm::solver" not in links.group(1).split(";")

    # The Python module from the prefix alone: the repository and the build are not on the
    # path (a scratch working directory, PYTHONPATH only the prefix's package folder).
    (packages,) = prefix.glob("lib/python3*/dist-packages")
    script = (
        "import pfm_mpm, sys; "
        "case = pfm_mpm.read_case(sys.argv[1]); "
        "print(pfm_mpm.__file__); print(case['grid']['n_cells'])"
    )
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(packages)
    printed = subprocess.run(
        [sys.executable, "-c", script, str(ROOT / "cases" / "column.json")],
        cwd=tmp_path,
        env=env,
        check=True,
        capture_output=True,
        text=True,
    ).stdout.splitlines()
    assert printed[0].startswith(str(packages)) and printed[1] == "[2, 12]"

    source, consumer = tmp_path / "consumer", tmp_path / "consumer-build"
    source.mkdir()
    (source / "CMakeLists.txt").write_text(CONSUMER_CMAKE)
    (source / "main.cpp").write_text(CONSUMER_MAIN)
    subprocess.run(
        [
            "cmake",
            "-S",
            str(source),
            "-B",
            str(consumer),
            f"-DCMAKE_PREFIX_PATH={prefix}",
        ],
        check=True,
        capture_output=True,
    )
    subprocess.run(["cmake", "--build", str(consumer)], check=True, capture_output=True)
    out = subprocess.run(
        [str(consumer / "consumer")], check=True, capture_output=True, text=True
    ).stdout
    assert float(out) == pytest.approx(1000.0 * 0.7 / (1.3 * 0.4), rel=1e-12)
