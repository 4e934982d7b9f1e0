"""Errors the user can fix: one line on stderr, exit 2; and the "did you mean" every typed name gets."""
from __future__ import annotations


class UsageError(Exception):
    """Bad arguments or input the user can fix."""


def did_you_mean(word: str, choices, n: int = 3) -> str:
    """'; did you mean X?' (or '... X or Y?') for the close matches of ``word``, else ''."""
    choices = [str(c) for c in choices]
    import difflib   # (only a bad word needs it)
    hits = difflib.get_close_matches(word, choices, n=n, cutoff=0.6)
    if not hits:  # a prefix or a part is a good hint too (--summary for --summary-json)
        low = word.lower().strip("-")
        hits = [c for c in choices if low and (c.lower().strip("-").startswith(low) or low in c.lower())][:n]
    if not hits:
        return ""
    return "; did you mean " + " or ".join(hits) + "?"
