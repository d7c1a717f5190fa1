"""float_repr.json: Python's repr(float), which the canonical command body uses."""

from __future__ import annotations

import math
import random
import struct

def float_reprs() -> list:
    rng = random.Random(11)
    values = [0.0, -0.0, 1.0, -1.0, 0.1, 0.30000000000000004, 1e-05, 0.0001, 0.00012345, 1e-4 * (1 - 2**-53),
              1e16, 9999999999999998.0, 1e16 - 2, 1.5e16, 1234567890123456.0, 123.456, 5e-324, 2.2250738585072014e-308,
              1.7976931348623157e308, 2**53, 2**53 + 2, 1e22, 1e23, 9007199254740993.0, 100.0, 1e15, 0.5, 1 / 3]
    for _ in range(400):
        bits = rng.getrandbits(64)
        v = struct.unpack("<d", struct.pack("<Q", bits))[0]
        if math.isfinite(v):
            values.append(v)
    for _ in range(400):  # decimal-looking values, as coordinates are, across the positional/exponent edges
        values.append(round(rng.uniform(-1, 1) * 10 ** rng.randint(-8, 20), rng.randint(0, 12)))
    # Binary fractions, as the fill controller's vertices are (multiples of 2^-17 m): many lie exactly halfway
    # between two shortest candidates, which Python breaks to the even digit (0.87348175048828125 -> ...812).
    values += [0.87348175048828125, 2.5 * 2**-52 + 1 - 2**-52]
    for _ in range(400):
        values.append(rng.randint(1, 2**24) * 2.0 ** rng.randint(-30, 10))
    return [[struct.pack("<d", v).hex(), repr(v)] for v in map(float, values)]
