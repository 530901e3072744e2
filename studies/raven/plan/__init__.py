"""Certified FMT* planning for the Raven-II arm (the Raven-II paper, §2.3): OMPL's FMT* plans in the
arm's joint space, and every returned path carries a certificate of rigorous interval bounds
that `certiloop check-path` re-checks independently.

    kinematics.py  closed-form wrist and tip positions (numpy, vectorised)
    intervals.py   outward-rounded interval arithmetic over numpy arrays
    scenes.py      planning scenes (raven.frs_box): joint box, start, goal, planes, block
    certify.py     proves joint-space segments clear by interval bisection (the planner's motion check)
    planner.py     OMPL FMT* glue (ompl imported lazily; extra certiloop[plan])
    check.py       the independent re-check of a certificate (mpmath intervals, DH chain)
    track.py       tracking a planned path with the virtual fixture
"""
