"""The `companion ...` command lines of docs/real-vehicle.md parse as written (issue 13: its
`companion run ... -v` did not), and their --goal forms are valid goals."""
import re
import shlex
from pathlib import Path

import pytest

from companion.__main__ import build_parser
from companion.cli.run import parse_goal

DOCS = [Path(__file__).resolve().parents[2] / "docs" / page
        for page in ("real-vehicle.md", "doctor.md")]


def documented_commands() -> list[str]:
    """`companion ...` lines in fenced code blocks, and inline code spans with options."""
    text = "\n".join(doc.read_text() for doc in DOCS)
    blocks = re.findall(r"^```[a-z]*\n(.*?)^```", text, flags=re.MULTILINE | re.DOTALL)
    lines = [line.strip() for block in blocks for line in block.splitlines()
             if line.strip().startswith("companion ")
             and not line.split()[1].endswith(":")]      # a command's output ("companion doctor: ...")
    inline = [c for c in re.findall(r"`(companion [^`]+)`", text) if " --" in c]
    return sorted(set(lines + inline))


def test_the_page_has_command_lines_to_check():
    assert any(c.startswith("companion -v run --connect") for c in documented_commands())
    assert any(c.startswith("companion doctor --connect") for c in documented_commands())


@pytest.mark.parametrize("line", documented_commands())
def test_documented_command_parses(line):
    argv = shlex.split(line)[1:]
    args = build_parser().parse_args(argv)
    if getattr(args, "goal", None):
        parse_goal(args.goal)


def test_the_old_placement_of_v_is_refused():
    with pytest.raises(SystemExit):
        build_parser().parse_args(["run", "--connect", "udpin:127.0.0.1:14560", "-v"])
