"""`python -m armlab record OUT.bag` (armlab.hardware.record) against a fake pyrealsense2 that logs the calls."""

from __future__ import annotations

import sys
from types import SimpleNamespace

import pytest

from armlab.hardware import record


@pytest.fixture
def fake_rs(monkeypatch):
    log = []

    class config:
        def enable_device(self, serial):
            log.append(("enable_device", serial))

        def enable_stream(self, *args):
            log.append(("enable_stream", *args))

        def enable_record_to_file(self, path):
            log.append(("enable_record_to_file", path))

    class pipeline:
        def start(self, cfg):
            log.append(("start",))

        def wait_for_frames(self, timeout_ms):
            log.append(("wait_for_frames",))

        def stop(self):
            log.append(("stop",))

    rs = SimpleNamespace(config=config, pipeline=pipeline, stream=SimpleNamespace(color="color", depth="depth"),
                         format=SimpleNamespace(bgr8="bgr8", z16="z16"))
    monkeypatch.setitem(sys.modules, "pyrealsense2", rs)
    return log


def test_record_writes_the_live_streams_to_a_bag(fake_rs, tmp_path, capsys):
    out = tmp_path / "session.bag"
    ticks = iter(range(100))
    n = record.record(out, seconds=3, serial="f02", warmup_frames=2, clock=lambda: next(ticks))
    assert n == 2                                   # clock reads 1 and 2 before the end at 0 + 3 s
    assert fake_rs[:4] == [("enable_device", "f02"), ("enable_stream", "color", 1280, 720, "bgr8", 30),
                           ("enable_stream", "depth", 1024, 768, "z16", 30), ("enable_record_to_file", str(out))]
    assert [c[0] for c in fake_rs[4:]] == ["start"] + ["wait_for_frames"] * 4 + ["stop"]


def test_record_refuses_to_overwrite_and_other_names(fake_rs, tmp_path, capsys):
    out = tmp_path / "old.bag"
    out.write_bytes(b"x")
    assert record.main([str(out), "--seconds", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("armlab record: error: ") and "--overwrite" in err and err.count("\n") == 1, err
    with pytest.raises(ValueError, match=".bag"):
        record.record(tmp_path / "x.mp4")
    assert fake_rs == []
