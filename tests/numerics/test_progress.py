"""One progress option for every long call: None/False (silent), True (a tqdm bar), or a
callback (stage, done, total) — fvf.numerics.progress. Each entrance reports its stages,
ends complete, and refuses a bad value before any work."""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from fvf.flows.fluid import fluid_time_step, ideal_fluid


@pytest.fixture(scope="module")
def sphere():
    return fvf.icosphere(3)  # 642 vertices: above the dense eigensolver's limit


def _recorder():
    seen: list[tuple[str, int, int]] = []
    return seen, lambda stage, done, total: seen.append((stage, done, total))


def _completed(seen, stage):
    rows = [(d, t) for s, d, t in seen if s == stage]
    assert rows, (stage, seen)
    assert all(0 <= d <= t for d, t in rows)
    assert rows[-1][0] == rows[-1][1], rows[-3:]  # the stage ends complete
    return rows


def _rotation(mesh):
    return fvf.rotate(mesh, fvf.gradient(mesh, mesh.vertices[:, 2]))


def test_eigenbasis_reports_factor_and_iterations(sphere):
    seen, cb = _recorder()
    fvf.SpectralBasis(sphere, 20, progress=cb)
    _completed(seen, "factor")
    rows = _completed(seen, "iterate")
    assert rows[-1] == (20, 20)
    seen2, cb2 = _recorder()
    fvf.laplace_basis(sphere, 20, progress=cb2)
    assert seen2 == seen  # the one-off form passes it on


def test_flows_report_their_fraction(sphere):
    f = sphere.vertices[:, 0]
    for method in ("chapter", "skew"):
        seen, cb = _recorder()
        fvf.flow(sphere, _rotation(sphere), f, [0.5, 1.0], method=method, progress=cb)
        assert _completed(seen, "flow")[-1] == (1000, 1000), method
    seen, cb = _recorder()
    fvf.FunctionalFlow(sphere, _rotation(sphere), progress=cb)(f, 1.0)
    _completed(seen, "flow")


def test_transport_and_fluid_report(sphere):
    seen, cb = _recorder()
    v = _rotation(sphere)
    fvf.FieldTransport(sphere, v, progress=cb)(fvf.gradient(sphere, sphere.vertices[:, 0]), 0.3)
    _completed(seen, "transport")
    X = sphere.vertices
    omega0 = np.exp(-8 * ((X - [0, 0, 1]) ** 2).sum(1)) - X[:, 0] ** 2
    dt = fluid_time_step(sphere, omega0)
    for method in ("midpoint", "spectral"):
        seen, cb = _recorder()
        ideal_fluid(sphere, omega0, dt, 5, method=method, k=16, progress=cb)
        assert [d for s, d, _ in seen if s == "steps"] == [1, 2, 3, 4, 5], method


def test_true_draws_tqdm_bars_on_stderr(sphere, capsys):
    pytest.importorskip("tqdm")
    fvf.SpectralBasis(sphere, 10, progress=True)
    fvf.flow(sphere, _rotation(sphere), sphere.vertices[:, 0], 1.0, progress=True)
    out, err = capsys.readouterr()
    assert out == "" and "factor" in err and "flow" in err  # one bar per stage, on stderr


def test_quads_report_each_stage_start_and_end():
    mesh = fvf.icosphere(2)
    seen, cb = _recorder()
    fvf.quad_mesh(mesh, target_faces=120, progress=cb)
    stages = [s for s, d, _ in seen if d == 0]
    assert stages[0] == "cross field" and stages[-1] == "quad extraction", stages
    assert any(s.startswith("Poisson fit") for s in stages)
    for stage in stages:  # every stage that starts also ends
        assert (stage, 1, 1) in seen, stage


@pytest.mark.parametrize(
    "call",
    [
        lambda m: fvf.SpectralBasis(m, 10, progress="yes"),
        lambda m: fvf.flow(m, _rotation(m), m.vertices[:, 0], 1.0, progress="yes"),
        lambda m: fvf.flow(m, _rotation(m), m.vertices[:, 0], 1.0, method="skew", progress=3),
        lambda m: fvf.FunctionalFlow(m, _rotation(m), progress="yes"),
        lambda m: fvf.FieldTransport(m, _rotation(m), progress="yes"),
        lambda m: ideal_fluid(m, m.vertices[:, 0], 0.01, 2, progress="yes"),
        lambda m: fvf.design_field(m, n=4, progress="yes"),
        lambda m: fvf.seamless_parameterization(m, target_faces=100, progress="yes"),
    ],
    ids=["basis", "flow", "skew", "FunctionalFlow", "FieldTransport", "fluid", "design", "quads"],
)
def test_a_bad_progress_value_is_a_parameter_error(sphere, call):
    with pytest.raises(fvf.ParameterError, match="progress must be"):
        call(sphere)


def test_cli_progress_flag_draws_bars(tmp_path, sphere, capsys):
    pytest.importorskip("tqdm")
    from fvf.cli.main import main

    fvf.write_mesh(tmp_path / "s.obj", sphere.vertices, sphere.faces)
    np.savez(tmp_path / "d.npz", f=sphere.vertices[:, 0], v=_rotation(sphere), u=_rotation(sphere))
    mesh, data = str(tmp_path / "s.obj"), str(tmp_path / "d.npz")
    assert main(["flow", mesh, data, "--t", "1", "-o", str(tmp_path / "o"), "--progress"]) == 0
    assert "flow" in capsys.readouterr().err
    assert (
        main(["transport", mesh, data, "--t", "0.2", "-o", str(tmp_path / "p"), "--progress"]) == 0
    )
    assert "transport" in capsys.readouterr().err
    assert main(["flow", mesh, data, "--t", "1", "-o", str(tmp_path / "q")]) == 0
    assert "flow" not in capsys.readouterr().err  # not a terminal: no bars without the flag
