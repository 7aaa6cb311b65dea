"""The command line (clshade/cli/): every flag validated before any work and refused in one line naming
the flag and its value, usage errors in one line, `--debug` showing the traceback, a child process's exit
status and stderr, commands that measure against the float64 oracle refusing a model it has no formula
for, the warning for a scene without light, and progress shown only on a terminal."""
from __future__ import annotations

import sys

import pytest

from clshade import budget, cli
from clshade.cli import main
from clshade.errors import ClshadeError
from clshade.models.registry import Registry

from conftest import SCENES, refused, render_refused, run_cli, run_cli_process, write_scene
from scene_toml import camera, obj, render, scene, small_red_sphere

BUILT_IN = Registry()          # the built-in lobes
RED_BALL = str(SCENES / "red_ball.toml")
SIZE = ["--width", "24", "--height", "16"]   # tiny renders keep the suite fast


# ---------------------------------------------------------------- flags checked before the work

@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e6", "65"])
def test_exposure_flag_validated_like_the_scene_key(capsys, tmp_path, value):
    err = refused(capsys, ["render", RED_BALL, f"--exposure={value}", "-o", str(tmp_path / "x.png")])
    assert "--exposure" in err and "[-64, 64]" in err
    assert not (tmp_path / "x.png").exists()


def test_empty_model_refused(capsys, tmp_path):
    assert "no model given" in refused(capsys, ["render", RED_BALL, "-m", "", "-o", str(tmp_path / "x.png")])
    assert "no model given" in refused(capsys, ["sweep", "-m", "", "-o", str(tmp_path / "x.png")])


@pytest.mark.parametrize("argv", [["sweep", "--size", "0"], ["sweep", "--size", "-3"],
                                  ["compare", RED_BALL, "--tile", "0"], ["compare", RED_BALL, "--width", "0"]])
def test_sizes_refused(capsys, tmp_path, argv):
    assert "must be within [1, " in refused(capsys, [*argv, "-o", str(tmp_path / "x.png")])


def test_zero_width_option(tmp_path, capsys):
    render_refused(tmp_path, capsys, small_red_sphere(), "--width = 0", extra=["--width", "0"])


@pytest.mark.parametrize("flag, value", [("--frames", "100000000000000000000"), ("--frames", "0"),
                                         ("--warmup", "100000000000000000000"), ("--warmup", "-1")])
def test_bench_frame_counts_are_bounded(tmp_path, capsys, flag, value):
    refused(capsys, ["bench", str(write_scene(tmp_path)), flag, value, *SIZE], f"{flag} = {value}",
            str(budget.MAX_FRAMES))


@pytest.mark.parametrize("args, needle", [
    (["--width", "0"], "--width = 0"), (["--height", "-3"], "--height = -3"),
    (["--numpy-frames", "-1"], "--numpy-frames = -1"), (["--peers", "bogus"], "--peers = 'bogus'"),
    (["--peers", ","], "--peers = ','"), (["--lights", "-1"], "--lights = -1"),
])
def test_bench_options_are_checked(tmp_path, capsys, args, needle):
    refused(capsys, ["bench", str(write_scene(tmp_path)), "--frames", "1", *args], needle)


@pytest.mark.parametrize("value, needles", [
    ("rho_d=nan", ("--param rho_d: 'nan' is not a finite number",)),
    ("alpha_x=1e309", ("--param alpha_x: '1e309' is not a finite number",)),
    ("rho_d=0.5,-inf,0", ("--param rho_d", "not a finite number")),
    ("rho_d=-5", ("--param rho_d=-5: R, G and B must be within [0, 1]", "ward.brdf")),
])
def test_param_values_are_refused_in_one_line(capsys, tmp_path, value, needles):
    """NaN, inf, 1e309 and a colour outside [0, 1] never reach the compiler (`undeclared identifier 'inf'`)
    nor the frame (negative radiance): one line naming the parameter, exit status 2."""
    ward = str(SCENES / "lobes" / "ward.brdf")
    refused(capsys, ["render", RED_BALL, "-m", ward, "--param", value, *SIZE, "-o", str(tmp_path / "x.png")], *needles)
    assert not (tmp_path / "x.png").exists()


def test_a_lobe_file_named_none_renders_itself(capsys, tmp_path):
    """`none` is the registry's "no lobe": a file so named gets its folder's prefix and shades the frame."""
    from clshade.render.image import read_image
    (tmp_path / "none.brdf").write_text((SCENES / "lobes" / "ward.brdf").read_text(encoding="utf-8"),
                                        encoding="utf-8")
    code, out, err = run_cli(capsys, ["render", RED_BALL, "-m", str(tmp_path / "none.brdf"), *SIZE,
                                      "-o", str(tmp_path / "x.exr")])
    assert code == 0 and err == "" and f"{tmp_path.name.lower()}_none" in out, out + err
    assert read_image(tmp_path / "x.exr")[..., :3].max() > 0.01


@pytest.mark.parametrize("model", ["", " ", ","])
def test_stability_with_an_empty_model_is_refused(capsys, model):
    refused(capsys, ["check", "stability", "--model", model], "no model given")


@pytest.mark.parametrize("command", [["bench", "--frames", "1", *SIZE], ["aa", "--frames", "1"],
                                     ["check", "stability"]])
def test_models_without_an_oracle_are_refused_before_the_run(tmp_path, capsys, command):
    """`bench -m phong/metallic` (an empirical lobe has no metallic-workflow formula in the float64 oracle)
    is refused in one line before the run by every command that measures error against the oracle;
    `render` still shades it."""
    scene = write_scene(tmp_path)
    if command[0] == "check":
        args = [*command, "--model", "phong/metallic"]
    else:
        args = [command[0], str(scene), "-m", "phong/metallic", *command[1:]]
        args += ["-o", str(tmp_path / "aa")] if command[0] == "aa" else []
    refused(capsys, args, "'lambert+phong/metallic'", "float64 oracle has no formula", "needs workflow='kdks'")
    code, _, err = run_cli(capsys, ["render", str(scene), "-m", "phong/metallic", "-o", str(tmp_path / "p.png")])
    assert code == 0 and err == ""


# ---------------------------------------------------------------- errors: one line, a traceback under --debug

@pytest.mark.parametrize("argv", [["render", "x.toml", "--tonemap", "filmic"], ["render", "x.toml", "--width", "abc"],
                                  ["check", "nonsense"], ["frobnicate"], ["render"]])
def test_usage_errors_are_one_line(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert len(err.strip().splitlines()) == 1 and ": error: " in err and "--help" in err, err


def test_debug_shows_traceback(tmp_path):
    scene = write_scene(tmp_path, small_red_sphere(red=dict(roughness=2)))
    with pytest.raises(ClshadeError, match="roughness"):
        cli.main(["--debug", "render", str(scene), "-o", str(tmp_path / "o.png")])


def test_subprocess_exit_status_and_one_line(tmp_path):
    scene = write_scene(tmp_path, small_red_sphere(red=dict(roughness=None, roughnes=0.4)))
    proc = run_cli_process(["render", str(scene), "-o", str(tmp_path / "o.png")], tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("clshade: error: ")
    assert "Traceback" not in proc.stderr and "did you mean 'roughness'" in proc.stderr
    assert not (tmp_path / "o.png").exists()


# ---------------------------------------------------------------- what a successful command says

def test_scene_without_lights_warns(capsys, tmp_path):
    parts = [camera(position=[0, 0, 3], width=8, height=8),
             obj(primitive="sphere", material={"base_color": [0.5, 0.5, 0.5]})]
    scene_path = write_scene(tmp_path, scene(*parts), "dark.toml")
    assert main(["render", str(scene_path), "-o", str(tmp_path / "d.png")]) == 0
    err = capsys.readouterr().err
    assert "warning: dark.toml has no [[lights]], no ambient and no emission" in err
    write_scene(tmp_path, scene(render(ambient=0.5), *parts), "dark.toml")
    assert main(["render", str(scene_path), "-o", str(tmp_path / "d.png")]) == 0
    assert "surfaces get only the ambient term" in capsys.readouterr().err


def test_progress_only_on_a_terminal(monkeypatch):
    import io
    from clshade.cli.common import progress_bar

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    with progress_bar("work", "step") as progress:
        assert progress is None                 # not a terminal: no bar, no callback
    assert log.getvalue() == ""
    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    with progress_bar("work", "step") as progress:
        progress(1, 3)
        progress(3, 3)
    assert "work:" in term.getvalue() and "/3 " in term.getvalue()   # drawn (then cleared: leave=False)


def test_long_commands_report_progress(runtime):
    """The loops behind sweep, compare, check stability and models call progress(done, total)."""
    from clshade.compare import sweep_sheet
    from clshade.verify import stability
    calls = []
    sweep_sheet(RED_BALL, [BUILT_IN.resolve("lambert")], (0.2, 0.8), size=4, runtime=runtime,
                progress=lambda d, t: calls.append((d, t)))
    assert calls == [(1, 2), (2, 2)]
    calls.clear()
    stability.run([BUILT_IN.resolve("lambert")], runtime=runtime, fast_math=(False,), shading=False, extras=False,
                  progress=lambda d, t: calls.append((d, t)))
    assert calls == [(1, 1)]
