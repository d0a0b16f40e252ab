"""A user's config holds only what differs from the shipped one: `companion run --config mine.yaml`
with one key layers it over config/companion.yaml. Unknown keys and bad values in the user's file
are still errors naming that file and the key."""
from __future__ import annotations

import subprocess
import sys

import pytest
import yaml

from companion.config.loader import layered
from companion.config.service import config_to_dict, load_config
from companion.errors import ConfigError
from tests.e2e.support import (REPO, GroundStation, companion_setpoints, read_tlog,
                               start_companion, start_stub, wait_until)

SHIPPED = REPO / "config" / "companion.yaml"


def one_key(tmp_path, text="avoidance: {safety_distance_m: 4}\n"):
    path = tmp_path / "mine.yaml"
    path.write_text(text)
    return path


def test_one_key_layers_over_the_shipped_config_and_changes_nothing_else(tmp_path):
    mine = load_config(one_key(tmp_path), over=SHIPPED)
    shipped = load_config(SHIPPED)
    assert mine.avoidance.safety_distance_m == 4.0 != shipped.avoidance.safety_distance_m
    got, want = config_to_dict(mine), config_to_dict(shipped)
    got["avoidance"].pop("safety_distance_m"), want["avoidance"].pop("safety_distance_m")
    assert got == want


def test_without_the_layer_a_one_key_file_is_incomplete(tmp_path):
    with pytest.raises(ConfigError, match="mine.yaml: .*missing"):
        load_config(one_key(tmp_path))


@pytest.mark.parametrize("text, where", [
    ("avoidance: {safety_distans_m: 4}\n", "mine.yaml: avoidance.safety_distans_m: unknown key"),
    ("avoidance: {safety_distance_m: fast}\n", "mine.yaml: avoidance.safety_distance_m: expected a number"),
    ("commanding: {cruise_speed_mps: 20}\n", "mine.yaml: commanding"),
])
def test_a_mistake_in_the_layer_names_the_users_file_and_key(tmp_path, text, where):
    with pytest.raises(ConfigError, match=where):
        load_config(one_key(tmp_path, text), over=SHIPPED)


def test_layering_merges_mappings_and_replaces_everything_else():
    base = {"a": {"x": 1, "y": [1, 2]}, "b": 3}
    assert layered(base, {"a": {"y": [5]}, "b": None}) == {"a": {"x": 1, "y": [5]}, "b": None}
    assert base == {"a": {"x": 1, "y": [1, 2]}, "b": 3}


def test_run_refuses_an_unknown_key_in_a_one_key_file(tmp_path):
    done = subprocess.run([sys.executable, "-m", "companion", "run", "--connect",
                           "udpout:127.0.0.1:9", "--goal", "180,0", "--config",
                           str(one_key(tmp_path, "avoidanse: {safety_distance_m: 4}\n"))],
                          cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "mine.yaml: avoidanse: unknown key" in done.stderr


def test_a_one_key_config_flies_with_its_value_in_the_effective_config(tmp_path):
    stub, tcp_port, udp_port = start_stub(tmp_path, "--speedup", "10", lockstep=True)
    processes = [stub]
    try:
        tlog = tmp_path / "run.tlog"
        companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", one_key(tmp_path),
                                    "--goal", "180,0", "--tlog", str(tlog), lockstep=True)
        processes.append(companion)
        gcs = GroundStation(tcp_port)
        gcs.fly_from_the_ground()
        wait_until(lambda: len(companion_setpoints(read_tlog(tlog))) >= 20, 30.0,
                   "setpoints from a companion run with a one-key config")
        gcs.close()
        effective = yaml.safe_load(tlog.with_suffix(".config.yaml").read_text())
        assert effective["avoidance"]["safety_distance_m"] == 4.0
        shipped = config_to_dict(load_config(SHIPPED))["avoidance"]
        assert {**effective["avoidance"], "safety_distance_m": None} == {
            **shipped, "safety_distance_m": None}
        assert "'safety_distance_m': 4.0" in companion.stderr()      # the logged effective config
    finally:
        for process in reversed(processes):
            if process.proc.poll() is None:
                process.stop()
