"""One entry of an archive read without parsing the others (models/kyx/slicing.py).

The witness is the whole file's parse: reading entry E of an archive through the cut must
give the same claim (canonical text) or the same one-line error as reading the whole file and
picking E. Header-like text inside comments, strings and Tactic blocks must not cut."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from certiloop.models.kyx import KyxError, read_entries, reader
from certiloop.models.kyx.slicing import one_entry

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"


def _read(text: str, name: str, whole: bool) -> tuple:
    """(canonical claim, error) of entry `name`, read through the cut or from the whole file."""
    saved = reader._only_tree
    if whole:
        reader._only_tree = lambda *args: None
    try:
        entries = read_entries(text, "a.kyx", only=name)
    except KyxError as exc:
        return ("raised", str(exc))
    finally:
        reader._only_tree = saved
    chosen = [e for e in entries if e.name == name]
    if not chosen:
        return ("absent", None)
    (entry,) = chosen
    return (entry.theorem.canonical if entry.theorem else None, entry.error)


def _names(text: str) -> list[str]:
    return [e.name for e in read_entries(text, "a.kyx")]


def _entry(name: str, problem: str, extra: str = "") -> str:
    return (f'ArchiveEntry "{name}"\n{extra}  ProgramVariables Real x; End.\n'
            f"  Problem\n    {problem}\n  End.\nEnd.\n\n")


SAFE = "x >= 0 -> [x := x + 1;] x >= 1"
UNSAFE = "x >= 0 -> [x := x - 1;] x >= 0"


@pytest.mark.parametrize("fixture", sorted(p.name for p in FIXTURES.glob("kyx_*.kyx")))
def test_every_fixture_entry_reads_the_same_through_the_cut(fixture):
    text = (FIXTURES / fixture).read_text()
    try:
        names = _names(text)
    except KyxError:
        pytest.skip("a file with a syntax error: no entry to compare")
    for name in names:
        assert _read(text, name, whole=False) == _read(text, name, whole=True), name
        if len(names) > 1:  # the cut is taken, not the fallback
            assert one_entry(text, name) is not None, name


def test_header_text_in_comments_strings_and_tactics_does_not_cut():
    decoys = (
        '/* ArchiveEntry "b" Problem x >= 0 -> [x := x - 1;] x >= 0 End. End. */\n'
        '  Description "Theorem \\"b\\" is proved elsewhere".\n'
    )
    tactic = '  Tactic "t" Lemma "b" ArchiveEntry "b" End.\n'
    text = (_entry("a", SAFE, decoys) + _entry("b", UNSAFE).replace("End.\nEnd.", "End.\n" + tactic + "End.")
            + _entry("c", SAFE))
    for name in ("a", "b", "c"):
        assert one_entry(text, name) is not None
        assert _read(text, name, whole=False) == _read(text, name, whole=True)
    # the cut keeps the entry's own text where it was: line and column do not move
    cut = one_entry(text, "b")
    assert len(cut) == len(text) and cut.count("\n") == text.count("\n")
    start = text.index('ArchiveEntry "b"\n')
    assert cut[start:start + 20] == text[start:start + 20]
    assert "x >= 1" not in cut[:start]  # entry a is blanked


def test_shared_definitions_are_kept():
    text = "SharedDefinitions\n  Real k = 2;\nEnd.\n\n" + _entry("a", "x >= 0 -> [x := x + k;] x >= 2") \
        + _entry("b", "x >= 0 -> [x := x - k;] x >= 0")
    for name in ("a", "b"):
        got = _read(text, name, whole=False)
        assert got == _read(text, name, whole=True) and got[0] is not None
        assert "Fraction(2, 1)" in got[0] or "Fraction(-2, 1)" in got[0]  # k = 2 expanded


def test_an_error_inside_the_chosen_entry_reads_as_the_whole_file_reads_it():
    text = _entry("a", SAFE) + _entry("b", "x >= 0 -> [x := ;] x >= 0") + _entry("c", SAFE)
    got = _read(text, "b", whole=False)
    assert got == _read(text, "b", whole=True)
    assert got[0] == "raised" and "a.kyx:" in got[1]


def test_an_error_elsewhere_does_not_stop_the_chosen_entry():
    text = _entry("a", SAFE) + _entry("b", "x >= 0 -> [x := ;] x >= 0") + _entry("c", UNSAFE)
    with pytest.raises(KyxError):
        read_entries(text, "a.kyx")
    got = _read(text, "c", whole=False)
    assert got[0] is not None and "Fraction(-1, 1)" in got[0]  # entry c, x := x - 1


@pytest.mark.parametrize("text, why", [
    (_entry("a", SAFE) + "/* unclosed\n" + _entry("b", SAFE), "an unclosed comment"),
    (_entry("a", SAFE) + _entry("a", UNSAFE), "a name twice"),
    (_entry("a", "Lemma >= 0 -> [x := Lemma;] x >= 0") + _entry("b", SAFE), "a keyword used as a name"),
    ('ArchiveEntry /* c */ "a"\n Problem x >= 0 -> [x := x + 1;] x >= 1 End.\nEnd.\n' + _entry("b", SAFE),
     "a header split by a comment"),
    (_entry("a", SAFE) + 'Tactic "no end" \n', "a tactic without End."),
    (_entry("a", SAFE) + "SharedDefinitions Real k; End.\n" + _entry("b", SAFE), "shared definitions late"),
])
def test_unsure_scans_fall_back_to_the_whole_file(text, why):
    assert one_entry(text, "b" if "b" in text else "a") is None, why


# a red team's finds: the scan took text lark reads otherwise for an entry, and proved it
KEYWORD_IN_A_WORD = ('ArchiveEntry "A"\nProblem x>0 -> x>0 End.\n'
                     'Tactic_ ArchiveEntry "B" Problem x>=0 -> [x:=x+1;]x>=1 End.\nEnd.\n'
                     'ArchiveEntry "C" Problem true End. End.\n'
                     'ArchiveEntryL: "B" ProgramVariables Real x; End.\n'
                     'Problem x>=0 -> [x:=x-1;]x>=0 End. End.\n')
TACTIC_AS_A_NAME = ('ArchiveEntry "A"\nProgramVariables Real x, Tactic; End.\n'
                    'Problem Tactic>=0 -> Tactic>=0 /* End.\n'
                    'ArchiveEntry "B" Problem x>=0 -> [x:=x+1;]x>=1 End. End.\nLemma "Z" */ End.\nEnd.\n')


@pytest.mark.parametrize("text", [KEYWORD_IN_A_WORD, TACTIC_AS_A_NAME])
def test_keywords_lark_may_read_as_names_make_the_scan_unsure(text):
    assert one_entry(text, "B") is None
    assert _read(text, "B", whole=False) == _read(text, "B", whole=True)


def test_a_name_not_in_the_archive_lists_the_names():
    from certiloop.api.loading import load_kyx
    from certiloop.models.lang.terms import ModelError

    path = Path(__file__).resolve().parents[2] / "fixtures" / "kyx_invalid.kyx"
    with pytest.raises(ModelError, match="no entry named 'nope' \\(it has: "):
        load_kyx(str(path), "nope")


_BLOCKS = st.sampled_from([
    _entry("p", SAFE), _entry("q", UNSAFE), _entry("r e\\\"s", "x > 0 -> [x := 2*x;] x > 0"),
    _entry("s", SAFE, '  Description "ArchiveEntry \\"q\\" End.".\n'),
    _entry("t", UNSAFE).replace("End.\nEnd.", 'End.\n  Tactic "x" Theorem "p" End.\nEnd.'),
    '/* Theorem "q" Problem x >= 0 -> [x := x - 1;] x >= 0 End. End. */\n',
    "\n\n", "/* a comment */ ",
])


@given(st.lists(_BLOCKS, min_size=1, max_size=7))
def test_any_arrangement_reads_the_same_through_the_cut(blocks):
    text = "".join(blocks)
    try:
        names = _names(text)
    except KyxError:  # two entries with one name, or no entry at all: no cut, the whole file's error
        assert all(one_entry(text, name) is None for name in ("p", "q", 'r e"s', "s", "t"))
        return
    for name in names:
        assert _read(text, name, whole=False) == _read(text, name, whole=True), name
