"""Every example of the user manual (``docs/*.md``) runs as written.

The convention (``docs/architecture.md``, "Examples in the manual"):

- A ```` ```console ```` block is a shell session: each ``$ `` line is a command (a line ending
  in ``\\`` goes on on the next one), run in the page's working directory; it must exit 0.
  A plain ``tensegrity ...`` line runs through ``tensegrity_ros.cli.main`` (what the
  ``tensegrity`` script runs) in the test's process, any other line in bash with the venv's
  ``tensegrity`` on the PATH. The lines after a command, up to the next ``$``, are its output
  as the manual shows it: each must equal (stripped) a line of what the command printed on
  stdout or stderr, ``...`` standing for any text.
- A ```` ```python ```` block runs in the page's one namespace (fresh for each page), in the
  page's working directory.
- A block right after ``<!-- file: NAME -->`` (a YAML scene, a structure, a CSV) is written
  to ``NAME`` in the page's working directory before the page's examples run.
- A console, python or bash block right after ``<!-- not run: REASON -->`` is not run (a
  live robot, a running suite, a long run); the reason is required, and a ``tests/...`` path
  it names must exist. A ```` ```bash ````
  block is a listing of commands and must carry that marker.

Each page gets one temporary working directory, where ``bags/`` is the project's sample bags
(so examples name them as from the project's folder: read them, never write there); its
blocks run in order (a block selected alone runs the page's earlier ones first)."""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").glob("*.md"))
#: Block languages that are examples to run; every other language is data or a listing.
RUNNABLE = frozenset({"console", "python"})
MARKER = re.compile(r"<!--\s*(not run|file):\s*(.*?)\s*-->")
#: Wall-time guard against a hanging example, s (a failure, never a timing claim).
HANG_GUARD_S = 300.0


@dataclass(frozen=True)
class Block:
    """One fenced block of a page: its language, text, first line (1-based, the fence's)
    and the marker of the line before it (``("not run", reason)``, ``("file", name)``)."""

    page: Path
    line: int
    language: str
    text: str
    marker: tuple[str, str] | None

    @property
    def name(self) -> str:
        return f"{self.page.name}:{self.line}"

    @property
    def runs(self) -> bool:
        return self.language in RUNNABLE and self.marker is None


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of a Markdown page, in order."""
    lines = page.read_text().splitlines()
    found, i = [], 0
    while i < len(lines):
        if lines[i].startswith("```"):
            end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
            before = next((lines[j] for j in range(i - 1, -1, -1) if lines[j].strip()), "")
            marker = MARKER.fullmatch(before.strip())
            found.append(Block(page, i + 1, lines[i][3:].strip(), "\n".join(lines[i + 1:end]) + "\n",
                               (marker[1], marker[2]) if marker else None))
            i = end
        i += 1
    return found


@dataclass(frozen=True)
class Command:
    """A ``$`` command of a console block and the output lines the manual shows for it."""

    line: str
    shown: tuple[str, ...]


def commands(text: str) -> list[Command]:
    """The commands of a console block with their shown output."""
    found: list[Command] = []
    pending = ""
    for raw in text.splitlines():
        if pending:
            pending += "\n" + raw
        elif raw.startswith("$ "):
            pending = raw[2:]
        elif found and raw.strip():
            found[-1] = Command(found[-1].line, (*found[-1].shown, raw.strip()))
            continue
        else:
            continue
        if not pending.endswith("\\"):
            found.append(Command(pending, ()))
            pending = ""
    return found


def shown_line_pattern(shown: str) -> re.Pattern[str]:
    """A shown output line as a pattern of a whole (stripped) line, ``...`` any text."""
    return re.compile(".*".join(re.escape(part) for part in shown.split("...")))


def test_the_console_parser():
    text = ("$ tensegrity fk 0.7 0.7   # D\nforward kinematics ...\n  D     = (1.4, ...) m\n\n"
            "$ tensegrity simulate x \\\n    --duration 1\n")
    found = commands(text)
    assert [c.line for c in found] == ["tensegrity fk 0.7 0.7   # D", "tensegrity simulate x \\\n    --duration 1"]
    assert found[0].shown == ("forward kinematics ...", "D     = (1.4, ...) m") and found[1].shown == ()
    assert shown_line_pattern("D     = (1.4, ...) m").fullmatch("D     = (1.4, 0.7141428429) m")
    assert not shown_line_pattern("rho1 = 0.7 m").fullmatch("rho1 = 0.75 m")


def test_the_block_parser(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("# P\n<!-- file: a.yaml -->\n```yaml\nx: 1\n```\n\n<!-- not run: needs a robot -->\n\n"
                    "```console\n$ tensegrity up\n```\n```python\nprint(1)\n```\n")
    found = blocks(page)
    assert [(b.line, b.language, b.marker, b.runs) for b in found] == [
        (3, "yaml", ("file", "a.yaml"), False), (9, "console", ("not run", "needs a robot"), False),
        (12, "python", None, True)]
    assert found[0].text == "x: 1\n"


@dataclass
class PageRun:
    """A page's working directory and Python namespace, and how far its blocks have run."""

    directory: Path
    namespace: dict[str, object] = field(default_factory=dict)
    done: int = 0
    failed: str = ""


_RUNS: dict[Path, PageRun] = {}


#: A command the ``tensegrity`` entry point runs in this process: no shell syntax after it.
IN_PROCESS = re.compile(r"tensegrity(?: [^|&;<>()$`\\'\"*?\n]*)?")


def run_command(line: str, directory: Path) -> tuple[int, str]:
    """Run a console line in ``directory``: its exit status and what it printed. A plain
    ``tensegrity ...`` line runs through :func:`tensegrity_ros.cli.main`, what the installed
    ``tensegrity`` script runs, in this process (the imports are paid once, not per example:
    a fresh interpreter's start-up costs 1-2 s of a 2-core machine's time per command); any
    other line runs in bash, with the venv's ``tensegrity`` on the PATH."""
    flat = re.sub(r"\\\n\s*", " ", line)                 # continuation lines joined
    # a comment's text is not shell syntax: before it, the command has no quote to hide a ``#``
    command = flat.split(" #", 1)[0].rstrip()
    if IN_PROCESS.fullmatch(command):
        from tensegrity_ros.cli import main

        out = io.StringIO()
        with contextlib.chdir(directory), contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            try:
                code = main(shlex.split(command)[1:])
            except SystemExit as stop:                    # argparse's usage errors
                code = stop.code if isinstance(stop.code, int) else 1
        return code, out.getvalue()
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    done = subprocess.run(["bash", "-c", line], cwd=directory, env=env, capture_output=True, text=True,
                          timeout=HANG_GUARD_S)
    return done.returncode, done.stdout + "\n" + done.stderr


def run_console(block: Block, directory: Path) -> None:
    for command in commands(block.text):
        code, output = run_command(command.line, directory)
        printed = [line.strip() for line in re.split(r"[\r\n]", output)]
        assert code == 0, f"{block.name}: `{command.line}` exited {code}:\n{output[-3000:]}"
        missing = [shown for shown in command.shown
                   if not any(shown_line_pattern(shown).fullmatch(line) for line in printed)]
        assert not missing, (f"{block.name}: `{command.line}` did not print {missing}; it printed:\n"
                             + "\n".join(printed)[-3000:])


def test_a_console_block_fails_on_a_wrong_output_or_exit_status(tmp_path):
    page = tmp_path / "p.md"
    right = "$ tensegrity fk 0.7 0.7\nforward kinematics ...\nrho1 = 0.7 m, rho2 = 0.7 m\n"
    run_console(Block(page, 1, "console", right, None), tmp_path)
    for wrong in ("$ tensegrity fk 0.7 0.7\nrho1 = 0.8 m, rho2 = 0.7 m\n",     # not what it prints
                  "$ tensegrity fk 0.7 0.7 | head -1\nrho1 = 0.7 m, rho2 = 0.7 m\n",   # in bash: not printed
                  "$ tensegrity fk 5 5\n"):                                      # exits 2
        with pytest.raises(AssertionError):
            run_console(Block(page, 1, "console", wrong, None), tmp_path)


def run_block(block: Block, run: PageRun) -> None:
    if not block.runs:
        return
    if block.language == "console":
        run_console(block, run.directory)
        return
    with contextlib.chdir(run.directory), contextlib.redirect_stdout(io.StringIO()):
        exec(compile(block.text, f"{block.page}:{block.line}", "exec"), run.namespace)


def run_page_through(page: Path, index: int, directory_factory: pytest.TempPathFactory) -> None:
    """Run the page's blocks up to and including ``index`` (those not run yet)."""
    page_blocks = blocks(page)
    if page not in _RUNS:
        _RUNS[page] = PageRun(directory_factory.mktemp(page.stem))
        (_RUNS[page].directory / "bags").symlink_to(ROOT / "bags", target_is_directory=True)
        for block in page_blocks:
            if block.marker and block.marker[0] == "file":
                (_RUNS[page].directory / block.marker[1]).write_text(block.text)
    run = _RUNS[page]
    while run.done <= index:
        block = page_blocks[run.done]
        if run.failed:
            pytest.fail(f"{block.name} follows {run.failed}, which failed")
        run.done += 1
        try:
            run_block(block, run)
        except BaseException:
            run.failed = block.name
            raise


EXAMPLES = [pytest.param(page, index, id=block.name)
            for page in PAGES for index, block in enumerate(blocks(page)) if block.runs]


@pytest.mark.timeout(HANG_GUARD_S)         # an example run in this process that hangs fails
@pytest.mark.parametrize(("page", "index"), EXAMPLES)
def test_the_example_runs(page: Path, index: int, tmp_path_factory: pytest.TempPathFactory):
    run_page_through(page, index, tmp_path_factory)


def test_every_example_block_runs_or_says_why_not():
    bad = []
    for page in PAGES:
        for block in blocks(page):
            if block.marker and not block.marker[1]:
                bad.append(f"{block.name}: a marker without its {'reason' if block.marker[0] == 'not run' else 'file name'}")
            elif block.language == "bash" and (not block.marker or block.marker[0] != "not run"):
                bad.append(f"{block.name}: a bash block is not run: make it a console block or say why not")
            elif block.language == "console" and not commands(block.text):
                bad.append(f"{block.name}: a console block without a `$ ` command")
            elif block.marker and block.marker[0] == "file" and block.language in RUNNABLE | {"bash"}:
                bad.append(f"{block.name}: a file marker on a {block.language} block")
            elif block.marker:
                bad += [f"{block.name}: the reason names {path}, which does not exist"
                        for path in re.findall(r"tests/[\w/]+(?:\.py)?", block.marker[1])
                        if not (ROOT / path).exists()]
    assert not bad, "\n".join(bad)
    assert EXAMPLES, "no example found to run"
