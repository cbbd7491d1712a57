"""HTML reports through the Python writers: each result's write(report=...)
writes the page `modal COMMAND --report` writes, byte for byte, with the same
data (the command of the same build is the reference; the pages' contents are
tested in C++ and in a browser by ctest), and all files or none."""

import subprocess

import pytest

import modal


def command_page(cli, tmp_path, args):
    """The page the command writes for `args` (one run, its own directory)."""
    page = tmp_path / "command.html"
    subprocess.run([cli] + args + ["--report", str(page)], check=True, capture_output=True)
    return page.read_text()


def test_every_result_writes_its_report(models, cli, tmp_path):
    dp = str(models / "double_pendulum.toml")
    cases = [
        (modal.analyze(dp, drawing=True), ["analyze", dp]),
        (modal.equilibria(dp), ["equilibria", dp]),
        (modal.sweep(str(models / "ziegler.toml"), vary="P=0:4:9"), ["sweep", str(models / "ziegler.toml"),
                                                                    "--vary", "P=0:4:9"]),
        (modal.simulate(dp, 2.0, at=[0.3, 0.0], interval=0.01), ["simulate", dp, "--duration", "2", "--at", "0.3,0",
                                                                  "--interval", "0.01"]),
        (modal.amplitude(dp, points=3, cycles=1), ["amplitude", dp, "--points", "3", "--cycles", "1"]),
    ]
    for result, args in cases:
        page = tmp_path / f"{args[0]}.html"
        result.write(report=str(page))
        text = page.read_text()
        assert text.startswith("<!DOCTYPE html>"), args[0]
        assert "src=\"http" not in text and "<link" not in text, args[0]  # self-contained
        # The command's page of the same scene and options, but for the
        # timings and paths in it: the same data block.
        reference = command_page(cli, tmp_path, args)
        start = '<script type="application/json" id="modal-data">'
        assert start in text and start in reference, args[0]
        data = text.split(start, 1)[1].split("</script>", 1)[0]
        expected = reference.split(start, 1)[1].split("</script>", 1)[0]
        assert data == expected, args[0]


def test_analysis_without_drawing_writes_bar_charts(models, tmp_path):
    a = modal.analyze(models / "double_pendulum.toml")
    a.write(report=str(tmp_path / "dp.html"))
    text = (tmp_path / "dp.html").read_text()
    assert '"shapes"' in text  # the bar charts' data, no drawing
    assert 'id="modal-drawing">null<' in text


def test_reports_are_written_with_the_other_files_or_not_at_all(models, tmp_path):
    s = modal.sweep(str(models / "ziegler.toml"), vary="P=0:4:9")
    with pytest.raises(modal.ReportError):
        s.write(csv=str(tmp_path / "z.csv"), report=str(tmp_path / "no" / "such" / "dir" / "z.html"))
    assert not (tmp_path / "z.csv").exists()
    with pytest.raises(modal.InputError, match="at least one file"):
        s.write()
    s.write(csv=str(tmp_path / "z.csv"), report=str(tmp_path / "z.html"))
    assert (tmp_path / "z.csv").exists() and (tmp_path / "z.html").exists()
