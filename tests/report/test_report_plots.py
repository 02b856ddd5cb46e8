"""Matplotlib figures: what is drawn is the logged data, thinned, against the limits."""

from __future__ import annotations

import numpy as np
import pytest

from redres.report import plots

from .conftest import Runs

PNG = b"\x89PNG\r\n\x1a\n"


def _colours(runs: Runs) -> dict[str, str]:
    return plots.palette([plots.run_name(log) for _, log in runs])


def test_palette_gives_each_name_one_stable_colour() -> None:
    colours = plots.palette(["pinv", "wln", "pinv", "dls"])
    assert list(colours) == ["pinv", "wln", "dls"]
    assert len(set(colours.values())) == 3
    assert all(c.startswith("#") and len(c) == 7 for c in colours.values())
    many = plots.palette([f"run{i}" for i in range(25)])
    assert len(many) == 25  # the palette wraps instead of failing


def test_robot_figures_are_pngs(runs: Runs) -> None:
    robot = runs[0][0]
    logs = [log for r, log in runs if r is robot]
    pngs = plots.robot_figures(robot, logs, _colours(runs))
    assert set(pngs) == {"joints", "position_error", "sigma_min", "objectives"}
    assert all(data.startswith(PNG) for data in pngs.values())
    iiwa, log = runs[2]
    assert "objectives" not in plots.robot_figures(iiwa, [log], _colours(runs))


def test_joint_panels_draw_the_logged_positions_and_the_limits(runs: Runs) -> None:
    robot = runs[0][0]
    logs = [log for r, log in runs if r is robot]
    fig = plots.joints_figure(robot, logs, _colours(runs), max_points=50)
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert len(panels) == robot.n
    for j, ax in enumerate(panels):
        curves = [line for line in ax.get_lines() if line.get_linestyle() == "-"]
        assert len(curves) == len(logs)
        for line, log in zip(curves, logs):
            t, y = (np.asarray(v, dtype=float) for v in line.get_data())
            assert len(t) <= 50
            steps = np.rint(t / log.dt).astype(int)  # t = k dt
            np.testing.assert_array_equal(y, log.q[steps, j])
            assert line.get_label() == plots.run_name(log)
        limits = sorted(
            float(np.asarray(line.get_ydata())[0])
            for line in ax.get_lines()
            if line.get_linestyle() == "--"
        )
        assert limits == pytest.approx([robot.q_min[j], robot.q_max[j]], abs=1e-12)
        low, high = ax.get_ylim()
        assert low < robot.q_min[j] and high > robot.q_max[j]


def test_error_and_sigma_plots_are_logarithmic_in_the_right_units(runs: Runs) -> None:
    robot = runs[0][0]
    logs = [log for r, log in runs if r is robot]
    colours = _colours(runs)
    error = plots.position_error_figure(robot.name, logs, colours)
    sigma = plots.sigma_min_figure(robot.name, logs, colours)
    for figure, attribute, scale in ((error, "position_error", 1e3), (sigma, "sigma_min", 1.0)):
        ax = figure.axes[0]
        assert ax.get_yscale() == "log"
        for line, log in zip(ax.get_lines(), logs):
            t, y = (np.asarray(v, dtype=float) for v in line.get_data())
            steps = np.rint(t / log.dt).astype(int)
            expected = scale * getattr(log, attribute)[steps]
            expected = np.where(expected > 0, expected, np.nan)  # zeros left out on log axes
            np.testing.assert_allclose(y, expected, rtol=1e-12)


def test_objective_panels_follow_the_logged_costs(runs: Runs) -> None:
    robot = runs[0][0]
    logs = [log for r, log in runs if r is robot]
    fig = plots.objectives_figure(robot.name, logs, _colours(runs))
    assert fig is not None
    names = list(dict.fromkeys(n for log in logs for n in log.objectives))
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title() for ax in panels] == [n.replace("_", " ") for n in names]
    for ax, name in zip(panels, names):
        owners = [log for log in logs if name in log.objectives]
        assert len(ax.get_lines()) == len(owners)
        for line, log in zip(ax.get_lines(), owners):
            t, y = (np.asarray(v, dtype=float) for v in line.get_data())
            np.testing.assert_array_equal(y, log.objectives[name][np.rint(t / log.dt).astype(int)])
    assert plots.objectives_figure(runs[2][0].name, [runs[2][1]], _colours(runs)) is None
