"""The vectorised seeding of a sweep's draws is numpy's SeedSequence and PCG64, bit for bit."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from slidingarm.sweep._seeding import pcg64_states, spawned_words
from slidingarm.sweep.space import Distribution
from slidingarm.sweep.staging import draw_runs, run_seeds

SEEDS = [0, 1, 5, 2**32 - 1, 2**32, 2**40 + 7, 2**63 - 1, 2**130 + 3]


def random_keys(rng: np.random.Generator, rows: int, width: int) -> np.ndarray:
    keys = rng.integers(0, 2**32, size=(rows, width), dtype=np.int64)
    keys[0] = 0  # the smallest words
    keys[1] = 2**32 - 1  # the largest
    return keys


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("width", [1, 2, 3, 6])
def test_the_words_are_those_of_numpy_seed_sequence(seed: int, width: int) -> None:
    rng = np.random.default_rng(seed % 2**64 + width)
    keys = random_keys(rng, 40, width)
    for n_words in (1, 5, 8):
        words = spawned_words(seed, keys, n_words)
        assert words.shape == (40, n_words) and words.dtype == np.uint32
        for row, key in zip(words, keys, strict=True):
            ss = np.random.SeedSequence(seed, spawn_key=tuple(int(k) for k in key))
            np.testing.assert_array_equal(row, ss.generate_state(n_words))


@pytest.mark.parametrize("seed", SEEDS)
def test_a_generator_set_to_the_state_draws_what_numpy_seeding_draws(seed: int) -> None:
    keys = random_keys(np.random.default_rng(3), 25, 3)
    states = pcg64_states(spawned_words(seed, keys, 8))
    bitgen = np.random.PCG64(0)
    mine = np.random.Generator(bitgen)
    for state, key in zip(states, keys, strict=True):
        ss = np.random.SeedSequence(seed, spawn_key=tuple(int(k) for k in key))
        ref_bitgen = np.random.PCG64(ss)
        assert state == ref_bitgen.state
        bitgen.state = state
        ref = np.random.Generator(ref_bitgen)
        np.testing.assert_array_equal(mine.normal(size=7), ref.normal(size=7))
        np.testing.assert_array_equal(mine.uniform(size=3), ref.uniform(size=3))


def test_draws_and_run_seeds_are_the_per_key_generators() -> None:
    dists = {
        "gains.k": Distribution("uniform", (10.0, 40.0)),
        "mismatch.mass_error": Distribution("normal", (0.0, 0.1)),
        "sensor.noise.sigma": Distribution("loguniform", (1e-5, 1e-3)),
        "simulation.q0": Distribution("normal", (0.0, 0.05), offset=True),
        "gains.p": Distribution("choice", (5.0, 7.0, 9.0)),
    }
    shapes = {"gains.k": 0, "mismatch.mass_error": 3, "sensor.noise.sigma": 0,
              "simulation.q0": 3, "gains.p": 0}  # fmt: skip
    bases = {"simulation.q0": [0.1, -0.2, 0.3]}
    seed, runs = 2**40 + 11, [0, 1, 2, 63, 64, 1000, 99_999]
    got = draw_runs(seed, runs, dists, shapes, bases)
    for i, values in zip(runs, got, strict=True):
        for key, dist in dists.items():
            ss = np.random.SeedSequence(seed, spawn_key=(i, 1, zlib.crc32(key.encode())))
            x = dist.draw(np.random.Generator(np.random.PCG64(ss)), shapes[key] or 1)
            if dist.offset:
                x = x + np.asarray(bases[key])
            assert values[key] == ([float(v) for v in x] if shapes[key] else float(x[0]))
    expected = [int(np.random.SeedSequence(seed, spawn_key=(i, 0)).generate_state(1)[0]) for i in runs]
    assert run_seeds(seed, runs) == expected


def test_bad_keys_and_seeds_are_refused() -> None:
    with pytest.raises(ValueError, match=r"\[0, 2\*\*32\)"):
        spawned_words(1, np.array([[2**32, 0]]), 1)
    with pytest.raises(ValueError, match=r"\[0, 2\*\*32\)"):
        spawned_words(1, np.array([[-1, 0]]), 1)
    with pytest.raises(ValueError, match="non-negative"):
        spawned_words(-3, np.array([[1, 0]]), 1)
    with pytest.raises(ValueError, match=r"\(P, m\)"):
        spawned_words(1, np.array([1, 2]), 1)
    with pytest.raises(ValueError, match=r"\(P, 8\)"):
        pcg64_states(np.zeros((2, 4), dtype=np.uint32))
