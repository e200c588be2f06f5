"""Configuration of the Main orchestrator: layer rates and run limits."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class RunConfig:
    """How Main schedules the three layers (seed 002, 2.1.1) and when a run ends."""

    control_rate_hz: float = 100.0
    """Reactive layer: control and safety, every tick."""
    plan_rate_hz: float = 10.0
    """Deliberative layer: the path planner."""
    output_record_rate_hz: float = 10.0
    """How often the map state is recorded (and hashed); plans and commands are recorded as made."""
    max_sim_time_s: float = 900.0
    """A simulation that has not finished by then stops (reason 'timeout')."""
    handover_standstill_s: float = 1.0
    """After the exploration lap the car stands this long before the remote 'go'."""
    exploration_overrun_m: float = 12.0
    """The scripted exploration lap drives this far past the start line before stopping."""
    render: bool = True
    """Render PNG frames (and a movie) of the run."""
    record: bool = True
    """Record raw sensor data and outputs to OUT/recording.mcap."""
    stale_input_s: float = 0.5
    """Readings older than this when they reach Main are rejected (counted)."""
