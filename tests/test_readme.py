"""The README's "From Python" block runs as a reader pastes it: into an empty directory."""

import os
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def python_block():
    """The ```python block of the README's "From Python" section."""
    section = (REPO / "README.md").read_text().split("## From Python\n", 1)[1]
    return re.search(r"^```python\n(.*?)^```", section, re.MULTILINE | re.DOTALL).group(1)


def test_the_python_block_runs_in_an_empty_directory_and_prints_its_comment(tmp_path):
    block = python_block()
    stated = re.findall(r"^print\(.*\)\s+# (\S+)$", block, re.MULTILINE)
    assert len(stated) == 1, block
    env = dict(
        os.environ,
        PYTHONPATH=os.pathsep.join(
            [str(REPO)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
        ),
    )
    done = subprocess.run(
        [sys.executable, "-c", block],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    printed = done.stdout.split()
    assert len(printed) == 1, done.stdout
    digits = len(stated[0].split(".")[1]) if "." in stated[0] else 0
    assert round(float(printed[0]), digits) == float(stated[0]), (printed, stated)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5"]  # what it wrote, no more
