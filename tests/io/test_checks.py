import cv2
import numpy as np
import pytest

from graphseg.io.checks import intrinsics, matrix, positive, reading, rigid
from graphseg.io.images import (
    check_size,
    confine,
    image_size,
    read_rgb,
    read_uint16,
    unique_file_names,
    write_png,
)
from graphseg.io.select import clamped_num_views, describe_views, parse_views, select_indices
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


def test_unknown_views_list_the_valid_ones():
    names = [f"{i:06d}" for i in range(1, 21)]
    valid = "valid: 000001, 000002, 000003, ..., 000018, 000019, 000020 (20 views) or indices 0..19"
    with pytest.raises(SceneError) as err:
        select_indices(20, views=parse_views("000001,000099"), names=names, where="ycbv/0001")
    assert str(err.value) == f"ycbv/0001: views: unknown view 99; {valid}"  # "000099" is no name, so index 99
    with pytest.raises(SceneError) as err:
        select_indices(20, views=["cat"], names=names, where="ycbv/0001")
    assert str(err.value) == f"ycbv/0001: views: unknown view 'cat' (no view has that name); {valid}"
    with pytest.raises(SceneError, match=r"unknown view 3; valid: a, b, c \(3 views\) or indices 0\.\.2$"):
        select_indices(3, views=[3], names=["a", "b", "c"])
    with pytest.raises(SceneError, match=r"unknown view 5; valid: indices 0\.\.1 \(2 views\)$"):
        select_indices(2, views=[5])
    assert describe_views(1, ["only"]) == "valid: only (1 view) or indices 0..0"


def test_num_views_is_clamped_to_the_scene():
    assert clamped_num_views(20, 25) == 20 and clamped_num_views(20, 5) == 5
    assert select_indices(20, num_views=25) == list(range(20))


def test_size_mismatch_is_written_width_x_height_with_a_fix():
    with pytest.raises(SceneError) as err:
        check_size(np.zeros((5, 7), np.uint16), np.zeros((480, 640, 3), np.uint8), "s/depth/000.png", "views[0].depth")
    assert str(err.value) == "s/depth/000.png: views[0].depth: the depth image is 7x5 but the rgb image is 640x480; resize it to 640x480 or remove the view from the scene"
    img = np.zeros((12, 16), np.uint16)
    assert check_size(img, np.zeros((12, 16, 3), np.uint8), "w", "depth") is img


@pytest.mark.parametrize("cut", [12, 200])
def test_truncated_png_prints_nothing_of_its_own(cut, tmp_path, capfd):
    """libpng writes "libpng error: ..." straight to fd 2; only graphseg's SceneError may come out."""
    rng = np.random.default_rng(0)
    write_png(tmp_path / "a.png", rng.integers(0, 255, (48, 64, 3), dtype=np.uint8))
    write_png(tmp_path / "d.png", rng.integers(0, 9999, (48, 64), dtype=np.uint16))
    for name, reader in (("a.png", read_rgb), ("d.png", read_uint16)):
        data = (tmp_path / name).read_bytes()
        (tmp_path / name).write_bytes(data[:-cut] if cut < 100 else data[:cut])
        with pytest.raises(SceneError, match=f"{name}: .*: cannot decode image \\(corrupt, truncated or not an image\\)"):
            reader(tmp_path / name)
    out = capfd.readouterr()
    assert out.err == "" and out.out == ""

