"""The recording and view flags of launch, demo and bench conveyor, as the commands parse and build them."""

from __future__ import annotations

import pytest

from latent_planner_ros.launcher import build_suite, parse_args
from latent_planner_ros.processes.node_suite import SuiteError


def test_launch_view_adds_the_view_process_on_its_port():
    specs = {s.name: s.argv for s in build_suite(parse_args(["--nodes", "sim", "--view", "--view-port", "8123"])).specs}
    assert list(specs) == ["sim", "view"]
    assert specs["view"][-4:] == ("latent_planner_ros", "view", "--port", "8123")
    assert "view" not in {s.name for s in build_suite(parse_args(["--nodes", "sim"])).specs}


def test_launch_record_refuses_a_directory_with_files(tmp_path):
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "x.mcap").write_bytes(b"")
    with pytest.raises(SuiteError, match="not empty"):
        build_suite(parse_args(["--nodes", "sim", "--record", str(tmp_path / "old")]))
    build_suite(parse_args(["--nodes", "sim", "--record", str(tmp_path / "new")]))  # a new directory is fine


def test_demo_records_unless_told_not_to():
    from latent_planner_ros.demo import parse_args as demo_args

    assert demo_args([]).no_record is False and demo_args(["--no-record"]).no_record is True
    assert demo_args(["--view", "--view-port", "9000"]).view_port == 9000


def test_bench_conveyor_has_the_record_flag(capsys):
    from latent_planner_ros.bench.conveyor import main

    with pytest.raises(SystemExit):
        main(["--help"])
    assert "--record" in capsys.readouterr().out
