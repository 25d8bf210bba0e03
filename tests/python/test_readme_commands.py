"""Every command block of the README runs as written, in order, on a scratch copy of the tree
(issue "Fits the tools its users already use", must-show 1), so the README cannot drift from the
code: each line of a fenced ``sh`` block runs with bash from the copy's root and exits 0.

The copy holds the project's files (``git ls-files``; without git, the tree but its builds and
results) with ``build`` a link to the build under
test; ``make`` lines run with its ``build`` step taken as done (``make -o build``): that build is
what ``make test`` has just made. ``make test`` itself is not run: it is what runs this test.
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def readme_commands(text: str) -> list[str]:
    """The lines of the fenced sh blocks, in order, without their trailing comments."""
    commands = []
    for block in re.findall(r"^```sh\n(.*?)^```", text, re.S | re.M):
        for line in block.splitlines():
            command = re.sub(r"\s+#.*$", "", line).strip()
            if command:
                commands.append(command)
    return commands


def test_the_readme_has_command_blocks_and_no_placeholders():
    commands = readme_commands((ROOT / "README.md").read_text())
    assert "make run" in commands and "make test" in commands
    for command in commands:
        assert not re.search(
            r"\[|\]|<|>|\.\.\.", command
        ), f"not runnable as written: {command}"


def test_every_readme_command_runs_as_written_on_a_scratch_copy(pfm_binary, tmp_path):
    build = Path(pfm_binary).resolve().parents[1]
    copy = tmp_path / "pfm-mpm"
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True)
    if listed.returncode == 0:
        for name in filter(None, (f.decode() for f in listed.stdout.split(b"\0"))):
            source = ROOT / name
            if source.is_file():
                (copy / name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(source, copy / name)
    else:  # a tree without git: everything but builds, results and caches
        shutil.copytree(
            ROOT,
            copy,
            symlinks=True,
            ignore=lambda folder, names: [
                n
                for n in names
                if n == "__pycache__"
                or (
                    Path(folder) == ROOT
                    and (n.startswith("build") or n in ("results", ".git"))
                )
            ],
        )
    (copy / "build").symlink_to(build, target_is_directory=True)
    env = dict(os.environ, PFM_BUILD_DIR=str(copy / "build"))
    ran = []
    for command in readme_commands((copy / "README.md").read_text()):
        if command == "make test":
            continue
        if command.startswith("make "):
            command = "make -o build " + command[len("make ") :]
        result = subprocess.run(
            ["bash", "-c", command], cwd=copy, env=env, capture_output=True, text=True
        )
        assert result.returncode == 0, (
            f"README command `{command}` exited {result.returncode}:\n"
            f"{result.stdout[-2000:]}\n{result.stderr[-2000:]}"
        )
        ran.append(command)
    assert len(ran) >= 3
