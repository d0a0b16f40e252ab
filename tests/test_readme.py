"""The README is a page a user reads in five minutes, and every command it shows exists: each
`companion`, `sitl-stub` and benchmark command line in it is run with --help, and every option it
shows must be one that command's help lists."""
from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"


def shown_commands(text: str) -> list[str]:
    """Command lines in indented or fenced blocks and in inline code spans; a chain split at &&."""
    blocks = re.findall(r"^```[a-z]*\n(.*?)^```", text, flags=re.MULTILINE | re.DOTALL)
    lines = [ln.strip() for b in blocks for ln in b.splitlines()]
    lines += [ln.strip() for ln in text.splitlines() if ln.startswith("    ") and ln.strip()]
    lines += re.findall(r"`([^`\n]+)`", text)
    found = []
    for line in lines:
        for part in line.split("&&"):
            part = part.strip()
            if re.match(r"(\.venv/bin/)?(companion|sitl-stub) |python3? (-m benchmarks\.|benchmarks/)", part):
                found.append(part)
    return sorted(set(found))


def help_argv(line: str) -> tuple[list[str], list[str]]:
    """(argv that prints the command's help, the options the line shows)."""
    words = shlex.split(line)
    if words[0].endswith("companion"):
        sub = next(w for w in words[1:] if not w.startswith("-"))
        argv = [sys.executable, "-m", "companion", sub, "--help"]
    elif words[0] == "sitl-stub":
        argv = [sys.executable, "-m", "sitl_stub", "--help"]
    elif words[1] == "-m":
        argv = [sys.executable, "-m", words[2], "--help"]
    else:
        argv = [sys.executable, words[1], "--help"]
    options = [w.split("=")[0] for w in words if re.match(r"--[a-z]", w)]
    return argv, options


def test_the_readme_fits_a_few_screens_with_both_commands_first():
    lines = README.read_text().splitlines()
    assert len(lines) <= 250
    first = "\n".join(lines[:30])
    assert "pip install . && .venv/bin/companion demo --scenario config/scenarios/paper.yaml" in first
    assert "pip install '.[test]' && .venv/bin/python -m pytest" in first


def test_the_readme_shows_commands_to_check():
    commands = shown_commands(README.read_text())
    assert any(c.startswith("companion doctor") for c in commands)
    assert len(commands) >= 10


@pytest.mark.parametrize("line", shown_commands(README.read_text()))
def test_every_command_the_readme_shows_exists_with_its_options(line):
    argv, options = help_argv(line)
    done = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, f"{' '.join(argv)}:\n{done.stderr[-2000:]}"
    missing = [o for o in options if o not in done.stdout]
    assert not missing, f"{line}: {missing} not in its --help"


def test_the_check_catches_an_option_that_does_not_exist():
    argv, options = help_argv("companion simulate --no-such-option 3")
    done = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=120)
    assert "--no-such-option" in options and "--no-such-option" not in done.stdout
