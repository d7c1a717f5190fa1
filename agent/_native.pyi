# Types of the compiled module agent._native (agent/native/python/src): what agent/records.py re-exports.
# Kept beside the module so mypy checks its callers; tests/test_native_records.py checks the names agree.

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
