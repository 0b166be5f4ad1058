"""Every command that makes a picture takes --up, --view AZ EL, --size W H and --dpi, and
they reach the picture (fvf.cli.common.add_picture_options)."""

from __future__ import annotations

import numpy as np
import pytest

import fvf

PICTURE_OPTIONS = ["--up", "x", "--view", "30", "10", "--size", "320", "240", "--dpi", "150"]
COMMANDS = {
    "render": ["render", "m.obj", "-o", "p.png"],
    "quad": ["quad", "m.obj", "--faces", "100", "-o", "q.obj", "--png", "p.png"],
    "match": ["match", "a.off", "b.off", "-o", "map.npz", "--png", "p.png"],
    "symmetry": ["symmetry", "a.off", "-o", "s.npz", "--png", "p.png"],
    "flow": ["flow", "m.obj", "d.npz", "--t", "1", "-o", "f.npz", "--png", "p.png"],
    "demo": ["demo"],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_picture_command_takes_the_same_options(command):
    from fvf.cli.common import picture_options
    from fvf.cli.main import parser

    args = parser().parse_args([*COMMANDS[command], *PICTURE_OPTIONS])
    assert picture_options(args) == {
        "up": "x",
        "view": (30.0, 10.0),
        "size": (320, 240),
        "dpi": 150,
    }
    assert picture_options(parser().parse_args(COMMANDS[command])) == {}


def test_quad_png_takes_a_view(tmp_path):
    """``fvf quad --png --view AZ EL``: seen from above (elevation 90) an ellipsoid tall
    in y is drawn as a disc; from the side, twice as tall as wide."""
    pytest.importorskip("matplotlib")
    Image = pytest.importorskip("PIL.Image")
    from fvf.cli.main import main

    ball = fvf.icosphere(2)
    path = tmp_path / "egg.obj"
    fvf.write_mesh(path, ball.vertices * [1.0, 2.0, 1.0], ball.faces)
    shapes = {}
    for elevation in ("0", "90"):
        png = tmp_path / f"q{elevation}.png"
        argv = ["quad", str(path), "--faces", "300", "-o", str(tmp_path / "q.obj"), "--force"]
        argv += ["--png", str(png), "--view", "0", elevation, "--size", "400", "400"]
        assert main(argv) == 0
        img = np.asarray(Image.open(png).convert("RGB")).astype(int)[40:, :275]  # no title, legend
        ys, xs = np.nonzero((img < 240).any(2))
        shapes[elevation] = (np.ptp(xs), np.ptp(ys))
    w, h = shapes["0"]
    assert h > 1.6 * w, shapes
    w, h = shapes["90"]
    assert abs(h - w) < 0.15 * w, shapes


def test_demo_view_aims_every_picture_and_keeps_both_sides_opposite(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    import fvf.viz
    from fvf.cli.report import Story

    seen = []

    def fake_render(mesh, path, **kwargs):
        seen.append(kwargs["view"])
        return fvf.viz.RenderInfo(path=path, backend="matplotlib", size=kwargs["size"])

    monkeypatch.setattr(fvf.viz, "render", fake_render)
    story = Story(tmp_path, True, (200, 150), options={"view": (40.0, 5.0)})
    st = story.begin("a section")
    story.picture(st, "one.png", fvf.icosphere(1), "one")
    story.picture(st, "two.png", fvf.icosphere(1), "two", view=fvf.viz.two_sides())
    one, two = seen
    assert [(v.azimuth, v.elevation, v.turn) for v in one] == [(40.0, 5.0, 0.0)]
    assert [(v.azimuth, v.elevation, v.turn) for v in two] == [(40.0, 5.0, 0.0), (40.0, 5.0, 180.0)]


@pytest.mark.parametrize("command", ["render", "quad", "symmetry", "flow"])
@pytest.mark.parametrize("name", ["kept.npz", "p.jpg", "p"])
def test_a_picture_under_a_name_of_another_kind_is_refused_and_nothing_is_replaced(
    command, name, tmp_path, capsys
):
    """``-o kept.npz`` for a picture used to replace the user's data file with PNG bytes:
    refused before any work, exit status 2, one line naming the fix, the file unchanged."""
    from fvf.cli.main import main

    ball = fvf.icosphere(1)
    mesh = tmp_path / "m.obj"
    fvf.write_mesh(mesh, ball.vertices, ball.faces)
    target = tmp_path / name
    target.write_bytes(b"the user's data")
    argv = [a if a != "p.png" else str(target) for a in COMMANDS[command]]
    argv = [str(mesh) if a in ("m.obj", "a.off") else a for a in argv]
    argv = [str(tmp_path / a) if a.endswith((".npz", ".obj")) and "/" not in a else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "PNG, PDF or SVG" in err and "Fix:" in err, err
    assert target.read_bytes() == b"the user's data"


def test_the_library_refuses_a_picture_suffix_before_drawing(tmp_path):
    viz = pytest.importorskip("fvf.viz")
    pytest.importorskip("matplotlib")
    with pytest.raises(fvf.OutputError, match="PNG, PDF or SVG"):
        viz.render(fvf.icosphere(1), tmp_path / "x.jpg")
    assert not (tmp_path / "x.jpg").exists()
