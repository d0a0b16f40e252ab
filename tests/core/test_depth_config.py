"""sensor.form depth in a scenario (companion/config/depth.py, sitl_stub/depth_config.py): the
D455 defaults, the mounts, and mistakes named by file, key and problem on both sides."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from companion.config.scenario import load_scenario
from companion.errors import ConfigError
from sitl_stub.world import ScenarioError, load_scenario as stub_scenario

REPO = Path(__file__).resolve().parents[2]
DEPTH = REPO / "config" / "scenarios" / "depth.yaml"


def test_the_depth_scenarios_load_with_a_d455_at_848x480_on_both_sides():
    for name, pitch in (("depth", 0.0), ("depth-pitched", -20.0)):
        s = load_scenario(REPO / "config" / "scenarios" / f"{name}.yaml")
        intr = s.sensor.depth.intrinsics()
        assert (intr.width_px, intr.height_px) == (848, 480)
        assert math.degrees(intr.hfov_rad) == pytest.approx(87.0)
        assert math.degrees(intr.vfov_rad) == pytest.approx(58.0)
        assert 0.3 < intr.min_depth_m < 0.4              # fx x 95 mm / 126 px
        mount = s.sensor.camera_mounts()[0]
        assert math.degrees(mount.pitch_rad) == pytest.approx(pitch)
        stub = stub_scenario(REPO / "config" / "scenarios" / f"{name}.yaml").sensor
        assert (stub.depth.fx_px, stub.depth.fy_px, stub.depth.cx_px, stub.depth.min_depth_m) \
            == pytest.approx((intr.fx_px, intr.fy_px, intr.cx_px, intr.min_depth_m), rel=1e-12)
        assert math.degrees(stub.cameras[0].pitch_rad) == pytest.approx(pitch)


def write(tmp_path, edit) -> Path:
    data = yaml.safe_load(DEPTH.read_text())
    edit(data)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("edit, key, words", [
    (lambda d: d["sensor"]["depth"].update(width_px=0), "sensor.depth.width_px", "image size"),
    (lambda d: d["sensor"]["depth"].update(fx_px=400.0), "sensor.depth.fx_px", "not both"),
    (lambda d: d["sensor"]["depth"].update(max_depth_m=80.0), "sensor.depth.max_depth_m",
     "65"),
    (lambda d: d["sensor"]["depth"].update(dropout_fraction=1.5),
     "sensor.depth.dropout_fraction", "fraction"),
    (lambda d: d["sensor"]["depth"].update(subpxiel=0.1), "sensor.depth.subpxiel", "unknown"),
    (lambda d: d["sensor"]["cameras"][0].update(pitch_deg=-120.0),
     "sensor.cameras[0].pitch_deg", "[-90, 90]"),
    (lambda d: d["sensor"]["cameras"][0].update(offset_frd_m=[0.1, 0.0]),
     "sensor.cameras[0].offset_frd_m", "forward, right, down"),
    (lambda d: d["sensor"].update(rate_hz=5.0), "sensor.rate_hz", "depth camera's rate"),
    (lambda d: d["sensor"].update(form="sectors"), "sensor.cameras", "depth form only"),
])
def test_a_mistake_names_file_key_and_problem(tmp_path, edit, key, words):
    path = write(tmp_path, edit)
    with pytest.raises(ConfigError) as exc:
        load_scenario(path)
    text = str(exc.value)
    assert text.startswith(f"{path}: {key}") and words in text, text


@pytest.mark.parametrize("edit, key", [
    (lambda d: d["sensor"]["depth"].update(width_px=0), "sensor.depth.width_px"),
    (lambda d: d["sensor"]["depth"].update(fx_px=400.0), "sensor.depth.fx_px"),
    (lambda d: d["sensor"]["depth"].update(subpxiel=0.1), "sensor.depth.subpxiel"),
    (lambda d: d["sensor"]["cameras"][0].update(pitch_deg=-120.0), "sensor.cameras[0].pitch_deg"),
    (lambda d: d["sensor"].update(rate_hz=5.0), "sensor.rate_hz"),
    (lambda d: d["sensor"].update(form="sectors"), "sensor.cameras"),
])
def test_the_stub_names_the_same_mistakes(tmp_path, edit, key):
    path = write(tmp_path, edit)
    with pytest.raises(ScenarioError) as exc:
        stub_scenario(path)
    assert str(exc.value).startswith(f"{path}: {key}:"), str(exc.value)


def test_focal_lengths_instead_of_fields_of_view(tmp_path):
    def edit(d):
        depth = d["sensor"]["depth"]
        del depth["hfov_deg"], depth["vfov_deg"]
        depth.update(width_px=640, height_px=480, fx_px=380.0, fy_px=380.0, cx_px=320.5,
                     cy_px=238.0)
    path = write(tmp_path, edit)
    intr = load_scenario(path).sensor.depth.intrinsics()
    assert (intr.fx_px, intr.cx_px, intr.cy_px) == (380.0, 320.5, 238.0)
    stub = stub_scenario(path).sensor.depth
    assert (stub.fx_px, stub.cx_px, stub.cy_px) == (380.0, 320.5, 238.0)


def test_depth_settings_without_the_depth_form_are_refused_on_both_sides(tmp_path):
    def edit(d):
        d["sensor"]["form"] = "sectors"
        del d["sensor"]["cameras"]
    path = write(tmp_path, edit)
    with pytest.raises(ConfigError, match=r"sensor\.depth: .*sensor\.form: depth"):
        load_scenario(path)
    with pytest.raises(ScenarioError, match=r"sensor\.depth: unknown key"):
        stub_scenario(path)


def test_the_stub_refuses_a_depth_stream_without_a_depth_camera():
    import subprocess
    import sys
    done = subprocess.run([sys.executable, "-m", "sitl_stub", "--scenario",
                           "config/scenarios/paper.yaml", "--tcp", "127.0.0.1:0",
                           "--depth-tcp", "127.0.0.1:0"], cwd=REPO, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2 and "needs sensor.form: depth" in done.stderr
