"""Round trips of the edit dialogs' text forms (`sessions.forms.one_line`): every value
reads back from its text exactly, texts settle after one parse, and malformed
text raises FormError saying what is expected."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sessions.format.schema import BandModel, PointModel, ResponseModel, SegmentModel
from sessions.forms import one_line as forms
from sessions.forms.one_line import FormError

FORMS = settings(max_examples=100, deadline=None, database=None)  # modest: the file runs in seconds

finite = st.floats(allow_nan=False, allow_infinity=False)
nonneg = st.floats(min_value=0, allow_nan=False, allow_infinity=False)
names = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,8}", fullmatch=True)
words = st.text(st.characters(blacklist_categories=("Cs",)), min_size=1, max_size=8).filter(lambda w: w.split() == [w])
expressions = st.text(min_size=1, max_size=20).map(str.strip).filter(bool)
# number spellings a user might type: exact, short, exponent, integer, and some that are not numbers
spelled = st.one_of(
    finite.map(repr),
    finite.map("{:g}".format),
    finite.map("{:.3e}".format),
    st.integers(-(10**6), 10**6).map(str),
    st.just("inf"),
    st.just("-inf"),
    st.just("nan"),
    st.just("none"),
    st.just(""),
)
TOKENS = [
    "push",
    "pull",
    "step",
    "ramp",
    "psd",
    "reference",
    "settling",
    "auto",
    "at_least",
    "true",
    "False",
    "none",
    "inf",
    "1/(s+1)",
    "j",
    "+",
    "-",
    "..",
    ":",
    "/",
    ";",
    ",",
    " ",
    " ",
    "  ",
    "\t",
    "x",
    "y",
    "K",
    "0",
    "1",
    "2.5",
    "-3",
    "1e3",
    "10",
    "400",
    "-7-3j",
    "1+2j",
]
token_texts = st.lists(st.one_of(st.sampled_from(TOKENS), spelled), max_size=12).map("".join)
any_text = st.one_of(token_texts, st.text(max_size=30))
space = st.sampled_from([" ", "  ", "\t", " \t "])
pad = st.sampled_from(["", " ", "\t"])


def joined(*parts, sep=space):
    """Text of the parts' texts separated by varied white space (or by ``sep``)."""
    return st.tuples(*parts, st.lists(sep, min_size=len(parts), max_size=len(parts))).map(
        lambda t: "".join(s + x for s, x in zip(t[-1], t[:-1]))
    )


def listed(part, sep=";"):
    """Texts of ';'-separated parts, with varied spacing and some empty parts."""
    return st.lists(st.one_of(part, part, part, pad), max_size=3).map(sep.join)


plain = st.one_of(nonneg.map(repr), nonneg.map("{:g}".format), st.integers(0, 1000).map(str))
num = st.one_of(plain, plain, plain, spelled)  # mostly valid
cased = st.sampled_from(["true", "false", "True", "FALSE", "auto", "at_least", "at_most", "At_Most", "none"])
spelled_range = joined(num, st.just(".."), num, sep=pad)
spelled_band = joined(spelled_range, st.just(":"), num, st.just("") | joined(st.just("/"), num), sep=pad)
spelled_point = joined(
    st.sampled_from(["push", "pull", "Push"]),
    num,
    st.sampled_from(["+", "-"]),
    num,
    st.sampled_from(["j", "j", "J", ""]),
    sep=pad,
)
clause = st.one_of(
    joined(st.sampled_from(["step", "ramp"]), num, num),
    joined(st.just("reference"), num),
    joined(st.just("settling"), st.sampled_from(["0.02", "2", "x"])),
    joined(st.just("psd"), st.sampled_from(["1/(s+1)", "K/(s + a)", "1/(s+1)", "s*(", ""])),
)
head = joined(names, names, num, st.one_of(st.just(""), st.integers(0, 200_000).map(str), st.just("50")))
# per form: texts near the form's grammar (most parse), besides arbitrary ones
GRAMMAR = {
    "number": num,
    "optional": num,
    "signed": listed(joined(st.sampled_from(["+", "-", ""]), words, sep=st.just("")), sep=" "),
    "parameter": joined(st.one_of(names, words), num, st.one_of(st.just(""), joined(num, num))),
    "block": joined(words, words, words, st.one_of(expressions, pad)),
    "matrix_entry": joined(st.integers(-1, 99).map(str), st.integers(0, 99).map(str), st.one_of(expressions, pad)),
    "range": spelled_range,
    "bands": listed(spelled_band),
    "points": listed(spelled_point),
    "sense": joined(cased, sep=pad),
    "bool": joined(cased, sep=pad),
    "response": st.tuples(head, listed(clause)).map(";".join),
}


@st.composite
def ranges(draw, low=nonneg):
    """(low, high or None) with high >= low."""
    lo = draw(low)
    high = draw(st.none() | st.floats(min_value=lo, allow_nan=False, allow_infinity=False))
    return lo, high


bands = st.builds(
    lambda r, d, q: BandModel(low=r[0], high=r[1], desired=d, required=q), ranges(), finite, st.none() | finite
)
points = st.builds(PointModel, real=finite, imag=finite, mode=st.sampled_from(["push", "pull"]))
segments = st.one_of(
    st.builds(SegmentModel, time=nonneg, step=finite), st.builds(SegmentModel, time=nonneg, slope=finite.filter(bool))
)
responses = st.builds(
    ResponseModel,
    input=names,
    output=names,
    horizon=st.floats(min_value=0, exclude_min=True, allow_infinity=False),
    points=st.integers(10, 100_000),
    profile=st.lists(segments, min_size=1, max_size=4),
    psd=st.none() | st.sampled_from(["1/(s+1)", "K/(s+a)", "2/(s^2 + 2*s + 1)"]),
    reference=finite,
    settling_band=st.floats(min_value=0, max_value=1, exclude_min=True, exclude_max=True),
)


@st.composite
def parameter_lines(draw):
    low, high = draw(st.none() | finite), draw(st.none() | finite)
    if low is not None and high is not None and low > high:
        low, high = high, low
    return forms.ParameterLine(draw(names), draw(finite), low, high)


def per_condition_values():
    return st.one_of(finite, st.lists(finite, min_size=1, max_size=5))


settings_values = st.one_of(
    st.booleans(),
    st.integers(),
    finite,
    st.none(),
    names.filter(lambda n: n.lower() != "none"),
    st.from_regex(r"[0-9]{1,4}", fullmatch=True),
)

# form name -> (parse, format, strategy of values)
PAIRS = {
    "number": (forms.parse_number, forms.format_number, finite),
    "optional": (forms.parse_optional, forms.format_optional, st.none() | finite),
    "signed": (
        forms.parse_signed,
        forms.format_signed,
        st.tuples(st.lists(words, max_size=4), st.lists(words, max_size=4)).filter(lambda v: v[0] or v[1]),
    ),
    "parameter": (forms.parse_parameter, forms.format_parameter, parameter_lines()),
    "block": (forms.parse_block, forms.format_block, st.builds(forms.BlockLine, words, words, words, expressions)),
    "matrix_entry": (
        forms.parse_matrix_entry,
        forms.format_matrix_entry,
        st.builds(forms.EntryLine, st.integers(1, 10**6), st.integers(1, 10**6), expressions),
    ),
    "range": (forms.parse_range, forms.format_range, ranges()),
    "bands": (forms.parse_bands, forms.format_bands, st.lists(bands, min_size=1, max_size=4)),
    "points": (forms.parse_points, forms.format_points, st.lists(points, max_size=4)),
    "sense": (forms.parse_sense, forms.format_sense, st.sampled_from([None, "at_least", "at_most"])),
    "bool": (forms.parse_bool, forms.format_bool, st.booleans()),
    "response": (forms.parse_response, forms.format_response, st.none() | responses),
}


@pytest.mark.parametrize("form", PAIRS)
def test_value_reads_back_from_its_text(form):
    parse, format_, values = PAIRS[form]

    @FORMS
    @given(values)
    def check(value):
        assert parse(format_(value)) == value

    check()


@pytest.mark.parametrize("form", PAIRS)
def test_parsed_text_is_stable_and_only_form_errors_escape(form):
    parse, format_, _ = PAIRS[form]

    @FORMS
    @given(st.one_of(GRAMMAR[form], any_text))
    def check(text):
        try:
            value = parse(text)
        except FormError as exc:
            assert str(exc)
            return
        canonical = format_(value)
        assert parse(canonical) == value
        assert format_(parse(canonical)) == canonical

    check()


@pytest.mark.parametrize("form", ["block", "matrix_entry"])
def test_checked_expressions_read_back(form):
    """With a variable given, the expression is checked and still reads back."""
    parse, format_, _ = PAIRS[form]
    text = "C e u K*(1+T*s)" if form == "block" else "1 2 K*(s+1)"
    assert format_(parse(text, variable="s")) == text
    with pytest.raises(FormError, match="expression"):
        parse(text.replace("*(", "("), variable="s")


@FORMS
@given(per_condition_values())
def test_values_read_back_in_their_shape(value):
    assert forms.parse_values(forms.format_values(value), value) == value


@FORMS
@given(per_condition_values(), st.one_of(listed(spelled, sep=","), listed(spelled, sep=" "), any_text))
def test_values_text_is_stable(old, text):
    try:
        value = forms.parse_values(text, old)
    except FormError:
        return
    assert isinstance(value, list) == isinstance(old, list)
    canonical = forms.format_values(value)
    assert forms.format_values(forms.parse_values(canonical, old)) == canonical


def test_one_value_for_all_conditions():
    assert forms.parse_values("2", [1.0, 1.0, 3.0]) == [2.0, 2.0, 2.0]
    assert forms.parse_values("1, 2 3", [0.0, 0.0, 0.0]) == [1.0, 2.0, 3.0]


@FORMS
@given(settings_values)
def test_setting_reads_back_with_its_type(value):
    back = forms.parse_setting(forms.format_setting(value), value)
    assert back == value and type(back) is type(value)


@FORMS
@given(st.sampled_from([True, 3, 2.5, "grid", None]), st.one_of(spelled, cased, any_text))
def test_setting_text_is_stable(current, text):
    try:
        value = forms.parse_setting(text, current)
    except FormError:
        return
    canonical = forms.format_setting(value)
    assert forms.parse_setting(canonical, current) == value
    assert forms.format_setting(forms.parse_setting(canonical, current)) == canonical


def test_setting_types():
    assert forms.parse_setting("True", False) is True
    assert forms.parse_setting("1e3", 5) == 1000 and isinstance(forms.parse_setting("1e3", 5), int)
    assert forms.parse_setting("1.5", 5) == 1.5
    assert forms.parse_setting("7", "grid") == "7"
    assert forms.parse_setting("7", None) == 7.0
    assert forms.parse_setting("none", 2.0) is None
    assert forms.format_setting(True) == "true"


def test_human_friendly_numbers():
    assert forms.format_bands([BandModel(low=0.5, high=8, desired=40, required=30)]) == "0.5..8: 40 / 30"
    assert forms.format_bands([BandModel(desired=0.49)]) == "0..inf: 0.49"
    assert forms.format_number(0.1 + 0.2) == "0.30000000000000004"
    assert forms.format_points([PointModel(real=-1.0)]) == "push -1+0j"
    assert forms.format_response(ResponseModel(input="r", output="y")) == "r y 10 400; step 0 1"


def test_inf_high_means_no_limit():
    assert forms.parse_range("1..inf") == (1.0, None)
    assert forms.parse_range("1 .. Infinity") == (1.0, None)
    assert forms.parse_bands("0..INF: 3 /")[0].high is None
    assert forms.parse_optional(" Inf ") is None and forms.parse_optional("-inf") is None  # no bound, either way
    assert forms.parse_optional("1.798e+308") is None  # overflows: no bound too
    assert forms.parse_parameter("K 1 -inf inf") == ("K", 1.0, None, None)


MALFORMED = [
    (forms.parse_number, "abc", "expected a number"),
    (forms.parse_number, "nan", "expected a number"),
    (forms.parse_optional, "x", "a number, or none"),
    (forms.parse_signed, "", "at least one signal"),
    (forms.parse_signed, "+r y", "write +SIGNAL or -SIGNAL"),
    (forms.parse_signed, "+r -", "write +SIGNAL or -SIGNAL"),
    (forms.parse_parameter, "K", "NAME VALUE"),
    (forms.parse_parameter, "1K 2", "NAME an identifier"),
    (forms.parse_parameter, "K 1 2", "NAME VALUE MIN MAX"),
    (forms.parse_parameter, "K one", "VALUE"),
    (forms.parse_parameter, "K 1 3 2", "must not exceed"),
    (forms.parse_parameter, "K 1 low 2", "bound"),
    (forms.parse_block, "C e u", "NAME INPUT OUTPUT EXPRESSION"),
    (forms.parse_matrix_entry, "1 x K", "ROW COL EXPRESSION"),
    (forms.parse_matrix_entry, "0 1 K", "from 1"),
    (forms.parse_matrix_entry, "1 ² K", "ROW COL EXPRESSION"),
    (forms.parse_range, "..", "LOW"),
    (forms.parse_range, "1..", "HIGH"),
    (forms.parse_range, "1", "LOW..HIGH"),
    (forms.parse_range, "-1..2", "LOW must be >= 0"),
    (forms.parse_range, "3..2", "must not be below LOW"),
    (forms.parse_range, "1..2..3", "HIGH"),
    (forms.parse_bands, "", "at least one band"),
    (forms.parse_bands, ": 3", "LOW"),
    (forms.parse_bands, "1..", "LOW..HIGH: DESIRED"),
    (forms.parse_bands, "0..1: 0.5; 1..inf 0.4", "LOW..HIGH: DESIRED"),
    (forms.parse_bands, "0..1:", "DESIRED"),
    (forms.parse_bands, "0..1: 2 / x", "REQUIRED"),
    (forms.parse_points, "push", "push|pull REAL+IMAGj"),
    (forms.parse_points, "shove -1", "push or pull"),
    (forms.parse_points, "push -1+", "complex number"),
    (forms.parse_points, "pull nanj", "not nan"),
    (forms.parse_sense, "most", "at_least, at_most or auto"),
    (forms.parse_bool, "yes", "true or false"),
    (forms.parse_response, "r y", "INPUT OUTPUT HORIZON"),
    (forms.parse_response, "r y ten", "HORIZON"),
    (forms.parse_response, "r y 10 4.5", "POINTS"),
    (forms.parse_response, "r y 10 5", "points: input should be greater than or equal to 10"),
    (forms.parse_response, "r y -1", "horizon"),
    (forms.parse_response, "r y 10; step 1", "step T A"),
    (forms.parse_response, "r y 10; ramp 1 x", "ramp T S"),
    (forms.parse_response, "r y 10; step -1 1", "time"),
    (forms.parse_response, "r y 10; psd", "psd"),
    (forms.parse_response, "r y 10; psd exp(-s)", "psd shaping filter"),
    (forms.parse_response, "r y 10; wind 3", "step T A; ramp T S"),
    (forms.parse_response, "r y 10; settling 2", "settling_band"),
    (lambda text: forms.parse_values(text, 1.0), "1 2", "one number"),
    (lambda text: forms.parse_values(text, [1.0, 2.0, 3.0]), "1 2", "or 3 (one per condition)"),
    (lambda text: forms.parse_values(text, 1.0), "x", "expected a number"),
    (lambda text: forms.parse_setting(text, True), "yes", "true or false"),
    (lambda text: forms.parse_setting(text, 2.0), "fast", "a number, or none"),
]


@pytest.mark.parametrize("parse, text, message", MALFORMED)
def test_malformed_text_says_what_is_expected(parse, text, message):
    with pytest.raises(FormError) as info:
        parse(text)
    assert message.lower() in str(info.value).lower()


def test_form_error_is_a_value_error():
    assert issubclass(FormError, ValueError)


def test_module_is_pure():
    """No Textual and no workbench: the module is importable without the TUI."""
    import ast
    import inspect

    tree = ast.parse(inspect.getsource(forms))
    modules = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    modules |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert {m.split(".")[0] for m in modules} <= {"__future__", "math", "collections", "typing", "engine", "sessions"}
