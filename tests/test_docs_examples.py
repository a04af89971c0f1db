"""Every code example of the documentation runs: the fenced ```python blocks of docs/*.md and
README.md, and the commands the shell blocks name exist.

Python blocks.  The blocks of one file run in order in one namespace, in a fresh Python process
(the test's own interpreter, the repository first on ``sys.path``) whose working directory is a
temporary folder.  Blocks that use YADE run there too, through a plain ``import yade`` (as
tests/_yadehelpers.py does; the venv made by scripts/setup.sh can import YADE).  A traceback
names the Markdown file and the line of the block.

Two HTML comments, invisible on the rendered page, may stand right before a python block:

``<!-- docs-test: skip REASON -->``
    the block is not run; REASON says why (it needs something this machine cannot have, such
    as a GPU engine or a SLURM cluster).  Every such block is listed in the test's output.
``<!-- docs-test-setup:`` ... ``-->``
    the Python lines between the two markers run before the block, in its namespace: the files
    or objects the prose says the reader already has (a sphere list, an exported file).

Shell blocks (fences without a language) are not run; the commands they name are checked where
that is cheap: ``make`` targets exist in the Makefile, ``python -m MODULE`` modules are found,
and repository paths given to ``python``, ``yade -x``, ``clumpprops`` and ``bash`` exist.
"""
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from importlib.util import find_spec
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]

FENCE = re.compile(r"^(?P<indent>[ \t]*)```(?P<lang>[^\s`]*)(?:[ \t].*)?$")
SKIP = re.compile(r"<!--\s*docs-test:\s*skip\s+(?P<reason>\S.*?)\s*-->")
SETUP = re.compile(r"<!--\s*docs-test-setup:\s*\n(?P<code>.*?)\n\s*-->\s*$", re.S)


def code_blocks(path):
    """The fenced code blocks of Markdown file ``path``: dicts with ``lang``, ``line`` (1-based,
    of the first code line), ``code`` (dedented by the fence's indent), ``skip`` (a reason or
    None) and ``setup`` (hidden setup code or "")."""
    lines = Path(path).read_text().split("\n")
    blocks, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent = len(m.group("indent"))
        end = i + 1
        while end < len(lines) and not re.match(r"^[ \t]*```[ \t]*$", lines[end]):
            end += 1
        if end == len(lines):
            raise AssertionError(f"{path}:{i + 1}: code fence never closed")
        before = "\n".join(lines[max(0, i - 40):i]).rstrip()
        skip = SKIP.search(before.rsplit("\n", 1)[-1]) if before else None
        setup = SETUP.search(before) if before.endswith("-->") else None
        blocks.append({"lang": m.group("lang"), "line": i + 2,
                       "code": "\n".join(line[indent:] for line in lines[i + 1:end]),
                       "skip": skip.group("reason") if skip else None,
                       "setup": setup.group("code") if setup else ""})
        i = end + 1
    return blocks


def python_blocks(path):
    return [b for b in code_blocks(path) if b["lang"] == "python"]


RUNNER = r"""
import json, os, sys
sys.path.insert(0, sys.argv[1])
blocks = json.load(sys.stdin)
namespace = {"__name__": "__main__"}
for b in blocks:
    for code, line in ((b["setup"], b["line"]), (b["code"], b["line"])):
        if code:
            exec(compile("\n" * (line - 1) + code, b["file"], "exec"), namespace)
    print(f"ran {b['file']}:{b['line']}", flush=True)
"""


def run_blocks(page, blocks, cwd):
    """Run ``blocks`` of ``page`` in one fresh Python process in ``cwd``; returns the process."""
    payload = [dict(b, file=str(page.relative_to(ROOT))) for b in blocks]
    env = dict(os.environ, OMP_NUM_THREADS="1", MPLBACKEND="Agg")
    env.pop("PYTHONPATH", None)
    return subprocess.run([sys.executable, "-c", RUNNER, str(ROOT)], input=json.dumps(payload), cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=900)


PYTHON_PAGES = [p for p in PAGES if python_blocks(p)]


def test_the_pages_have_python_examples():
    """The pages hold python blocks to run (a fence renamed away would empty this test)."""
    names = {p.name for p in PYTHON_PAGES}
    assert {"README.md", "library.md", "yade_adapter.md", "engines.md"} <= names, names


def test_block_parser_reads_markers(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("text\n\n<!-- docs-test: skip needs a GPU -->\n```python\nimport gpu\n```\n\n"
                    "<!-- docs-test-setup:\nx = 2\n-->\n  ```python\n  print(x)\n  ```\n\n```\n$ make docs\n```\n")
    a, b, c = code_blocks(page)
    assert (a["lang"], a["skip"], a["setup"], a["code"], a["line"]) == ("python", "needs a GPU", "", "import gpu", 5)
    assert (b["skip"], b["setup"], b["code"]) == (None, "x = 2", "print(x)")
    assert (c["lang"], c["code"]) == ("", "$ make docs")


@pytest.mark.parametrize("page", PYTHON_PAGES, ids=lambda p: p.name)
def test_python_examples_run(page, tmp_path):
    blocks = python_blocks(page)
    run = [b for b in blocks if b["skip"] is None]
    for b in blocks:
        if b["skip"] is not None:
            print(f"not run: {page.name}:{b['line']}: {b['skip']}")
    p = run_blocks(page, run, tmp_path)
    assert p.returncode == 0, f"{page.name}: a python example failed\n{p.stdout[-3000:]}\n{p.stderr[-6000:]}"
    assert p.stdout.count("\nran ") + p.stdout.startswith("ran ") == len(run), p.stdout


def test_a_failing_example_names_its_page_and_line(tmp_path):
    page = ROOT / "docs" / "example.md"          # never written: only its name is used
    p = run_blocks(page, [{"lang": "python", "line": 7, "code": "x = 1\nraise ValueError('boom')", "skip": None,
                           "setup": ""}], tmp_path)
    assert p.returncode != 0
    assert 'File "docs/example.md", line 8' in p.stderr, p.stderr


# -- shell blocks --------------------------------------------------------------------------------

TOP_DIRS = ("examples/", "tests/", "benchmarks/", "studies/", "scripts/", "yade_scripts/", "docs/", "clumpprops/")


def shell_commands(path):
    """(line, argv) of each command line of the shell blocks of ``path``: in a block with ``$ ``
    prompts the prompted lines (the others are output), else every line naming a known command;
    comments cut."""
    out = []
    for b in code_blocks(path):
        if b["lang"] not in ("", "sh", "bash", "shell", "console"):
            continue
        lines = b["code"].split("\n")
        prompted = any(line.strip().startswith("$ ") for line in lines)   # then the rest is output
        for k, text in enumerate(lines):
            text = text.strip()
            if prompted and not text.startswith("$ "):
                continue
            text = text[2:] if prompted else text
            text = text.split("  #", 1)[0].split(" # ", 1)[0].strip()
            try:
                argv = shlex.split(text)
            except ValueError:
                continue
            while argv and re.match(r"^[A-Z_][A-Z0-9_]*=", argv[0]):   # VAR=value prefixes
                argv = argv[1:]
            if argv and argv[0] in ("make", "python", "python3", ".venv/bin/python", "clumpprops", "yade", "bash"):
                out.append((b["line"] + k, argv))
    return out


def make_targets():
    return set(re.findall(r"^([A-Za-z][\w-]*):", (ROOT / "Makefile").read_text(), re.M))


def command_problems(argv):
    """What is missing for command ``argv`` (a list of strings; empty when all is there)."""
    problems = []
    if argv[0] == "make":
        problems += [f"no make target {t!r}" for t in argv[1:] if not t.startswith("-") and "=" not in t
                     and t not in make_targets()]
        return problems
    if argv[0].endswith("python") or argv[0] == "python3":
        if "-m" in argv[1:]:
            module = argv[argv.index("-m") + 1]
            sys.path.insert(0, str(ROOT))
            try:
                if find_spec(module) is None:
                    problems.append(f"no module {module}")
            finally:
                sys.path.remove(str(ROOT))
    paths = [a for a in argv[1:] if a.startswith(TOP_DIRS) and not a.endswith("/")]
    problems += [f"no file {a}" for a in paths if not (ROOT / a).exists()]
    return problems


SHELL_PAGES = [p for p in PAGES if shell_commands(p)]


@pytest.mark.parametrize("page", SHELL_PAGES, ids=lambda p: p.name)
def test_shell_commands_exist(page):
    problems = [f"{page.name}:{line}: {' '.join(argv)}: {why}" for line, argv in shell_commands(page)
                for why in command_problems(argv)]
    assert not problems, "\n".join(problems)


def test_command_check_finds_missing_things():
    assert command_problems(["make", "no-such-target"]) == ["no make target 'no-such-target'"]
    assert command_problems([".venv/bin/python", "-m", "studies.no_such_module"]) == ["no module studies.no_such_module"]
    assert command_problems(["clumpprops", "examples/no_such_file.txt"]) == ["no file examples/no_such_file.txt"]
    assert command_problems(["make", "docs"]) == [] and command_problems(["python", "-m", "studies", "plan", "x"]) == []


@pytest.mark.parametrize("module", ["clumpprops", "clumpprops.io"])
def test_docstring_examples_of_the_public_modules_run(module, tmp_path, monkeypatch):
    """The ``>>>`` examples in module docstrings (shown on the API pages) run as written."""
    import doctest
    import importlib

    shutil.copy(ROOT / "examples" / "engines" / "dimer.csv", tmp_path / "dimer.csv")   # the file the io example reads
    monkeypatch.chdir(tmp_path)
    mod = importlib.import_module(module)
    finder = doctest.DocTestFinder(recurse=False)
    tests = [t for t in finder.find(mod) if t.examples]
    assert tests, f"{module}'s docstring has no examples"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0 and result.attempted > 0, result
