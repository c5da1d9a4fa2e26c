"""Benchmarks of the class-2 controller (issue 15), against the demo's present law in the same run.

- ``waypoints``: the demo's four end-effector waypoints (2 s moves, 2 s holds, sampled at
  100 Hz; full mode also 1 kHz): settled error 2 s after each move, settling time below
  0.05 mm and below 2 % of the move, overshoot, peak force, for the
  :class:`TrackingController` and the demo's :class:`ActuatorTracker`; target: every move
  below 0.05 mm within 2 s, no force over the 5 N limit;
- ``circle``: D on a 5 cm circle at one turn per 4 s: RMS and maximum error during the
  constant-rate turn;
- ``tick_cost``: one controller evaluation (state in, forces out) against the demo law's;
  target < 1 ms (1 kHz on one core); and the cost of planning and scheduling a move.

Quick mode runs everything at 100 Hz with the first two waypoints.
"""

from __future__ import annotations

from threadpoolctl import threadpool_limits

from studies.closed_loop import BASELINE_GAINS, WAYPOINT_OFFSETS, circle_study, waypoint_study
from studies.closed_loop_plots import plot_waypoints
from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics
from tensegrity_core.class2.control import ActuatorTracker, TrackingController, plan_move, rest_state
from tests.bench.harness import Context, Row, benchmark, best_run, time_per_call

G = "control"
TOL = 5e-5


@benchmark
def waypoints(ctx: Context) -> list[Row]:
    offsets = WAYPOINT_OFFSETS[:2] if ctx.quick else WAYPOINT_OFFSETS
    rows = []
    with threadpool_limits(1):
        lqr = waypoint_study("lqr", offsets=offsets, rate=100.0, tolerance=TOL)
        base = waypoint_study("baseline", offsets=offsets, rate=100.0, tolerance=TOL)
        fast = None if ctx.quick else waypoint_study("lqr", offsets=offsets, rate=1000.0, tolerance=TOL)
    for i, (m, b) in enumerate(zip(lqr.moves, base.moves), start=1):
        rows += [
            Row(G, f"move{i}_settled_error_baseline", b.settled_error * 1e3, "mm",
                note=f"demo law {BASELINE_GAINS}, 2 s after the move"),
            Row(G, f"move{i}_settled_error", m.settled_error * 1e3, "mm", baseline=f"move{i}_settled_error_baseline",
                target="< 0.05 mm", note=f"TrackingController 100 Hz, move {m.start} -> {m.target}"),
            Row(G, f"move{i}_settling_time_2pc_baseline", b.settling_time_2pc, "s",
                note="inside 2 % of the move from then on (inf: not within the 2 s hold)"),
            Row(G, f"move{i}_settling_time_2pc", m.settling_time_2pc, "s",
                note="inside 2 % of the move from then on, after the move's end"),
            Row(G, f"move{i}_settling_time", m.settling_time, "s", target="<= 2 s",
                note="inside 0.05 mm from then on, after the move's end (baseline: never)"),
            Row(G, f"move{i}_overshoot_baseline", b.overshoot * 1e3, "mm", note="beyond the waypoint along the move"),
            Row(G, f"move{i}_overshoot", m.overshoot * 1e3, "mm", baseline=f"move{i}_overshoot_baseline"),
            Row(G, f"move{i}_max_force", m.max_force, "N", target="<= 5 N", note="limit 5 N"),
            Row(G, f"move{i}_max_tracking_error", m.max_tracking_error * 1e3, "mm",
                note="|D - reference D| during the move and hold"),
        ]
    if fast is not None:
        rows.append(Row(G, "settled_error_max_1kHz", max(m.settled_error for m in fast.moves) * 1e3, "mm",
                        target="< 0.05 mm", note="the same at 1 kHz (gains designed for 1 ms)"))
    rows.append(Row(G, "settled_error_max_baseline", max(m.settled_error for m in base.moves) * 1e3, "mm"))
    rows.append(Row(G, "settled_error_max", max(m.settled_error for m in lqr.moves) * 1e3, "mm",
                    baseline="settled_error_max_baseline", target="< 0.05 mm"))
    path = ctx.plot_path("control_waypoints.png")
    if path is not None:
        plot_waypoints([lqr, base], path)
    ctx.save_json("control_waypoints.json", {
        s.law: [m.__dict__ for m in s.moves] for s in (lqr, base)})
    return rows


@benchmark
def circle(ctx: Context) -> list[Row]:
    with threadpool_limits(1):
        lqr = circle_study("lqr", radius=0.05, period=4.0)
        base = circle_study("baseline", radius=0.05, period=4.0)
    return [
        Row(G, "circle_rms_error_baseline", base.extra["rms_error"] * 1e3, "mm",
            note="demo law on the IK of the circle, constant-rate turn"),
        Row(G, "circle_rms_error", lqr.extra["rms_error"] * 1e3, "mm", baseline="circle_rms_error_baseline",
            note="5 cm radius, 4 s per turn, 100 Hz"),
        Row(G, "circle_max_error_baseline", base.extra["max_error"] * 1e3, "mm"),
        Row(G, "circle_max_error", lqr.extra["max_error"] * 1e3, "mm", baseline="circle_max_error_baseline"),
        Row(G, "circle_max_error_with_ramps", lqr.extra["max_error_whole"] * 1e3, "mm",
            note="including the 2 s speed-up and slow-down"),
        Row(G, "circle_max_force", lqr.extra["max_force"], "N", target="<= 5 N"),
    ]


@benchmark
def tick_cost(ctx: Context) -> list[Row]:
    p = PAPER_PARAMS
    d = forward_kinematics(0.7, 0.7, p)
    q0 = rest_state(0.7, 0.7, p)
    with threadpool_limits(1):
        ctrl = TrackingController(p, dt=0.001)
        ref = plan_move(q0, (d.x + 0.08, d.y + 0.06), p, duration=2.0)
        ctrl.follow(ref, 0.0)
        tracker = ActuatorTracker(p, **BASELINE_GAINS)
        q, qd = ref.q[500] + 1e-4, ref.qdot[500]
        k = iter(range(10**9))
        min_time = None if ctx.quick else 0.5        # quick: the mode's (harness.QUICK_TIMING)
        t_law = time_per_call(lambda: ctrl.update(1.0 + 1e-6 * next(k), q, qd), min_time=min_time)
        t_base = time_per_call(lambda: tracker.forces(q[:2], q[:2], qd[:2], float(qd[2])), min_time=min_time)
        t_plan, _ = best_run(lambda: ctrl.schedule(plan_move(q0, (d.x + 0.08, d.y + 0.06), p, duration=2.0)),
                             repeat=1 if ctx.quick else 3, min_time=0.0 if ctx.quick else 1.0)
    return [
        Row(G, "tick_baseline", t_base * 1e6, "us", note="ActuatorTracker.forces (holding forces + PD)"),
        Row(G, "tick", t_law * 1e6, "us", baseline="tick_baseline", target="< 1000 us (1 kHz)",
            note="TrackingController.update: reference, gains, feedback, saturation, integral"),
        Row(G, "tick_rate", 1.0 / t_law, "Hz", target=">= 1000 Hz", note="ticks per second on one core"),
        Row(G, "plan_move_and_schedule", t_plan * 1e3, "ms",
            note="2 s move: IK along the path, dynamic reference, 20 gain knots (Riccati)"),
    ]

