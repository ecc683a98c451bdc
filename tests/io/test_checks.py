import cv2
import numpy as np
import pytest

from graphseg.io.checks import intrinsics, matrix, positive, reading, rigid
from graphseg.io.images import confine, image_size, unique_file_names
from graphseg.io.select import parse_views, select_indices
from graphseg.scene import SceneError


@pytest.mark.parametrize("ext", [".png", ".jpg"])
@pytest.mark.parametrize("shape", [(1, 1), (37, 91), (480, 640)])
def test_image_size_reads_headers(ext, shape):
    ok, buf = cv2.imencode(ext, np.zeros((*shape, 3), np.uint8))
    assert ok and image_size(buf.tobytes()[:65536]) == (shape[1], shape[0])


def test_image_size_unknown_or_truncated():
    assert image_size(b"") is None and image_size(b"\xff\xd8\xff") is None and image_size(b"BM....") is None


def test_confine(tmp_path):
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "a.png").write_bytes(b"x")
    (tmp_path / "s" / "in.png").symlink_to(tmp_path / "s" / "a.png")  # a link inside is fine
    (tmp_path / "s" / "out.png").symlink_to(tmp_path / "secret")
    assert confine(tmp_path / "s", "in.png", where="w", field="f").name == "in.png"
    for bad, msg in [("out.png", "leaves"), ("../secret", "leaves"), (str(tmp_path / "secret"), "absolute"), ("", "relative path"), (3, "relative path")]:
        with pytest.raises(SceneError, match=msg):
            confine(tmp_path / "s", bad, where="w", field="f")


def test_checks_name_the_field():
    assert rigid(np.eye(4), where="w", field="T").shape == (4, 4)
    assert matrix(list(range(9)), (3, 3), where="w", field="K").shape == (3, 3)  # BOP-style flat list
    with pytest.raises(SceneError, match="w: K: focal lengths"):
        intrinsics(np.diag([1.0, -1, 1]), where="w", field="K")
    with pytest.raises(SceneError, match="last row"):
        intrinsics([[1, 0, 0], [0, 1, 0], [0, 1, 1]], where="w", field="K")
    with pytest.raises(SceneError, match="w: s: expected a positive finite number"):
        positive(float("inf"), where="w", field="s")
    with pytest.raises(SceneError, match="w: meta: malformed \\(KeyError"):
        with reading("w", "meta"):
            {}["x"]
    with pytest.raises(SceneError, match="w: meta: malformed \\(LinAlgError"):
        with reading("w", "meta"):
            np.linalg.inv(np.zeros((3, 3)))


def test_views_names_first_then_indices():
    names = ["000001", "000006", "3"]
    assert select_indices(3, views=parse_views("000006,000001"), names=names) == [1, 0]
    assert select_indices(3, views=parse_views("3"), names=names) == [2]  # the name "3", not index 3
    assert select_indices(3, views=parse_views("1,-1"), names=names) == [1, 2]
    with pytest.raises(SceneError, match="unknown view 5"):
        select_indices(3, views=["5"], names=names)


def test_unique_file_names_never_collide():
    names = ["a/b", "a_b", "a?b", "A_B", ".hidden", "", "a_b-2"]
    out = unique_file_names(names)
    assert len({n.lower() for n in out}) == len(out)
    assert all(n and not n.startswith(".") and "/" not in n for n in out)


def test_read_ply_rejects_malformed_files(tmp_path):
    from graphseg.io import read_ply, write_ply

    write_ply(tmp_path / "a.ply", np.zeros((4, 3), np.float32))
    good = (tmp_path / "a.ply").read_bytes()
    (tmp_path / "b.ply").write_bytes(good.replace(b"element vertex 4", b"element vertex 4000000000"))
    (tmp_path / "c.ply").write_bytes(b"garbage")
    for name, msg in [("b.ply", "declares 4000000000 vertices"), ("c.ply", "not a PLY")]:
        with pytest.raises(ValueError, match=msg):
            read_ply(tmp_path / name)
    assert read_ply(tmp_path / "a.ply")[0].shape == (4, 3)
