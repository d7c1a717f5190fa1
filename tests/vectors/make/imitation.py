"""imitation.json: agent.protocol.imitation's decoders (imitation.rs through agent._native) on plans and notes:
the record (as JSON), or null (dropped). agent/native/tests/all/imitation_vectors.rs checks that the crate
decodes each the same and encodes each valid one to that JSON."""

from __future__ import annotations

import json

from agent.protocol.imitation import MAX_COMMANDS, MAX_TEXT, decode_note, decode_plan, note_json
from make.common import body, sign

JPEG = "ffd8ffe000104a464946"  # the first bytes of a JPEG (the record checks its start only)
MASK = {"rows": 2, "cols": 3, "runs": [1, 2, 3]}
STARTS_TRUE = {"rows": 1, "cols": 4, "runs": [0, 4]}


def _text(obj) -> bytes:
    return json.dumps(obj).encode()


def _plan_cases() -> list:
    env = sign(body()).hex()  # a signed command envelope (the coordinator verifies it)
    one = {"v": 1, "record": "plan", "frame_steps": 0, "commands": [[0, env]]}
    seq = {"v": 1, "record": "plan", "frame_steps": 40, "commands": [[0, env], [3, env], [9, env]]}
    return [
        ("plan_one_command", one),
        ("plan_sequence", seq),
        # rejected
        ("plan_version_2", dict(one, v=2)),
        ("plan_unversioned", {k: v for k, v in one.items() if k != "v"}),
        ("plan_is_a_note", dict(one, record="note")),
        ("plan_unknown_field", dict(one, extra=1)),
        ("plan_no_command", dict(one, commands=[])),
        ("plan_two_commands_without_frame_steps", dict(seq, frame_steps=0)),
        ("plan_first_not_0", dict(seq, commands=[[1, env], [3, env]])),
        ("plan_firsts_not_rising", dict(seq, commands=[[0, env], [3, env], [3, env]])),
        ("plan_upper_case_hex", dict(one, commands=[[0, env.upper()]])),
        ("plan_odd_hex", dict(one, commands=[[0, env[:-1]]])),
        ("plan_empty_envelope", dict(one, commands=[[0, ""]])),
        ("plan_envelope_too_long", dict(one, commands=[[0, "00" * (64 * 1024 + 1)]])),
        ("plan_too_many_commands", dict(seq, commands=[[i, "7b7d"] for i in range(MAX_COMMANDS + 1)])),
        ("plan_frame_steps_negative", dict(seq, frame_steps=-1)),
        ("plan_frame_steps_float", dict(seq, frame_steps=40.0)),
        ("plan_first_bool", dict(one, commands=[[False, env]])),
    ]


def _note_cases() -> list:
    head = {"v": 1, "record": "note"}
    seen = {
        **head,
        "note": "observation",
        "seq": 1,
        "observed": "body",
        "label": "left_side-right_side",
        "index": 14,
        "mask": MASK,
        "parts": {"torso": MASK, "left_arm": {"rows": 2, "cols": 3, "runs": [6]}},
        "picture": JPEG,
    }
    command = {**head, "note": "command", "seq": 2, "gesture": "hand_2", "why": "gesture", "mask": STARTS_TRUE}
    return [
        ("subject_given", {**head, "note": "subject", "subject": "hand", "how": "given"}),
        ("subject_auto", {**head, "note": "subject", "subject": "person", "how": "auto", "frames": 3}),
        ("observation", seen),
        ("observation_of_a_hand", dict(seen, observed="hand", label="hand_5", parts={})),
        ("command", command),
        ("command_unlabelled", dict(command, gesture="")),
        ("missing", {**head, "note": "missing", "what": "no hand found: the image is blank (uniform)"}),
        ("end", {**head, "note": "end", "frames": 72}),
        # rejected
        ("note_version_2", dict(command, v=2)),
        ("note_is_a_plan", dict(command, record="plan")),
        ("note_unknown_kind", dict(command, note="exploded")),
        ("note_unknown_field", dict(command, t=1.5)),
        ("note_field_missing", {k: v for k, v in command.items() if k != "why"}),
        ("subject_unknown", {**head, "note": "subject", "subject": "cat", "how": "given"}),
        ("subject_auto_without_frames", {**head, "note": "subject", "subject": "hand", "how": "auto"}),
        ("subject_given_with_frames", {**head, "note": "subject", "subject": "hand", "how": "given", "frames": 3}),
        ("command_seq_0", dict(command, seq=0)),
        ("command_why_unknown", dict(command, why="bored")),
        ("command_gesture_too_long", dict(command, gesture="x" * (MAX_TEXT + 1))),
        ("mask_runs_short", dict(command, mask={"rows": 2, "cols": 3, "runs": [1, 2, 2]})),
        ("mask_runs_long", dict(command, mask={"rows": 2, "cols": 3, "runs": [1, 2, 4]})),
        ("mask_empty_run_inside", dict(command, mask={"rows": 2, "cols": 3, "runs": [1, 0, 5]})),
        ("mask_no_rows", dict(command, mask={"rows": 0, "cols": 3, "runs": []})),
        ("mask_too_large", dict(command, mask={"rows": 20000, "cols": 20000, "runs": [400000000]})),
        ("mask_negative_run", dict(command, mask={"rows": 2, "cols": 3, "runs": [7, -1]})),
        ("observation_part_unknown", dict(seen, parts={"tail": MASK})),
        ("observation_part_of_another_size", dict(seen, parts={"torso": STARTS_TRUE})),
        ("observation_picture_not_jpeg", dict(seen, picture="89504e47")),
        ("observation_kind_unknown", dict(seen, observed="cat")),
        ("missing_empty", {**head, "note": "missing", "what": ""}),
        ("end_negative", {**head, "note": "end", "frames": -1}),
        ("not_an_object", [1, 2]),
    ]


def imitation_vectors() -> dict:
    plans = [(name, _text(obj)) for name, obj in _plan_cases()] + [("plan_not_json", b"{")]
    notes = [(name, _text(obj)) for name, obj in _note_cases()] + [("note_not_utf8", b"\xff\xfe")]
    out: dict = {"plans": [], "notes": []}
    for name, data in plans:
        plan = decode_plan(data)
        out["plans"].append(
            {"name": name, "payload_hex": data.hex(), "expect": None if plan is None else plan.as_json()}
        )
    for name, data in notes:
        note = decode_note(data)
        out["notes"].append(
            {"name": name, "payload_hex": data.hex(), "expect": None if note is None else note_json(note)}
        )
    return out
