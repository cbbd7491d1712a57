"""modal.load: a path, TOML text, a dict and a Model give the same scene;
overrides as numbers or expressions."""

import math
import pathlib

import numpy as np
import pytest

import modal
from modal import _toml

DOUBLE_PENDULUM = {
    "title": "Planar double pendulum (point masses)",
    "gravity": [0, 0, "-g"],
    "parameters": {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 1.0},
    "body": [
        {"name": "upper", "joint": "hinge", "axis": [0, 1, 0], "mass": "m1", "com": [0, 0, "-l1"]},
        {"name": "lower", "parent": "upper", "joint": "hinge", "axis": [0, 1, 0], "origin": [0, 0, "-l1"],
         "mass": "m2", "com": [0, 0, "-l2"]},
    ],
}


def same_analysis(a, b):
    np.testing.assert_array_equal(a.omega2, b.omega2)
    np.testing.assert_array_equal(a.M, b.M)
    np.testing.assert_array_equal(a.K, b.K)
    np.testing.assert_array_equal(a.shapes, b.shapes)
    assert a.coordinates == b.coordinates and a.parameters == b.parameters and a.title == b.title


def test_path_text_dict_and_model_agree(models):
    path = models / "double_pendulum.toml"
    from_path = modal.load(path)
    from_str_path = modal.load(str(path))
    from_text = modal.load(path.read_text())
    from_dict = modal.load(DOUBLE_PENDULUM)
    assert from_path.file == str(path) and from_text.file == "<string>" and from_dict.file == "<dict>"
    for m in (from_str_path, from_text, from_dict):
        assert m.title == from_path.title and m.coordinates == from_path.coordinates
        assert m.parameters == from_path.parameters and m.size == 2
    reference = modal.analyze(from_path)
    for m in (from_str_path, from_text, from_dict):
        same_analysis(modal.analyze(m), reference)
    assert modal.load(from_path) is from_path
    assert list(from_path.parameters) == ["m1", "m2", "l1", "l2", "g"]  # file order
    assert from_path.kinds == ["angle", "angle"]
    assert "upper" in from_path.summary()


def test_overrides_numbers_and_expressions(models):
    path = models / "double_pendulum.toml"
    m = modal.load(path, set={"m2": 2, "l2": "2*l1", "g": 9.81})
    assert m.parameters == {"m1": 1.0, "m2": 2.0, "l1": 1.0, "l2": 2.0, "g": 9.81}
    assert m.overrides == ["m2=2", "l2=2*l1", "g=9.81"]
    same_analysis(modal.analyze(path, set=["m2=2", "l2=2*l1", "g=9.81"]), modal.analyze(m))
    # Overrides on a Model add to its own; on a dict as on a file.
    again = modal.load(modal.load(path, set={"m2": 2}), set={"l2": "2*l1", "g": 9.81})
    assert again.parameters == m.parameters
    same_analysis(modal.analyze(DOUBLE_PENDULUM, set={"m2": 2, "l2": "2*l1", "g": 9.81}), modal.analyze(m))
    # Closed form (R1) with the overrides: g/(2 m1 l1 l2)[(m1+m2)(l1+l2) ∓ sqrt(...)].
    m1, m2, l1, l2, g = 1.0, 2.0, 1.0, 2.0, 9.81
    root = math.sqrt((m1 + m2) * ((m1 + m2) * (l1 + l2) ** 2 - 4 * m1 * l1 * l2))
    expected = g / (2 * m1 * l1 * l2) * np.array([(m1 + m2) * (l1 + l2) - root, (m1 + m2) * (l1 + l2) + root])
    a = modal.analyze(m)
    assert np.all(np.abs(a.omega2 - expected) <= a.errors + 1e-14 * expected)
    # Numbers keep every digit.
    x = 0.1 + 0.2
    assert modal.load(path, set={"g": x}).parameters["g"] == x
    assert modal.load(path, set={"g": np.float64(x)}).parameters["g"] == x


def test_dict_serializer_round_trips_awkward_values():
    doc = {
        "title": 'quote " backslash \\ tab \t newline \n unicode ω²',
        "parameters": {"a": 1, "b-c": 2.5e-300, "big": 1e20, "neg": -0.0},
        "weird key": {"nested": {"deep": [1, 2, [3, 4]]}, "flag": True},
        "array": [{"x": 1, "sub": {"y": "z"}, "list": [{"inline": 1}]}, {"x": 2}],
        "np": np.arange(3.0),
    }
    text = _toml.dumps(doc)
    import tomllib
    parsed = tomllib.loads(text)
    assert parsed["title"] == doc["title"]
    assert parsed["parameters"] == {"a": 1, "b-c": 2.5e-300, "big": 1e20, "neg": -0.0}
    assert parsed["weird key"] == {"nested": {"deep": [1, 2, [3, 4]]}, "flag": True}
    assert parsed["array"] == [{"x": 1, "sub": {"y": "z"}, "list": [{"inline": 1}]}, {"x": 2}]
    assert parsed["np"] == [0.0, 1.0, 2.0]
    assert list(parsed["parameters"]) == ["a", "b-c", "big", "neg"]
    with pytest.raises(TypeError):
        _toml.dumps({"x": object()})


def test_text_name_and_pathlike(models, tmp_path):
    text = (models / "double_pendulum.toml").read_text()
    m = modal.load(text, name="dp.toml")
    assert m.file == "dp.toml"
    p = tmp_path / "copy.toml"
    p.write_text(text)
    assert modal.load(p).file == str(p)
    assert modal.load(pathlib.Path(str(p))).size == 2
    with pytest.raises(TypeError):
        modal.load(42)
