"""Shared fixtures: where the built binaries are, and a run of a case document."""
import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def pfm_binary() -> Path:
    build = Path(os.environ.get("PFM_BUILD_DIR", ROOT / "build"))
    binary = build / "bin" / "pfm-mpm"
    if not binary.exists():
        pytest.fail(f"{binary} not built: run `make build` first")
    return binary


@pytest.fixture
def run_case(pfm_binary):
    """run_case(case, folder, *options): `pfm-mpm run` of the case document written to
    folder/case.json into folder/out (quiet); the CompletedProcess."""

    def run(case: dict, folder: Path, *options):
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "case.json"
        path.write_text(json.dumps(case))
        return subprocess.run(
            [pfm_binary, "run", path, "--out", folder / "out", "--quiet", *options],
            capture_output=True,
            text=True,
        )

    return run
