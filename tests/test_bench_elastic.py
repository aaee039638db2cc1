"""The elastic-body bench section: structure and round-off (never timings)."""

import numpy as np

from emorbit.bench import elastic as bench_elastic


def test_tiny_bench_section():
    """Two beams of 2 and 7 cells (6 tetrahedra per cube, 3 x 3 cubes per cell). Full Newton
    factorises once per iteration; measured 2 iterations per step and energy errors 3.9e-16
    and 2.0e-16 (limit 10x the larger)."""
    section = bench_elastic.run(config="tiny")
    assert section["name"] == "elastic" and len(section["rows"]) == 2
    for row in section["rows"]:
        n = row["elements_along"]
        assert row["dof"] == 48 * (n + 1)
        assert row["tetrahedra"] == 54 * n
        assert np.isfinite(row["cpu_s_per_step"]), row
        assert 1.0 <= row["newton_iterations"] <= 3.0, row
        assert row["newton"] != "full" or row["factorizations_per_step"] == row["newton_iterations"], row
        assert row["energy_error"] < 4e-15, row
    assert "ms/step" in bench_elastic.table(section)
