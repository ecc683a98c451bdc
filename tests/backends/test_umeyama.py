import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphseg.backends.lifters.align import umeyama


def test_shapes():
    s, R, t = umeyama(np.random.default_rng(0).normal(size=(5, 3)), np.random.default_rng(1).normal(size=(5, 3)))
    assert isinstance(s, float) and R.shape == (3, 3) and t.shape == (3,)
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_recovers_a_similarity():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(20, 3))
    R0 = Rotation.from_euler("xyz", [10, -40, 75], degrees=True).as_matrix()
    dst = 3.5 * src @ R0.T + [0.1, -2, 5]
    s, R, t = umeyama(src, dst)
    assert s == pytest.approx(3.5)
    np.testing.assert_allclose(R, R0, atol=1e-9)
    np.testing.assert_allclose(t, [0.1, -2, 5], atol=1e-9)
    s1, _, _ = umeyama(src, dst, with_scale=False)
    assert s1 == 1.0


def test_reflection_is_not_returned():
    src = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    dst = src * [1, 1, -1]  # a mirror image: the best proper rotation, not the reflection
    _, R, _ = umeyama(src, dst)
    assert np.linalg.det(R) == pytest.approx(1.0)


@pytest.mark.parametrize("a, b", [(np.zeros((3, 2)), np.zeros((3, 2))), (np.zeros((3, 3)), np.zeros((4, 3))), (np.zeros((0, 3)), np.zeros((0, 3)))])
def test_bad_shapes(a, b):
    with pytest.raises(ValueError, match="expected"):
        umeyama(a, b)


def test_nan_rejected():
    a = np.zeros((3, 3))
    a[0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        umeyama(a, np.zeros((3, 3)))
