"""numpy's :class:`~numpy.random.SeedSequence` for many spawn keys at once.

A sweep seeds a generator per draw and key, ``SeedSequence(S, spawn_key=(i, 1, crc32(k)))``,
and one more per draw for its run seed: constructing a ``SeedSequence`` and a ``PCG64`` from it
costs about 40 µs in numpy (the hashing runs word by word in Python-level loops), which was
most of a draw's cost. The hashing is the same arithmetic for every key, so it vectorises: here
it runs on arrays, one lane per spawn key, and the ``PCG64`` seeding of
``PCG64(SeedSequence(...))`` is applied to its output. The words and the generators' states
are numpy's own, bit for bit (the tests compare them with ``SeedSequence`` and ``PCG64`` on
random seeds and keys), and a generator set to such a state draws exactly what
``Generator(PCG64(SeedSequence(...)))`` draws.

The algorithm is numpy's (``numpy/random/bit_generator.pyx``, the hash of M. E. O'Neill's
``seed_seq_fe``) with a pool of four 32-bit words: the entropy words are hashed into the pool,
the pool words are mixed with each other, the remaining entropy words are mixed into each pool
word, and ``generate_state`` hashes the pool cyclically into the output words.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

_POOL = 4
_INIT_A = 0x43B0D7E5
_MULT_A = 0x931E8875
_INIT_B = 0x8B51F9DD
_MULT_B = 0x58F38DED
_MIX_L = 0xCA01F9DD
_MIX_R = 0x4973F715
_SHIFT = 16
_MASK32 = 0xFFFFFFFF
_MASK128 = (1 << 128) - 1
#: PCG64's default 128-bit multiplier.
_PCG_MULT = (2549297995355413924 << 64) + 4865540595714422341

U32 = NDArray[np.uint32]


def _words(x: int) -> list[int]:
    """The 32-bit words of a non-negative integer, least significant first (``[0]`` for 0),
    as ``SeedSequence`` coerces an integer."""
    if x < 0:
        raise ValueError(f"a seed must be non-negative, got {x}")
    out = [x & _MASK32] if x == 0 else []
    while x > 0:
        out.append(x & _MASK32)
        x >>= 32
    return out


def spawned_words(entropy: int, keys: NDArray[np.int64], n_words: int) -> U32:
    """``SeedSequence(entropy, spawn_key=tuple(keys[p])).generate_state(n_words)`` for each row
    ``p`` of ``keys`` (P, m), every key element in ``[0, 2**32)``: (P, n_words) uint32.

    Raises
    ------
    ValueError
        For a key element outside ``[0, 2**32)`` or a negative ``entropy``.
    """
    keys = np.asarray(keys, dtype=np.int64)
    if keys.ndim != 2 or keys.shape[1] < 1:
        raise ValueError(f"keys must be a (P, m) array with m >= 1, got shape {keys.shape}")
    if keys.size and (keys.min() < 0 or keys.max() > _MASK32):
        raise ValueError("every spawn-key element must be in [0, 2**32)")
    run = _words(int(entropy))
    run += [0] * (_POOL - len(run))  # a spawn key pads the run entropy to the pool size
    p = keys.shape[0]
    lanes: list[U32 | int] = [*run, *(keys[:, j].astype(np.uint32) for j in range(keys.shape[1]))]
    const = [_INIT_A]

    def hashmix(value: U32 | int) -> U32:
        v = np.asarray(value, dtype=np.uint32) ^ np.uint32(const[0])
        const[0] = (const[0] * _MULT_A) & _MASK32
        v = v * np.uint32(const[0])
        return np.asarray(v ^ (v >> np.uint32(_SHIFT)), dtype=np.uint32)

    def mix(x: U32, y: U32) -> U32:
        r = np.uint32(_MIX_L) * x - np.uint32(_MIX_R) * y
        return np.asarray(r ^ (r >> np.uint32(_SHIFT)), dtype=np.uint32)

    with np.errstate(over="ignore"):
        pool = [np.broadcast_to(hashmix(lanes[i]), (p,)).copy() for i in range(_POOL)]
        for src in range(_POOL):
            for dst in range(_POOL):
                if src != dst:
                    pool[dst] = mix(pool[dst], hashmix(pool[src]))
        for word in lanes[_POOL:]:
            for dst in range(_POOL):
                pool[dst] = mix(pool[dst], hashmix(word))
        out = np.empty((p, n_words), dtype=np.uint32)
        c = _INIT_B
        for i in range(n_words):
            v = pool[i % _POOL] ^ np.uint32(c)
            c = (c * _MULT_B) & _MASK32
            v = v * np.uint32(c)
            out[:, i] = v ^ (v >> np.uint32(_SHIFT))
    return out


def pcg64_states(words: U32) -> list[dict[str, Any]]:
    """The state of ``PCG64(SeedSequence(...))`` per row of ``words`` (P, 8), the rows being
    that sequence's ``generate_state(8)`` (:func:`spawned_words`): a dict for
    ``PCG64.state``.

    ``PCG64`` takes ``generate_state(4, uint64)`` (the eight words, little-endian pairs) as a
    128-bit seed ``s`` and increment ``i`` and runs PCG's ``srandom``: ``inc = 2 i + 1``,
    ``state = (inc + s) a + inc`` modulo :math:`2^{128}` with ``a`` its multiplier.
    """
    w = np.asarray(words, dtype=np.uint64)
    if w.ndim != 2 or w.shape[1] != 8:
        raise ValueError(f"words must be (P, 8), got shape {w.shape}")
    u64 = (w[:, 0::2] | (w[:, 1::2] << np.uint64(32))).tolist()
    out = []
    for a, b, c, d in u64:
        inc = ((((c << 64) | d) << 1) | 1) & _MASK128
        state = (inc + ((a << 64) | b)) & _MASK128  # state 0, one step (0 a + inc), + s
        state = (state * _PCG_MULT + inc) & _MASK128
        out.append(
            {
                "bit_generator": "PCG64",
                "state": {"state": state, "inc": inc},
                "has_uint32": 0,
                "uinteger": 0,
            }
        )
    return out
