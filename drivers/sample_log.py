"""The latest samples of a stream, kept as the blocks that came (the simulated rig's drive and
real-time loop records): appending and reading the latest samples cost what those samples cost,
not what the whole record holds (a minute at 10 kHz, read after every block of a loop)."""

from __future__ import annotations

from collections import deque

import numpy as np


class SampleLog:
    """Blocks of samples along the last axis, the oldest dropped while the rest hold at least
    ``keep`` samples (:meth:`append`); ``shape`` the shape of a block without its sample axis."""

    def __init__(self, shape: tuple[int, ...] = ()) -> None:
        self.shape = shape
        self._blocks: deque[np.ndarray] = deque()
        self.held = 0  # samples held

    def append(self, block: np.ndarray, keep: int) -> None:
        """Add ``block`` (samples along its last axis), then drop the oldest blocks while the
        others hold at least ``keep`` samples."""
        self._blocks.append(block)
        self.held += block.shape[-1]
        while self._blocks and self.held - self._blocks[0].shape[-1] >= keep:
            self.held -= self._blocks.popleft().shape[-1]

    def array(self) -> np.ndarray:
        """Every sample held, oldest first (a copy)."""
        if not self._blocks:
            return np.zeros((*self.shape, 0))
        return np.concatenate(self._blocks, axis=-1)

    def tail(self, samples: int) -> np.ndarray:
        """The latest ``samples`` samples, oldest first (a copy).

        Raises
        ------
        ValueError
            More samples asked for than held.
        """
        if not 0 <= samples <= self.held:
            raise ValueError(f"{samples} samples asked for, {self.held} held")
        picked: list[np.ndarray] = []
        count = 0
        for block in reversed(self._blocks):
            if count >= samples:
                break
            picked.append(block)
            count += block.shape[-1]
        if not picked:
            return np.zeros((*self.shape, 0))
        joined = np.concatenate(picked[::-1], axis=-1)
        return joined[..., joined.shape[-1] - samples :]
