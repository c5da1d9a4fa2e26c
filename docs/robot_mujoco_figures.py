"""Figures and numbers of docs/mujoco.md, "Robots": the exported robots run in MuJoCo.

Run from the repository root with the ``mujoco`` extra installed (``./run setup``)::

    .venv/bin/python docs/robot_mujoco_figures.py          # writes docs/img/mujoco_*.png, prints the numbers

1. Drop and settle (three_bar, six_bar): each touching cap's penetration over 30 s in
   MuJoCo against the Hunt-Crossley rest ``F_n / k`` of its final normal force.
2. The six_bar under the shipped gait ``six_bar_roll``: the centre of mass on the floor and
   over time, with the faces it stands on (from MuJoCo's contacts).
3. MuJoCo's real-time factor on one core at 1 ms for each shipped robot (both integrators).
4. The project's robot dynamics against MuJoCo on the same scenes: ``six_bar_roll`` (faces
   in order, centre-of-mass travel) and the drops ``three_bar_drop``, ``six_bar_drop``
   (the face it settles on, penetration, rest height), each scene exported with
   ``export_mjcf(load_scene(name))`` and simulated with ``tensegrity_core.sim.simulate``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tensegrity_core.export import export_mjcf  # noqa: E402
from tensegrity_core.robot.faces import faces_visited  # noqa: E402
from tensegrity_core.robot.gait import GAITS_DIR, gait_from_file  # noqa: E402
from tensegrity_core.robot.loading import load_robot  # noqa: E402
from tensegrity_core.sim import load_scene, simulate  # noqa: E402
from tests.mujoco_peer import play_gait, robot_real_time_factor, touching_caps  # noqa: E402

IMG = ROOT / "docs" / "img"
SETTLE = 30.0


def settle_figure() -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    for ax, name in zip(axes, ("three_bar", "six_bar")):
        robot = load_robot(name)
        m = mujoco.MjModel.from_xml_string(export_mjcf(robot).xml)
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
        caps = [f"cap:{n}" for n in robot.node_names]
        ids = {m.geom(c).id: c for c in caps}
        every = 10
        n = round(SETTLE / m.opt.timestep)
        times, depth = [], {c: [] for c in caps}
        for k in range(n + 1):
            if k % every == 0:
                mujoco.mj_forward(m, d)
                times.append(d.time)
                now = dict.fromkeys(caps, np.nan)
                for j in range(d.ncon):
                    con = d.contact[j]
                    cap = ids.get(con.geom[0]) or ids.get(con.geom[1])
                    if cap is not None:
                        now[cap] = -1e3 * con.dist
                for c in caps:
                    depth[c].append(now[c])
            if k < n:
                mujoco.mj_step(m, d)
        wrench = np.zeros(6)
        final = {}
        for j in range(d.ncon):
            con = d.contact[j]
            cap = ids.get(con.geom[0]) or ids.get(con.geom[1])
            mujoco.mj_contactForce(m, d, j, wrench)
            final[cap] = (wrench[0], -con.dist)
        k_floor = robot.floor.stiffness
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        for i, cap in enumerate(sorted(final)):
            F, delta = final[cap]
            colour = colours[i % len(colours)]
            ax.plot(times, depth[cap], color=colour, lw=1, label=f"{cap} (MuJoCo)")
            ax.axhline(1e3 * F / k_floor, color=colour, ls="--", lw=1,
                       label=f"{cap}: F_n/k = {1e3 * F / k_floor:.3f} mm ({F:.1f} N)")
            print(f"{name}: {cap} rests on the floor with F_n = {F:.2f} N, penetration {1e3 * delta:.4f} mm, "
                  f"Hunt-Crossley F_n/k = {1e3 * F / k_floor:.4f} mm")
        print(f"{name}: settled on {sorted(touching_caps(m, d))}")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("penetration of the floor [mm]")
        ax.set_title(f"{name} dropped from its drawing (MuJoCo, implicitfast, 1 ms)")
        ax.set_ylim(0, 1.0)
        ax.legend(fontsize=7, loc="upper right")
    fig.savefig(IMG / "mujoco_settle.png", dpi=110)
    plt.close(fig)


def roll_figure() -> None:
    robot = load_robot("six_bar")
    gait = gait_from_file(GAITS_DIR / "six_bar_roll.yaml")
    run = play_gait(export_mjcf(robot).xml, gait, gait.duration + 1.0)
    com = run.com
    fig, (top, side) = plt.subplots(1, 2, figsize=(12, 4.2), constrained_layout=True)
    top.plot(com[:, 0], com[:, 1], color="C0", lw=1.2, label="centre of mass (MuJoCo)")
    side.plot(run.times, com[:, 0], color="C0", lw=1.2, label="centre of mass x (MuJoCo)")
    for k, (t, face) in enumerate(run.faces):
        i = min(np.searchsorted(run.times, t), len(run.times) - 1)
        label = "reached a new face" if k == 0 else None
        top.plot(com[i, 0], com[i, 1], "o", color="C3", ms=4, label=label)
        side.axvline(t, color="C3", lw=0.6, alpha=0.6, label=label)
        top.annotate(" ".join(sorted(face)), (com[i, 0], com[i, 1]), fontsize=6, rotation=30)
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_aspect("equal")
    top.set_title("six_bar under six_bar_roll: centre of mass on the floor")
    top.legend(fontsize=8)
    side.set_xlabel("time [s]")
    side.set_ylabel("centre of mass x [m]")
    side.set_title("the same over time, with the faces reached")
    side.legend(fontsize=8)
    fig.savefig(IMG / "mujoco_six_bar_roll.png", dpi=110)
    plt.close(fig)
    within = [f for t, f in run.faces if t <= 10.0]
    print(f"six_bar_roll in MuJoCo: faces {[' '.join(sorted(f)) for _, f in run.faces]}")
    print(f"  {len(set(within))} distinct faces within 10 s; centre of mass moved "
          f"{com[-1, 0] - com[0, 0]:.3f} m in x, {com[-1, 1] - com[0, 1]:.3f} m in y over the gait "
          f"({gait.duration:.2f} s, one cycle)")


def speed() -> None:
    for name in ("three_bar", "six_bar", "spine"):
        robot = load_robot(name)
        for integrator in ("implicitfast", "RK4"):
            rtf = robot_real_time_factor(export_mjcf(robot, integrator=integrator).xml, 5.0)
            print(f"{name}: MuJoCo {integrator} at 1 ms runs {rtf:.1f}x real time (best of 3, 5 s simulated)")


def project_run(name: str):
    """The project's run of a robot scene: times, node positions, the faces it stood on (caps
    carrying more than 2 % of the weight, as :func:`tests.mujoco_peer.play_gait` counts them)
    and the centre of mass of its rods."""
    scene = load_scene(name)
    robot = scene.model.robot
    run = simulate(scene)
    caps = robot.rods.ends.ravel()                       # the contact forces' order: each rod's two caps
    weight = robot.total_mass() * float(np.linalg.norm(robot.gravity))
    faces = [(t, frozenset(robot.node_names[caps[i]] for i in f))
             for t, f in faces_visited(run.times, np.asarray(run.contact_forces) > 0.02 * weight, hold=0.0)]
    m = robot.rods.mass
    mid = 0.5 * (run.nodes[:, robot.rods.ends[:, 0]] + run.nodes[:, robot.rods.ends[:, 1]])
    com = np.einsum("r,trk->tk", m, mid) / m.sum()
    return robot, run, faces, com


def compare_roll() -> None:
    robot, run, faces, com = project_run("six_bar_roll")
    scene = load_scene("six_bar_roll")
    gait = gait_from_file(GAITS_DIR / "six_bar_roll.yaml")
    peer = play_gait(export_mjcf(scene).xml, gait, float(run.times[-1]))
    print("six_bar_roll faces, project:", [f"{t:.2f} s " + " ".join(sorted(f)) for t, f in faces])
    print("six_bar_roll faces, MuJoCo: ", [f"{t:.2f} s " + " ".join(sorted(f)) for t, f in peer.faces])
    d_p, d_m = com[-1] - com[0], peer.com[-1] - peer.com[0]
    print(f"centre of mass travel over {run.times[-1]:.1f} s: project {d_p[0]:.3f} m x, {d_p[1]:.3f} m y; "
          f"MuJoCo {d_m[0]:.3f} m x, {d_m[1]:.3f} m y")
    breaks = gait.table()[0]
    ours = np.array([com[min(np.searchsorted(run.times, t - 1e-9), len(com) - 1)] - com[0] for t in breaks])
    theirs = np.array([peer.com[min(np.searchsorted(peer.times, t - 1e-9), len(peer.com) - 1)] - peer.com[0]
                       for t in breaks])
    for t, a, b in zip(breaks, ours, theirs):
        print(f"  gait breakpoint {t:5.2f} s: project ({a[0]:.3f}, {a[1]:.3f}) m, MuJoCo ({b[0]:.3f}, {b[1]:.3f}) m, "
              f"apart {np.hypot(*(a - b)[:2]):.3f} m = {np.hypot(*(a - b)[:2]) / max(np.hypot(*b[:2]), 1e-9):.1%} "
              f"of MuJoCo's travel")
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    ax.plot(com[:, 0], com[:, 1], color="C0", lw=1.2, label="project (robot back end)")
    ax.plot(peer.com[:, 0], peer.com[:, 1], color="C1", lw=1.2, label="MuJoCo (exported six_bar_roll, RK4 1 ms)")
    for (series, path, times, colour, marker) in (("project", com, run.times, "C0", "o"),
                                                  ("MuJoCo", peer.com, peer.times, "C1", "s")):
        pts = np.array([path[min(np.searchsorted(times, t), len(times) - 1)]
                        for t, _ in (faces if series == "project" else peer.faces)])
        ax.plot(pts[:, 0], pts[:, 1], marker, color=colour, ms=4, ls="none", label=f"{series}: reached a new face")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.set_title("centre of mass on the floor")
    ax.legend(fontsize=8)
    t = peer.times
    ours_t = np.array([com[min(np.searchsorted(run.times, s - 1e-9), len(com) - 1)] - com[0] for s in t])
    theirs_t = peer.com - peer.com[0]
    bx.plot(t, np.hypot(*(ours_t - theirs_t)[:, :2].T), "C3", lw=1.4, label="project to MuJoCo, on the floor")
    bx.plot(t, 0.1 * np.hypot(*theirs_t[:, :2].T), "k--", lw=1.0, label="10 % of MuJoCo's travel from the start")
    for k, s in enumerate(breaks):
        bx.axvline(s, color="0.7", lw=0.6, ls=":", label="a gait breakpoint" if k == 0 else None)
    for series, span, colour in (("project", airborne(run.times, np.asarray(run.contact_forces).sum(axis=1)), "C0"),
                                 ("MuJoCo", mujoco_airborne(scene, gait, float(run.times[-1])), "C1")):
        if span is None:
            continue
        t0, t1 = span
        print(f"{series}: off the floor {t0:.2f}-{t1:.2f} s")
        bx.axvspan(t0, t1, color=colour, alpha=0.2, label=f"{series}: robot off the floor ({t0:.2f}-{t1:.2f} s)")
    bx.set_xlabel("t [s]")
    bx.set_ylabel("distance between the centres of mass [m]")
    bx.set_title("how far apart the two runs are")
    bx.legend(fontsize=8, loc="upper left")
    bx.grid(alpha=0.3)
    fig.suptitle("six_bar_roll: project and MuJoCo")
    fig.savefig(IMG / "mujoco_six_bar_roll_compared.png", dpi=110)
    plt.close(fig)


def airborne(times: np.ndarray, floor_force: np.ndarray) -> tuple[float, float] | None:
    """The first span [s] after the start in which nothing touches the floor (its first and
    last sample), None if the robot never leaves it."""
    off = np.flatnonzero((floor_force <= 0) & (times > 0.05))
    if not len(off):
        return None
    end = off[:-1][np.diff(off) > 1]
    last = int(end[0]) if len(end) else int(off[-1])
    return float(times[off[0]]), float(times[last])


def mujoco_airborne(scene, gait, duration: float) -> tuple[float, float] | None:
    """:func:`airborne` of the scene's export in MuJoCo driven by ``gait`` for ``duration`` [s]
    (the floor's normal force from MuJoCo's contacts at every step)."""
    m = mujoco.MjModel.from_xml_string(export_mjcf(scene).xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    t_table, v_table = gait.table()
    motors = np.array([m.actuator(f"cable:{c}").id for c in gait.cables])
    times, force, f6 = [], [], np.zeros(6)
    while d.time < duration:
        d.ctrl[motors] = [np.interp(d.time, t_table, v_table[:, j]) for j in range(len(motors))]
        mujoco.mj_step(m, d)
        total = 0.0
        for i in range(d.ncon):
            mujoco.mj_contactForce(m, d, i, f6)
            total += f6[0]
        times.append(d.time)
        force.append(total)
    return airborne(np.array(times), np.array(force))


def compare_drops() -> None:
    for name in ("three_bar_drop", "six_bar_drop"):
        robot, run, faces, com = project_run(name)
        m = mujoco.MjModel.from_xml_string(export_mjcf(load_scene(name)).xml)
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
        mujoco.mj_step(m, d, nstep=round(float(run.times[-1]) / m.opt.timestep))
        mujoco.mj_forward(m, d)
        r_c = float(robot.rods.cap_radius.max())
        depth_p = r_c - run.nodes[-1, :, 2]
        touching = sorted(touching_caps(m, d))
        depth_m = {c: r_c - d.site(f"node:{c}").xpos[2] for c in touching}
        print(f"{name} after {run.times[-1]:.1f} s: project on {' '.join(sorted(faces[-1][1])) if faces else '-'}, "
              f"centre of mass at {com[-1, 2]:.4f} m, deepest cap {1e3 * depth_p.max():.3f} mm; MuJoCo on "
              f"{' '.join(touching)}, centre of mass at {d.subtree_com[0][2]:.4f} m, deepest cap "
              f"{1e3 * max(depth_m.values()):.3f} mm")


if __name__ == "__main__":
    settle_figure()
    roll_figure()
    compare_roll()
    compare_drops()
    speed()
