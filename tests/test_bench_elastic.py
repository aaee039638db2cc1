"""The elastic-body bench section: structure and round-off (never timings)."""

from emorbit.bench import elastic as bench_elastic


def test_tiny_bench_section():
    section = bench_elastic.run(config="tiny")
    assert section["name"] == "elastic" and len(section["rows"]) == 2
    for row in section["rows"]:
        assert row["dof"] == 48 * (row["elements_along"] + 1)
        assert row["cpu_s_per_step"] > 0 and row["newton_iterations"] >= 1
        assert row["energy_error"] < 1e-13
    assert "ms/step" in bench_elastic.table(section)
