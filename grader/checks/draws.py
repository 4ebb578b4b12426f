"""Seeded random test inputs with the numpy Generator methods the checks use, on Python's `random`.

`random` is already loaded with numpy; numpy.random is not, and importing it would add about
10 ms to every `grade chNN`. Sequences are reproducible across runs and machines (string seeds
are hashed with SHA-512 by `random.Random`, not with Python's salted hash).
"""

from __future__ import annotations

import math
import random

import numpy as np


class Draws:
    """uniform, integers, choice, normal, standard_normal, random, permutation: numpy's signatures."""

    def __init__(self, seed: str) -> None:
        self._random = random.Random(seed)

    def _many(self, size, draw) -> object:
        if size is None:
            return draw()
        shape = (size,) if isinstance(size, int) else tuple(size)
        return np.array([draw() for _ in range(math.prod(shape))], dtype=float).reshape(shape)

    def uniform(self, low: float = 0.0, high: float = 1.0, size=None):
        return self._many(size, lambda: self._random.uniform(low, high))

    def random(self, size=None):
        return self._many(size, self._random.random)

    def normal(self, loc: float = 0.0, scale: float = 1.0, size=None):
        return self._many(size, lambda: self._random.gauss(loc, scale))

    def standard_normal(self, size=None):
        return self.normal(0.0, 1.0, size)

    def integers(self, low: int, high: int | None = None, size=None):
        if high is None:
            low, high = 0, low
        if size is None:
            return self._random.randrange(low, high)
        return self._many(size, lambda: self._random.randrange(low, high)).astype(np.int64)

    def choice(self, a, size=None, replace: bool = True):
        population = range(a) if isinstance(a, int) else list(a)
        if size is None:
            return self._random.choice(population)
        count = size if isinstance(size, int) else math.prod(size)
        picked = (self._random.sample(population, count) if not replace
                  else [self._random.choice(population) for _ in range(count)])
        return np.array(picked).reshape(size if not isinstance(size, int) else (size,))

    def permutation(self, x):
        items = list(range(x)) if isinstance(x, int) else list(x)
        self._random.shuffle(items)
        return np.array(items)
