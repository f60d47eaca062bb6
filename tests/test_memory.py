"""A running robot keeps what it built out of the garbage collector's way, and reuses big freed
blocks instead of page-faulting them in afresh (cyborg.app.tuning)."""

from __future__ import annotations

import gc
import resource

import numpy as np

from cyborg.app.tuning import freeze_built, thaw


def test_what_exists_when_the_robot_starts_is_left_out_of_collections_until_it_closes() -> None:
    built = [[index] for index in range(10_000)]  # stands for the robot: a machine, modules, a map
    freeze_built()
    try:
        assert gc.get_freeze_count() >= len(built)
    finally:
        thaw()
    assert gc.get_freeze_count() == 0


def test_a_big_array_freed_and_made_again_costs_no_fresh_pages() -> None:
    freeze_built()
    thaw()

    def faults_of_a_search() -> int:
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        arrays = [np.ones(4_000_000, dtype=np.float32) for _ in range(3)]  # a campus search: 3 x 16 MB
        del arrays
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

    faults_of_a_search()
    again = [faults_of_a_search() for _ in range(3)]
    assert max(again) < 100, again  # glibc's defaults gave back and faulted in ~600 pages each time
