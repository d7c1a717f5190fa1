"""radio.json: agent.sph.radio (the oracle of the imperfect radio): the counter-based uniforms for chosen and
extreme counters, and per radio setting which states a receiver loses and each sender's position error.
agent/native/tests/all/radio_vectors.rs checks agent/native/src/radio.rs against it, so the agents and the
reference driver draw the same numbers."""

from __future__ import annotations

from agent.sph.radio import LOSS, MASK, NOISE_A, NOISE_R, RadioModel, uniform


def radio_vectors() -> dict:
    counters = [(0, LOSS, 0, 0, 0), (MASK, NOISE_A, 2**32 - 1, 8191, 2**32 - 1), (12345, NOISE_R, 7, 0, 300)]
    counters += [
        (seed, stream, a, b, step)
        for seed in (0, 1, 2012)
        for stream in (LOSS, NOISE_R, NOISE_A)
        for a, b, step in ((3, 5, 0), (5, 3, 0), (3, 5, 1), (63, 62, 299))
    ]
    uniforms = [
        {"seed": s, "stream": st, "a": a, "b": b, "step": k, "u": uniform(s, st, a, b, k)}
        for s, st, a, b, k in counters
    ]
    settings = [
        RadioModel(loss=0.1, latency=2, noise=0.05),
        RadioModel(loss=0.5, noise=1.0, seed=MASK),
        RadioModel(loss=0.999, seed=7),
        RadioModel(noise=0.05, seed=2**63),
    ]
    radios = []
    for r in settings:
        draws = []
        for receiver, sender, step in ((0, 1, 0), (1, 0, 0), (5, 9, 17), (63, 62, 299), (8191, 0, 4_000_000_000)):
            dx, dy = r.position_error(sender, step)
            draws.append(
                {
                    "receiver": receiver,
                    "sender": sender,
                    "step": step,
                    "lost": r.lost(receiver, sender, step),
                    "error": [dx, dy],
                }
            )
        radios.append({"radio": r.as_dict(), "draws": draws})
    return {"uniforms": uniforms, "radios": radios}
