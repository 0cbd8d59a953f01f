"""The documentation's examples as tests (Sybil): `python -m pytest -q -p no:randomly README.md docs`.

Each page runs in a scratch folder of its own (with `missions/`, `campaigns/` and `docs/` linked from the
repository, so the commands find their files as they would from a checkout), its examples in order:

- a ```python block runs in the page's one namespace;
- a ```python block whose first line is `# test_<name>.py` is a pytest file: it is written there and run with
  pytest, as a user would run it (the pytest plugin comes with the install);
- a ```sh block runs in bash (-e, -u, -o pipefail) and must exit 0;
- ```console blocks (sessions that never end by themselves: `vtol up`, a ground station) and ```text blocks are
  shown, not run; `<!-- skip: next "why" -->` skips the next example (only for what CI does itself: the install
  and the test suite).

The test paths of the suite (pyproject.toml) do not include the docs: they run as their own step of .ci/run.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from sybil import Example, Sybil
from sybil.evaluators.python import PythonEvaluator
from sybil.parsers.markdown import CodeBlockParser, SkipParser

ROOT = Path(__file__).resolve().parent
LINKED = ("missions", "campaigns", "docs")  # what the examples read, as from a checkout
EXAMPLE_TIMEOUT_S = 900


def _run(argv: list[str], example: Example) -> None:
    folder = example.namespace["scratch"]
    completed = subprocess.run(argv, cwd=folder, capture_output=True, text=True, timeout=EXAMPLE_TIMEOUT_S)
    if completed.returncode != 0:
        raise AssertionError(
            f"{example.path}, line {example.line}: exit code {completed.returncode}\n"
            f"--- stdout ---\n{completed.stdout[-4000:]}\n--- stderr ---\n{completed.stderr[-4000:]}"
        )


def run_shell(example: Example) -> None:
    _run(["bash", "-euo", "pipefail", "-c", example.parsed], example)


_evaluate_python = PythonEvaluator()


def run_python(example: Example) -> None:
    source = example.parsed
    first_line = source.split("\n", 1)[0].strip()
    if first_line.startswith("# test_") and first_line.endswith(".py"):
        test_file = Path(example.namespace["scratch"]) / first_line.removeprefix("# ")
        test_file.write_text(source)
        _run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", test_file.name], example)
    else:
        _evaluate_python(example)


def set_up(namespace: dict) -> None:
    scratch = Path(tempfile.mkdtemp(prefix="tiltrotor-sitl-docs-"))
    for name in LINKED:
        (scratch / name).symlink_to(ROOT / name)
    namespace["scratch"] = str(scratch)
    namespace["_previous_cwd"] = os.getcwd()
    os.chdir(scratch)


def tear_down(namespace: dict) -> None:
    os.chdir(namespace["_previous_cwd"])
    shutil.rmtree(namespace["scratch"], ignore_errors=True)


pytest_collect_file = Sybil(
    parsers=[
        CodeBlockParser(language="python", evaluator=run_python),
        CodeBlockParser(language="sh", evaluator=run_shell),
        SkipParser(),
    ],
    patterns=["README.md", "docs/*.md", "docs/**/*.md"],
    setup=set_up,
    teardown=tear_down,
).pytest()
