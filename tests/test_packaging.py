"""What `pip install .` ships, checked cheaply: pyproject.toml's package list and package data cover every
file the installed product reads (the scenarios and their inputs, the perception models), and the compiled
programs are found where pip puts them. The real thing — a wheel built from a clean clone, installed in a
fresh venv, `fluidswarm demo` from another folder — is scripts/pip_install_check.sh (minutes: a cold cargo
build), run by hand and in the report of the change that touches packaging."""

from __future__ import annotations

import os
import sysconfig
import tomllib
from pathlib import Path

import pytest

from fluidswarm.cli import main
from fluidswarm.scenario import PACKAGED_SCENARIOS, load_scenario, scenarios_dir
from swarmhost import executable

REPO = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())
SETUPTOOLS = PYPROJECT["tool"]["setuptools"]
EXTENSIONS = [e["target"] for e in PYPROJECT["tool"]["setuptools-rust"]["ext-modules"]]  # built by cargo
ROOTS = ("agent", "swarmhost", "coordinator", "perception", "ros2link", "fluidswarm")


def package_dir(package: str) -> Path:
    mapped = SETUPTOOLS.get("package-dir", {}).get(package)
    return REPO / (mapped or package.replace(".", "/"))


def shipped() -> set[Path]:
    """The files the wheel carries, as setuptools picks them: each listed package's modules and the files
    its package-data patterns ("*": every package's) match."""
    data = SETUPTOOLS["package-data"]
    out: set[Path] = set()
    for package in SETUPTOOLS["packages"]:
        where = package_dir(package)
        out |= set(where.glob("*.py"))
        for pattern in data.get("*", []) + data.get(package, []):
            out |= {p for p in where.glob(pattern) if p.is_file()}
    for target in EXTENSIONS:  # setuptools-rust puts the compiled module in its package (agent/_native*.so)
        package, _, name = target.rpartition(".")
        assert package in SETUPTOOLS["packages"]
        out |= set(package_dir(package).glob(f"{name}.*.so"))
    return out


def test_every_source_package_is_listed_and_the_scenarios_are_one():
    found = {
        ".".join(p.parent.relative_to(REPO).parts)
        for root in ROOTS
        for p in (REPO / root).rglob("__init__.py")
        if "native" not in p.parts
    }
    assert set(SETUPTOOLS["packages"]) == found | {PACKAGED_SCENARIOS}
    assert package_dir(PACKAGED_SCENARIOS) == REPO / "scenarios"  # the top-level folder stays where it is
    assert scenarios_dir() == REPO / "scenarios"  # a source tree reads it in place
    # the research tools (research/: the thesis reproduction) stay outside the wheel
    assert (REPO / "research" / "__init__.py").is_file()
    assert not {p for p in SETUPTOOLS["packages"] if p.split(".")[0] == "research"}


def test_every_file_of_the_packages_and_the_scenarios_ships():
    wheel = shipped()
    files = [
        p
        for root in (*ROOTS, "scenarios")
        for p in (REPO / root).rglob("*")
        if p.is_file()
        and "__pycache__" not in p.parts
        and "native" not in p.relative_to(REPO).parts
        and p.suffix != ".pyc"
    ]
    assert len(files) > 100  # the walk found the tree
    missing = sorted(str(p.relative_to(REPO)) for p in files if p not in wheel)
    assert not missing, f"not in pyproject.toml's packages/package-data, so not installed: {missing}"


def test_every_input_a_scenario_reads_ships_beside_it():
    wheel = shipped()
    scenarios = sorted((REPO / "scenarios").glob("*.toml"))
    assert (REPO / "scenarios" / "demo_v_sign.toml") in scenarios
    for path in scenarios:
        assert path in wheel
        sc = load_scenario(path)
        src = sc.input_path()
        if src is None:
            continue
        # relative to the scenario file: the installed copy (site-packages/fluidswarm/scenarios) finds it too
        assert src == (path.parent / sc.input).resolve(), f"{path.name}: input {sc.input} not beside the scenario"
        needed = sorted(src.rglob("*")) if src.is_dir() else [src]
        assert needed and all(f in wheel for f in needed if f.is_file()), f"{path.name}: {sc.input} not shipped"


def test_a_shipped_scenario_is_found_by_name_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name in ("demo_v_sign", "demo_v_sign.toml", "scenarios/demo_v_sign.toml"):
        sc = load_scenario(name)
        assert sc.path == REPO / "scenarios" / "demo_v_sign.toml"
        assert sc.input_path().is_file()
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "demo_v_sign.toml").write_text('name = "mine"\nexperiment = "branching"\n')
    assert load_scenario("scenarios/demo_v_sign.toml").name == "mine"  # a file that exists wins


@pytest.fixture
def no_build(tmp_path, monkeypatch):
    """No source-tree build and an empty scripts folder: where an installed package looks, and finds nothing."""
    monkeypatch.delenv(executable.ENV_OVERRIDE, raising=False)
    monkeypatch.delenv(executable.ROUTER_ENV_OVERRIDE, raising=False)
    monkeypatch.setattr(executable, "NATIVE_DIR", tmp_path / "site-packages" / "agent" / "native")
    scripts = tmp_path / "bin"
    scripts.mkdir()
    monkeypatch.setattr(executable, "installed_dirs", lambda: [scripts])
    return scripts


def _program(path: Path) -> Path:
    path.write_text("#!/bin/sh\n")
    path.chmod(0o755)
    return path


def test_an_installed_program_is_found_in_the_scripts_folder(no_build):
    with pytest.raises(executable.AgentNotBuilt, match=r"not installed .*https://rustup.rs") as err:
        executable.agent_executable()
    assert "\n" not in str(err.value)
    agent, router = _program(no_build / "fluidswarm-agent"), _program(no_build / "fluidswarm-router")
    assert executable.agent_executable() == str(agent)
    assert executable.router_executable() == str(router)


def test_the_environment_overrides_and_a_bad_override_is_named(no_build, tmp_path, monkeypatch):
    _program(no_build / "fluidswarm-agent")
    own = tmp_path / "own"
    own.mkdir()
    monkeypatch.setenv(executable.ENV_OVERRIDE, str(_program(own / "fluidswarm-agent")))
    assert executable.agent_executable() == str(own / "fluidswarm-agent")
    with pytest.raises(executable.AgentNotBuilt, match="next to"):  # the router is taken from beside it
        executable.router_executable()
    monkeypatch.setenv(executable.ROUTER_ENV_OVERRIDE, str(tmp_path / "nowhere"))
    with pytest.raises(executable.AgentNotBuilt, match=f"{executable.ROUTER_ENV_OVERRIDE}=.*nowhere"):
        executable.router_executable()


def test_the_lookup_covers_pips_layouts():
    dirs = executable.installed_dirs()
    assert dirs[0] == Path(sysconfig.get_path("scripts"))  # a venv's bin/, where the wheel's scripts go
    assert len(dirs) == len(set(dirs))
    prefix = Path("/opt/p")  # pip install --prefix /opt/p: /opt/p/lib/python3.X/site-packages/swarmhost
    assert (
        executable._parent_above(
            prefix / "lib" / "python3.11" / "site-packages" / "swarmhost", "lib/python*/site-packages/swarmhost"
        )
        == prefix
    )
    assert executable._parent_above(Path("/opt/t/swarmhost"), "lib/python*/site-packages/swarmhost") is None


def test_a_missing_agent_program_is_one_line_and_exit_1(no_build, capsys):
    code = main(["agent", "--spec", "{}"])
    err = capsys.readouterr().err
    assert code == 1 and "Traceback" not in err
    assert err.count("\n") == 1 and "fluidswarm-agent is not installed" in err and "rustup" in err
    assert os.environ.get(executable.ENV_OVERRIDE) is None
