"""Source composition: spec strings to worker configs, and replay of files through a worker."""

from __future__ import annotations

import time

import numpy as np
import pytest

from mimucap.acquisition.replay import ReplaySourceConfig
from mimucap.acquisition.simulated import SimulatedSourceConfig
from mimucap.acquisition.supervisor import Supervisor
from mimucap.acquisition.udp import UdpSourceConfig
from mimucap.core.samples import SensorSamples
from mimucap.io.session import Session, write_session
from mimucap.session.sources import SourceOptions, load_replay, parse_sensor_ids, source_configs


def collect(configs, timeout_s=30.0):
    blocks = []
    with Supervisor(configs) as supervisor:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and not supervisor.all_finished():
            blocks.extend(supervisor.poll(0.05))
        blocks.extend(supervisor.poll(0.05))
        status = supervisor.sources()
    return blocks, status


def test_specs_map_to_configs_with_session_options():
    options = SourceOptions(sensor_ids=(1, 2), allowed_addresses=("127.0.0.1",))
    (udp,) = source_configs("udp:0.0.0.0:5600", options)
    assert isinstance(udp, UdpSourceConfig) and udp.port == 5600 and udp.intake.sensor_ids == (1, 2)
    assert udp.allowed_addresses == ("127.0.0.1",)
    (sim,) = source_configs("simulated:walk", SourceOptions(sensor_count=15))
    assert isinstance(sim, SimulatedSourceConfig) and sim.sensor_segments()["S11"] == "head"
    with pytest.raises(ValueError, match="scenario"):
        source_configs("simulated:moonwalk")
    with pytest.raises(ValueError, match="does not exist"):
        source_configs("replay:/nonexistent/file.h5")
    assert parse_sensor_ids("1-3, 7") == (1, 2, 3, 7)
    with pytest.raises(ValueError, match="1-4,7"):
        parse_sensor_ids("one")


def test_a_session_file_replays_sample_for_sample(tmp_path):
    t = np.arange(300) / 100.0
    rng = np.random.default_rng(0)
    streams = {sid: SensorSamples(sensor_id=sid, t_s=t, seq=np.arange(300), acc=rng.normal(size=(300, 3)),
                                 gyr=rng.normal(size=(300, 3)), battery_pct=np.full(300, 50.0))
               for sid in ("A", "B")}
    holey = SensorSamples(sensor_id="C", t_s=t[:10], seq=np.arange(10), gyr=np.ones((10, 3)))
    holey.gyr[3] = np.nan                                      # e.g. a channel missing for a while
    path = write_session(tmp_path / "in.h5", Session(metadata={"source": "test"},
                                                     sensors={**streams, "C": holey}))
    loaded = load_replay(path)
    assert loaded.skipped_rows == {"A": 0, "B": 0, "C": 1}
    assert 3 not in next(s for s in loaded.streams if s.sensor_id == "C").seq
    (config,) = source_configs(f"replay:{path}@10")
    assert isinstance(config, ReplaySourceConfig) and config.speed == 10.0
    blocks, status = collect([config])
    assert status["replay"].state == "finished"
    for sid, stream in streams.items():
        mine = [b for b in blocks if b.sensor_id == sid]
        np.testing.assert_array_equal(np.concatenate([b.seq for b in mine]), stream.seq)
        np.testing.assert_array_equal(np.concatenate([b.acc for b in mine]), stream.acc)
        np.testing.assert_array_equal(np.concatenate([b.battery_pct for b in mine]), 50.0)
        host = np.concatenate([b.t_s for b in mine])
        np.testing.assert_allclose(np.diff(host), 0.01 / 10.0, atol=1e-9)   # 10 × real time


@pytest.mark.data("opensense")
def test_an_xsens_export_folder_replays_every_data_row(shared_data):
    folder = shared_data / "body" / "opensense_example" / "IMUData"
    loaded = load_replay(folder)
    # independent count: data rows are the lines after the header that start with a digit
    for stream in loaded.streams:
        (path,) = folder.glob(f"*_{stream.sensor_id}.txt")
        rows = [line for line in path.read_text().splitlines() if line[:1].isdigit()]
        assert len(stream.t_s) + loaded.skipped_rows[stream.sensor_id] == len(rows)
        assert stream.acc is not None and np.all(np.isfinite(stream.acc))
        # a standing subject's accelerometers read about 1 g at the start
        assert np.linalg.norm(stream.acc[0]) == pytest.approx(9.81, abs=0.6)
    assert len(loaded.streams) == 8
    short = tuple(type(s)(sensor_id=s.sensor_id, t_s=s.t_s[:200], seq=s.seq[:200], acc=s.acc[:200],
                          q_world_from_sensor=s.q_world_from_sensor[:200]) for s in loaded.streams)
    blocks, status = collect([ReplaySourceConfig(streams=short, speed=8.0)])
    assert sum(len(b) for b in blocks) == 8 * 200


def test_a_replayed_session_keeps_the_sensor_placement_stored_in_it(tmp_path):
    from mimucap.session.feeds import SupervisorFeed
    from mimucap.session.live import LiveSession
    from mimucap.session.sources import sensor_segments

    t = np.arange(50) / 100.0
    worn = {"A": "thigh_r", "B": "pelvis"}
    sensors = {sid: SensorSamples(sensor_id=sid, t_s=t, seq=np.arange(50), gyr=np.zeros((50, 3)), segment=segment)
               for sid, segment in worn.items()}
    sensors["C"] = SensorSamples(sensor_id="C", t_s=t, seq=np.arange(50), gyr=np.zeros((50, 3)))  # worn nowhere
    path = write_session(tmp_path / "placed.h5", Session(metadata={"source": "test"}, sensors=sensors))
    assert load_replay(path).segments == worn
    assert sensor_segments(source_configs(f"replay:{path}")) == worn
    live = LiveSession(SupervisorFeed(f"replay:{path}"))  # not started: no worker runs
    assert live.sensor_segments == worn


def test_a_replayed_session_is_the_devices_it_recorded(tmp_path):
    from mimucap.core.device_identity import SensorDevice
    from mimucap.io.session import DEVICE_NOT_RECORDED

    t = np.arange(50) / 100.0
    sensors = {sid: SensorSamples(sensor_id=sid, t_s=t, seq=np.arange(50), gyr=np.zeros((50, 3))) for sid in "AB"}
    metadata = {"source": "test", "devices": {"A": {"device_id": "mac:A1B2C3D4E5F6"}}}
    path = write_session(tmp_path / "devices.h5", Session(metadata=metadata, sensors=sensors))
    config, = source_configs(f"replay:{path}")
    assert dict(config.devices) == {"A": SensorDevice("mac:A1B2C3D4E5F6"), "B": SensorDevice(None, DEVICE_NOT_RECORDED)}
    blocks, status = collect([config])
    assert status["replay"].devices == dict(config.devices)     # reported as the source's


def test_refusals_of_no_known_sensor_are_the_sources_less_the_sensors():
    from types import SimpleNamespace

    from mimucap.acquisition.stats import SensorStats
    from mimucap.session.feeds import SupervisorFeed

    feed = SupervisorFeed.__new__(SupervisorFeed)  # no worker: only the bookkeeping is tested
    status = SimpleNamespace(rejections={"stale_sequence": 5, "unknown_address": 340, "bad_checksum": 2},
                             unknown_sensors={"address 10.0.0.9": 340})
    stats = {"1": SensorStats("1", "udp", 10, 0, 100.0, 0.0, 0.0, 0.0, {"stale_sequence": 5}),
             "2": SensorStats("2", "udp", 10, 0, 100.0, 0.0, 0.0, 0.0, {"bad_checksum": 1})}
    feed.supervisor = SimpleNamespace(sources=lambda: {"udp": status}, stats=lambda: stats)
    assert feed.refused_without_sensor() == ({"unknown_address": 340, "bad_checksum": 1}, {"address 10.0.0.9": 340})
