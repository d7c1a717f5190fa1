"""`fluidswarm auth-file` (fluidswarm/auth_file.py): a users file of mode 0600 that the routers and launchers
read, never written over unless --force, bad input in one line (a real router taking it:
tests/test_split_run.py)."""

from __future__ import annotations

from agent.protocol.access import ROLES, read_users_file
from fluidswarm.cli import main


def test_auth_file_writes_every_role_and_agent_with_mode_0600(tmp_path, capsys):
    out = tmp_path / "users.txt"
    assert main(["auth-file", "--agents", "5", "--out", str(out)]) == 0
    assert oct(out.stat().st_mode & 0o777) == "0o600"
    users = {c.user: c.password for c in read_users_file(str(out))}
    assert set(users) == set(ROLES) | {f"agent-{k}" for k in range(5)}
    assert len(set(users.values())) == len(users)  # each its own password
    assert capsys.readouterr().out.strip() == f"users_file={out} agents=5 mode=0600"
    # a second file: fresh passwords (a new run key), not the first file's
    again = tmp_path / "again.txt"
    assert main(["auth-file", "--agents", "5", "--out", str(again)]) == 0
    assert {c.password for c in read_users_file(str(again))}.isdisjoint(users.values())


def test_auth_file_keeps_an_existing_file_unless_forced(tmp_path, capsys):
    out = tmp_path / "users.txt"
    out.write_text("mine\n")
    out.chmod(0o644)
    assert main(["auth-file", "--agents", "2", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists (--force replaces it" in err
    assert out.read_text() == "mine\n"
    assert main(["auth-file", "--agents", "2", "--out", str(out), "--force"]) == 0
    assert oct(out.stat().st_mode & 0o777) == "0o600"  # the replacement's mode, not the old file's
    assert [c.user for c in read_users_file(str(out))][-1] == "agent-1"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["users.txt"]  # no temporary file left beside it


def test_auth_file_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys):
    cases = [
        (["--agents", "0", "--out", str(tmp_path / "a")], "--agents: must be 1..8192"),
        (["--agents", "8193", "--out", str(tmp_path / "a")], "--agents: must be 1..8192"),
        (["--agents", "3", "--out", str(tmp_path / "no" / "such" / "dir")], "cannot write (No such file"),
        (["--agents", "3", "--out", str(tmp_path)], "is a directory"),
        (["--agents", "3", "--out", str(tmp_path / "no" / "dir"), "--force"], "cannot write (No such file"),
    ]
    for args, message in cases:
        assert main(["auth-file", *args]) == 1
        err = capsys.readouterr().err
        assert err.startswith("fluidswarm auth-file: error: ") and err.count("\n") == 1 and message in err, err
    assert list(tmp_path.iterdir()) == []
