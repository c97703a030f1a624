"""Scoring helpers of the end-to-end benchmark (walker_gait.bench.endtoend)."""

from __future__ import annotations

import numpy as np

from walker_gait.bench.endtoend import IN_VIEW_LEAD_S, steps_in_view


def test_steps_in_view_need_a_second_with_the_user_in_view_before_the_heel_strike() -> None:
    assert IN_VIEW_LEAD_S == 1.0
    stamps = np.arange(0, 300) / 30.0  # 10 s at 30 fps
    present = np.ones(300, dtype=bool)
    present[:90] = False  # the user walks in at 3 s
    present[150:153] = False  # and leaves the view for 0.1 s at 5 s
    steps = np.array([0.5, 2.0, 3.5, 4.05, 5.05, 5.9, 6.2, 9.9, 10.5])
    got = steps_in_view(steps, stamps, present)
    np.testing.assert_array_equal(got, [False, False, False, True, False, False, True, True, False])
    # all in view: only the steps in the first second (no history) and after the end are out
    got = steps_in_view(np.array([0.5, 1.0, 5.0, 10.5]), stamps, np.ones(300, dtype=bool))
    np.testing.assert_array_equal(got, [False, True, True, False])
    # a shorter lead
    assert steps_in_view(np.array([3.5]), stamps, present, lead_s=0.4).tolist() == [True]
    assert steps_in_view(np.zeros(0), stamps, present).shape == (0,)


def test_rendered_present_needs_one_leg_trackable_needs_both() -> None:
    from walker_gait.bench.endtoend import Rendered

    r = Rendered(frames=[], visible_pixels=np.array([[0, 0], [500, 0], [0, 300], [250, 250], [150, 150]]), seconds=0.0)
    assert r.present(min_pixels=200).tolist() == [False, True, True, True, False]
    assert r.trackable(min_pixels=200).tolist() == [False, False, False, True, False]
