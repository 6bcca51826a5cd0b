"""Reproduction of the paper's figures (Section IV) and our additions, with one command.

    python -m experiments figures            # full sweep: T = 40..200 s, M in {2000, 4000, 6000}
    python -m experiments figures --quick    # a tiny version (two T values, small M)

See :mod:`experiments.sweep` (the points, parallel solving, the resumable cache) and
:mod:`experiments.figures` (the panels and the check of the paper's claims).
"""
