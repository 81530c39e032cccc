"""The damped least squares IK that benchmarks/kinematics.py compares the closed form with
(benchmarks/scenarios/dls_ik.py: kept out of the package, whose release must not print exercise ik.numerical's
answer): it converges to the closed form's answer from nearby seeds, says why when it does not, and refuses bad
input naming the argument."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from armlab import kinematics as k
from armlab.robot import rx200

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
if not BENCHMARKS.is_dir():
    pytest.skip("no benchmarks here (a student release)", allow_module_level=True)
sys.path.insert(0, str(BENCHMARKS))
from scenarios.dls_ik import ik_numerical  # noqa: E402

ROBOT = rx200()


def test_converges_to_the_closed_form_from_nearby_seeds():
    rng = np.random.default_rng(11)
    for _ in range(40):
        p = np.array([rng.uniform(-300, 300), rng.uniform(100, 400), rng.uniform(10, 200)])
        pitch = min(k.steepest_pitch(p) - 0.05, 1.2)     # off the full stretch (singular: joint angles ill-posed)
        exact = k.ik(p, pitch, 0.2)[0]
        seed = np.clip(exact + rng.uniform(-0.15, 0.15, 5), ROBOT.lower, ROBOT.upper)
        res = ik_numerical(p, pitch, 0.2, q0=seed)
        assert res.success and res.position_error_mm < 1e-6, (p, pitch, res)
        np.testing.assert_allclose(res.q, exact, atol=1e-6)          # the same branch
        np.testing.assert_allclose(k.fk(res.q)[:3, :3], k.fk(exact)[:3, :3], atol=1e-8)


def test_answers_with_q_success_and_reason():
    good = ik_numerical([0.0, 250.0, 19.0], np.pi / 2)
    assert isinstance(good, k.IKResult) and good.success and good.reason == "" and good.q.shape == (5,)
    bad = ik_numerical([0.0, 700.0, 19.0], np.pi / 2, max_iterations=30)
    assert not bad.success and bad.reason.startswith("did not converge in 30 iterations") and "mm from" in bad.reason


@pytest.mark.parametrize("kwargs, message", [
    ({"pitch": np.nan}, "pitch contains NaN"),
    ({"q0": [0, 0, 3.0, 0, 0]}, "elbow = 3.000000 rad"),
    ({"damping": 0}, "damping must be a positive number"),
    ({"position": [0, 300]}, "position must have shape"),
])
def test_bad_input_raises_naming_the_argument(kwargs, message):
    args = {"position": [0, 300, 30], "pitch": 1.0} | kwargs
    with pytest.raises(ValueError, match=message):
        ik_numerical(args.pop("position"), args.pop("pitch"), **args)
