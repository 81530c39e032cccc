"""The course around the armlab engine: the exercise registry and its markers, the student release, the rubric and
the grader. It imports the engine (`armlab`); the engine imports nothing of it.

    armlab_course.exercises   the one declaration per exercise, the solution markers, the release builder, the rubric
    armlab_course.grading     the instructor's grader (python -m armlab grade), its sandbox and the Gradescope bundle
"""
