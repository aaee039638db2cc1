"""How long a run's chunks of steps are, and when its next checkpoint is due.

A run (:class:`emorbit.stepping.ChunkDriver`) takes its steps in chunks, each one call of the
body systems' step kernels. :class:`Pace` sizes them from the measured wall time of the
chunks before, so that a chunk takes about :data:`CHUNK_SECONDS` (chunks grow at most 4-fold
from one to the next, so the first, short ones time the step before the long ones run), and
says when a checkpoint is due: at most :data:`CHECKPOINT_SECONDS` of wall time after the last.

Where events split steps (impulses, a burn's switches, steps landing on an effect's edges), a
split drops the steps its chunk took after it, which are taken again, so chunks stay short
there: about half the gap between the last two splits, from 8 to :data:`SPLIT_STEPS` steps.
Splits that repeat every other gap (a shadow's entry and exit) are foreseen: once one came
within a sixteenth of the gap (2 steps at least) of where the ones before said, the chunks run
up to that margin before the next one due and take the steps around it in one short chunk,
so that a split takes a few steps again, not half a gap. Where chunks end changes no result.
"""

from __future__ import annotations

import time as _time

__all__ = ["CHUNK_SECONDS", "CHECKPOINT_SECONDS", "SPLIT_STEPS", "Pace"]

#: the wall time a chunk of steps aims at, s (chunks grow at most 4-fold from one to the next)
CHUNK_SECONDS = 0.5
#: the most wall time between checkpoints when ``checkpoint_every`` is not given, s
CHECKPOINT_SECONDS = 5.0
#: steps per chunk at most where events split their steps (impulses, a burn's switches, steps
#: landing on an effect's edges): a split drops the chunk's steps after it, which are taken
#: again, so long chunks would take the steps after every split many times over
SPLIT_STEPS = 64


class Pace:
    """Chunk sizes from the measured wall time of earlier chunks, and when a checkpoint is due."""

    def __init__(self, max_records: int):
        self.records = 2  # the first chunk is short: it is timed before chunks grow
        self.max_records = max_records
        self.per_record = 0.0  # s
        self.steps = 1024  # steps of one call in a record interval longer than a chunk
        self.last_checkpoint = _time.monotonic()
        self.split_cap = SPLIT_STEPS  # steps per chunk at most where events split steps
        self.splits: list[int] = []  # the step counts of the last splits, at most 3
        self.foreseen = False  # whether the last split came where the splits before it said

    def split(self, steps: int) -> None:
        """A step was split at step count ``steps``: chunks of about half the steps between
        the last two splits (from 8 to :data:`SPLIT_STEPS`), so that the steps a split drops
        and takes again stay few beside the calls' own cost; and whether it came where
        :meth:`split_steps` expected it."""
        due = self._due()
        if self.splits and steps > self.splits[-1]:
            self.split_cap = max(8, min(SPLIT_STEPS, (steps - self.splits[-1]) // 2))
        self.foreseen = due is not None and abs(steps - due[0]) <= due[1]
        self.splits = [*self.splits[-2:], steps]

    def _due(self):
        """The next split expected from the last ones, (step count, margin), or None: splits
        that repeat every other gap (a shadow's entry and exit) come the gap before the last
        after the last split, within a sixteenth of it (2 steps at least)."""
        if len(self.splits) < 3:
            return None
        gap = self.splits[-2] - self.splits[-3]
        return self.splits[-1] + gap, max(2, gap // 16)

    def split_steps(self, at: int) -> int:
        """Steps per chunk at most from step count ``at`` where events split steps. Once a
        split came where the ones before it said (:meth:`_due`), the chunks run up to the
        margin before the next one expected and then take the steps around it in one short
        chunk, so that a split drops and takes again a few steps, not half a gap; else, and
        once past the margin after the expected one, :attr:`split_cap`."""
        due = self._due()
        if not self.foreseen or due is None or at > due[0] + due[1]:
            return self.split_cap
        step, margin = due
        return step - margin - at if at < step - margin else 2 * margin + 1

    def measured(self, nrec: int, seconds: float, steps: int | None = None) -> None:
        self.per_record = seconds / nrec
        target = int(CHUNK_SECONDS / max(self.per_record, 1e-12))
        self.records = max(1, min(target, 4 * self.records, self.max_records))
        if steps is not None:
            self.measured_steps(steps, seconds)

    def measured_steps(self, steps: int, seconds: float) -> None:
        """Steps per call in a long record interval, from a call of ``steps`` steps."""
        target = int(CHUNK_SECONDS * steps / max(seconds, 1e-12))
        self.steps = max(1, min(target, 4 * max(self.steps, steps)))

    def checkpoint_due(self) -> bool:
        """A checkpoint now, or the next chunk would end more than CHECKPOINT_SECONDS after the last."""
        ahead = self.per_record * self.records
        return _time.monotonic() - self.last_checkpoint + ahead >= CHECKPOINT_SECONDS

    def checkpointed(self) -> None:
        self.last_checkpoint = _time.monotonic()
