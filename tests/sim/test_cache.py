"""The per-process cache keeps what a next run reuses and nothing else: a bench worker's new draws (another
reference, another plant) reuse one tracking controller, retargeted, with traces bit for bit those of a
fresh build, and the cache holds one plant and one controller per method however many draws it has seen."""

from __future__ import annotations

import numpy as np

from ftc_mj.config import load_config
from ftc_mj.sim import cache
from ftc_mj.sim.run import execute

DRAWS = ({"reference.kind": "circle", "reference.radius": 3.0, "plant.tyre_friction": 0.9},
         {"reference.kind": "line", "reference.speed": 0.4, "plant.tyre_friction": 0.7},
         {"reference.kind": "figure8", "reference.radius": 2.5, "plant.tyre_friction": 0.8})
"""Three 'draws' of scenario 2 (1.5 s each): other paths, speeds and tyre frictions."""


def _trace(overrides: dict) -> dict[str, np.ndarray]:
    return execute(load_config("scenario2", {"duration": 1.5, **overrides})).result.trace


def test_new_draws_reuse_one_retargeted_controller_bitwise() -> None:
    cache.clear()
    reused = []
    for i, draw in enumerate(DRAWS):
        hits = cache.stats["controller_hits"]
        reused.append(_trace(draw))
        assert cache.stats["controller_hits"] == hits + (i > 0)  # the first draw builds, the others reuse
        assert len(cache._controllers) == 1 and len(cache._plants) == 1
    for draw, trace in zip(DRAWS, reused, strict=True):
        cache.clear()
        fresh = _trace(draw)
        assert list(fresh) == list(trace)
        for col in fresh:
            if col != "solve_time_ms":  # wall clock
                np.testing.assert_array_equal(fresh[col], trace[col], err_msg=col)
    # the draws do track other paths
    assert not np.array_equal(reused[0]["cross_track_error"], reused[1]["cross_track_error"])
