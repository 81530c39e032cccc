"""The hidden checks of the open tasks (OPEN_TASKS: an event strategy, the grasp and release plan, teach and repeat;
each runs the simulator at length, so they run apart from test_hidden_checks.py, on a worker of their own): the
reference passes them, plausible wrong answers fail them (tests/course/wrong_answers.py)."""

from __future__ import annotations

import pytest
from wrong_answers import OPEN_TASKS, check_alone, check_wrong_answers

# the design exercises (issue 35): the reference passes, the blank and both wrong answers fail. Those that are open
# tasks are held by the test of the open tasks (their blank stubs too: a blank raises at once, so that run is short);
# the station's machine on its own
DESIGN = ("events.line_up", "events.sky", "station.machine", "grab.sequence")


def test_open_tasks_hidden_checks_pass_the_reference_and_fail_wrong_answers():
    check_wrong_answers(list(OPEN_TASKS), blank=[e for e in DESIGN if e in OPEN_TASKS])


@pytest.mark.parametrize("exercise_id", [e for e in DESIGN if e not in OPEN_TASKS])
def test_a_design_exercise_passes_its_reference_and_fails_the_blank_and_each_wrong_answer(exercise_id):
    check_alone(exercise_id)
