"""The hidden checks of the open tasks (OPEN_TASKS: an event strategy, the grasp and release plan, teach and repeat,
the tuned segmentation; each runs the simulator at length, so they run apart from test_hidden_checks.py, on a worker
of their own): the reference passes them, plausible wrong answers fail them (tests/course/wrong_answers.py)."""

from __future__ import annotations

from wrong_answers import OPEN_TASKS, check_wrong_answers


def test_open_tasks_hidden_checks_pass_the_reference_and_fail_wrong_answers():
    check_wrong_answers(list(OPEN_TASKS))
