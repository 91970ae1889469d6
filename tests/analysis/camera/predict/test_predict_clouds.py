"""analysis.camera.predict.clouds: point clouds in (text tables, meshio formats), one-line
errors."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from analysis.camera.predict.clouds import read_cloud, write_cloud
from analysis.errors import AnalysisError, CloudError


@pytest.fixture
def cloud():
    rng = np.random.default_rng(0)
    return rng.normal(scale=[120.0, 80.0, 40.0], size=(50, 3)) + np.array([0.0, 0.0, 300.0])


def _one_line_error(path: Path, **kw) -> str:
    with pytest.raises(CloudError) as info:
        read_cloud(path, **kw)
    msg = str(info.value)
    assert "\n" not in msg
    assert path.name in msg or str(path) in msg
    return msg


def test_cloud_error_is_an_analysis_value_error():
    assert issubclass(CloudError, AnalysisError) and issubclass(CloudError, ValueError)


@pytest.mark.parametrize("name", ["c.csv", "c.txt", "c.xyz", "c.asc", "c.ply", "c.vtk",
                                  "c.vtu"])
def test_write_then_read_gives_the_same_float64_points(tmp_path, cloud, name):
    path = write_cloud(tmp_path / name, cloud)
    xyz = read_cloud(path)
    assert xyz.dtype == np.float64 and xyz.shape == (50, 3)
    np.testing.assert_array_equal(xyz, cloud)


def test_units_m_gives_mm(tmp_path, cloud):
    path = write_cloud(tmp_path / "m.csv", cloud / 1000.0)
    np.testing.assert_allclose(read_cloud(path, units="m"), cloud, rtol=1e-12)


@pytest.mark.parametrize("text", [
    "x,y,z\n1,2,3\n4,5,6\n",                                   # named header
    "# a comment\n\n1 2 3\n4\t5   6\n",                          # whitespace, no header
    "id,Z [mm],X [mm],Y [mm],r\np1,3,1,2,9\np2,6,4,5,9\n",       # named, reordered, units
    "p1,1,2,3\np2,4,5,6\n",                                      # label column, no header
    'label,a,b,c\n"p1","1","2","3"\n"p2",4,5,6\n',               # quoted, unnamed header
    "x;y;z\n1;2;3\n4;5;6  # trailing comment\n",                 # semicolons
    "\ufeffx_mm,y_mm,z_mm,nx,ny,nz\r\n1,2,3,0,0,1\r\n4,5,6,0,0,1\r\n",  # BOM, CRLF, normals
])
def test_text_variants(tmp_path, text):
    path = tmp_path / "v.csv"
    path.write_bytes(text.encode())
    np.testing.assert_array_equal(read_cloud(path), [[1, 2, 3], [4, 5, 6]])


HOSTILE = {
    "header.csv": ("x,y,z\n", "no points"),
    "comments.txt": ("# nothing\n\n   \n", "no data lines"),
    "two.csv": ("1,2\n3,4\n", "column"),
    "short.csv": ("x,y,z\n1,2,3\n4,5\n", "line 3"),
    "word.csv": ("x,y,z\n1,2,3\n4,abc,6\n", "'abc' is not a number"),
    "code.csv": ("x,y,z\n1,2,3\n__import__('os').system('touch pwned'),2,3\n", "not a number"),
    "blank.csv": ("x,y,z\n1,2,3\n4,,6\n", "empty"),
    "nan.csv": ("x,y,z\n1,2,3\nnan,5,6\n", "NaN or inf at line 3"),
    "inf.txt": ("1 2 3\n4 -inf 6\n", "NaN or inf at line 2"),
    "comma.csv": ("x;y;z\n1,5;2;3\n", "decimal point"),
    "unknown.foo": ("1,2,3\n", "unknown extension"),
    "noext": ("1,2,3\n", "unknown extension"),
}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_bad_text_files_give_one_line(tmp_path, name):
    text, expected = HOSTILE[name]
    path = tmp_path / name
    path.write_text(text)
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        msg = _one_line_error(path)
    finally:
        os.chdir(cwd)
    assert expected in msg
    assert not (tmp_path / "pwned").exists()


@pytest.mark.parametrize("name,expected", [
    ("garbage.csv", "binary data"),
    ("garbage.txt", "binary data"),
    ("garbage.ply", "not a readable PLY"),
    ("garbage.vtk", "not a readable VTK"),
    ("garbage.vtu", "not a readable VTU"),  # meshio calls sys.exit on this one
    ("garbage.stl", "not a readable STL"),
    ("garbage.msh", "not a readable GMSH"),
])
def test_binary_garbage_gives_one_line(tmp_path, name, expected):
    path = tmp_path / name
    path.write_bytes(np.random.default_rng(1).bytes(4000))
    assert expected in _one_line_error(path)


def test_latin1_text_gives_one_line(tmp_path):
    path = tmp_path / "latin.csv"
    path.write_bytes(b"x,y,z\n1,2,3\n" * 3 + "4,5,6 # \xb0".encode("latin-1") + b"\n")
    assert "not UTF-8" in _one_line_error(path)


def test_missing_empty_directory(tmp_path):
    assert "no such file" in _one_line_error(tmp_path / "absent.csv")
    (tmp_path / "empty.csv").touch()
    assert "empty" in _one_line_error(tmp_path / "empty.csv")
    (tmp_path / "dir.csv").mkdir()
    assert "directory" in _one_line_error(tmp_path / "dir.csv")


@pytest.mark.skipif(not Path("/dev/null").exists(), reason="no /dev/null")
def test_a_device_is_refused():
    assert "not a regular file" in _one_line_error(Path("/dev/null"))


def test_too_many_points(tmp_path, cloud):
    path = write_cloud(tmp_path / "big.csv", cloud)
    assert "more than 40 points" in _one_line_error(path, max_points=40)
    ply = write_cloud(tmp_path / "big.ply", cloud)
    assert "more than 40 points" in _one_line_error(ply, max_points=40)
    assert "bytes, more than" in _one_line_error(path, max_points=2)  # by size, unread


def test_a_mesh_with_nan_points(tmp_path):
    import meshio

    pts = np.array([[0.0, 0.0, 0.0], [1.0, np.nan, 0.0], [0.0, 1.0, 0.0]])
    meshio.write_points_cells(tmp_path / "n.vtu", pts, [("vertex", np.arange(3)[:, None])])
    assert "NaN or inf" in _one_line_error(tmp_path / "n.vtu")


def test_write_cloud_refuses_bad_clouds(tmp_path):
    for bad in (np.zeros((4, 2)), np.zeros((0, 3)), np.array([[0.0, np.inf, 1.0]])):
        with pytest.raises(CloudError):
            write_cloud(tmp_path / "b.csv", bad)
    with pytest.raises(CloudError, match="unknown extension"):
        write_cloud(tmp_path / "b.stl", np.zeros((3, 3)))
