"""Tests of drake_disamb.diagram_io."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Gain

from drake_disamb.diagram_io import write_diagram_graph


def _small_diagram():
    builder = DiagramBuilder()
    src = builder.AddNamedSystem("source", ConstantVectorSource([1.0, 2.0]))
    gain = builder.AddNamedSystem("gain", Gain(3.0, 2))
    builder.Connect(src.get_output_port(), gain.get_input_port())
    builder.ExportOutput(gain.get_output_port(), "y")
    return builder.Build()


def test_writes_dot_without_dot_program(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    written = write_diagram_graph(_small_diagram(), tmp_path / "sub" / "pic")
    assert written == [tmp_path / "sub" / "pic.dot"]
    text = written[0].read_text()
    assert text.startswith("digraph") and "gain" in text and "source" in text
    assert not (tmp_path / "sub" / "pic.svg").exists()


def test_writes_svg_with_a_dot_program(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # A stand-in `dot` that copies its input: checks we call it with -Tsvg and report the file.
    bindir = tmp_path / "bin"
    bindir.mkdir()
    fake = bindir / "dot"
    fake.write_text('#!/bin/sh\n[ "$1" = "-Tsvg" ] || exit 3\necho "<svg>" > "$4"\n')
    fake.chmod(fake.stat().st_mode | stat.S_IXUSR)
    monkeypatch.setenv("PATH", str(bindir) + os.pathsep + os.environ.get("PATH", ""))
    written = write_diagram_graph(_small_diagram(), tmp_path / "pic", max_depth=0)
    assert [p.name for p in written] == ["pic.dot", "pic.svg"]
    assert written[1].read_text().strip() == "<svg>"


def test_failing_dot_is_skipped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bindir = tmp_path / "bin"
    bindir.mkdir()
    fake = bindir / "dot"
    fake.write_text("#!/bin/sh\nexit 1\n")
    fake.chmod(fake.stat().st_mode | stat.S_IXUSR)
    monkeypatch.setenv("PATH", str(bindir))
    written = write_diagram_graph(_small_diagram(), tmp_path / "pic")
    assert [p.name for p in written] == ["pic.dot"]


@pytest.mark.parametrize("depth", [-1, 1.5, True])
def test_bad_depth(tmp_path: Path, depth) -> None:
    with pytest.raises(ValueError, match="max_depth"):
        write_diagram_graph(_small_diagram(), tmp_path / "pic", max_depth=depth)


def test_bad_diagram(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="diagram"):
        write_diagram_graph(object(), tmp_path / "pic")
