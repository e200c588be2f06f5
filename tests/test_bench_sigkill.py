"""``bench sigkill``'s reference: the third-party modules ``sim`` imports, which a bare
interpreter imports to measure the import floor."""

from __future__ import annotations

from bench.bench_sigkill import import_floor_s, third_party_modules

OUR_PACKAGES = {"bench", "common", "controller", "main", "mapper", "orchestrator", "planner",
                "recordings", "scale", "sensors", "simulator", "visualiser"}


def test_the_floor_imports_the_libraries_the_sim_imports_and_none_of_ours() -> None:
    modules = third_party_modules()
    # mcap is not among them: sim records in a process of its own, which imports it
    for library in ("numpy", "scipy.interpolate", "scipy.spatial", "cantools",
                    "google.protobuf"):
        assert library in modules, library
    assert not {name.split(".")[0] for name in modules} & OUR_PACKAGES
    assert modules.index("numpy") < modules.index("scipy.interpolate")  # import order kept
    floor_s, failed = import_floor_s(modules)
    assert failed == 0
    assert floor_s > 0.0
