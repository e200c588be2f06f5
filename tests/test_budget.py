"""The budget table of ``sim --profile`` and ``bench sim`` (issue 42)."""

from orchestrator.budget import budget_rows, format_budget


def _stage(total_s: float, count: int) -> dict[str, float]:
    return {"total_s": total_s, "count": count, "mean_ms": 0.0, "p99_ms": 0.0, "max_ms": 0.0}


def test_rows_are_ms_per_simulated_second_and_add_up_to_the_wall_time() -> None:
    stages = {"simulator": _stage(1.0, 1000), "sensors": _stage(0.5, 1000),
              "health": _stage(0.5, 1000), "planner": _stage(2.0, 100),
              "outputs": _stage(0.25, 1000), "truth_out": _stage(0.25, 100),
              "tick": _stage(3.5, 1000)}
    rows = {row["stage"]: row for row in budget_rows(stages, sim_time_s=10.0, wall_time_s=5.0)}
    assert rows["simulator"]["ms_per_s"] == 100.0
    assert rows["sensors"]["ms_per_s"] == 100.0  # decoding and health together
    assert rows["planner"]["mean_ms"] == 20.0
    assert rows["outputs"]["ms_per_s"] == 50.0
    assert "mapper" not in rows  # a stage that never ran is left out
    assert rows["other"]["ms_per_s"] == 50.0  # 5 s of wall less 4.5 s in the stages
    assert rows["total"]["ms_per_s"] == 500.0
    text = format_budget(list(rows.values()), 10.0, 5.0)
    assert "real-time factor 2.00" in text
