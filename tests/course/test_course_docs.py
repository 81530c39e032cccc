"""The course around the notebooks (docs/course/, issue 35): the time per notebook, the real-arm sessions with their
check-offs and safety briefing, the competition brief per event and level (its numbers are the scorers'), the report
template, and the instructor's walkthrough, which the student release leaves out."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from armlab.tasks.events import scoring
from armlab.tasks.events.registry import events, max_points
from armlab.tasks.experiments import LAB_LOCATIONS_MM
from armlab_course.exercises import EXERCISES
from armlab_course.exercises.registry import NOTEBOOKS
from armlab_course.exercises.release import make_student_release, released

ROOT = Path(__file__).resolve().parents[2]
COURSE = ROOT / "docs" / "course"
PAGES = ("README.md", "time-per-notebook.md", "real-arm-sessions.md", "competition.md", "report-template.md")
WALKTHROUGH = "docs/course/instructor/walkthrough.md"


def read(name: str) -> str:
    return (COURSE / name).read_text()


def test_the_course_pages_are_there_and_released_and_the_walkthrough_is_not():
    for name in PAGES:
        assert read(name).startswith("# "), name
        assert released(f"docs/course/{name}")
    assert (ROOT / WALKTHROUGH).is_file() and not released(WALKTHROUGH)
    assert not any(released(name) for name in ("tools/course-pictures", "tools/course-times",
                                               "tests/course/test_course_docs.py"))
    assert all(released(f"docs/course/img/{p.name}") for p in (COURSE / "img").glob("*.png"))


def test_the_release_leaves_the_walkthrough_out(tmp_path):
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    make_student_release(ROOT, tmp_path / "student")
    assert (tmp_path / "student/docs/course/competition.md").is_file()
    assert not (tmp_path / "student/docs/course/instructor").exists()
    assert not any("walkthrough" in p.name for p in (tmp_path / "student").rglob("*"))


def test_the_walkthrough_covers_every_exercise():
    text = (ROOT / WALKTHROUGH).read_text()
    missing = [e.id for e in EXERCISES if f"`{e.id}`" not in text]
    assert not missing, f"the walkthrough does not cover {missing}"


def test_the_time_table_has_every_notebook_with_a_measured_run_time():
    text = read("time-per-notebook.md")
    rows = {m[0]: m for m in re.findall(r"^\| (\d\d_\w+) \| (\d*) \| (\d+) \| (\d+) \| (\d+) \| (\d+) \| ([\d.]+) \|$",
                                         text, re.M)}
    assert set(rows) == set(NOTEBOOKS), f"rows for {sorted(rows)}"
    assert all(int(r[2]) > 0 for r in rows.values())


def test_the_sessions_have_the_check_offs_the_issue_asks_for():
    text = read("real-arm-sessions.md")
    assert "## Safety briefing" in text and "emergency_stop()" in text and "set_torque(False)" in text
    assert "grid residual" in text.lower()
    for x, y in LAB_LOCATIONS_MM.astype(int):
        assert f"({x}, {y})" in text.replace("−", "-"), f"the reach test's location ({x}, {y}) is not in the plan"
    for item in ("click-to-grab", "sort 'n stack", "line 'em up", "to the sky"):
        assert item in text.lower(), item
    sheet = text.split("## Check-off sheet")[1]
    assert len(re.findall(r"^\| \d[a-d]? \|", sheet, re.M)) >= 12


def section(text: str, title: str) -> str:
    return text.split(f"## {title}")[1].split("\n## ")[0]


@pytest.mark.parametrize("spec", list(events().values()), ids=lambda s: s.name)
def test_the_competition_brief_states_each_events_rules_as_scored(spec):
    """Each event has its section with its time limit, every level's most points as the scorer counts them on the
    level's seed-0 board, and a start and an end picture for each level."""
    from armlab.tasks.events import event_station

    text = read("competition.md")
    mine = section(text, f"{spec.title[0].upper()}{spec.title[1:]} ({spec.time_limit_s:.0f} s")
    for level in spec.levels:
        for when in ("start", "end"):
            picture = f"img/{spec.name}_L{level}_{when}.png"
            assert picture in mine and (COURSE / picture).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", picture
        if len(spec.levels) > 1:
            station = event_station(spec.name, level, seed=0)
            most = max_points(spec.name, level, station.world.objects)
            row = re.search(rf"^\| {level} \|.*\| (\d+)(?: \(.*\))? \|$", mine, re.M)
            assert row and int(row[1]) == most, f"{spec.name} level {level}: the brief says {row and row[1]}, " \
                                                f"the scorer {most}"


def test_the_competition_brief_quotes_the_scorers_constants():
    text = read("competition.md")
    quoted = {scoring.BLOCK_POINTS: "+30 per block", scoring.NEATNESS_POINTS: "Neatness +20 per line",
              scoring.LINE_TOL_MM: "within **30 mm**", scoring.LINE_MAX_MM: "**shorter than 300 mm**",
              scoring.SKY_FIRST_POINTS: "**30 points for each of the", scoring.SKY_LATER_POINTS: "50 for each block"}
    for value, phrase in quoted.items():
        assert phrase in text and str(int(value)) in phrase, phrase
    assert f"first {scoring.SKY_FIRST} blocks" in text
    assert f"{scoring.NEAT_OFFSET_MM:.0f} mm of the line" in text and "within 10°" in text
    assert f"within {scoring.HANDOVER_RADIUS_MM:.0f} mm of it" in text
