"""`fluidswarm replay`: pictures, GIF, the three plots with one value per step, fidelity, --check, and
one-line errors for bad files (issue 6)."""

import dataclasses

import numpy as np
import pytest
from PIL import Image

from agent.protocol.errors import UserError
from fluidswarm.cli import main
from fluidswarm.recording.analysis import series
from fluidswarm.recording.reader import check, load_run
from fluidswarm.recording.render import GIF_SIZE, PLOT_SIZE, SNAPSHOT_SIZE, FormationRenderer
from fluidswarm.recording.synthetic import write_synthetic_run
from fluidswarm.replay import replay

STEPS, N = 40, 24


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    path = tmp_path_factory.mktemp("runs") / "run.mcap"
    write_synthetic_run(path, steps=STEPS, n=N, kill={2: 20, 5: 31})
    return path


def _image(path, size):
    assert path.is_file() and path.stat().st_size > 0
    with Image.open(path) as im:
        assert im.size == size
        arr = np.asarray(im.convert("RGB"))
    assert arr.std() > 1.0  # not a blank canvas
    return arr


def test_blitted_frames_equal_a_full_draw_across_a_target_change(recorded):
    """The renderer keeps the axes and target as pixels and draws only what moves: every frame must equal
    matplotlib's full draw of the same figure, also after the target changed mid-run (a gesture sequence)."""
    run = load_run(recorded, images=False)
    first = run.targets[0]
    mid = run.frames[len(run.frames) // 2].t
    run.targets.append(dataclasses.replace(first, t=mid, mask=np.roll(first.mask, 20, axis=1)))
    blit = FormationRenderer(run, GIF_SIZE)
    frames = [blit.render(f) for f in run.frames]
    assert run.scene_at(run.frames[-1].t) is not None  # the scene's waypoints and ellipses are drawn too
    full = FormationRenderer(run, GIF_SIZE)
    for k in (0, len(run.frames) // 2 - 1, len(run.frames) // 2, len(run.frames) - 1):
        full.render(run.frames[k])
        for artist in full.ax.get_children():
            artist.set_animated(False)
        full.canvas.draw()
        want = np.asarray(full.canvas.buffer_rgba())[..., :3]
        assert np.array_equal(frames[k], want), f"frame {k} differs from a full draw"
        for artist in (*full._patches, full._scatter, full._title):
            artist.set_animated(True)
    assert not np.array_equal(frames[0], frames[-1])


def test_replay_writes_snapshots_gif_and_plots(recorded, tmp_path):
    result = replay(recorded, tmp_path / "out", max_frames=15)
    assert len(result.snapshots) == 5
    for snap in result.snapshots:
        _image(snap, SNAPSHOT_SIZE)
    _image(result.gif, GIF_SIZE)
    with Image.open(result.gif) as gif:
        assert gif.n_frames == 15
    assert set(result.plots) == {"speed", "pressure", "distance"}
    for plot in result.plots.values():
        _image(plot, PLOT_SIZE)
    assert result.fidelity is not None and result.fidelity.iou > 0.5  # the synthetic swarm settles on T


def test_plotted_series_have_one_value_per_recorded_step(recorded):
    run = load_run(recorded)
    s = series(run)
    assert len(run.frames) == STEPS
    for values in [s.steps, s.t, s.pressure, s.nn_distance, s.pair_distance, *s.speed_by_class.values()]:
        assert len(values) == STEPS
    assert sorted(s.speed_by_class) == [0, 1, 2]
    assert np.isfinite(s.pressure).all() and np.isfinite(s.nn_distance).all()
    # the synthetic swarm slows down as it settles
    assert all(v[-1] < v[0] for v in s.speed_by_class.values())


def test_series_values_match_a_direct_computation(recorded):
    run = load_run(recorded)
    s = series(run)
    f = run.frames[7]
    d = np.linalg.norm(f.positions[:, None] - f.positions[None], axis=2)
    np.fill_diagonal(d, np.inf)
    assert s.nn_distance[7] == pytest.approx(d.min(axis=1).mean())
    np.fill_diagonal(d, 0)
    assert s.pair_distance[7] == pytest.approx(d.sum() / (len(f.ids) * (len(f.ids) - 1)))
    assert s.pressure[7] == pytest.approx(f.pressure.mean())


def test_cli_replay_prints_fidelity_and_paths(recorded, tmp_path, capsys):
    assert main(["replay", str(recorded), "--out", str(tmp_path / "cli"), "--max-frames", "5"]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert [ln.split("=")[0] for ln in lines[:4]] == ["fidelity_iou", "fidelity_inside", "fidelity_coverage", "nn_cv"]
    assert all(0.0 <= float(ln.split("=")[1]) <= 1.0 for ln in lines[:3])
    assert float(lines[3].split("=")[1]) >= 0.0
    wrote = [ln.removeprefix("wrote ") for ln in lines[4:]]
    assert len(wrote) == 9 and all((tmp_path / "cli").joinpath(p.split("/")[-1]).is_file() for p in wrote)
    assert "replay [" in err  # progress bar on stderr


def test_cli_check(recorded, tmp_path, capsys):
    assert main(["replay", str(recorded), "--check"]) == 0
    assert capsys.readouterr().out.splitlines() == ["complete=true", f"steps={STEPS}", "missing_states=0"]

    lossy = tmp_path / "lossy.mcap"
    from fluidswarm.recording.writer import RunWriter

    with RunWriter(lossy, {"agent_ids": [0, 1]}) as w:
        w.write_states(0, 0.0, [0], [[0, 0]], [[0, 0]], [1], [0], [0])
    assert main(["replay", str(lossy), "--check"]) == 1
    assert capsys.readouterr().out.splitlines() == ["complete=false", "steps=1", "missing_states=1"]


def test_bad_files_are_one_line_user_errors(recorded, tmp_path, capsys):
    missing = tmp_path / "nope.mcap"
    text = tmp_path / "notes.mcap"
    text.write_text("hello, not an mcap file\n")
    truncated = tmp_path / "cut.mcap"
    data = recorded.read_bytes()
    truncated.write_bytes(data[: len(data) // 2])
    for path, words in [(missing, "no such file"), (text, "not an MCAP")]:
        with pytest.raises(UserError, match=words) as info:
            check(path)
        assert str(path) in str(info.value) and "\n" not in str(info.value)
        assert main(["replay", str(path), "--check"]) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(path) in err and words in err
    # A file cut short (its writer died) is read up to its last whole record, and says so (issue 36)
    main(["replay", str(truncated), "--check"])
    out = capsys.readouterr().out
    assert "truncated=true" in out and "bytes_dropped=" in out
