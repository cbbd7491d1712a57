"""modal's errors as Python exceptions: the classes, the CLI's message and
exit status, and the scene's file:line:column: key."""

import subprocess

import pytest

import modal


def cli_message(cli, *args):
    out = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    return out.returncode, out.stderr.strip()


def test_class_hierarchy():
    assert issubclass(modal.SceneError, modal.Error) and issubclass(modal.SceneError, ValueError)
    assert issubclass(modal.InputError, modal.Error) and issubclass(modal.InputError, ValueError)
    assert issubclass(modal.SweepInputError, modal.InputError)
    assert issubclass(modal.NumericalError, modal.Error) and issubclass(modal.NumericalError, RuntimeError)
    assert issubclass(modal.SingularMassMatrix, modal.NumericalError)
    assert issubclass(modal.ReportError, modal.Error) and issubclass(modal.ReportError, OSError)
    assert modal.SceneError.__module__ == "modal"


def test_syntax_error_names_file_line_column(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('title = "x"\n\n[parameters]\nm = [1, \n')
    with pytest.raises(modal.SceneError) as info:
        modal.load(path)
    e = info.value
    assert str(e).startswith(f"{path}:{e.line}:{e.column}: ")
    assert e.file == str(path) and e.line >= 4 and e.exit_status == 2


def test_bad_value_names_the_key(tmp_path, models):
    text = (models / "double_pendulum.toml").read_text().replace('mass = "m2"', 'mass = "m3*2"')
    path = tmp_path / "dp.toml"
    path.write_text(text)
    with pytest.raises(modal.SceneError) as info:
        modal.analyze(path)
    e = info.value
    line = text.splitlines().index('mass = "m3*2"') + 1
    assert e.line == line and e.key.endswith(".mass") and "m3" in e.reason
    assert str(e).startswith(f"{path}:{line}:")


def test_messages_are_the_commands(tmp_path, models, cli):
    path = tmp_path / "dp.toml"
    path.write_text((models / "double_pendulum.toml").read_text().replace('mass = "m2"', 'mass = "m3*2"'))
    with pytest.raises(modal.SceneError) as info:
        modal.analyze(path)
    assert cli_message(cli, "analyze", path) == (2, str(info.value))
    with pytest.raises(modal.InputError) as info:
        modal.analyze(models / "double_pendulum.toml", at=[1, 1])
    assert cli_message(cli, "analyze", models / "double_pendulum.toml", "--at", "1,1") == (2, str(info.value))
    free_fall = tmp_path / "fall.toml"
    free_fall.write_text('title = "falls"\ngravity = [0, 0, -9.81]\n[[body]]\nname = "slider"\njoint = "slide"\n'
                         'axis = [0, 0, 1]\nmass = 1.0\n')
    with pytest.raises(modal.NumericalError) as info:
        modal.analyze(free_fall)
    assert cli_message(cli, "analyze", free_fall) == (4, str(info.value))


def test_missing_file_and_dict_errors(tmp_path):
    with pytest.raises(modal.SceneError) as info:
        modal.load(tmp_path / "nothing.toml")
    assert str(tmp_path / "nothing.toml") in str(info.value) and info.value.line is None
    with pytest.raises(modal.SceneError) as info:
        modal.load({"title": "t", "body": [{"name": "a", "joint": "hinge", "axis": [0, 1, 0], "mass": "q*2"}]})
    assert str(info.value).startswith("<dict>:") and info.value.key == "body[1].mass"
    with pytest.raises(modal.SceneError, match="not a parameter"):
        modal.load({"title": "t", "parameters": {"a": 1.0}}, set={"b": 2})


def test_numerical_errors():
    falls = ('title = "falls"\ngravity = [0, 0, -9.81]\n'
             '[[body]]\nname = "s"\njoint = "slide"\naxis = [0, 0, 1]\nmass = 1.0\n')
    with pytest.raises(modal.NumericalError) as info:
        modal.analyze(falls)
    assert str(info.value).startswith("modal: numerical failure: no equilibrium found")
    assert info.value.exit_status == 4
    massless = ('title = "m"\n'
                '[[body]]\nname = "a"\njoint = "hinge"\naxis = [0, 1, 0]\nmass = 0.0\ncom = [0, 0, -1]\nstiffness = 1.0\n')
    with pytest.raises(modal.SingularMassMatrix, match="mass matrix is singular"):
        modal.analyze(massless)


def test_input_errors(models):
    dp = models / "double_pendulum.toml"
    with pytest.raises(modal.InputError, match="'auto', 'dense', 'sparse'"):
        modal.analyze(dp, solver="fast")
    with pytest.raises(modal.InputError, match="--shift applies to the sparse solver"):
        modal.analyze(dp, shift=1.0)
    with pytest.raises(modal.InputError, match="--at expects 2 values"):
        modal.analyze(dp, at=[0, 0, 0])
    with pytest.raises(modal.InputError, match="--step"):
        modal.analyze(dp, step=1e-6)
    with pytest.raises(modal.SweepInputError):
        modal.sweep(dp, vary="nothing=0:1:3")
    with pytest.raises(modal.SweepInputError):
        modal.sweep(dp, vary="g=0:1")
    with pytest.raises(modal.InputError, match="--duration"):
        modal.simulate(dp, duration=-1)
    with pytest.raises(modal.InputError, match="--mode 3"):
        modal.amplitude(dp, mode=3)
    with pytest.raises(TypeError):
        modal.analyze(dp, nonsense=1)


def test_report_error(models, tmp_path):
    a = modal.analyze(models / "double_pendulum.toml")
    with pytest.raises(modal.ReportError) as info:
        a.write(csv=str(tmp_path / "no" / "such" / "dir" / "x"))
    assert info.value.exit_status == 2 and isinstance(info.value, OSError)
    assert not list(tmp_path.iterdir())
