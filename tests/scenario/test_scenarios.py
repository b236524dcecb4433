"""Scenario validation: every problem at once, suggestions, merging, registry."""

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from hammerstein import runner
from hammerstein.signals.references import REFERENCE_KINDS
from hammerstein.scenario import registry
from hammerstein.scenario.resolve import load_scenario
from hammerstein.scenario.schema import ScenarioError
from hammerstein.scenario.validate import validate_scenario

ROOT = Path(__file__).resolve().parents[2]
BUNDLED = sorted(p for p in (ROOT / "scenarios").rglob("*.toml")
                 if "presets" not in p.relative_to(ROOT / "scenarios").parts)   # preset files

GOOD_CASE = """
[[cases]]
name = "x"
reference = { kind = "sine", output = "x", amplitude = 50.0, frequency = 50.0, periods = 2 }
"""
HEAD = """
[plant]
preset = "rakotondrabe-2dof"
dynamics = false
[compensator]
kind = "multivariable"
"""


def _write(tmp_path, text, name="s.toml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_bundled_scenarios_exist():
    names = {p.name for p in BUNDLED}
    for fig in ["fig05-characterization", "fig08-compensated-sine", "fig10-circles",
                "fig11-spiral", "fig12-lissajous-3-2", "fig13-lissajous-4-3"]:
        assert f"{fig}.toml" in names
    assert "default.toml" in names


@pytest.mark.parametrize("path", BUNDLED, ids=[p.stem for p in BUNDLED])
def test_bundled_scenarios_validate(path):
    """Validation only (nothing identified or simulated); the slow end-to-end tests run them."""
    sc = validate_scenario(path)
    assert sc.cases and sc.name == path.stem


def test_every_problem_is_reported_at_once(tmp_path):
    text = """
titel = "typo"
[plant]
preset = "rakotondrabe-2dof"
dynamics = "yes"
[compensator]
kind = "multivariable"
gian = "secant"
[[cases]]
name = "a"
reference = { kind = "sine", output = "x", amplitude = -5.0, frequncy = 50.0, periods = 2 }
[[cases]]
name = "b"
reference = { kind = "circle", radius = 10.0, frequency = 20000.0, periods = 2 }
settle_periods = -1
"""
    p = _write(tmp_path, text)
    with pytest.raises(ScenarioError) as err:
        load_scenario(p)
    problems = err.value.problems
    assert all(line.startswith(f"{p}: ") for line in problems)
    joined = "\n".join(problems)
    expected = [
        "titel: unknown key (did you mean 'title'?)",
        "plant.dynamics: expected true or false",
        "compensator.gian: unknown key (did you mean 'gain'?)",
        "cases[0].reference.amplitude: expected a number > 0 [µm]",
        "cases[0].reference.frequncy: unknown key (did you mean 'frequency'?)",
        "cases[0].reference.frequency: missing (required)",
        "cases[1].settle_periods: expected a number >= 0",
        "cases[1].reference.frequency: 20000 Hz is at or above the Nyquist frequency",
    ]
    for e in expected:
        assert e in joined, e
    assert len(problems) >= len(expected)


@pytest.mark.parametrize("body, message", [
    ("[plant]\npreset = 'rakotondrabe-2dof'\n[[cases]]\nname = 'a'\n"
     "reference = { kind = 'sine', output = 'x', amplitude = 5.0, frequency = 50.0, periods = 2 }",
     "cases[0].reference: a reference needs a compensator"),
    (HEAD + "[[cases]]\nname = 'a'\n"
     "reference = { kind = 'sine', output = 'z', amplitude = 5.0, frequency = 50.0, periods = 2 }",
     "cases[0].reference.output: expected one of ['x', 'y'], found 'z'"),
    (HEAD + "[[cases]]\nname = 'a'\n"
     "drive = { kind = 'sine', input = 'ux', amplitude = 5.0, frequency = 50.0, periods = 2 }\n"
     "reference = { kind = 'circle', radius = 5.0, frequency = 50.0, periods = 2 }",
     "cases[0]: expected exactly one of reference"),
    (HEAD + "[[cases]]\nname = 'a'\n"
     "reference = { kind = 'circel', radius = 5.0, frequency = 50.0, periods = 2 }",
     f"cases[0].reference.kind: expected one of {', '.join(map(repr, REFERENCE_KINDS))}, "
     "found 'circel' (did you mean 'circle'?)"),   # the list read from the registry
    (HEAD.replace('"multivariable"', '"multivariabel"') + GOOD_CASE,
     "compensator.kind: expected one of 'none', 'multivariable'"),
    (HEAD + "gain = 'identity'\n" + GOOD_CASE,
     "cases[0].compensator: gain: rho(I - K^-1 J) reaches"),
    (HEAD.replace("rakotondrabe-2dof", "no-such-preset") + GOOD_CASE,
     ": plant.preset: no-such-preset: not a bundled preset"),   # the key the file has
    (HEAD + GOOD_CASE.replace('name = "x"', 'name = "x"\nplant = { preset = "no-such" }'),
     "cases[0].plant.preset: no-such: not a bundled preset"),
    (HEAD + GOOD_CASE + "settle_periods = 2",
     "cases[0].settle_periods: 2 periods of settling leave less than one period"),
    (HEAD + GOOD_CASE + GOOD_CASE, "cases[1].name: duplicate case name 'x'"),
    ("name = 'bad name!'\n" + HEAD + GOOD_CASE, "name: expected a name of letters"),
    (HEAD, "cases: missing (required)"),
    ("this is not toml", "invalid TOML"),
])
def test_single_problems(tmp_path, body, message):
    p = _write(tmp_path, body)
    with pytest.raises(ScenarioError) as err:
        load_scenario(p)
    assert message in str(err.value)


def test_case_overrides_merge_and_a_new_kind_does_not_inherit(tmp_path):
    text = HEAD + "gain = 'identity'\ncheck = 'warn'\niterations = 2\n" + """
[[cases]]
name = "merged"
reference = { kind = "sine", output = "x", amplitude = 50.0, frequency = 50.0, periods = 2 }
compensator = { gain = "secant", check = "error" }
plant = { dynamics = true }
[[cases]]
name = "open-loop"
drive = { kind = "sine", input = "uy", amplitude = 10.0, frequency = 50.0, periods = 2 }
compensator = { kind = "none" }
"""
    sc = load_scenario(_write(tmp_path, text))
    merged, drive = sc.cases
    assert merged.compensator_spec == {"kind": "multivariable", "gain": "secant", "check": "error",
                                       "iterations": 2, "model": "plant"}
    assert merged.compensator.iterations == 2 and not merged.plant.is_static
    assert drive.compensator_spec == {"kind": "none"} and drive.compensator is None
    assert drive.driven_input == 1 and drive.period_samples == 400


def test_lissajous_period_and_default_name(tmp_path):
    text = HEAD + """
[[cases]]
name = "l"
reference = { kind = "lissajous", amplitude = [50.0, 40.0], frequencies = [40.0, 30.0], periods = 1.5 }
settle_periods = 0.5
"""
    sc = load_scenario(_write(tmp_path, text, "my-liss.toml"))
    assert sc.name == "my-liss"
    case = sc.cases[0]
    assert case.period_samples == 2000 and case.signal.shape == (2, 3000)
    assert case.scale == 50.0


class _StaticGain:
    """A toy compensator: U = Yr / g (what a registry entry can add)."""

    name = "static-gain"

    def __init__(self, g):
        self.g = g

    def simulate(self, reference, initial_state=None):
        return np.asarray(reference) / self.g, None


def test_registry_accepts_a_new_compensator_kind(tmp_path, monkeypatch, no_figures):
    from hammerstein.scenario.schema import Field, number
    monkeypatch.setitem(registry.COMPENSATORS, "static-gain", registry.CompensatorKind(
        lambda spec, plant, base: _StaticGain(spec["gain"]),
        {"gain": Field(number("µm/V", 0), required=True)}, "U = Yr / gain"))
    text = HEAD.replace('"multivariable"', '"static-gain"') + "gain = 5.0\n" + GOOD_CASE
    p = _write(tmp_path, text)
    sc = load_scenario(p)
    assert isinstance(sc.cases[0].compensator, _StaticGain)
    out = runner.run_scenario(p, tmp_path / "out", renderer=no_figures)
    assert out.ok, out.error
    rms = out.metrics.query("channel == 'x' and metric == 'rms_error'")["value"].item()
    assert rms > 1.0  # a static gain cannot cancel the hysteresis
    bad = _write(tmp_path, HEAD.replace('"multivariable"', '"static-gain"') + "gian = 5.0\n"
                 + GOOD_CASE, "bad.toml")
    with pytest.raises(ScenarioError, match="did you mean 'gain'"):
        load_scenario(bad)


DYNAMICS_HEAD = """
[plant]
preset = "rakotondrabe-2dof"
dynamics = {dynamics}
[compensator]
kind = "{kind}"
model = "plant"
"""


@pytest.mark.parametrize("dynamics, kind, case, expected", [
    ("true", "multivariable",
     'reference = { kind = "sine", output = "y", amplitude = 30.0, frequency = 300.0, periods = 3 }',
     "compensator kind = 'multivariable' is rate independent: at 300 Hz"),
    ("true", "per-axis",
     'reference = { kind = "circle", radius = 20.0, frequency = 40.0, periods = 2 }',
     "compensator kind = 'per-axis' is rate independent: at 40 Hz"),
    ("true", "multivariable",   # 5 Hz: 2 % of the first resonance, gain within 0.1 %
     'reference = { kind = "sine", output = "y", amplitude = 30.0, frequency = 5.0, periods = 2 }',
     None),
    ("false", "multivariable",  # no dynamics to warn about
     'reference = { kind = "sine", output = "y", amplitude = 30.0, frequency = 300.0, periods = 3 }',
     None),
    ("true", "multivariable",   # open loop, compared with the static PI
     'drive = { kind = "sine", input = "ux", amplitude = 5.0, frequency = 100.0, periods = 3 }\n'
     'model = "plant"',
     "the comparison model is static (PI only): at 100 Hz"),
])
def test_dynamics_warning(tmp_path, dynamics, kind, case, expected):
    """One warning when a rate-independent treatment meets the plant's dynamics
    (above 10 % of the first resonance, 290 Hz, or a gain change over 2 %)."""
    text = DYNAMICS_HEAD.format(dynamics=dynamics, kind=kind) + f'''
[[cases]]
name = "c"
{case}
'''
    sc = load_scenario(_write(tmp_path, text))
    from hammerstein.scenario.resolve import dynamics_warning
    message = dynamics_warning(sc.cases[0])
    if expected is None:
        assert message is None
    else:
        assert message.startswith(expected) and "first resonance 290 Hz" in message
        assert "docs/hammerstein-plant.md" in message and len(message) < 240


def test_a_bad_preset_is_reported_with_missing_cases(tmp_path):
    """A file without cases and with a misspelled preset: both problems at once (the preset,
    loaded per case, went unreported), and the preset's name suggested."""
    path = tmp_path / "broken.toml"
    path.write_text('[plant]\npreset = "rakotondrabe-2dfo"\n')
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert "cases: missing" in text and "plant.preset" in text
    assert "did you mean 'rakotondrabe-2dof'" in text


def test_a_missing_preset_is_named_once_when_a_case_overrides_the_plant(tmp_path, repo_root):
    """The default scenario with its preset misspelled: its static case (plant = {
    dynamics = false }) loads the preset again, and the same line was printed twice."""
    text = (repo_root / "scenarios" / "default.toml").read_text()
    path = tmp_path / "s.toml"
    path.write_text(text.replace('preset = "rakotondrabe-2dof"', 'preset = "nope"'))
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert len(err.value.problems) == 1 and "plant.preset: nope: not a bundled preset" \
        in err.value.problems[0], err.value.problems
    assert ScenarioError(["a", "b", "a"]).problems == ["a", "b"]


def test_an_inherited_bad_value_is_named_once_at_the_top(tmp_path):
    """A bad top-level compensator value, inherited by cases with tables of their own: it
    was named again under every such case, word for word. A case's own bad value is still
    named under the case."""
    case = GOOD_CASE.replace('name = "x"', 'name = "NAME"')
    text = (HEAD + 'gain = "nope"\n' + case.replace("NAME", "a") + "compensator = { iterations = 2 }\n"
            + case.replace("NAME", "b") + "compensator = { iterations = 3, cutoff_hz = -1.0 }\n"
            + case.replace("NAME", "c"))
    with pytest.raises(ScenarioError) as err:
        load_scenario(_write(tmp_path, text))
    said = err.value.problems
    assert sum(".gain: expected" in q for q in said) == 1, said
    assert any(q.endswith("compensator.gain: expected 'secant', 'midpoint', 'identity' or a "
                          "square matrix [[..],[..]] of finite numbers [µm/V], found 'nope'")
               and "cases[" not in q for q in said), said
    assert any("cases[1].compensator.cutoff_hz" in q for q in said), said


def test_a_fade_in_that_leaves_no_period_is_named_with_its_case(tmp_path):
    """Six periods of a 300 Hz sine are 0.02 s, the shortest fade compensate gives an
    identified preset (records' amplifier, dynamics): the metrics, which start at the fade's
    end, had nothing left, and the error blamed settle_periods (5.97 periods where the file
    said 1) without naming the case. Twelve periods run."""
    import shutil
    from hammerstein.cli.main import main
    shutil.copy(Path(__file__).parents[1] / "hardware" / "data" / "outside-classical-deadzone.toml",
                tmp_path / "p.toml")
    text = ('name = "short"\n[plant]\npreset = "p.toml"\n[compensator]\nkind = "hammerstein"\n'
            'model = "p.toml"\n[[cases]]\nname = "fast-sine"\nreference = { kind = "sine", '
            'output = "x", amplitude = 10.0, frequency = 300.0, periods = PERIODS }\n'
            'settle_periods = 1\n')
    for periods, code_expected in ((6, 1), (3, 1), (12, 0)):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(["run", str(_write(tmp_path, text.replace("PERIODS", str(periods)))),
                         "--out", str(tmp_path / f"o{periods}"), "-q"])
        assert code == code_expected, err.getvalue()
        if code:
            line = err.getvalue().strip()
            assert "\n" not in line and "fast-sine: the drive's fade-in, " in line
            assert "more periods (at least 7)" in line and "settle_periods" not in line


@pytest.mark.parametrize("preset, kind, refused", [
    ("rakotondrabe-2dof", "preisach-inverse", True),    # a classical PI: no exact inverse
    ("rakotondrabe-2dof", "per-axis", False),
    ("realistic-2dof", "preisach-inverse", False),
])
def test_validate_refuses_a_kind_the_models_class_does_not_take(tmp_path, preset, kind, refused):
    """``validate`` said "ok" and ``run`` then failed building the compensator; the class
    registry is asked when the file is validated, and names the kinds that work."""
    text = (f'name = "k"\n[plant]\npreset = "{preset}"\n[compensator]\nkind = "{kind}"\n'
            '[[cases]]\nname = "c"\nreference = { kind = "circle", radius = 10.0, '
            'frequency = 20.0, periods = 2 }\n')
    if not refused:
        validate_scenario(_write(tmp_path, text))
        return
    with pytest.raises(ScenarioError) as info:
        validate_scenario(_write(tmp_path, text))
    assert len(info.value.problems) == 1
    assert ("cases[0].compensator: kind: the model is a classical PI model, which kind "
            "'preisach-inverse' does not take; the kinds that work with it: hammerstein, "
            "multivariable") in info.value.problems[0]


def test_a_dimensionless_bound_is_told_without_an_empty_unit():
    from hammerstein.core.schema import Invalid, number
    with pytest.raises(Invalid) as info:
        number("", 0, exclusive=False)(-0.1)
    assert str(info.value) == "expected a number >= 0, found -0.1"      # was "... >= 0 [], ..."
    with pytest.raises(Invalid, match=r"expected a number > 0 \[s\], found -0.1"):
        number("s", 0)(-0.1)


@pytest.mark.parametrize("identify, refused", [
    ('{ frequency = 10.0 }', True),                                   # the classical PI route
    ('{ records = "excitation", model = "classical" }', True),
    ('{ records = "excitation" }', False),                            # auto: judged when identified
    ('{ records = "excitation", model = "preisach" }', False),
])
def test_validate_judges_the_class_an_identify_table_names(tmp_path, identify, refused):
    """The class an identify table asks for is known before anything is identified; one
    mistake written once is said once, however many cases inherit it (it was said per case)."""
    text = ('name = "k"\n[plant]\npreset = "realistic-2dof"\n[compensator]\n'
            f'kind = "preisach-inverse"\nmodel = "identified"\nidentify = {identify}\n'
            + "".join(f'[[cases]]\nname = "c{i}"\nreference = {{ kind = "circle", radius = 10.0, '
                      f'frequency = {10 * (i + 1)}.0, periods = 2 }}\n' for i in range(3)))
    if not refused:
        validate_scenario(_write(tmp_path, text))
        return
    with pytest.raises(ScenarioError) as info:
        validate_scenario(_write(tmp_path, text))
    assert len(info.value.problems) == 1, info.value.problems
    assert ("kind: the model identified is a classical PI model (identify.model = 'classical'), "
            "which kind 'preisach-inverse' does not take") in info.value.problems[0]


@pytest.mark.parametrize("value", ['"multivariable"', "[]", "0", "false"])
def test_a_compensator_that_is_not_a_table_is_named(tmp_path, value):
    """compensator = "multivariable" ran a drive case as kind 'none' without a word."""
    text = (f'name = "t"\ncompensator = {value}\n[plant]\npreset = "rakotondrabe-2dof"\n'
            '[[cases]]\nname = "d"\ndrive = { kind = "sine", input = "ux", amplitude = 5.0, '
            'frequency = 20.0, periods = 2 }\n')
    with pytest.raises(ScenarioError, match=r": compensator: expected a table, e\.g\. "
                                            r"\[compensator\] kind = \"multivariable\""):
        validate_scenario(_write(tmp_path, text))


def test_keys_a_kind_does_not_take_are_not_also_told_to_pair(tmp_path):
    """feedback and cutoff_hz on a per-axis compensator: both unknown keys, and not also
    "cutoff_hz: only used with feedback = 'lowpass' (feedback is 'delay')" of a file that
    set it to 'lowpass'."""
    text = ('name = "t"\n[plant]\npreset = "rakotondrabe-2dof"\n[[cases]]\nname = "a"\n'
            'reference = { kind = "sine", output = "x", amplitude = 20.0, frequency = 10.0, '
            'periods = 3 }\ncompensator = { kind = "per-axis", feedback = "lowpass", '
            'cutoff_hz = 100.0 }\n')
    with pytest.raises(ScenarioError) as info:
        validate_scenario(_write(tmp_path, text))
    keys = [p.split(": ")[1] for p in info.value.problems]
    assert keys == ["cases[0].compensator.feedback", "cases[0].compensator.cutoff_hz"], keys


def test_a_plant_that_does_not_load_is_the_one_problem_of_its_references(tmp_path):
    """A sine without output is right on a one-output plant; with a preset that did not load
    it was also told "reference.output: missing (required)"."""
    (tmp_path / "model.toml").write_text("[model]\n")
    text = ('name = "t"\n[plant]\npreset = "model.toml"\ndynamics = false\n[compensator]\n'
            'kind = "multivariable"\n[[cases]]\nname = "c"\nreference = { kind = "sine", '
            'amplitude = 20.0, frequency = 1.0, periods = 3 }\n')
    with pytest.raises(ScenarioError) as info:
        validate_scenario(_write(tmp_path, text))
    assert all("plant.preset" in p for p in info.value.problems), info.value.problems


def test_the_kinds_named_for_a_static_plant_leave_out_those_that_need_dynamics(tmp_path):
    text = ('name = "k"\n[plant]\npreset = "rakotondrabe-2dof"\ndynamics = false\n'
            '[compensator]\nkind = "preisach-inverse"\n[[cases]]\nname = "c"\nreference = { '
            'kind = "circle", radius = 10.0, frequency = 20.0, periods = 2 }\n')
    with pytest.raises(ScenarioError) as info:
        validate_scenario(_write(tmp_path, text))
    (line,) = info.value.problems
    assert line.endswith("the kinds that work with it: multivariable, diagonal, per-axis, "
                         "static-gain"), line


HAMMERSTEIN_HEAD = """
[plant]
preset = "rakotondrabe-2dof"
[compensator]
kind = "hammerstein"
{extra}
[[cases]]
name = "a"
reference = {{ kind = "circle", radius = 10.0, frequency = 50.0, periods = 3 }}
settle_periods = 1
[[cases]]
name = "b"
reference = {{ kind = "circle", radius = 10.0, frequency = 20.0, periods = 3 }}
settle_periods = 1
compensator = {{ dynamics = "own-guess.toml", iterations = 0 }}
"""


def test_a_bad_value_does_not_hide_the_kinds_own_checks_of_the_other_keys(tmp_path):
    """``gain = "secnt"`` (a field problem) and ``dynamics = "guessed"`` (found only by the
    kind's own check, which needs the other keys' values) in one table: both are named,
    under the case they were found for; the case's own table's problems under the case."""
    p = _write(tmp_path, HAMMERSTEIN_HEAD.format(extra='gain = "secnt"\ndynamics = "guessed"'))
    with pytest.raises(ScenarioError) as err:
        load_scenario(p)
    problems = [line.removeprefix(f"{p}: ") for line in err.value.problems]
    assert any(line.startswith("compensator.gain:") for line in problems)
    assert any(line.startswith("cases[0].compensator.dynamics:") and "guessed" in line
               for line in problems), problems
    assert any(line.startswith("cases[1].compensator.iterations:") for line in problems)
    assert any(line.startswith("cases[1].compensator.dynamics:") and "own-guess.toml" in line
               for line in problems), problems


@pytest.mark.parametrize("extra, case, said, unsaid", [
    # a bad dynamics value: identify_dynamics, which goes with it, is not judged on a default
    ("dynamics = 42\nidentify_dynamics = {}", "", "compensator.dynamics: expected a string",
     "identify_dynamics"),
    # a bad value beside a case's own misspelt model: the model is named, and the keys whose
    # defaults follow it are not judged
    ('gain = "secnt"\nidentify_dynamics = {}', 'compensator = { model = "identifed" }',
     "identifed: no such file", "identify_dynamics"),
    # a case that overrides dynamics: its conflict is the case's, not the top table's
    ('model = "identified"\ndynamics = "identified"\nidentify_dynamics = {}',
     'compensator = { dynamics = "plant" }',
     "cases[0].compensator.identify_dynamics: only used with dynamics = 'identified'",
     "\ncompensator.identify_dynamics"),
])
def test_what_a_wrong_key_leaves_unjudged_and_where_problems_are_named(tmp_path, extra, case,
                                                                       said, unsaid):
    """A reviewer's scenarios: a dependent key judged on the default a bad key would have
    changed, a case's own wrong model hidden behind a bad value with a dependent message
    instead, a case's conflict blamed on a consistent top table."""
    text = HAMMERSTEIN_HEAD.format(extra=extra).split("[[cases]]")[0] + (
        '[[cases]]\nname = "a"\n'
        'reference = { kind = "circle", radius = 10.0, frequency = 50.0, periods = 3 }\n'
        f"settle_periods = 1\n{case}\n")
    p = _write(tmp_path, text)
    with pytest.raises(ScenarioError) as err:
        load_scenario(p)
    joined = "\n" + "\n".join(line.removeprefix(f"{p}: ") for line in err.value.problems)
    assert said in joined, joined
    assert unsaid not in joined, joined


@pytest.mark.parametrize("model", ['"identifed"', "42"])
def test_a_bad_model_leaves_the_keys_that_depend_on_it_unjudged(tmp_path, model):
    """With ``model`` wrong (a misspelt ``"identified"`` read as a file; not a string),
    ``dynamics``'s default, which follows the model, is not judged: only the model's problem,
    not "identify_dynamics: only used with dynamics = 'identified', found 'plant'"."""
    text = HAMMERSTEIN_HEAD.format(extra=f"model = {model}\nidentify_dynamics = {{}}")
    text = text.replace('compensator = { dynamics = "own-guess.toml", iterations = 0 }', "")
    p = _write(tmp_path, text)
    with pytest.raises(ScenarioError) as err:
        load_scenario(p)
    problems = [line.removeprefix(f"{p}: ") for line in err.value.problems]
    assert any(line.startswith("compensator.model:") for line in problems), problems
    assert not any("identify_dynamics" in line for line in problems), problems
