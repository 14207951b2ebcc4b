"""The command line, end to end in a subprocess."""

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

import xrough


def run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "xrough.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli")
    topo = xrough.self_affine_surface(hurst=0.8, lambda_r="2 um", lambda_s="100 nm",
                                      size="8 um", n=256, rms_gradient=0.5, seed=1,
                                      unit="nm")
    topo.to_netcdf(folder / "afm.nc")
    (folder / "broken.nc").write_bytes(b"CDF\x01" + b"\x00" * 20)
    (folder / "noise.xyz").write_bytes(bytes(range(256)) * 4)
    return folder, topo


def test_info(files):
    folder, topo = files
    res = run("info", "afm.nc", cwd=folder)
    assert res.returncode == 0, res.stderr
    assert "256 x 256 points" in res.stdout and "netcdf" in res.stdout


def test_acf_writes_netcdf(files):
    folder, topo = files
    res = run("acf", "afm.nc", "-o", "g.nc", cwd=folder)
    assert res.returncode == 0, res.stderr
    back = xrough.open_analysis(folder / "g.nc")
    xr.testing.assert_allclose(back["afm"]["G"], topo.rough.acf())
    assert back["afm"]["G"].attrs["source_sha256"] == xrough.io.file_sha256(folder / "afm.nc")


def test_report_table_figure_and_archive(files):
    folder, _ = files
    res = run("report", "afm.nc", "--E-star", "25MPa", "--p0", "0.1MPa", "--gamma",
              "50mJ/m^2", "-o", "out/report.nc", cwd=folder)
    assert res.returncode == 0, res.stderr
    for column in ("sigma_h", "H", "lambda_r", "rms grad", "v_el", "a_r", "sigma_c",
                   "patch radius"):
        assert column in res.stdout
    assert (folder / "out" / "report.png").stat().st_size > 10_000
    back = xrough.open_analysis(folder / "out" / "report.nc")
    assert set(back["afm"]) >= {"G", "fit", "persson", "energy", "patch", "gradient"}
    assert "E_star=25MPa" in back["_provenance"]["history"]
    assert np.isfinite(float(back["afm"]["energy"].v_el))


@pytest.mark.parametrize("args, message", [
    (("info", "missing.nc"), "no such file"),
    (("info", "broken.nc"), "broken.nc"),
    (("info", "noise.xyz"), "noise.xyz"),
    (("report", "afm.nc", "--E-star=-1MPa", "--p0", "1MPa"), "E_star"),
    (("report", "afm.nc", "--E-star", "25 nm", "--p0", "1MPa"), "not a pressure"),
])
def test_bad_input_exits_1_with_a_one_line_reason(files, args, message):
    folder, _ = files
    res = run(*args, cwd=folder)
    assert res.returncode == 1
    assert message in res.stderr and len(res.stderr.strip().splitlines()) == 1
