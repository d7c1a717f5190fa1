# Types of the compiled module agent._native (agent/native/python/src): what agent/records.py re-exports.
# Kept beside the module so mypy checks its callers; tests/test_native_records.py checks the names agree.

from typing import Any

# --- the state record (agent/protocol/wire.py) ---
STATE_VERSION: int
STATE_KIND: int
STATE_SIZE: int
STATE_MAX_ID: int
STATE_MAX_ABS: float

def state_encode(agent_id: int, step: int, state: list[float], particle_class: int) -> bytes: ...
def state_decode(
    data: bytes,
) -> tuple[tuple[int, int, int, tuple[float, ...]], None] | tuple[None, str]: ...
def state_peek_id_position(data: bytes) -> tuple[tuple[int, float, float], None] | tuple[None, str]: ...
def state_peek_id_step(data: bytes) -> tuple[int, int] | None: ...

# --- the gesture command (agent/protocol/command.py) ---
COMMAND_MAX_BYTES: int
COMMAND_MAX_CLASSES: int
COMMAND_MAX_ROUTE: int
COMMAND_MAX_COORD: float
COMMAND_MAX_RINGS: int
COMMAND_MAX_VERTICES: int
COMMAND_MAX_ZONES: int
COMMAND_MAX_DEPTH: int

def command_canonical(body: object) -> bytes: ...
def command_sign(body: bytes, secret: bytes) -> bytes: ...
def command_verify(data: bytes, secret: bytes) -> bytes | str: ...
def command_decode(data: bytes, secret: bytes) -> dict[str, Any] | str: ...
def command_check_body(body: object) -> str | None: ...
def fill_edges_cross(rings: list[list[tuple[float, float]]]) -> bool: ...
