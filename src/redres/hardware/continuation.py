"""The command stream a Franka accepts after missed cycles: the client follows the robot's
own command history (internal to :mod:`redres.hardware.franka`).

The robot checks each command by backward
differences against the commands it applied, and carries a cycle nobody answered on at
frozen acceleration (reporting the carried-on command in ``q_d``, ``dq_d``, ``ddq_d``).
A command that arrives late is dropped by the robot (Franka's documentation of the
interface) but applied by franka-sim, which then differences the next command against it
over the cycles between them; and a state read just after a late write may predate it.
So the client compares each state with its own commands carried on at frozen acceleration:
the robot continues our line (then the next command continues it, with zero jerk if the
robot's history sits cycles behind), or it does not, and then the first such state after
a write is not answered (the late command is either dropped or shows up in the next
state) and the next one is taken as the robot's history.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import FloatArray
from ..control.shaping import CommandShaper

#: The Franka control period, s (``franka::kDeltaT``).
DT = 1e-3


class State:
    """What a cycle reads: measured ``q``, ``dq``; commanded ``q_d``, ``dq_d``,
    ``ddq_d``; the robot's command success rate; elapsed robot time, s."""

    __slots__ = ("ddq_d", "dq", "dq_d", "elapsed", "q", "q_d", "success")

    def __init__(self, raw: Any, elapsed: float) -> None:
        self.q, self.dq = np.array(raw.q), np.array(raw.dq)
        self.q_d, self.dq_d = np.array(raw.q_d), np.array(raw.dq_d)
        self.ddq_d = np.array(raw.ddq_d)
        self.success = float(raw.control_command_success_rate)
        self.elapsed = elapsed


class Continuation:
    """The command history the robot differences our next command against, followed
    across missed cycles (module docstring).

    The robot checks the command signal — the joint velocity in velocity mode, the joint
    position in position mode — by backward differences against the last command it
    applied, over the cycles between them, and carries a cycle that brought no command on
    at frozen acceleration (Franka's interface documentation: "keep acceleration constant
    and integrate"). Each state reports that history, rounded to single precision on the
    wire: ``dq_d``, ``ddq_d`` (velocity mode); ``q_d``, ``dq_d``, ``ddq_d`` (position mode).
    :meth:`plan` finds it on one of our last commands carried on that way, ``i`` cycles on
    (in double precision: a rounded ``q_d`` would be a jerk of 100 rad/s³), and so knows
    the ``s`` cycles the next command is differenced over:

    * on our last command, ``s = 1`` (every ordinary cycle, and a gap the robot carried our
      command through): a shaped step from it;
    * on our last command, ``s > 1`` (franka-sim applied our late command and carried it on
      from there, the state ahead of its history): the zero-jerk continuation of that line,
      whose differences over the ``s`` cycles are the line's own;
    * on an earlier command, or nowhere, in the first state after a write: our last
      command may have come late — dropped (the robot), or applied after this state went
      out (franka-sim) — so this cycle is not answered and the next state tells which;
    * on an earlier command otherwise: as on the last one; nowhere: the zero-jerk
      continuation of the reported history (its rounding is then a jerk once, not twice).
    """

    #: Commands kept to find the robot's history on.
    KEPT = 4
    #: How far the reported history may be from our line and still be taken for it: single
    #: precision on the wire (4 units in the last place), and what changes the jerk the
    #: robot computes by at most ``JERK_SLACK`` (a fifth of what the shaping margin of
    #: :mod:`redres.hardware.franka` keeps in hand).
    RTOL, JERK_SLACK = 2.0**-22, 50.0

    def __init__(self, position: bool, shaper: CommandShaper) -> None:
        self.position, self.shaper = position, shaper
        orders = (3, 2, 1) if position else (2, 1)  # value, derivatives: to the jerk in DT^k
        self.atol = [self.JERK_SLACK * DT**k for k in orders]
        self.sent: list[tuple[int, list[FloatArray]]] = []  # (tick, history), newest first
        self.answered = False  # whether the last state read was answered

    def _reported(self, state: State) -> list[FloatArray]:
        if self.position:
            return [state.q_d, state.dq_d, state.ddq_d]
        return [state.dq_d, state.ddq_d]

    def _line(self, history: list[FloatArray], i: int) -> list[FloatArray]:
        """``history`` carried on ``i`` cycles at frozen acceleration, as the robot does
        (velocity, then position: ``v += a dt``, ``q += v dt``)."""
        if not self.position:
            return [history[0] + i * DT * history[1], history[1]]
        q, qd, qdd = history
        return [q + DT * (i * qd + i * (i + 1) / 2 * DT * qdd), qd + i * DT * qdd, qdd]

    def _find(self, reported: list[FloatArray], tick: int) -> tuple[int, list[FloatArray], int]:
        """Which of our commands the reported history continues: ``(j, history, s)``, ``j =
        0`` the last, ``history`` the robot's in double precision, ``s`` the cycles from it
        to ``tick``; ``j = -1`` and the reported history if none."""
        for j, (sent, history) in enumerate(self.sent):
            for i in range(tick - sent - 1, -1, -1):
                line = self._line(history, i)
                if all(np.all(np.abs(r - x) <= self.RTOL * np.abs(x) + tol)
                       for r, x, tol in zip(reported, line, self.atol)):  # fmt: skip
                    return j, line, tick - sent - i
        return -1, reported, 1

    def plan(self, state: State, tick: int, q_c: FloatArray) -> tuple[str, FloatArray]:
        """What to do with the state of robot tick ``tick``: ``("step", q_c)``, a shaped
        step (the shaper set to the robot's history where it is not ours, and the position
        command to integrate from); ``("hold", command)``, the zero-jerk continuation of
        the robot's history; ``("skip", q_c)``, no command this cycle."""
        if not self.sent:
            return "step", q_c  # the first cycle: the shaper starts from the robot's state
        j, history, cycles = self._find(self._reported(state), tick)
        if j == 0 and cycles == 1 and tick - self.sent[0][0] == 1:
            return "step", q_c  # the ordinary cycle: the robot applied our last command
        if j != 0 and self.answered:
            self.answered = False
            return "skip", q_c
        if j >= 0 and cycles == 1:
            self.shaper.reset(*history[-2:])
            return "step", history[0] if self.position else q_c
        s = DT * cycles  # differenced over that many cycles: continue at frozen acceleration
        if self.position:
            qd = history[1] + s * history[2]
            self.shaper.reset(qd, history[2])
            return "hold", history[0] + s * qd
        qd = history[0] + s * history[1]
        self.shaper.reset(qd, history[1])
        return "hold", qd

    def wrote(self, tick: int, q_c: FloatArray) -> None:
        """Our command answering the state of robot tick ``tick`` was sent; ``q_c`` the
        position command (position mode)."""
        qd, qdd = self.shaper.qd, self.shaper.qdd
        if not self.sent:  # the robot takes the first command as a standstill
            qd, qdd = (0.0 * qd if self.position else qd), 0.0 * qdd
            self.shaper.reset(qd, qdd)
        history = [q_c.copy(), qd, qdd] if self.position else [qd, qdd]
        self.sent = [(tick, history), *self.sent[: self.KEPT - 1]]
        self.answered = True
