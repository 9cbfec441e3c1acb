"""Optional dependencies: a missing one is named by its extra, in one line with exit
status 2 from the ``rperc`` command, never a traceback; ``import rperc`` reaches every
subpackage."""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

import pytest

import rperc
from rperc._extras import EXTRAS, MissingExtraError, require
from rperc.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def without(monkeypatch: pytest.MonkeyPatch):
    """Makes the given top-level modules unimportable, as in a bare install."""

    def hide(*names: str) -> None:
        for name in list(sys.modules):
            if name.split(".")[0] in names:
                monkeypatch.delitem(sys.modules, name)
        for name in names:
            # A None entry makes `import name` raise ModuleNotFoundError(name=name).
            monkeypatch.setitem(sys.modules, name, None)

    return hide


def test_every_extra_named_is_declared_in_pyproject():
    # (tomllib is 3.11+; the section's `name = [` lines are all this needs.)
    text = (ROOT / "pyproject.toml").read_text()
    section = text.split("[project.optional-dependencies]")[1].split("\n[")[0]
    extras = set(re.findall(r"^([\w-]+) = \[", section, re.M))
    assert set(EXTRAS.values()) <= extras
    # `all` installs every extra the library itself names.
    listed = re.search(r'^all = \["rperc\[([\w,-]+)\]"\]', section, re.M)
    assert listed is not None
    assert set(EXTRAS.values()) <= set(listed.group(1).split(","))


@pytest.mark.parametrize("module", sorted(EXTRAS))
def test_a_missing_module_names_its_extra(without, module):
    without(module)
    with pytest.raises(MissingExtraError, match=rf"rperc\[{EXTRAS[module]}\]"):
        require(module, "this feature")


def test_an_import_error_inside_an_installed_module_is_not_hidden(without):
    # numpy is installed; a module it cannot find is a real bug, not a missing extra.
    without("numpy_helper_that_does_not_exist")
    with pytest.raises(ModuleNotFoundError) as info:
        require("numpy.this_submodule_does_not_exist", "x")
    assert not isinstance(info.value, MissingExtraError)


def test_a_command_needing_opencv_exits_2_naming_the_extra(without, capsys, tmp_path):
    without("cv2")
    importlib.import_module("rperc.tracking.planar")
    status = main(["demo", "pattern", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 2
    assert "rperc[opencv]" in err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_reading_a_video_without_imageio_exits_2_naming_the_extra(without, capsys, tmp_path):
    without("imageio")
    video = tmp_path / "clip.mp4"
    video.write_bytes(b"\x00" * 16)
    status = main(["track", str(video), "--box", "1,1,4,4", "--json", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert status == 2
    assert "rperc[video]" in err


@pytest.mark.parametrize("name", rperc.SUBPACKAGES)
def test_import_rperc_reaches_every_subpackage(name):
    assert getattr(rperc, name) is importlib.import_module(f"rperc.{name}")
    assert name in dir(rperc)


def test_a_cluster_run_without_dask_exits_2_naming_the_extra(without, capsys, data):
    without("distributed", "dask")
    corpus = str(data / "otb")
    status = main(["bench", "track", "--corpus", corpus, "--scheduler", "local"])
    err = capsys.readouterr().err
    assert status == 2, err
    assert "rperc[cluster]" in err


def test_demo_all_on_a_bare_install_runs_the_rest_and_names_each_missing_extra(
    without, capsys, tmp_path, monkeypatch
):
    from rperc.cli import demo as demo_module
    from rperc.cli.outputs import DemoResult

    def needs_opencv(out: Path, seed: int) -> DemoResult:
        require("cv2", "the needy demo")
        raise AssertionError("cv2 was hidden")

    def plain(out: Path, seed: int) -> DemoResult:
        return DemoResult("plain: ran", [], {})

    entries = (demo_module.Demo("needy", "x", needs_opencv), demo_module.Demo("plain", "y", plain))
    monkeypatch.setattr(demo_module, "registry", lambda: entries)
    without("cv2")
    # One process: the modules are hidden here, and the demos patched in, only in it.
    status = main(["demo", "all", "--out", str(tmp_path), "--jobs", "1"])
    out, err = capsys.readouterr()
    assert status == 2
    assert out == "plain: ran\n"  # the demo after the one that could not run still ran
    (line,) = [e for e in err.splitlines() if "needy" in e]
    assert "rperc[opencv]" in line and "Traceback" not in err


def test_a_bench_of_an_opencv_peer_without_opencv_exits_2_naming_the_extra(without, capsys, data):
    without("cv2")
    status = main(["bench", "track", "--corpus", str(data / "otb" / "Girl"), "--trackers", "csrt"])
    err = capsys.readouterr().err
    assert status == 2, err
    assert "rperc[opencv]" in err and "Traceback" not in err


def test_the_install_step_lists_what_pip_would_install():
    """``make install`` installs the requirements ``.ci/requirements.py`` prints
    while cargo builds; they must be what ``pip install -e ".[extras]"`` would have
    installed: the core list plus each extra's, read from pyproject.toml here by a
    plain TOML parse, and an unknown extra must stop the install, not be skipped."""
    import subprocess

    tomllib = pytest.importorskip("tomllib", reason="tomllib is in the standard library from 3.11")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    script = [sys.executable, str(ROOT / ".ci" / "requirements.py")]
    listed = subprocess.run([*script, "test", "docs"], capture_output=True, text=True, check=True)
    expected = set(project["dependencies"])
    expected |= set(project["optional-dependencies"]["test"])
    expected |= set(project["optional-dependencies"]["docs"])
    assert set(listed.stdout.split("\n")) - {""} == expected
    bad = subprocess.run([*script, "tset"], capture_output=True, text=True)
    assert bad.returncode != 0 and "tset" in bad.stderr
