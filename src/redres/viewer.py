"""A live 3D viewer in the browser, on viser (the ``viewer`` extra; from a checkout:
``pip install -e '.[viewer]'``).

>>> viewer = rr.view(robot, obstacles=[ball])          # doctest: +SKIP
>>> for k in range(steps):                             # doctest: +SKIP
...     q = controller.step(q)
...     viewer.push(q)                                 # never waits for the browser

:class:`Viewer` draws the robot — its visual meshes when its file has them
(``robot.visuals``), else its link capsules, else the polyline through its frame origins —
the obstacles (a half-space as a square of its surface), a floor grid, the tool frame, the
target, and the collision pairs within ``d_i`` as segments between witness points (of
``collisions=``, or a scrubbed run's record, binding ones red). :meth:`Viewer.push` only
stores the configuration (a copy, under a lock) and returns; a sender thread sends the
latest one at most ``rate`` times a second, so a loop is never slowed by the viewer and,
when the browser lags, intermediate configurations are dropped, never queued.
:meth:`Viewer.show_runs` adds finished runs with a drop-down, a time slider to scrub them
and a play button. Each link is one scene node whose pose is updated: its meshes are sent
once; so is each obstacle's, whose node :meth:`Viewer.push` moves when a loop passes the
obstacles where they are now (``push(q, obstacles=[ball(t)])``). The configuration shown
is also written in the side panel (``q = [...]``, and each obstacle's place), which
automated checks read.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ._validate import FloatArray, as_scalar, as_vector, real_array
from .errors import (
    InvalidParameterError,
    MissingDependencyError,
    NonFiniteError,
    ShapeError,
    install_hint,
)

if TYPE_CHECKING:
    from .collision import Collisions
    from .control import RunLog
    from .objectives import Obstacle
    from .robot import Robot


#: The slowest and fastest scene update rates, Hz.
MIN_RATE, MAX_RATE = 0.01, 1000.0


def _viser() -> Any:
    try:
        import viser
    except ImportError:
        raise MissingDependencyError(
            f"the live viewer needs viser; install the viewer extra: {install_hint('viewer')}"
        ) from None
    return viser


def _wxyz(R: FloatArray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    import pinocchio as pin

    quat = pin.Quaternion(np.asarray(R, dtype=float)).coeffs()  # x, y, z, w
    return float(quat[3]), float(quat[0]), float(quat[1]), float(quat[2])


def _rgb(colour: str) -> tuple[int, int, int]:
    c = colour.lstrip("#")
    return int(c[0:2], 16), int(c[2:4], 16), int(c[4:6], 16)


class Viewer:
    """A robot in a browser tab, updated from a loop (module docstring).

    Args:
        robot: the robot to show.
        obstacles: spheres, points, capsules, boxes and half-spaces to draw (world
            coordinates).
        host, port: where viser serves the page (``port=0``: a free port).
        rate: at most this many scene updates per second, Hz (:data:`MIN_RATE` to
            :data:`MAX_RATE`).
        geometry: ``"auto"`` (meshes, else capsules, else lines), ``"meshes"``,
            ``"capsules"`` or ``"lines"``.
        collisions: draw the pairs of this constraint closer than its ``influence`` at each
            configuration shown (computed in the viewer's thread, on its own model).

    Raises:
        MissingDependencyError: viser is not installed.
    """

    def __init__(
        self,
        robot: Robot,
        *,
        obstacles: Sequence[Obstacle] = (),
        host: str = "127.0.0.1",
        port: int = 8080,
        rate: float = 30.0,
        geometry: str = "auto",
        collisions: Collisions | None = None,
    ) -> None:
        viser = _viser()
        self.robot = robot
        self.rate = as_scalar(rate, "rate", minimum=MIN_RATE, maximum=MAX_RATE)
        _check_address(host, port)
        if geometry not in ("auto", "meshes", "capsules", "lines"):
            raise InvalidParameterError(
                f"geometry must be 'auto', 'meshes', 'capsules' or 'lines'; got {geometry!r}"
            )
        if geometry == "auto":
            geometry = "meshes" if robot.visuals else "capsules" if robot.capsules else "lines"
        self.geometry = geometry
        self._pair_model, self._influence = _pair_model(robot, collisions, obstacles)
        self.server = viser.ViserServer(host=host, port=port, label=f"redres · {robot.name}",
                                         verbose=False)  # fmt: skip
        self._lock = threading.Lock()
        self._pending: FloatArray | None = None
        self._target: FloatArray | None = None
        self._shown: FloatArray | None = None
        self._moved: list[Obstacle] | None = None
        self._stop = threading.Event()
        self._runs: list[RunLog] = []
        self._slider: Any = None
        self._pairs: Any = None  # the segments to draw with the next configuration
        self._shown_pairs: Any = None
        self._build_scene(list(obstacles))
        self._place(list(obstacles))  # the side panel names each obstacle and its place
        self.push(robot.neutral())
        self._send(robot.neutral(), None)
        self._thread = threading.Thread(target=self._sender, name="redres-viewer", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ public
    @property
    def url(self) -> str:
        """Address of the page."""
        host = self.server.get_host()
        return f"http://{'127.0.0.1' if host in ('0.0.0.0', '::') else host}:{self.port}"

    @property
    def port(self) -> int:
        """The port the page is served on."""
        return int(self.server.get_port())

    @property
    def shown(self) -> FloatArray | None:
        """The configuration last sent to the browser."""
        return None if self._shown is None else self._shown.copy()

    def push(self, q: Any, target: Any = None, obstacles: Sequence[Obstacle] | None = None) -> None:
        """Show configuration ``q`` (shape ``(n,)``) and, optionally, a target pose (4x4) or
        position (3,), and the viewer's obstacles where they are now (``obstacles``: as
        many as it was built with, in the same order: a moving ball is drawn where the loop
        says it is), soon: returns at once; only the latest push is sent.

        Raises:
            ShapeError, NonFiniteError: ``q`` or ``target`` of the wrong shape, or not finite.
            InvalidParameterError: ``obstacles`` of another count than the viewer's.
        """
        qv = np.array(as_vector(q, "q", self.robot.n), dtype=float)
        tv = None if target is None else _target(target)
        moved = None
        if obstacles is not None:
            moved = list(obstacles)
            if len(moved) != len(self._obstacles):
                raise InvalidParameterError(
                    f"obstacles: the viewer draws {len(self._obstacles)} obstacles; push "
                    f"them all, in the order it was built with (got {len(moved)})"
                )
        with self._lock:
            self._pending, self._target = qv, tv if tv is not None else self._target
            if moved is not None:
                self._moved = moved

    def show_runs(self, runs: Sequence[RunLog]) -> None:
        """Add finished runs of this robot: a drop-down to pick one, a time slider to
        scrub it, a play button, and its target (dashed) and actual paths."""
        self._runs = [log for log in runs if log.steps]
        if not self._runs:
            raise InvalidParameterError("show_runs needs at least one run with steps")
        gui = self.server.gui
        labels = [f"{i}: {log.label or log.scheme}" for i, log in enumerate(self._runs)]
        pick = gui.add_dropdown("run", options=labels, initial_value=labels[0])
        slider = gui.add_slider("t (s)", min=0.0, max=1.0, step=1e-3, initial_value=0.0)
        play = gui.add_button("play")
        self._slider = slider  # (the tests move it from the page and read it here)

        def current() -> RunLog:
            return self._runs[labels.index(pick.value)]

        def scrub(_: Any = None) -> None:
            from .report.view3d import pair_segments

            log = current()
            k = int(np.clip(round(slider.value / log.dt), 0, log.steps - 1))
            record = log.extra.get("collision_pairs")
            with self._lock:  # the run's own pairs, the binding ones among them
                self._pairs = None if record is None else pair_segments(record, k)
            self.push(log.q[k], log.target[k] if np.any(log.target) else None)

        def repick(_: Any = None) -> None:
            log = current()
            slider.max = float(log.t[-1]) if log.steps > 1 else 1.0
            slider.value = 0.0
            self._draw_paths(log)
            scrub()

        def run_once(_: Any = None) -> None:
            threading.Thread(target=self._play, args=(current(), slider), daemon=True).start()

        slider.on_update(scrub)
        pick.on_update(repick)
        play.on_click(run_once)
        repick()

    def close(self) -> None:
        """Stop the sender and the server."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.server.stop()

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ internals
    def _play(self, log: RunLog, slider: Any) -> None:
        start = time.perf_counter()
        while not self._stop.is_set():
            t = time.perf_counter() - start
            if t > log.t[-1]:
                break
            slider.value = float(t)
            time.sleep(1.0 / self.rate)

    def _sender(self) -> None:
        period = 1.0 / self.rate
        while not self._stop.wait(period):
            with self._lock:
                q, target, self._pending = self._pending, self._target, None
                moved, self._moved = self._moved, None
                self._shown_pairs, self._pairs = self._pairs, None
            if moved is not None:
                self._place(moved)
            if q is not None:
                self._send(q, target)

    def _place(self, obstacles: list[Obstacle]) -> None:
        """Move the obstacles' scene nodes to ``obstacles`` (a new shape is drawn anew)."""
        from .report.scene3d import obstacle_anchor

        with self.server.atomic():
            lines = []
            for i, obs in enumerate(obstacles):
                anchor, shape = obstacle_anchor(obs)
                node = self._obstacle_nodes[i]
                node.position = tuple(float(x) for x in anchor)
                same = shape.shape == self._obstacle_shapes[i].shape and np.allclose(
                    shape, self._obstacle_shapes[i], rtol=0.0, atol=1e-12)  # fmt: skip
                if not same:
                    self._obstacle_meshes[i].remove()
                    self._obstacle_meshes[i] = self._add_shape(node.name, obs, anchor)
                    self._obstacle_shapes[i] = shape
                lines.append(f"{obs.name} at (" + ", ".join(f"{x:.4f}" for x in anchor) + ")")
            self._obstacles = obstacles
            self._obstacle_status.content = "; ".join(lines)

    def _add_shape(self, node: str, obstacle: Obstacle, anchor: FloatArray) -> Any:
        """An obstacle's mesh under ``node`` (at ``anchor``); a point as a 5 mm ball."""
        from .report.scene3d import OBSTACLE_COLOUR, obstacle_mesh

        vertices, faces = obstacle_mesh(obstacle, min_radius=0.005)
        return self.server.scene.add_mesh_simple(
            f"{node}/shape", vertices=(vertices - anchor).astype(np.float32),
            faces=faces.astype(np.uint32), color=_rgb(OBSTACLE_COLOUR), opacity=0.6,
            side="double",
        )  # fmt: skip

    def _frames(self) -> list[str]:
        if self.geometry == "meshes":
            return sorted({m.frame for m in self.robot.visuals if m.frame is not None})
        if self.geometry == "capsules":
            return sorted({c.frame for c in self.robot.capsules})
        return []

    def _build_scene(self, obstacles: list[Obstacle]) -> None:
        from .report.scene3d import CAPSULE_COLOUR, PAIR_COLOURS, capsule_mesh, obstacle_anchor

        scene = self.server.scene
        scene.set_up_direction("+z")
        robot = self.robot
        tip = robot.fk(robot.neutral())[:3, 3]
        reach = max(0.5, float(np.linalg.norm(tip)))
        camera = self.server.initial_camera
        camera.look_at = tuple(float(x) for x in 0.5 * tip)
        camera.position = tuple(float(x) for x in 0.5 * tip + reach * np.array([1.6, -1.6, 1.0]))
        scene.add_grid("/floor", width=2.0, height=2.0, cell_size=0.1)
        self._links: dict[str, Any] = {}
        for frame in self._frames():
            self._links[frame] = scene.add_frame(f"/robot/{frame}", show_axes=False)

        def add_mesh(name: str, vertices: Any, faces: Any, colour: str, **style: Any) -> None:
            vertices, faces = vertices.astype(np.float32), faces.astype(np.uint32)
            scene.add_mesh_simple(name, vertices=vertices, faces=faces, color=_rgb(colour), **style)

        if self.geometry == "meshes":
            for i, mesh in enumerate(self.robot.visuals):
                parent = f"/robot/{mesh.frame}" if mesh.frame is not None else "/base"
                add_mesh(f"{parent}/mesh{i}", mesh.vertices, mesh.triangles, mesh.colour)
        elif self.geometry == "capsules":
            for i, cap in enumerate(self.robot.capsules):
                vertices, faces = capsule_mesh(cap.a, cap.b, cap.radius)
                name = f"/robot/{cap.frame}/capsule{i}"
                add_mesh(name, vertices, faces, CAPSULE_COLOUR, opacity=0.8)
        self._arm = None
        if self.geometry == "lines":
            self._arm = scene.add_line_segments("/robot/arm", points=np.zeros((1, 2, 3)),
                                                colors=(31, 119, 180), thickness=0.008)  # fmt: skip
        self._obstacles = obstacles
        self._obstacle_nodes: list[Any] = []
        self._obstacle_meshes: list[Any] = []
        self._obstacle_shapes: list[FloatArray] = []
        for i, obs in enumerate(obstacles):
            anchor, shape = obstacle_anchor(obs)
            node = scene.add_frame(f"/obstacles/{i}_{obs.name}", show_axes=False,
                                   position=tuple(float(x) for x in anchor))  # fmt: skip
            self._obstacle_nodes.append(node)
            self._obstacle_meshes.append(self._add_shape(node.name, obs, anchor))
            self._obstacle_shapes.append(shape)
        self._pair_nodes = {kind: scene.add_line_segments(
            f"/pairs/{kind}", points=np.zeros((1, 2, 3), np.float32), colors=_rgb(colour),
            thickness=0.003 if kind == "free" else 0.006, visible=False,
        ) for kind, colour in PAIR_COLOURS.items()}  # fmt: skip
        self._pair_toggle = self.server.gui.add_checkbox("collision pairs", initial_value=True)
        self._pair_toggle.on_update(self._redraw)
        self._pair_status = self.server.gui.add_markdown("")
        self._tool = scene.add_frame("/tool", axes_length=0.08, axes_radius=0.004)
        self._goal = scene.add_icosphere("/target", radius=0.012, color=(214, 39, 40),
                                         visible=False)  # fmt: skip
        self._paths: list[Any] = []
        self._status = self.server.gui.add_markdown("q = ")
        self._obstacle_status = self.server.gui.add_markdown("")

    def _draw_paths(self, log: RunLog) -> None:
        for handle in self._paths:
            handle.remove()
        self._paths = []
        stride = max(1, log.steps // 500)
        for name, points, colour in (("actual", log.position, (31, 119, 180)),
                                     ("target", log.target, (85, 85, 85))):  # fmt: skip
            p = points[::stride]
            if len(p) > 1 and np.any(p):
                segments = np.stack([p[:-1], p[1:]], axis=1).astype(np.float32)
                self._paths.append(self.server.scene.add_line_segments(
                    f"/paths/{name}", points=segments, colors=colour, thickness=0.004))  # fmt: skip

    def _send(self, q: FloatArray, target: FloatArray | None) -> None:
        import pinocchio as pin

        robot = self.robot
        model, data = robot.model, robot.data
        pin.framesForwardKinematics(model, data, q)
        with self.server.atomic():
            for frame, handle in [*self._links.items(), (None, self._tool)]:
                T = data.oMf[robot.frame_id(frame)]
                handle.position = tuple(float(x) for x in T.translation)
                handle.wxyz = _wxyz(T.rotation)
            if self._arm is not None:
                from .report.view3d import arm_points

                p = arm_points(robot, q)
                self._arm.points = np.stack([p[:-1], p[1:]], axis=1).astype(np.float32)
            if target is not None:
                position = target[:3, 3] if target.shape == (4, 4) else target[:3]
                self._goal.position = tuple(float(x) for x in position)
                self._goal.visible = True
            self._status.content = "q = [" + ", ".join(f"{x:.4f}" for x in q) + "]"
            self._draw_pairs(q)
        self._shown = q

    def _redraw(self, _: Any = None) -> None:
        """Send the shown configuration again, with its pairs (the checkbox changed)."""
        with self._lock:
            self._pairs = self._shown_pairs
        if self._shown is not None:
            self.push(self._shown)

    def _draw_pairs(self, q: FloatArray) -> None:
        """The pairs at ``q``: a scrubbed run's record, else the viewer's model's within d_i."""
        from .report.view3d import near_pairs

        pairs = self._shown_pairs
        if pairs is None and self._pair_model is not None:
            pairs = near_pairs(self._pair_model, q, self._influence)
        show = bool(self._pair_toggle.value) and pairs is not None
        for kind, node in self._pair_nodes.items():
            seg = getattr(pairs, kind, ())
            if show and len(seg):
                node.points = np.asarray(seg, np.float32)
            node.visible = show and bool(len(seg))
        if pairs is None:
            return
        every = [*pairs.bound_labels, *pairs.free_labels]
        head = f"pairs within d_i: {len(every)}, binding: {len(pairs.bound_labels)}"
        self._pair_status.content = "; ".join([head, *every[:4]])


def _pair_model(robot: Robot, c: Any, obstacles: Sequence[Obstacle]) -> tuple[Any, float]:
    """Checked first: the obstacles; ``c``'s model for the viewer's thread, ``d_i``."""
    from .collision import CollisionModel, Collisions
    from .report.scene3d import obstacle_anchor

    [obstacle_anchor(obs) for obs in obstacles]  # raises for what is not an obstacle
    if c is None:
        return None, 0.0
    if not isinstance(c, Collisions):
        raise InvalidParameterError(f"collisions must be a Collisions(...); got {c!r}")
    return CollisionModel(robot, c.obstacles, capsules=c.capsules, self_collision=c.self_collision,
                          allowed=c.allowed, srdf=c.srdf, safety=c.safety), c.influence  # fmt: skip


def _check_address(host: Any, port: Any) -> None:
    """Refuse, before viser starts its server thread (whose failure would leave the caller
    waiting for good), a port outside 0–65535 and a host that is not an address."""
    if isinstance(port, bool) or not isinstance(port, (int, np.integer)) or not 0 <= port <= 65535:
        raise InvalidParameterError(f"port must be an integer from 0 to 65535; got {port!r}")
    if not isinstance(host, str) or not host:
        raise InvalidParameterError(f"host must be a host name or address; got {host!r}")
    try:
        socket.getaddrinfo(host, int(port), type=socket.SOCK_STREAM)
    except (OSError, UnicodeError) as exc:
        raise InvalidParameterError(f"host {host!r} is not an address here: {exc}") from None


def _target(target: Any) -> FloatArray:
    """A pushed target: a 4x4 pose or a position (3,), finite."""
    arr = real_array(target, "target", "a 4x4 pose or a position (3,)")
    if arr.shape not in ((3,), (4, 4)):
        raise ShapeError(f"target must be a 4x4 pose or a position (3,); got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise NonFiniteError("target contains NaN or infinity")
    return np.array(arr, dtype=float)


def view(robot: Robot, **kwargs: Any) -> Viewer:
    """Show ``robot`` in the browser (a :class:`Viewer`; its ``url`` is printed)."""
    viewer = Viewer(robot, **kwargs)
    print(f"redres: viewer at {viewer.url}")
    return viewer


def serve_scenario(
    spec: Any, *, host: str = "127.0.0.1", port: int = 8080, seconds: float | None = None
) -> int:
    """``redres view``: run every scheme of a scenario, then serve the runs (drop-down,
    time slider, play) until interrupted or for ``seconds``; returns the exit code."""
    from .scenarios.runner import run_scenario, summarise, warning_lines

    logs = run_scenario(spec, progress=False)
    for line in warning_lines([summarise(spec.robot, log) for log in logs]):
        print(line)
    return serve_runs(spec, logs, host=host, port=port, seconds=seconds)


def serve_runs(
    spec: Any,
    logs: Sequence[RunLog],
    *,
    host: str = "127.0.0.1",
    port: int = 8080,
    seconds: float | None = None,
    viewer: Viewer | None = None,
) -> int:
    """Serve finished runs of a scenario's robot (``redres run --view``, ``redres view``)
    until interrupted or for ``seconds``, in ``viewer`` (the one that showed them live)
    or a new one at ``host:port``; returns the exit code."""
    owned = viewer is None
    if viewer is None:
        viewer = Viewer(spec.robot, obstacles=spec.obstacles, host=host, port=port)
    viewer.show_runs(logs)
    print(f"redres: {spec.name}: {len(logs)} runs at {viewer.url} (Ctrl-C to stop)", flush=True)
    try:
        deadline = None if seconds is None else time.monotonic() + seconds
        while deadline is None or time.monotonic() < deadline:
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        if owned:
            viewer.close()
    return 0
