import pytest

from graphseg.backends.weights import load_into, load_state_dict_file
from graphseg.registry import MissingDependencyError
from graphseg.scene import SceneError

torch = pytest.importorskip("torch")


def test_reads_a_bare_and_a_wrapped_state_dict(tmp_path):
    w = {"a.weight": torch.ones(2, 3), "a.bias": torch.zeros(2)}
    torch.save(w, tmp_path / "bare.pt")
    torch.save({"state_dict": {"model": w}, "epoch": 3}, tmp_path / "wrapped.pt")
    for name in ("bare.pt", "wrapped.pt"):
        got = load_state_dict_file(tmp_path / name, "demo")
        assert sorted(got) == ["a.bias", "a.weight"] and tuple(got["a.weight"].shape) == (2, 3)
    # only the wrappers asked for are unwrapped
    assert sorted(load_state_dict_file(tmp_path / "wrapped.pt", "demo", keys=("model",))) == ["epoch", "state_dict"]


def test_strip_prefix_only_when_every_key_has_it(tmp_path):
    torch.save({"model.x": torch.zeros(1), "model.y": torch.zeros(1)}, tmp_path / "all.pt")
    torch.save({"model.x": torch.zeros(1), "y": torch.zeros(1)}, tmp_path / "some.pt")
    assert sorted(load_state_dict_file(tmp_path / "all.pt", "demo", strip_prefix="model.")) == ["x", "y"]
    assert sorted(load_state_dict_file(tmp_path / "some.pt", "demo", strip_prefix="model.")) == ["model.x", "y"]


def test_unreadable_file_and_non_dict_are_one_line_errors(tmp_path):
    (tmp_path / "junk.pt").write_bytes(b"not a torch file\nsecond line")
    with pytest.raises(SceneError) as err:
        load_state_dict_file(tmp_path / "junk.pt", "roma", option="dinov2_checkpoint")
    assert "\n" not in str(err.value) and "cannot read the weights" in str(err.value)
    assert err.value.where == str(tmp_path / "junk.pt") and err.value.field == "backends.options.roma.dinov2_checkpoint"
    torch.save([torch.zeros(1)], tmp_path / "list.pt")
    with pytest.raises(SceneError, match=r"expected a state dict \(got list\)") as err:
        load_state_dict_file(tmp_path / "list.pt", "da3", field="checkpoint")
    assert err.value.field == "checkpoint"


def test_missing_safetensors_names_the_extra(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "safetensors", None)  # import fails as if not installed
    monkeypatch.setitem(sys.modules, "safetensors.torch", None)
    (tmp_path / "m.safetensors").write_bytes(b"")
    with pytest.raises(MissingDependencyError, match=r'graphseg\[da3\]'):
        load_state_dict_file(tmp_path / "m.safetensors", "da3")


def test_load_into_strict_mismatch_is_one_line(tmp_path):
    lin = torch.nn.Linear(3, 2)
    load_into(lin, {"weight": torch.ones(2, 3), "bias": torch.zeros(2)}, tmp_path / "w.pt", "demo")
    assert float(lin.weight.detach().sum()) == 6.0
    with pytest.raises(SceneError, match=r"weights do not fit tiny linear \(") as err:
        load_into(lin, {"weight": torch.ones(2, 3)}, tmp_path / "w.pt", "demo", what="tiny linear")
    assert "\n" not in str(err.value) and err.value.field == "backends.options.demo.checkpoint"
