"""The package imports and the demo entry point runs."""

from armlab.__main__ import main


def test_demo_runs(capsys, tmp_path):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    assert "RX200" in capsys.readouterr().out
