"""Hidden checks of exercise detect.segment: the student's segmentation with their own
tuned boxes on held-out simulator frames, scored against the truth (an open task: outcome only)
(armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _segment_scenes(rng):
    # held-out simulator frames of other seeds (scenes with stacks and distractors, the arm over the board in some)
    from armlab.sim.detection_eval import SCENES

    return [[[str(SCENES[int(k)]), int(seed), bool(arm)]] for k, seed, arm in
            zip(rng.integers(0, len(SCENES), 3), rng.integers(5000, 9000, 3), (False, True, False))]


def _judge_segment(call, scene, seed, arm_over_board):
    """The held-out white-balanced frame made here; the child's label image from the student's segment_colours with
    their own tuned_hsv_ranges(), scored here against the simulator's truth: [at least 95 % of the visible faces
    right, under 0.5 % of the board labelled] (1.0 / 0.0)."""
    from armlab.sim.detection_eval import balanced_frame, score_segmentation, sim_case

    case = sim_case(str(scene), int(seed), arm_over_board=bool(arm_over_board))
    rgb, board = balanced_frame(case)
    score = score_segmentation(case, np.asarray(call(rgb)), board)
    return [float(score.face_accuracy >= 0.95), float(score.board_labelled < 0.005)]


SPECS = (HiddenSpec("segment_colours", _segment_scenes, atol=0, adapter="_call_segment", judge=_judge_segment,
                    prelude="definitions", criteria=("at least 95 % of the visible faces labelled right",
                                                     "under 0.5 % of the bare board labelled")),)
FORBIDDEN = ("ColorModel", "segment_by_colour_model", "default_color_model", "hsv_table_classify")
