"""Machine profiles written as TOML (postproc.machine.profile): whatever text a name or a string
key holds, the file written reads back with tomllib as that text."""

from __future__ import annotations

import dataclasses
import tomllib

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from postproc.machine.profile import DEFAULT, INCREMENTS, from_mapping, starter, to_toml, toml_string

#: any text a command line or a profile file can hold: every code point but the lone surrogates
TEXT = st.text(st.characters(exclude_categories=("Cs",)), max_size=40)
NASTY = st.text(st.sampled_from(['"', "\\", "\n", "\r", "\t", "\b", "\f", "\x00", "\x1f", "\x7f", "'", "#", "=",
                                 "[", "]", "\u2028", "\ufeff", "a", "é", " "]), max_size=20)


@given(st.one_of(TEXT, NASTY))
def test_a_toml_string_reads_back_as_its_text(text):
    assert tomllib.loads(f"key = {toml_string(text)}\n") == {"key": text}


@given(st.one_of(TEXT, NASTY))
def test_a_starter_profile_reads_back_as_the_default_under_any_name(name):
    data = tomllib.loads(starter(name))
    assert data["name"] == name
    assert from_mapping(data) == dataclasses.replace(DEFAULT, name=name)


@given(name=st.one_of(TEXT, NASTY), controller=st.one_of(TEXT, NASTY))
def test_a_profile_shown_reads_back_as_itself(name, controller):
    profile = dataclasses.replace(DEFAULT, name=name, controller=controller)
    assert from_mapping(tomllib.loads(to_toml(profile))) == profile


def test_a_lone_surrogate_is_refused_not_written():
    with pytest.raises(ValueError, match="not UTF-8 text"):
        toml_string("lathe\udcff")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.one_of(TEXT, NASTY).filter(lambda text: "\x00" not in text))
def test_profile_init_writes_a_file_that_reads_back_with_the_name_given(run, tmp_path_factory, name):
    """Through the command line (an argument cannot hold NUL)."""
    target = tmp_path_factory.mktemp("init") / "lathe.toml"
    result = run("profile", "init", str(target), "--name", name)
    if not name.strip():  # empty: a shell variable never set (exit 2); blank: no name (exit 3)
        assert (result.exit_code, result.stdout) == (2 if name == "" else 3, "")
        assert result.stderr == ("postproc: error: --name is empty (a shell variable that is not set?): give a value, "
                                 "or leave the option out (nothing was written)\n" if name == "" else
                                 f"postproc: error: --name {name!r}: a profile's name cannot be blank\n")
        assert not target.exists()
        return
    assert (result.exit_code, result.stdout) == (0, "")
    assert result.stderr.startswith(f"{target}: starter machine profile written")
    assert tomllib.loads(target.read_text(encoding="utf-8"))["name"] == name
    shown = run("profile", "show", "--machine", str(target))
    assert shown.exit_code == 0 and shown.stderr == ""


def test_profile_init_refuses_a_name_that_is_not_text(run, tmp_path):
    target = tmp_path / "lathe.toml"
    result = run("profile", "init", str(target), "--name", "lathe\udcff")
    assert (result.exit_code, result.stdout) == (3, "")
    assert result.stderr == ("postproc: error: the profile's name (--name, else the file's name): 'lathe\\udcff' "
                             "holds a byte that is not UTF-8 text; give --name as text\n")
    assert not target.exists()


@pytest.mark.parametrize("increment, finest_mm, finest_inch", [("IS-A", 2, 3), ("IS-B", 3, 4), ("IS-C", 4, 5)])
@pytest.mark.parametrize("decimals_mm, decimals_inch", [(2, 3), (3, 4), (4, 5), (5, 6)])
def test_output_decimals_finer_than_the_input_increment_are_refused(increment, finest_mm, finest_inch, decimals_mm,
                                                                    decimals_inch):
    """A number written with more decimals than the control's least input increment is one the
    control reads otherwise (or alarms on): such a profile is refused, naming the key."""
    from postproc.diagnostics import OptionError

    data = {"input_increment": increment, "output_decimals_mm": decimals_mm, "output_decimals_inch": decimals_inch}
    if decimals_mm <= finest_mm and decimals_inch <= finest_inch:
        profile = from_mapping(data, "p.toml")
        assert (profile.output_decimals_mm, profile.output_decimals_inch) == (decimals_mm, decimals_inch)
        return
    with pytest.raises(OptionError) as refused:
        from_mapping(data, "p.toml")
    unit = "mm" if decimals_mm > finest_mm else "inch"
    assert f"output_decimals_{unit} = " in refused.value.message and increment in refused.value.message
    assert f"set output_decimals_{unit} = {finest_mm if unit == 'mm' else finest_inch}" in refused.value.message


@given(inch=st.booleans(), system=st.sampled_from(sorted(INCREMENTS)), data=st.data(),
       largest=st.floats(1e-5, 0.1), tolerance=st.sampled_from([None, 0.002]))
def test_finer_output_names_the_decimals_that_bring_the_default_tolerance_below_the_correction(
        inch, system, data, largest, tolerance):
    """When the default tolerance is the output grid's (above 1 um), the remedy names the profile
    key: the fewest decimals the control can read whose default tolerance is below the largest
    correction; else the finest it can read, with a finer --tolerance. Never for a tolerance set in
    the profile, nor for the 1 um default."""
    finest = round(-__import__("math").log10(INCREMENTS[system][1 if inch else 0]))
    key = f"output_decimals_{'inch' if inch else 'mm'}"
    profile = dataclasses.replace(DEFAULT, input_increment=system, tolerance=tolerance,
                                  **{key: data.draw(st.integers(0, finest), label="decimals")})
    remedy = profile.finer_output(inch, largest)
    if tolerance is not None or profile.default_tolerance(inch) <= 0.001:
        assert remedy is None
        return
    now = getattr(profile, key)
    assert f"{key} = {now} in the machine profile" in remedy
    fewer = [d for d in range(now + 1, finest + 1)
             if dataclasses.replace(profile, **{key: d}).default_tolerance(inch) < largest]
    if fewer:
        assert remedy.endswith(f": set {key} = {fewer[0]}, or give a finer --tolerance")
    elif now < finest:
        assert f": set {key} = {finest}, the finest the control's least input increment ({system}" in remedy
    else:
        assert remedy.endswith("allows: give a finer --tolerance, or leave the program uncompensated")


@given(st.text(alphabet="XZCYBAUWHVQxzc ", max_size=6))
def test_axes_are_the_lathes_axis_letters_each_once_with_x_and_z(axes):
    """Only capitals a FANUC lathe has as axes, each once, X and Z among them: ``XZU`` (U is X
    written incrementally) would read every U word as another axis's move, ``xzc`` would leave
    the C words read as chamfers; such a profile is refused, naming the key."""
    from postproc.diagnostics import OptionError

    valid = set(axes) <= set("XZCYBA") and len(set(axes)) == len(axes) and {"X", "Z"} <= set(axes)
    if valid:
        assert from_mapping({"axes": axes}, "p.toml").axes == axes
        return
    with pytest.raises(OptionError) as refused:
        from_mapping({"axes": axes}, "p.toml", f"axes = {axes!r}\n")
    assert refused.value.message.startswith(f"axes = {axes!r}: ") and refused.value.location.line == 1


def test_the_nose_radius_remedy_the_refusal_names_is_a_profile_the_command_line_takes(run, tmp_path):
    """Under G42 a corrected path that needs a join is refused, naming two remedies: a program for
    the nose centre, or nose_radius_mm = 0 for a control that does not offset this tool. The
    second is a profile that loads (0 is a setting of its own, not a missing radius) and lets the
    program through with its joins; a negative radius is refused."""
    program = tmp_path / "part.nc"
    program.write_text("G18 G21 G99 F0.1 S500\nG00 X40. Z5.\nG01 G42 X42. Z1.\nZ0.\nX44. Z-1.\nZ-20.\n"
                       "G02 X50. Z-23. R3.\nG01 X52.\nG40 G00 X60. Z5.\n")
    from support import SAMPLES

    compensator = ["--plugin", "parametric", "--option", "extrapolate=true",
                   "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
                   "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv")]
    target = tmp_path / "out.nc"
    refused = run("compensate", str(program), *compensator, "--tolerance", "0.001", "-o", str(target))
    assert refused.exit_code == 4 and "state nose_radius_mm = 0 in the machine profile" in refused.stderr
    assert not target.exists()
    profile = tmp_path / "lathe.toml"
    profile.write_text("nose_radius_mm = 0\n")
    written = run("compensate", str(program), *compensator, "--tolerance", "0.001", "--machine", str(profile),
                  "-o", str(target))
    assert written.exit_code == 0, written.stderr
    assert target.read_text() != program.read_text()
    profile.write_text("nose_radius_mm = -0.4\n")
    negative = run("check", str(program), "--machine", str(profile))
    assert negative.exit_code == 3 and "nose_radius_mm must be a number, 0 or more" in negative.stderr


#: every profile key that has two spellings (``max_correction`` and ``max-correction``)
_TWO_SPELLINGS = sorted(name for name in dataclasses.asdict(DEFAULT) if "_" in name
                        and name not in ("extra", "source", "source_sha256"))


@pytest.mark.parametrize("name", _TWO_SPELLINGS)
def test_a_key_in_both_its_spellings_is_refused_at_the_second(run, tmp_path, name):
    """``max-correction = 0.05`` then ``max_correction = 0.08`` read as 0.08 without a word: which
    spelling wins is a guess, whichever key it is."""
    value = tomllib.loads(to_toml(DEFAULT)).get(name)
    if value is None:  # unset by default: any valid value will do
        value = {"x_limits": [0.0, 100.0], "z_limits": [-100.0, 0.0], "tolerance": 0.002,
                 "calculator_input": True}[name]
    written = "\n".join(f"{key} = {_toml(value)}" for key in (name.replace("_", "-"), name)) + "\n"
    machine = tmp_path / "m.toml"
    machine.write_text(written)
    result = run("profile", "show", "--machine", str(machine))
    assert (result.exit_code, result.stdout) == (3, "")
    assert result.stderr.startswith(f"{machine}:2:1: error: {name} is given twice, as "
                                    f"'{name.replace('_', '-')}' and as '{name}'; keep one"), result.stderr


def _toml(value) -> str:
    return toml_string(value) if isinstance(value, str) else str(value).lower() if isinstance(value, bool) else str(value)


@pytest.mark.parametrize("text, position, meant", [
    ("[simulaton]\nseed = 1\n", "2:2", "simulation"),
    ("[[simulatoin.term]]\naxis = 'x'\n", "2:3", "simulation"),
    ("[ x_limit ]\nlow = 0\n", "2:3", "x_limits"),
])
def test_a_misspelt_table_is_named_where_its_header_is_with_the_key_meant(run, tmp_path, text, position, meant):
    machine = tmp_path / "m.toml"
    machine.write_text('name = "lathe"\n' + text)
    result = run("profile", "show", "--machine", str(machine))
    assert result.exit_code == 3
    assert result.stderr.startswith(f"{machine}:{position}: error: unknown key "), result.stderr
    assert f"did you mean '{meant}'?" in result.stderr


@pytest.mark.parametrize("text", ['bogus = 1\n', 'name = "lathe"\n[simulation.x]\nscalin = 1e-5\n',
                                  '[simulation]\nseed = "one"\n'])
def test_profile_show_checks_the_whole_profile_before_it_prints_anything(run, tmp_path, text):
    """The comment lines went out before the profile was read, so a bad profile left them on
    stdout with exit 3; and a [simulation] table, which is not printed, was not checked at all."""
    machine = tmp_path / "m.toml"
    machine.write_text(text)
    result = run("profile", "show", "--machine", str(machine))
    assert (result.exit_code, result.stdout) == (3, "")
    assert result.stderr.startswith(f"{machine}"), result.stderr


@pytest.mark.parametrize("key, limits", [("x_limits", [-5000, 265000]), ("z_limits", [-450000, 450000]),
                                         ("x_limits", [-1e6, 0])])
def test_soft_limits_in_micrometres_are_refused(key, limits):
    """Soft limits written in um (265000 for 265 mm) would lift every check against travel: a
    limit further than any lathe reaches (100 m) is refused at its key, with the mm reading.
    A large machine's real limits (a 20 m bed) are read."""
    from postproc.diagnostics import OptionError

    text = f"{key} = [{limits[0]}, {limits[1]}]\n"
    with pytest.raises(OptionError, match=r"further than any lathe reaches: written in um\?") as refused:
        from_mapping(tomllib.loads(text), "p.toml", text)
    assert str(refused.value).startswith("p.toml:1:1: error:")
    assert from_mapping({"z_limits": [-20000.0, 500.0]}).z_limits == (-20000.0, 500.0)
