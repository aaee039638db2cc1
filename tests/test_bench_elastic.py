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


def test_tiny_precision_rows():
    """The coupled structure's tiny work-precision rows: em order 2 and tfe order 4 at 20 ms
    over 0.2 s against tfe order 6 at 5 ms. At the same step tfe is the more accurate (measured
    1.1e-5 m against 2.7e-4 m), both keep the energy at round-off, and neither reaches 1e-5 m,
    so the summary has no ratio."""
    p = bench_elastic.run(config="tiny")["precision"]
    em, tfe = p["points"]
    assert (em["method"], tfe["method"]) == ("em", "tfe")
    assert tfe["position_error"] < 0.2 * em["position_error"], p["points"]
    assert tfe["omega_error"] < 0.1 * em["omega_error"], p["points"]
    assert max(em["energy_error"], tfe["energy_error"]) < 1e-15
    assert all(s["em_over_tfe"] is None for s in p["summary"])
