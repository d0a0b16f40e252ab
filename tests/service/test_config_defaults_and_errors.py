"""Code defaults equal the documented ones (config/companion.yaml), and every config mistake
reads `file: key: problem` (or `--goal: problem`) with exit 2 and no traceback (issue 14)."""
import dataclasses
import re
import subprocess
import sys

import pytest

from companion.config.scenario import load_scenario
from companion.config.sections import AvoidanceConfig
from companion.config.service import load_config
from companion.config.loader import parse_yaml
from companion.errors import ConfigError

SHIPPED = "config/companion.yaml"
TEXT = open(SHIPPED).read()
# Sections whose every optional key must be documented in the shipped file.
FULLY_DOCUMENTED = ("link", "streams", "commanding", "failsafe", "safety")


def documented_keys():
    """(section, key, documented default, line) for each key line of the shipped file."""
    section, out = None, []
    for line in TEXT.splitlines():
        top = re.match(r"^(\w+):", line)
        if top:
            section = top.group(1)
            continue
        key = re.match(r"^  (\w+):\s*([^#\s][^#]*?)\s*(#.*)?$", line)
        if key and section:
            code_default = re.search(r"\(code default ([^)]+)\)", key.group(3) or "")
            value = code_default.group(1) if code_default else key.group(2)
            out.append((section, key.group(1), value, line))
    return out


def optional_fields(section):
    cls = type(getattr(load_config(SHIPPED), section))
    return [f for f in dataclasses.fields(cls)
            if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING]


@pytest.mark.parametrize("section", FULLY_DOCUMENTED)
def test_every_optional_key_of_the_service_sections_is_documented(section):
    documented = {key for s, key, _, _ in documented_keys() if s == section}
    missing = [f.name for f in optional_fields(section) if f.name not in documented]
    assert not missing, f"{section}: {missing} not in {SHIPPED}"


@pytest.mark.parametrize("section, key, documented, line", documented_keys(),
                         ids=[f"{s}.{k}" for s, k, _, _ in documented_keys()])
def test_without_the_key_the_code_default_is_the_documented_one(tmp_path, section, key,
                                                                documented, line):
    cls = type(getattr(load_config(SHIPPED), section))
    field = {f.name: f for f in dataclasses.fields(cls)}[key]
    if field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
        pytest.skip("required key")
    path = tmp_path / "without.yaml"
    path.write_text(TEXT.replace(line + "\n", ""))
    expected = parse_yaml(f"v: {documented}")["v"]
    assert getattr(getattr(load_config(path), section), key) == expected, (section, key)


def test_the_default_strategy_is_union_as_documented():
    assert "strategy: union              # union (default)" in TEXT
    assert AvoidanceConfig(safety_distance_m=10.0, horizon_s=4.0, eta=1.25).strategy == "union"


# ------------------------------------------------------------------ errors
def error_for(path):
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    return message


def test_a_file_that_is_not_utf8_is_named_not_a_traceback(tmp_path):
    path = tmp_path / "latin1.yaml"
    path.write_bytes(TEXT.replace("# MAV_COMP_ID_ONBOARD_COMPUTER", "# caf\xe9").encode("latin-1"))
    assert "not UTF-8" in error_for(path)


def test_yaml_1_1_exponent_numbers_are_read_as_numbers(tmp_path):
    path = tmp_path / "exp.yaml"
    path.write_text(TEXT.replace("inbox_size: 1000", "inbox_size: 1e3")
                    .replace("max_speed_mps: 8.0", "max_speed_mps: 8e0")
                    .replace("rate_check_s: 5.0", "rate_check_s: 5E-0"))
    config = load_config(path)
    assert config.link.inbox_size == 1000 and isinstance(config.link.inbox_size, int)
    assert config.commanding.max_speed_mps == 8.0 and config.streams.rate_check_s == 5.0


def test_a_duplicate_key_is_refused_with_its_path(tmp_path):
    path = tmp_path / "dup.yaml"
    path.write_text(TEXT.replace("  inbox_size: 1000", "  inbox_size: 1000\n  inbox_size: 10"))
    assert ": link.inbox_size: duplicate key" in error_for(path)


@pytest.mark.parametrize("old, new, key", [
    ("max_speed_mps: 8.0", "max_speed_mps: 1e300", "commanding.max_speed_mps"),
    ("max_speed_mps: 8.0", "max_speed_mps: 300.0", "commanding.max_speed_mps"),
    ("heartbeat_timeout_s: 3.0", "heartbeat_timeout_s: 1.0e+30", "link.heartbeat_timeout_s"),
    ("inbox_size: 1000", "inbox_size: 1000000000000", "link.inbox_size"),
])
def test_absurd_magnitudes_are_refused_naming_the_key(tmp_path, old, new, key):
    path = tmp_path / "absurd.yaml"
    path.write_text(TEXT.replace(old, new))
    assert f": {key}: expected" in error_for(path)


def test_an_absurd_scenario_speed_is_refused(tmp_path):
    path = tmp_path / "fast.yaml"
    text = open("config/scenarios/paper.yaml").read()
    assert "speed_mps: 5.0" in text
    path.write_text(text.replace("speed_mps: 5.0", "speed_mps: 1e300", 1))
    with pytest.raises(ConfigError, match=r": vehicle.speed_mps: expected"):
        load_scenario(path)


BAD_GOALS = [
    ("nan,0", "--goal: expected finite numbers"),
    ("10,inf", "--goal: expected finite numbers"),
    ("10,0,0", "--goal: radius_m: expected a value > 0"),
    ("1e300,0", "--goal: expected metres of sane magnitude"),
    ("ten,0", "--goal: expected NORTH,EAST"),
]
BAD_CONFIGS = [
    (TEXT.encode("utf-8") + b"\n# \xff\xfe\n", "not UTF-8"),
    (TEXT.replace("  inbox_size: 1000", "  inbox_size: 1000\n  inbox_size: 10").encode(),
     "link.inbox_size: duplicate key"),
    (TEXT.replace("max_speed_mps: 8.0", "max_speed_mps: 1e300").encode(),
     "commanding.max_speed_mps: expected"),
]


@pytest.fixture(scope="module")
def refusals(tmp_path_factory):
    """`companion run` of every bad goal and bad config file below, each its own process, all
    started at once (one after the other, their interpreters' start-up was 8 s of the run):
    {case: (exit code, stderr)}, with the config files' paths."""
    work = tmp_path_factory.mktemp("refusals")
    cases = {("goal", goal): ("--goal", goal) for goal, _ in BAD_GOALS}
    paths = {}
    for i, (content, _) in enumerate(BAD_CONFIGS):
        paths[i] = work / f"site{i}.yaml"
        paths[i].write_bytes(content)
        cases[("config", i)] = ("--config", str(paths[i]), "--goal", "100,0")
    procs = {case: subprocess.Popen(
        [sys.executable, "-m", "companion", "run", "--connect", "udpin:127.0.0.1:0", *args],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        for case, args in cases.items()}
    results = {}
    try:
        for case, proc in procs.items():
            _, stderr = proc.communicate(timeout=60)
            results[case] = (proc.returncode, stderr)
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    return results, paths


@pytest.mark.parametrize("goal, problem", BAD_GOALS)
def test_bad_goals_exit_2_with_the_problem_and_no_traceback(refusals, goal, problem):
    returncode, stderr = refusals[0][("goal", goal)]
    assert returncode == 2, stderr
    assert problem in stderr and "Traceback" not in stderr


@pytest.mark.parametrize("case", range(len(BAD_CONFIGS)),
                         ids=[problem for _, problem in BAD_CONFIGS])
def test_bad_config_files_exit_2_naming_file_and_key(refusals, case):
    (returncode, stderr), path = refusals[0][("config", case)], refusals[1][case]
    problem = BAD_CONFIGS[case][1]
    assert returncode == 2, stderr
    assert f"companion: {path}: " in stderr and problem in stderr
    assert "Traceback" not in stderr
