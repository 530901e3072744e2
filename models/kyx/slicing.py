"""One entry of an archive without parsing the others.

`certiloop prove FILE.kyx:"Entry"` needs one entry, but parsing a 61-entry archive with lark
takes a quarter of a second, a quarter of an easy entry's whole run. `one_entry` scans the
text for entry headers the way the grammar's terminals read it (comments, strings, the
opaque Tactic text) and blanks every other entry: line and column of what is kept do not
move, so errors read the same. It answers None whenever the scan is not certain (an
unclosed comment or string, a keyword anywhere but after `End.`, a name found twice or not
at all); the caller then parses the whole file. The grammar still reads the kept entry, and
the caller checks it is exactly that one entry.

A syntax error in another entry is not seen this way (the whole file's parse, as `prove
FILE.kyx` does, reports it); the entry asked for reads as it would in a correct file.
"""

from __future__ import annotations

import json
import re

_STRING = r'"(?:\\.|[^"\\])*"'
# what changes the reading of the text around it; anything else is skipped in one search. The
# keywords are found inside longer words too: where no name may come next, lark's contextual
# lexer reads `Tactic_` as the keyword and then `_`.
_NOTABLE = re.compile(r'/\*|"|ArchiveEntry|Theorem|Lemma|Exercise|Tactic|SharedDefinitions')
_COMMENT_END = re.compile(r"\*/")
_STRING_AT = re.compile(_STRING)
_HEADER_AT = re.compile(r"(?:ArchiveEntry|Theorem|Lemma|Exercise)\s+(?:[A-Za-z][A-Za-z0-9_]*\s*:\s*)?"
                        rf"({_STRING})")
_TACTIC_END = re.compile(r"End\.")  # the grammar's TACTIC_TEXT runs to the first `End.`
# the grammar's END token at the end of a stretch of text: a keyword may only follow it (or
# the start of the file), where the grammar accepts no name, so lark reads it as the keyword
_ENDS_WITH_END = re.compile(r"(?:^|[^A-Za-z0-9_'])End(?:[ \t]+[A-Za-z][A-Za-z0-9_]*)?\.$")
_BLANK = re.compile(r"[^\n]")


def one_entry(text: str, name: str) -> str | None:
    """The text with every entry but `name` blanked (SharedDefinitions kept), or None."""
    headers = _headers(text)
    if headers is None:
        return None
    starts = [start for start, _ in headers]
    names = [found for _, found in headers]
    if names.count(name) != 1 or len(set(names)) != len(names):
        return None
    i = names.index(name)
    begin, end = starts[i], (starts[i + 1] if i + 1 < len(starts) else len(text))
    return (text[:starts[0]] + _BLANK.sub(" ", text[starts[0]:begin]) + text[begin:end]
            + _BLANK.sub(" ", text[end:]))


def _headers(text: str) -> list[tuple[int, str]] | None:
    """(offset, decoded name) of every entry header, in order; None if the scan is unsure.
    Every keyword must come right after the start of the file or an `End.` (comments and
    blanks between): there the grammar accepts no name, so lark too reads the keyword."""
    found: list[tuple[int, str]] = []
    at, after_end, anything = int(text.startswith("\ufeff")), True, False  # parse_tree drops a BOM
    while (hit := _NOTABLE.search(text, at)) is not None:
        token, start = hit.group(), hit.start()
        gap = text[at:start].rstrip()
        if gap:
            after_end, anything = bool(_ENDS_WITH_END.search(gap)), True
        if token == "/*":
            close = _COMMENT_END.search(text, start + 2)
            if close is None:
                return None
            at = close.end()  # a comment is blank: `after_end` carries over it
            continue
        if token == '"':
            string = _STRING_AT.match(text, start)
            if string is None:
                return None
            at, after_end, anything = string.end(), False, True
            continue
        if not after_end:  # a keyword inside a name, or where a name may stand
            return None
        if token == "Tactic":
            close = _TACTIC_END.search(text, hit.end())
            if close is None:
                return None
            at, after_end = close.end(), True
        elif token == "SharedDefinitions":
            if anything:  # only at the very start
                return None
            at, after_end = hit.end(), False
        else:
            header = _HEADER_AT.match(text, start)
            if header is None:  # a header split by a comment
                return None
            literal = header.group(1)
            try:
                found.append((start, json.loads(literal) if "\\" in literal else literal[1:-1]))
            except ValueError:  # an escape JSON does not know: the reader's error, from the full parse
                return None
            at, after_end = header.end(), False
        anything = True
    return found
