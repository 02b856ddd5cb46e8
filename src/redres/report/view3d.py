"""Animated 3D view of a run: the arm as a polyline through its frame origins.

:func:`arm_animation` samples a run (about 80 configurations, forward kinematics on each)
and :func:`animation_figure` turns it into a plotly figure (plain JSON-ready dicts, so
plotly.js draws it without the Python plotly objects): the arm, its visual meshes and its
link capsules (behind a legend entry when it has meshes), the obstacles at their place and
size (a half-space as a square of its surface), the closest arm–obstacle pair at each
instant, the pairs the collision constraint watched (those within its influence distance,
as segments between their witness points, the binding ones in red: each a legend entry,
so a click hides them), the target and actual paths of the task frame and a time slider
(play/pause are the page's), equal scale. The meshes are built in :mod:`.scene3d`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_vector
from . import scene3d
from .plots import run_name
from .series import IntArray, even_indices

if TYPE_CHECKING:
    from ..control import RunLog
    from ..objectives import Obstacle
    from ..robot import Robot

DECIMALS = 5  # 10 µm: finer than the screen, and keeps the page small


def arm_frames(robot: Robot) -> list[str]:
    """Frames whose origins draw the arm, base to tip.

    Built-in models: the root frame (``base``/``link0``), the frames whose names start
    with ``link`` in kinematic order, then the tip. Models without ``link…`` frames (URDF):
    the root frame, the frames of the joints, then the tip.
    """
    bodies = robot.frames(include_joint_frames=False)
    chain = [f for f in bodies if f.startswith("link")]
    if not chain:
        every = set(robot.frames())
        chain = [j for j in robot.joint_names if j in every]
    if bodies and bodies[0] not in chain:
        chain.insert(0, bodies[0])
    if robot.tip not in chain:
        chain.append(robot.tip)
    return chain


def arm_points(robot: Robot, q: Any, frames: Sequence[str] | None = None) -> FloatArray:
    """World positions of the arm's frame origins at ``q``.

    Args:
        q: joint positions, shape ``(n,)``, rad (m for prismatic joints).
        frames: frames to use, in order (default :func:`arm_frames`).

    Returns:
        Shape ``(k, 3)``, m: row ``i`` is ``robot.fk(q, frames[i])[:3, 3]``.
    """
    qv = as_vector(q, "q", robot.n)
    names = arm_frames(robot) if frames is None else list(frames)
    return np.array([robot.fk(qv, name)[:3, 3] for name in names]).reshape(len(names), 3)


@dataclass(frozen=True)
class ArmAnimation:
    """What the 3D view of one run shows.

    Attributes:
        robot, label: names of the robot and the run.
        times: time of each animation frame, shape ``(F,)``, s.
        steps: the run's step index of each frame, ``(F,)``.
        arm: arm points per frame, ``(F, k, 3)``, m.
        target, position: the task frame's target and actual paths, ``(P, 3)``, m;
            ``target`` is ``None`` when the run did not log a frame target.
        now: the target at each frame (the tip when there is no target), ``(F, 3)``, m.
        obstacles: the obstacles of the run (drawn at their place and size).
        closest: the closest (arm, obstacle) witness points at each frame, ``(F, 2, 3)``,
            m, and ``clearance`` their distance ``(F,)``, m; ``None`` without obstacles or
            link capsules.
        bodies: what moves with the arm, posed at each frame
            (:class:`~.scene3d.RigidBodies`): the robot's visual meshes, then its link
            capsules (``hidden`` when there are meshes); empty when it has neither.
        pairs: at each frame, the collision pairs within the influence distance that did
            not bind and those that did, as segments between their witness points
            (``(k, 2, 3)`` each, m) with a label per segment (pair and distance); None
            when the run has no record of them (``log.extra["collision_pairs"]``, kept
            by a scenario run with ``collisions``).
    """

    robot: str
    label: str
    times: FloatArray
    steps: IntArray
    arm: FloatArray
    target: FloatArray | None
    position: FloatArray
    now: FloatArray
    obstacles: tuple[Obstacle, ...] = ()
    closest: FloatArray | None = None
    clearance: FloatArray | None = None
    bodies: tuple[scene3d.RigidBodies, ...] = ()
    pairs: tuple[PairSegments, ...] | None = None


@dataclass(frozen=True)
class PairSegments:
    """The collision pairs of one frame: ``free`` and ``bound`` segments ``(k, 2, 3)``
    (m, from the link capsule's witness point to the other shape's) and their labels."""

    free: FloatArray
    bound: FloatArray
    free_labels: list[str]
    bound_labels: list[str]


def _labels(pairs: Sequence[Any], index: Any, distance: Any) -> list[str]:
    return [f"{pairs[i].first}–{pairs[i].second}: {1e3 * d:.1f} mm"
            for i, d in zip(index, distance)]  # fmt: skip


def pair_segments(record: Any, k: int) -> PairSegments:
    """The pairs of step ``k`` of a run's collision record (``log.extra["collision_pairs"]``,
    ``redres.control.analysis.CollisionRecord``)."""
    rows = record.at(k)
    seg = np.stack([record.point_a[rows], record.point_b[rows]], axis=1).reshape(-1, 2, 3)
    labels = _labels(record.pairs, record.pair[rows], record.distance[rows])
    bound = np.asarray(record.binding[rows], bool)
    return PairSegments(seg[~bound], seg[bound], [t for t, b in zip(labels, bound) if not b],
                        [t for t, b in zip(labels, bound) if b])  # fmt: skip


def near_pairs(model: Any, q: FloatArray, influence: float) -> PairSegments:
    """The pairs of a :class:`~redres.collision.CollisionModel` within ``influence`` (m)
    at ``q``, all ``free`` (whether a row binds needs the step's velocity)."""
    found = model.compute(q, influence)
    near = np.flatnonzero(found.distance < influence)
    seg = np.stack([found.point_a[near], found.point_b[near]], axis=1).reshape(-1, 2, 3)
    labels = _labels(found.pairs, near, found.distance[near])
    return PairSegments(seg, np.zeros((0, 2, 3)), labels, [])


def arm_animation(
    robot: Robot,
    log: RunLog,
    *,
    frames: int = 80,
    path_points: int = 1000,
    obstacles: Sequence[Obstacle] = (),
) -> ArmAnimation:
    """Sample a run for the 3D view.

    Args:
        robot: the robot the run was recorded on.
        log: the run.
        frames: number of animation frames (≥ 2; fewer for shorter runs).
        path_points: at most this many points per path.
        obstacles: spheres, points, capsules, boxes and half-spaces to draw; with link
            capsules on the robot the closest pair between arm and obstacles is found at
            every frame. The collision pairs are drawn when the log has their record.
    """
    names = arm_frames(robot)
    idx = even_indices(log.steps, frames)
    arm = np.stack([arm_points(robot, log.q[k], names) for k in idx])
    path = even_indices(log.steps, path_points)
    if np.any(log.position) or np.any(log.target):
        target: FloatArray | None = log.target[path]
        position = log.position[path]
        now = log.target[idx]
    else:  # the task had no frame: show the tip's path instead
        target = None
        position = np.array([robot.fk(log.q[k])[:3, 3] for k in path])
        now = arm[:, -1]
    caps, closest, clearance = list(robot.capsules), None, None
    if obstacles and caps:
        from ..objectives import proximities

        pairs = [scene3d.closest_pair(proximities(robot, log.q[k], obstacles, caps)) for k in idx]
        clearance = np.array([d for d, _ in pairs])
        closest = np.stack([p for _, p in pairs])
    bodies = scene3d.rigid_bodies(robot, log.q[idx])
    record = log.extra.get("collision_pairs")
    segments = None if record is None else tuple(pair_segments(record, int(k)) for k in idx)
    return ArmAnimation(
        robot.name, run_name(log), log.t[idx], idx, arm, target, position, now,
        tuple(obstacles), closest, clearance, bodies, segments,
    )  # fmt: skip


def _xyz(points: FloatArray) -> dict[str, list[float]]:
    return scene3d.xyz(points, DECIMALS)


def _plane_half_side(anim: ArmAnimation) -> float:
    """Half the side of a half-space's square: the arm's reach and 10 cm."""
    return float(np.linalg.norm(anim.arm, axis=-1).max()) + 0.1


def _scene(anim: ArmAnimation) -> dict[str, Any]:
    clouds = [anim.arm.reshape(-1, 3), anim.position, np.zeros((1, 3))]
    clouds.append(scene3d.obstacle_points(anim.obstacles, _plane_half_side(anim)))
    for b in anim.bodies:  # the hidden ones too: shown, they stay in the scene
        clouds += [b.world(0), b.world(len(anim.arm) - 1)]
    if anim.target is not None:
        clouds.append(anim.target)
    every = np.concatenate(clouds)
    low, high = every.min(axis=0), every.max(axis=0)
    centre = 0.5 * (low + high)
    half = 0.54 * (high - low)  # 8 % margin
    half = np.maximum(half, max(0.025, 0.1 * float(half.max())))  # flat scenes: some depth
    span = half / half.max()
    axes = {
        f"{c}axis": {
            "range": [round(float(centre[i] - half[i]), 4), round(float(centre[i] + half[i]), 4)],
            "title": {"text": f"{c} (m)"},
            "backgroundcolor": "#f7f7f9",
        }
        for i, c in enumerate("xyz")
    }
    return {
        **axes,
        "aspectmode": "manual",  # equal scale: ratios proportional to the ranges
        "aspectratio": {c: round(float(span[i]), 4) for i, c in enumerate("xyz")},
        "camera": {"eye": {"x": 1.1, "y": -1.1, "z": 0.6}, "center": {"x": 0, "y": 0, "z": -0.1}},
    }


def _path(name: str, points: FloatArray, mode: str = "lines", **style: Any) -> dict[str, Any]:
    """A plotly ``scatter3d`` trace through ``points``."""
    return {"type": "scatter3d", "mode": mode, "name": name, **_xyz(points), **style}


#: Decimals of the robot meshes' vertices (0.1 mm; they are many).
MESH_DECIMALS = 4


def _segments(seg: FloatArray, labels: list[str]) -> dict[str, Any]:
    """Segments ``(k, 2, 3)`` as one plotly line trace's coordinates (``None`` between
    segments) and hover texts."""
    cols: dict[str, list[Any]] = {"x": [], "y": [], "z": [], "hovertext": []}
    for (a, b), label in zip(np.round(seg, DECIMALS).tolist(), labels):
        for c, axis in enumerate("xyz"):
            cols[axis] += [a[c], b[c], None]
        cols["hovertext"] += [label, label, None]
    return cols


def _pair_traces(anim: ArmAnimation, f: int, styled: bool) -> list[dict[str, Any]]:
    """The two traces of the collision pairs at frame ``f`` (none without a record)."""
    if anim.pairs is None:
        return []
    p = anim.pairs[f]
    out = []
    for kind, seg, labels in (("free", p.free, p.free_labels), ("bound", p.bound, p.bound_labels)):
        trace = {"type": "scatter3d", **_segments(seg, labels)}
        if styled:
            name = "collision pairs within d_i" if kind == "free" else "binding collision pairs"
            width = 3 if kind == "free" else 7
            trace.update(mode="lines", name=name, hoverinfo="text",
                         line={"color": scene3d.PAIR_COLOURS[kind], "width": width},
                         meta={"kind": "pairs", "binding": kind == "bound"})  # fmt: skip
        out.append(trace)
    return out


def _animated(anim: ArmAnimation, f: int, colour: str) -> list[dict[str, Any]]:
    """The traces that move, at frame ``f``: arm, target now, then the closest pair when
    there is one, then the collision pairs when recorded (:func:`_traces` puts them first,
    in this order)."""
    markers = {"size": 4, "color": "#333"}
    diamond = {"size": 5, "color": "#d62728", "symbol": "diamond"}
    now = "target now" if anim.target is not None else "tip now"
    arm = {"line": {"color": colour, "width": 8}, "marker": markers}
    out = [
        _path("arm", anim.arm[f], "lines+markers", **arm),
        _path(now, anim.now[f : f + 1], "markers", marker=diamond),
    ]
    if anim.closest is not None and anim.clearance is not None:
        gap = f"closest pair: {1e3 * anim.clearance[f]:.1f} mm"
        style = {"line": {"color": "#c0392b", "width": 3, "dash": "dot"}, "marker": {"size": 3}}
        out.append({**_path("closest pair", anim.closest[f], "lines+markers", **style),
                    "hovertext": gap, "hoverinfo": "text"})  # fmt: skip
    return out + _pair_traces(anim, f, styled=True)


def _traces(anim: ArmAnimation, colour: str) -> list[dict[str, Any]]:
    first = anim.arm[0]
    grey = {"color": "#b0b0b0", "width": 4}
    traces = [
        *_animated(anim, 0, colour),
        _path("arm at t = 0", first, line=grey, opacity=0.6, visible="legendonly"),
        _path("actual path", anim.position, line={"color": colour, "width": 3}),
    ]
    if anim.target is not None:
        dashed = {"color": "#555", "width": 2, "dash": "dash"}
        traces.append(_path("target path", anim.target, line=dashed))
    traces += [_body_trace(b) for b in anim.bodies]  # posed at frame 0; the page moves them
    return traces + scene3d.obstacle_traces(anim.obstacles, _plane_half_side(anim))


def _body_trace(b: scene3d.RigidBodies) -> dict[str, Any]:
    """The mesh trace of ``b`` at frame 0 (``meta.kind`` ``"robot"``)."""
    opacity = 1.0 if b.name == "robot meshes" else 0.35
    style: dict[str, Any] = {"uid": b.name}  # a legend click holds across runs
    if b.hidden:
        style["visible"] = "legendonly"
    if len(set(b.face_colours)) > 1:
        style["facecolor"] = b.face_colours
    colour = b.face_colours[0] if b.face_colours else scene3d.CAPSULE_COLOUR
    return scene3d.mesh_trace(b.world(0), b.triangles, name=b.name, colour=colour,
                              opacity=opacity, decimals=MESH_DECIMALS,
                              meta={"kind": "robot"}, **style)  # fmt: skip


def _frames(anim: ArmAnimation) -> list[dict[str, Any]]:
    """Per frame, only the coordinates of the moving traces (their styles stay)."""
    out = []
    for f in range(len(anim.arm)):
        data = [
            {"type": "scatter3d", **_xyz(anim.arm[f])},
            {"type": "scatter3d", **_xyz(anim.now[f : f + 1])},
        ]
        if anim.closest is not None:
            data.append({"type": "scatter3d", **_xyz(anim.closest[f])})
        data += _pair_traces(anim, f, styled=False)
        out.append({"name": str(f), "traces": list(range(len(data))), "data": data})
    return out


def frame_delay_ms(anim: ArmAnimation) -> int:
    """Milliseconds per animation frame: about real time, within 20–250 ms."""
    duration_s = float(anim.times[-1] - anim.times[0])
    return int(np.clip(1000.0 * duration_s / max(len(anim.times) - 1, 1), 20, 250))


def _slider(anim: ArmAnimation) -> dict[str, Any]:
    """A time slider bound to the frames (step labels hidden: the current time shows)."""
    jump = {
        "mode": "immediate",
        "frame": {"duration": 0, "redraw": True},
        "transition": {"duration": 0},
    }
    steps = [
        {"method": "animate", "label": f"{t:.2f}", "args": [[str(f)], jump]}
        for f, t in enumerate(anim.times)
    ]
    return {
        "active": 0,
        "steps": steps,
        "x": 0.02,
        "len": 0.96,
        "y": 0.0,
        "yanchor": "top",
        "pad": {"t": 4},
        "ticklen": 0,
        "font": {"color": "rgba(0,0,0,0)", "size": 1},
        "currentvalue": {"prefix": "t = ", "suffix": " s", "font": {"size": 13, "color": "#333"}},
        "transition": {"duration": 0},
    }


def animation_figure(anim: ArmAnimation, colour: str = "#1f77b4") -> dict[str, Any]:
    """A plotly figure (``{"data", "layout", "frames"}`` of plain JSON types) of a run,
    with a time slider. The play/pause buttons are the page's (see :mod:`.html`): they
    drive ``Plotly.animate`` themselves so that pausing raises no unhandled promise
    rejection, as plotly's own animation buttons do; ``play.frame_ms`` gives their speed.

    Args:
        anim: the sampled run.
        colour: colour of the arm and of the actual path (``#rrggbb``).
    """
    layout = {
        "title": {"text": f"{anim.robot} · {anim.label}", "x": 0.02, "font": {"size": 15}},
        "scene": _scene(anim),
        "height": 680,
        "margin": {"l": 0, "r": 0, "t": 40, "b": 70},
        "legend": {"x": 0.01, "y": 0.95, "bgcolor": "rgba(255,255,255,0.7)"},
        "uirevision": "arm-view",
        "sliders": [_slider(anim)],
    }
    data = _traces(anim, colour)
    figure = {
        "data": data,
        "layout": layout,
        "frames": _frames(anim),
        "play": {"frame_ms": frame_delay_ms(anim)},
    }
    if anim.bodies:  # one entry per moving mesh trace, in the order of ``data``
        robot = [i for i, t in enumerate(data) if t.get("meta", {}).get("kind") == "robot"]
        figure["rigid"] = [_rigid_spec(anim.bodies, k, i) for k, i in enumerate(robot)]
    return figure


def _rigid_spec(bodies: tuple[scene3d.RigidBodies, ...], k: int, trace: int) -> dict[str, Any]:
    """Entry ``k`` of the figure's ``rigid`` list; poses an earlier entry has are not
    written twice (the meshes and the capsules move with the same frames)."""
    same = (j for j in range(k) if np.array_equal(bodies[j].poses, bodies[k].poses))
    return scene3d.rigid_spec(bodies[k], trace, MESH_DECIMALS, poses_of=next(same, None))
