"""One entry of an archive without parsing the others.

`certiloop prove FILE.kyx:"Entry"` needs one entry, but parsing a 61-entry archive with lark
takes a quarter of a second, a quarter of an easy entry's whole run. `one_entry` scans the
text for entry headers the way the grammar's terminals read it (comments, strings, the
opaque Tactic text) and blanks every other entry: line and column of what is kept do not
move, so errors read the same. It answers None whenever the scan is not certain (an
unclosed comment or string, a keyword outside a header, a name found twice or not at all);
the caller then parses the whole file. The grammar still reads the kept entry: a wrong cut
makes the kept text fail to parse as exactly that one entry, which the caller checks.
"""

from __future__ import annotations

import json
import re

_STRING = r'"(?:\\.|[^"\\])*"'
# what changes the reading of the text around it; anything else is skipped in one search
_NOTABLE = re.compile(r'/\*|"|\b(?:ArchiveEntry|Theorem|Lemma|Exercise|Tactic|SharedDefinitions)\b')
_COMMENT_END = re.compile(r"\*/")
_STRING_AT = re.compile(_STRING)
_HEADER_AT = re.compile(r"(?:ArchiveEntry|Theorem|Lemma|Exercise)\s+(?:[A-Za-z][A-Za-z0-9_]*\s*:\s*)?"
                        rf"({_STRING})")
_TACTIC_END = re.compile(r"End\.")  # the grammar's TACTIC_TEXT runs to the first `End.`
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
    """(offset, decoded name) of every entry header, in order; None if the scan is unsure."""
    found: list[tuple[int, str]] = []
    at = 0
    while (hit := _NOTABLE.search(text, at)) is not None:
        token, start = hit.group(), hit.start()
        if token == "/*":
            close = _COMMENT_END.search(text, start + 2)
            if close is None:
                return None
            at = close.end()
        elif token == '"':
            string = _STRING_AT.match(text, start)
            if string is None:
                return None
            at = string.end()
        elif token == "Tactic":
            close = _TACTIC_END.search(text, hit.end())
            if close is None:
                return None
            at = close.end()
        elif token == "SharedDefinitions":
            if found:  # only before the first entry
                return None
            at = hit.end()
        else:
            header = _HEADER_AT.match(text, start)
            if header is None:  # the word used as a name, or a header split by a comment
                return None
            literal = header.group(1)
            try:
                found.append((start, json.loads(literal) if "\\" in literal else literal[1:-1]))
            except ValueError:  # an escape JSON does not know: the reader's error, from the full parse
                return None
            at = header.end()
    return found
